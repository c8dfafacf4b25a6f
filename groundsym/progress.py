"""Progress on the terminal (stderr): done/total, rate, ETA, and a free-form status.

Quiet when stderr is not a terminal, except for occasional plain lines, so logs stay readable.
The ETA is the rate since the first update applied to the work left: what came before the first
update (starting worker processes, loading compiled kernels, the part of a resumed run already
done) says nothing about the rate, and counted in it made ``learn``'s first ETA 1h15m for a
search that took 31 s.
"""

from __future__ import annotations

import sys
import time


class Progress:
    def __init__(self, total: int, label: str = "", *, stream=None, min_interval: float = 0.2,
                 enabled: bool = True):
        self.total = max(int(total), 1)
        self.label = label
        self.stream = stream or sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.min_interval = min_interval if self.tty else 10.0
        self.enabled = enabled
        self.start = time.monotonic()
        self.last = 0.0
        self.done = 0
        self._first: tuple[float, int] | None = None   # (time, done) of the first update

    def update(self, done: int, status: str = "", force: bool = False) -> None:
        self.done = done
        now = time.monotonic()
        if self._first is None:
            self._first = (now, done)
        if not self.enabled or (not force and now - self.last < self.min_interval and done < self.total):
            return
        self.last = now
        elapsed = now - self.start
        frac = min(done / self.total, 1.0)
        eta = self.eta(now, done)
        eta_s = "?" if eta != eta else _fmt(eta)
        width = 24
        bar = "#" * int(frac * width) + "-" * (width - int(frac * width))
        line = f"{self.label} [{bar}] {done}/{self.total} {_fmt(elapsed)} elapsed, ETA {eta_s}"
        if status:
            line += f" | {status}"
        if self.tty:
            self.stream.write("\r\x1b[K" + line)
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def eta(self, now: float, done: int) -> float:
        """Seconds left at the rate since the first update; NaN until the work has moved on from
        there (0 when all is done)."""
        if done >= self.total:
            return 0.0
        t0, d0 = self._first if self._first is not None else (now, done)
        if done <= d0 or now <= t0:
            return float("nan")
        return (now - t0) / (done - d0) * (self.total - done)

    def close(self, status: str = "") -> None:
        if not self.enabled:
            return
        self.update(self.done, status, force=True)
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


def _fmt(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{(seconds % 3600) // 60:02d}m"
