"""The episode loop decides with BLAS on one thread, and only while deciding."""

from __future__ import annotations

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from groundsym.threads import decide, limited_blas


def _blas_threads() -> list[int]:
    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_limited_blas_sets_one_thread_and_restores_the_setting():
    np.ones((4, 4)) @ np.ones((4, 4))            # numpy's BLAS is loaded
    with threadpool_limits(limits=2, user_api="blas"):
        assert _blas_threads() and set(_blas_threads()) == {2}
        with limited_blas():
            assert set(_blas_threads()) == {1}
        assert set(_blas_threads()) == {2}


def test_decide_calls_the_planner_under_the_limit():
    seen = []

    class Probe:
        def choose(self, observation):
            seen.append((observation, _blas_threads()))
            return "decision"

    with threadpool_limits(limits=2, user_api="blas"):
        assert decide(Probe(), "obs") == "decision"
    assert seen[0][0] == "obs" and set(seen[0][1]) == {1}
