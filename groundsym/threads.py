"""BLAS threads while a planner decides.

A planner's decision is many small matrix products (PRADA: 500 x ~100 tables, four steps deep).
Multi-threaded BLAS splits each product over the cores, and on a busy machine every product then
waits for a core: with the default two threads on a shared two-core machine one 500 x 108
product took 16-25 ms and a decision 70-94 ms, against 14 ms single-threaded. The episode loop
(``groundsym plan`` and ``groundsym evaluate``) therefore decides with BLAS limited to one thread,
and only while deciding: symbol learning and everything else keep the library's own setting.

The limit is applied with threadpoolctl to the BLAS libraries loaded at the first decision; its
cost (about 60 microseconds per decision) is what one product costs on a single thread.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Iterator

PLANNER_BLAS_THREADS = 1

_controller: Any = None


def _blas_controller() -> Any:
    """One threadpoolctl controller, made once the planner's libraries are loaded."""
    global _controller
    if _controller is None:
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
    return _controller


@contextmanager
def limited_blas(threads: int = PLANNER_BLAS_THREADS) -> Iterator[None]:
    """BLAS (OpenBLAS, MKL, BLIS) limited to ``threads`` inside the block, as before after it."""
    with _blas_controller().limit(limits=threads, user_api="blas"):
        yield


def decide(planner: Any, observation: Any, threads: int = PLANNER_BLAS_THREADS) -> Any:
    """``planner.choose(observation)`` with BLAS limited to ``threads`` (the episode loop's call)."""
    with limited_blas(threads):
        return planner.choose(observation)
