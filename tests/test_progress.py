"""Progress lines: the ETA is the rate since the first update times the work left (hand-computed
cases on a fake clock)."""

import io

import groundsym.progress as progress_mod
from groundsym.progress import Progress


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def _lines(stream: io.StringIO) -> list[str]:
    return [line for line in stream.getvalue().splitlines() if line]


def test_eta_leaves_out_what_came_before_the_first_update(monkeypatch):
    """A slow start (10 s before the first 10 of 1,000 items: workers starting, kernels loading)
    does not count: 100 more items in the next second leave 890 at 100 per second, 9 s; the old
    estimate from the whole elapsed time said 89 s."""
    clock = Clock()
    monkeypatch.setattr(progress_mod.time, "monotonic", clock)
    out = io.StringIO()
    bar = Progress(1000, "work", stream=out)
    clock.t = 10.0
    bar.update(10, force=True)
    clock.t = 11.0
    bar.update(110, force=True)
    first, second = _lines(out)
    assert "ETA ?" in first                       # no rate yet
    assert "110/1000 11s elapsed, ETA 9s" in second
    assert bar.eta(11.0, 1000) == 0.0


def test_eta_of_a_resumed_run_counts_this_run_only(monkeypatch):
    """Resumed at 600 of 1,000: 100 items in 20 s leave 300 at 5 per second, 60 s (not the 400
    items' worth of time the first run took)."""
    clock = Clock()
    monkeypatch.setattr(progress_mod.time, "monotonic", clock)
    out = io.StringIO()
    bar = Progress(1000, "work", stream=out)
    bar.update(600, force=True)
    clock.t = 20.0
    bar.update(700, force=True)
    assert "700/1000 20s elapsed, ETA 1m00s" in _lines(out)[-1]
