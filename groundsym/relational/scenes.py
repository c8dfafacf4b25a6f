"""Continuous scenes: the distance as a linear assignment with the actions' arguments pinned,
and the naive enumeration it is tested against."""

from __future__ import annotations

import itertools
from typing import Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..logic import Atom
from ..world import Scene
from .encoding import INF, lock_vector


def _pins(objects_a: Sequence[str], action_a: Atom | None, objects_b: Sequence[str],
          action_b: Atom | None) -> list[tuple[int, int]] | None:
    """Index pairs forced by the action constraint; None if the actions cannot correspond."""
    if (action_a is None) != (action_b is None):
        raise ValueError("give both actions or neither")
    if action_a is None:
        return []
    if action_a.predicate != action_b.predicate or action_a.arity != action_b.arity:
        return None
    la = lock_vector(objects_a, action_a, len(objects_a))
    lb = lock_vector(objects_b, action_b, len(objects_b))
    pins = []
    for x, y in zip(action_a.args, action_b.args):
        i, j = list(objects_a).index(x), list(objects_b).index(y)
        if la[i] != lb[j]:
            return None
        pins.append((i, j))
    return sorted(set(pins))


def _scene_cost(fa: np.ndarray, fb: np.ndarray) -> np.ndarray:
    return ((fa[:, None, :] - fb[None, :, :]) ** 2).sum(-1)


def scene_distance(a: Scene, b: Scene, action_a: Atom | None = None,
                   action_b: Atom | None = None) -> tuple[float, dict[str, str]]:
    """Exact ``min_pi sum_i |y_i - y'_pi(i)|^2`` over the unary features of two scenes.

    With actions, the primitive must be the same (else the distance is inf and the mapping empty)
    and the permutation maps ``action_a``'s arguments onto ``action_b``'s. Returns the distance and
    the mapping from ``a``'s objects onto ``b``'s. Both scenes need the same number of objects.
    """
    if a.n_objects != b.n_objects:
        raise ValueError(f"scenes with {a.n_objects} and {b.n_objects} objects cannot be matched")
    pins = _pins(a.objects, action_a, b.objects, action_b)
    if pins is None:
        return INF, {}
    cost = _scene_cost(np.asarray(a.features, float), np.asarray(b.features, float))
    perm = _assign_with_pins(cost, pins)
    return float(cost[np.arange(len(perm)), perm].sum()), {a.objects[i]: b.objects[int(j)] for i, j in enumerate(perm)}


def _assign_with_pins(cost: np.ndarray, pins: list[tuple[int, int]]) -> np.ndarray:
    m = cost.shape[0]
    perm = np.full(m, -1, dtype=np.int64)
    for i, j in pins:
        perm[i] = j
    rows = [i for i in range(m) if perm[i] < 0]
    cols = sorted(set(range(m)) - {j for _, j in pins})
    if rows:
        r, c = linear_sum_assignment(cost[np.ix_(rows, cols)])
        perm[np.array(rows)[r]] = np.array(cols)[c]
    return perm


def naive_scene_distance(a: Scene, b: Scene, action_a: Atom | None = None,
                         action_b: Atom | None = None) -> tuple[float, dict[str, str]]:
    """Reference for :func:`scene_distance`: enumerate all permutations."""
    pins = _pins(a.objects, action_a, b.objects, action_b)
    if pins is None:
        return INF, {}
    cost = _scene_cost(np.asarray(a.features, float), np.asarray(b.features, float))
    best, arg = INF, None
    for perm in itertools.permutations(range(a.n_objects)):
        if any(perm[i] != j for i, j in pins):
            continue
        c = float(cost[np.arange(len(perm)), list(perm)].sum())
        if c < best:
            best, arg = c, perm
    return best, ({a.objects[i]: b.objects[j] for i, j in enumerate(arg)} if arg is not None else {})
