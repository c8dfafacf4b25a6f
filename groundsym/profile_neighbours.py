"""Nearest neighbours by relational profile: the reward term of the local distance.

The local distance (groundsym/relational/local.py) keeps the relations near an action's
arguments, which is what a rule's outcome can depend on, but a reward is a function of the whole
scene (the tower's: the heights of every cube). Views from the arguments lose that: measured on
the tower at 7 and 10 cubes, a reward term on the views made the search trade `on` for a unary
`ontable` (docs/symbol-search.md). So with the local distance the reward's neighbours are found on
the whole state, by a cheaper distance: the L1 difference of the states' *profiles* (per unary
symbol how many objects hold it, per binary symbol the sorted out- and in-degree sequences, the
latter at half weight), which is the count-and-degree lower bound the exact search orders its
candidates by (:func:`groundsym.neighbourhood.profile_bound`). States with equal profiles form a
class and predict each other; a lone state's neighbours are every member of its nearest other
classes (ties form a mixture), as in the exact pass. The profile sees how many relations hold and
how they pile up on objects, not which objects they join.

:func:`profile_neighbours` runs the compiled pass (:mod:`groundsym.compiled.profiles`: the same
classes up to their numbering, the same nearest distances and hits, so the same reward term bit
for bit); :func:`profile_neighbours_reference` is its numpy reference.
"""

from __future__ import annotations

import numpy as np

from .compiled.profiles import profile_nearest
from .neighbourhood import Neighbourhood, class_profiles, group_rows, profile_bound


def profile_neighbours(u: np.ndarray, b: np.ndarray, rows: np.ndarray | None = None) -> Neighbourhood:
    """Leave-one-out nearest neighbours of each state (``u`` (N, M, K), ``b`` (N, M, M, L); or of
    the scenes ``rows`` of them) by profile distance, as a :class:`Neighbourhood` for the reward
    mixture (identity orders: a reward needs no mapping of objects). Compiled; the classes may be
    numbered otherwise than by :func:`profile_neighbours_reference`, which the mixture does not see."""
    rows = np.arange(len(u), dtype=np.int64) if rows is None else np.ascontiguousarray(rows, dtype=np.int64)
    cls, lone, best, hit_query, hit_class = profile_nearest(np.ascontiguousarray(u), np.ascontiguousarray(b), rows)
    m = u.shape[1]
    perms = np.broadcast_to(np.arange(m), (len(rows), m)).copy()
    return Neighbourhood(cls, perms, lone, best, hit_query, hit_class,
                         np.zeros((len(hit_query), m), dtype=np.int64))


def profile_neighbours_reference(u: np.ndarray, b: np.ndarray) -> Neighbourhood:
    """The numpy reference of :func:`profile_neighbours` (classes numbered in byte order of the
    profiles)."""
    n, m = u.shape[:2]
    profile = class_profiles(u, b, np.arange(n))
    first, cls = group_rows(profile)
    sizes = np.bincount(cls, minlength=len(first))
    lone = np.flatnonzero(sizes == 1)
    perms = np.broadcast_to(np.arange(m), (n, m)).copy()
    if len(lone) == 0:
        empty = np.zeros(0, dtype=np.int64)
        return Neighbourhood(cls, perms, lone, np.zeros(0), empty, empty, np.zeros((0, m), dtype=np.int64))
    dist = np.atleast_2d(profile_bound(profile[first], lone, u.shape[2]))
    dist[np.arange(len(lone)), lone] = np.inf
    best = dist.min(axis=1)
    hit_query, hit_class = np.nonzero(dist == best[:, None])    # sorted by query, then class
    return Neighbourhood(cls, perms, lone.astype(np.int64), best, hit_query.astype(np.int64),
                         hit_class.astype(np.int64), np.zeros((len(hit_query), m), dtype=np.int64))
