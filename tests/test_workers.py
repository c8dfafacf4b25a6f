"""groundsym.workers: the worker processes of ``learn`` and ``evaluate``, which a Ctrl-C must always be
able to stop."""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import time

import numpy as np
import pytest

from conftest import descendants
from groundsym.executors import ProcessExecutor
from groundsym.workers import Workers, running

CTX = mp.get_context("fork")
_STATE: dict[str, int] = {}


def _init(offset: int) -> None:
    _STATE["offset"] = offset


def _job(x: int) -> tuple[int, int]:
    time.sleep(0.01 * (x % 3))          # uneven durations: answers come back out of order
    return x + _STATE["offset"], os.getpid()


def _sleep(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def _big(x: int) -> np.ndarray:
    return np.full(8_000_000, x, dtype=np.float64)     # 64 MB: its send blocks until read


def _fail(x: int) -> int:
    raise ValueError(f"bad job {x}")


def _die(x: int) -> int:
    os._exit(3)


def test_map_gives_every_result_in_job_order_from_several_workers():
    w = Workers(2, _init, (100,), ctx=CTX)
    try:
        out = w.map(_job, list(range(12)))
        assert [r for r, _ in out] == [x + 100 for x in range(12)]
        assert len({pid for _, pid in out}) == 2 and os.getpid() not in {pid for _, pid in out}
        assert w.map(_job, []) == []
    finally:
        w.close()
    assert all(p.exitcode == 0 for p in w.procs)      # closed: they finished, nobody killed them


def test_kill_returns_at_once_while_workers_are_sending_large_results():
    """The case multiprocessing.Pool.terminate() could wait on forever: workers blocked in the
    middle of sending (nobody reads their pipes), then stopped."""
    w = Workers(2, _init, (0,), ctx=CTX)
    for conn in w.conns:
        conn.send((_big, 1))
    time.sleep(0.5)                      # both are now blocked writing 64 MB into a pipe
    t = time.monotonic()
    w.kill()
    assert time.monotonic() - t < 5
    assert all(p.exitcode == -signal.SIGKILL for p in w.procs)


def test_a_workers_exception_reaches_the_caller_and_a_dead_worker_is_an_error():
    w = Workers(2, _init, (0,), ctx=CTX)
    try:
        with pytest.raises(ValueError, match="bad job 1"):
            w.map(_fail, [1])
    finally:
        w.kill()
    w = Workers(1, _init, (0,), ctx=CTX)
    try:
        with pytest.raises(RuntimeError, match="worker process died"):
            w.map(_die, [0])
    finally:
        w.kill()


def test_workers_ignore_sigint_and_running_holds_it_back_while_forking(monkeypatch):
    before = signal.pthread_sigmask(signal.SIG_BLOCK, set())
    held: list[bool] = []
    fork = Workers.__init__

    def spy(self, *args, **kwargs):
        held.append(signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, set()))
        fork(self, *args, **kwargs)

    monkeypatch.setattr(Workers, "__init__", spy)
    with running(2, _init, (5,), ctx=CTX) as w:
        assert held == [True]                                          # held back while they forked
        assert signal.pthread_sigmask(signal.SIG_BLOCK, set()) == before    # let in once they are up
        for p in w.procs:
            os.kill(p.pid, signal.SIGINT)
        assert [r for r, _ in w.map(_job, [1, 2])] == [6, 7]          # still there, still working
    assert all(p.exitcode == 0 for p in w.procs)                       # closed at the block's end


def test_as_completed_yields_every_result_as_it_finishes():
    with running(2, _init, (0,), ctx=CTX) as w:
        got = list(w.as_completed(_job, [2, 0, 1, 3]))
        assert sorted(r for r, _ in got) == [0, 1, 2, 3] and len({pid for _, pid in got}) == 2
        assert list(w.as_completed(_sleep, [1.0, 0.0])) == [0.0, 1.0]   # the short job overtakes the long one


def test_running_kills_the_workers_when_its_block_raises():
    with pytest.raises(KeyboardInterrupt):
        with running(2, _init, (0,), ctx=CTX) as w:
            for conn in w.conns:
                conn.send((_big, 1))                # busy workers: a close would wait for them
            raise KeyboardInterrupt
    assert all(p.exitcode == -signal.SIGKILL for p in w.procs) and w.conns == []


def _add(a: int, b: int) -> tuple[int, int]:
    return a + b + _STATE.get("offset", 0), os.getpid()


def test_process_executor_maps_in_order_and_yields_units_as_completed():
    """Both of the executor's ways of running work go through the same workers: ``mapper``
    (annealing rounds, initialised once per worker) and ``as_completed`` (evaluation units)."""
    with ProcessExecutor(2).mapper(_init, (10,)) as run:
        assert [r for r, _ in run(_job, [3, 4, 5])] == [13, 14, 15]
    units = list(ProcessExecutor(2).as_completed(_add, [(1, 2), (3, 4), (5, 6)]))
    assert sorted(r for r, _ in units) == [3, 7, 11] and os.getpid() not in {pid for _, pid in units}
    _STATE.pop("offset", None)
    with ProcessExecutor(1).mapper(_init, (20,)) as run:                 # one worker: this process
        assert run(_job, [1]) == [(21, os.getpid())]
    _STATE.pop("offset", None)
    assert list(ProcessExecutor(1).as_completed(_add, [(1, 2)])) == [(3, os.getpid())]


def test_a_consumer_that_stops_reading_units_kills_the_workers():
    """``evaluate`` interrupted while it saves a unit: the generator of units is closed, and its
    workers are killed at once rather than left running the remaining units."""
    others = descendants(os.getpid())
    units = ProcessExecutor(2).as_completed(_add, [(1, 2), (3, 4), (5, 6)])
    next(units)
    workers = descendants(os.getpid()) - others
    assert len(workers) == 2
    units.close()
    assert not workers & descendants(os.getpid())


_DRIVER = """
import sys, time
sys.path.insert(0, {tests!r})
from test_workers import _sleep, CTX
from groundsym.workers import running
with running(2, ctx=CTX) as workers:
    print(*[p.pid for p in workers.procs], flush=True)
    workers.map(_sleep, [600.0, 600.0])
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="needs Linux's prctl")
@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGTERM])
def test_workers_in_the_middle_of_a_job_die_with_a_main_process_killed_outright(how):
    """A driver that dies without stopping its workers (``kill -9``; SIGTERM's default action in a
    script that uses groundsym in-process) must not leave them computing: their job here would run
    ten minutes, and they only see the closed pipe between jobs."""
    import subprocess
    import sys
    from pathlib import Path
    code = _DRIVER.format(tests=str(Path(__file__).parent))
    driver = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                              start_new_session=True)
    try:
        pids = [int(p) for p in driver.stdout.readline().split()]
        assert len(pids) == 2
        time.sleep(0.5)                                   # both workers are inside their job
        assert all(_alive(p) for p in pids)
        driver.send_signal(how)
        assert driver.wait(timeout=30) == -how
        deadline = time.monotonic() + 10
        while any(_alive(p) for p in pids) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(_alive(p) for p in pids)
    finally:
        try:
            os.killpg(driver.pid, signal.SIGKILL)         # the driver's session: nothing is left
        except ProcessLookupError:
            pass


def _alive(pid: int) -> bool:
    """Is ``pid`` a live process (not a zombie: a killed worker whose reaper is gone is re-parented
    and reaped by init, but may be seen for a moment before)?"""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False

