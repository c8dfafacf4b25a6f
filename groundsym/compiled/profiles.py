"""The reward term's neighbours by relational profile, compiled whole (reference:
``profile_neighbours_reference`` of :mod:`groundsym.profile_neighbours`).

Profiled at 20 objects (fixture world, 160 transitions, 1+1 symbols, ``distance=signature``),
the numpy reference took 27% of a loss evaluation: the degree sequences are sorted per state
and symbol, the classes grouped through a byte view, and the lone classes' bounds taken as a
(Q, C, P) float array, each a few numpy calls of small arrays. Here it is one pass: profiles
(``classes._profiles_of``), classes (``group_keys``), then per lone class the L1 profile
distance to every other class in integers (twice the bound: unary differences count 2, degree
differences 1, so the float bound ``U + B / 2`` of the reference is that integer halved, exactly).
Classes may be numbered in another order than the reference's; the reward mixture does not
depend on the numbering (each item's partners are taken in increasing item order,
``mixtures.reward_entries``), and every class's first member is its smallest, as there.
"""

from __future__ import annotations

import numpy as np

from .base import njit
from .classes import _profiles_of, group_keys, lone_classes


@njit(cache=True)
def profile_nearest(u, b, rows):
    """Per state ``rows[i]`` of ``u`` (S, M, K) and ``b`` (S, M, M, L): its profile class, the lone
    classes, their nearest profile distance (float, as the reference's bound) and their hits (query
    index into ``lone``, class) sorted by query, then class."""
    prof = _profiles_of(u, b, rows)
    first, cls = group_keys(prof)
    c_n = len(first)
    lone = lone_classes(cls, c_n)
    n_lone = len(lone)
    k = u.shape[2]
    width = prof.shape[1]
    dist = np.empty(c_n, dtype=np.int64)
    best = np.empty(n_lone)
    cap = 4 * n_lone + 16
    hq = np.empty(cap, dtype=np.int64)
    hc = np.empty(cap, dtype=np.int64)
    h = 0
    for q in range(n_lone):
        rq = first[lone[q]]
        top = np.iinfo(np.int64).max
        for c in range(c_n):
            if c == lone[q]:
                continue
            rc = first[c]
            d = 0
            for col in range(k):
                d += 2 * abs(prof[rq, col] - prof[rc, col])
            for col in range(k, width):
                d += abs(prof[rq, col] - prof[rc, col])
            dist[c] = d
            if d < top:
                top = d
        best[q] = top / 2.0 if c_n > 1 else np.inf
        for c in range(c_n):
            if c == lone[q] or dist[c] != top:
                continue
            if h == cap:
                cap *= 2
                hq = np.concatenate((hq, np.empty(cap - h, dtype=np.int64)))
                hc = np.concatenate((hc, np.empty(cap - h, dtype=np.int64)))
            hq[h] = q
            hc[h] = c
            h += 1
    return cls, lone, best, hq[:h].copy(), hc[:h].copy()
