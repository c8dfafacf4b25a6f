"""groundsym.workers: the worker processes of ``learn``, which a Ctrl-C must always be able to stop."""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import time

import numpy as np
import pytest

from groundsym.workers import Workers, start

CTX = mp.get_context("fork")
_STATE: dict[str, int] = {}


def _init(offset: int) -> None:
    _STATE["offset"] = offset


def _job(x: int) -> tuple[int, int]:
    time.sleep(0.01 * (x % 3))          # uneven durations: answers come back out of order
    return x + _STATE["offset"], os.getpid()


def _big(x: int) -> np.ndarray:
    return np.full(8_000_000, x, dtype=np.float64)     # 64 MB: its send blocks until read


def _fail(x: int) -> int:
    raise ValueError(f"bad job {x}")


def _die(x: int) -> int:
    os._exit(3)


def test_map_gives_every_result_in_job_order_from_several_workers():
    w = Workers(CTX, 2, _init, (100,))
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
    w = Workers(CTX, 2, _init, (0,))
    for conn in w.conns:
        conn.send((_big, 1))
    time.sleep(0.5)                      # both are now blocked writing 64 MB into a pipe
    t = time.monotonic()
    w.kill()
    assert time.monotonic() - t < 5
    assert all(p.exitcode == -signal.SIGKILL for p in w.procs)


def test_a_workers_exception_reaches_the_caller_and_a_dead_worker_is_an_error():
    w = Workers(CTX, 2, _init, (0,))
    try:
        with pytest.raises(ValueError, match="bad job 1"):
            w.map(_fail, [1])
    finally:
        w.kill()
    w = Workers(CTX, 1, _init, (0,))
    try:
        with pytest.raises(RuntimeError, match="worker process died"):
            w.map(_die, [0])
    finally:
        w.kill()


def test_workers_ignore_sigint_and_start_holds_it_back_while_forking():
    before = signal.pthread_sigmask(signal.SIG_BLOCK, set())
    w, mask = start(CTX, 2, _init, (5,))
    try:
        assert signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, set())   # held back until restored
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        assert signal.pthread_sigmask(signal.SIG_BLOCK, set()) == before
        for p in w.procs:
            os.kill(p.pid, signal.SIGINT)
        assert [r for r, _ in w.map(_job, [1, 2])] == [6, 7]          # still there, still working
    finally:
        w.close()
