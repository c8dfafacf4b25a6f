"""The public symbolic API: :func:`state_distance` of two states over object lists and
:func:`nearest` candidates of a query, all ties returned, with their object mappings."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..logic import Atom
from ..world import Scene
from .branch_and_bound import exact_state_distance
from .encoding import Encoded, INF, predicates_of, encode_state
from .scenes import scene_distance


def _pad_to(objects: Sequence[str], size: int) -> tuple[str, ...]:
    return tuple(objects) + tuple(f"\0pad{k}" for k in range(size - len(objects)))


def state_distance(a: frozenset, objects_a: Sequence[str], b: frozenset, objects_b: Sequence[str],
                   action_a: Atom | None = None, action_b: Atom | None = None,
                   predicates: dict[str, int] | None = None) -> tuple[float, dict[str, str]]:
    """Exact relational Hamming distance between two symbolic states (frozensets of atoms).

    Predicates of arity 0, 1 and 2 are supported (taken from the atoms unless ``predicates`` is
    given). With actions, the primitive must match (else inf) and arguments map onto each other.
    Returns ``(distance, mapping)``, the mapping from ``objects_a`` onto ``objects_b``.
    """
    preds = predicates or predicates_of(a, b)
    size = max(len(objects_a), len(objects_b))
    labels = _labels(action_a, action_b)
    if labels is None:
        return INF, {}
    ea = encode_state(a, objects_a, preds, action_a, labels, size)
    eb = encode_state(b, objects_b, preds, action_b, labels, size)
    d, perm = exact_state_distance(ea, eb)
    return d, _mapping(perm, objects_a, _pad_to(objects_b, size))


def _labels(action_a: Atom | None, action_b: Atom | None) -> dict[str, int] | None:
    if (action_a is None) != (action_b is None):
        raise ValueError("give both actions or neither")
    if action_a is None:
        return {}
    if action_a.predicate != action_b.predicate or action_a.arity != action_b.arity:
        return None
    return {action_a.predicate: 0}


def _mapping(perm: np.ndarray | None, objects_a: Sequence[str], objects_b: Sequence[str]) -> dict[str, str]:
    if perm is None:
        return {}
    out = {}
    for i, o in enumerate(objects_a):
        target = objects_b[int(perm[i])]
        if not target.startswith("\0pad"):
            out[o] = target
    return out


@dataclass(frozen=True)
class Neighbours:
    """The nearest candidates of a query: the minimum distance, every candidate index at that
    distance (in candidate order) and, for each, the mapping of the query's objects onto its objects."""

    distance: float
    indices: tuple[int, ...]
    mappings: tuple[dict[str, str], ...]


def count_bound(a: Encoded, b: Encoded) -> float:
    """A lower bound on the exact distance that costs almost nothing: per-predicate count differences."""
    if a.label != b.label:
        return INF
    return float(np.abs(a.unary.sum(0).astype(int) - b.unary.sum(0)).sum()
                 + np.abs(a.binary.sum((0, 1)).astype(int) - b.binary.sum((0, 1))).sum()
                 + np.sum(a.nullary != b.nullary))


def nearest(query: frozenset | Scene, objects: Sequence[str] | None,
            candidates: Sequence[tuple[frozenset, Sequence[str]]] | Sequence[Scene],
            action: Atom | None = None, candidate_actions: Sequence[Atom] | None = None,
            predicates: dict[str, int] | None = None, tol: float = 1e-9) -> Neighbours:
    """All candidates nearest to ``query`` under the exact relational distance.

    Symbolic: ``query`` is a frozenset of atoms over ``objects`` and each candidate a pair
    ``(state, objects)``. Continuous: ``query`` and the candidates are :class:`Scene` objects
    (``objects`` is ignored). With ``action`` and ``candidate_actions`` the match is of
    state-action pairs (candidates with another primitive are never nearest). Candidates are visited
    in order of a cheap lower bound and skipped once it exceeds the best distance found, so the
    answer is exact. Returns :class:`Neighbours` (distance inf and no indices if none can match).
    """
    if isinstance(query, Scene):
        results = [scene_distance(query, c, action, candidate_actions[k] if candidate_actions else None)
                   for k, c in enumerate(candidates)]
        return _collect(results, tol)
    objects = tuple(objects or ())
    preds = dict(predicates or predicates_of(query, *(s for s, _ in candidates)))
    size = max([len(objects), *(len(o) for _, o in candidates)])
    prims = sorted({a.predicate for a in ([action] if action else []) + list(candidate_actions or [])})
    labels = {p: k for k, p in enumerate(prims)}
    q = encode_state(query, objects, preds, action, labels, size)
    encoded = [encode_state(s, o, preds, candidate_actions[k] if candidate_actions else None, labels, size)
               for k, (s, o) in enumerate(candidates)]
    bounds = np.array([count_bound(q, e) for e in encoded])
    best = INF
    found: list[tuple[int, float, dict[str, str]]] = []
    for k in np.argsort(bounds, kind="stable"):
        if bounds[k] > best + tol or bounds[k] == INF:
            break
        d, perm = exact_state_distance(q, encoded[k], threshold=best + 2 * tol if best < INF else INF)
        if perm is None:
            continue
        best = min(best, d)
        found.append((int(k), d, _mapping(perm, objects, _pad_to(candidates[k][1], size))))
    return _collect([(d, m) for _, d, m in sorted(found)], tol, [k for k, _, _ in sorted(found)])


def _collect(results: list[tuple[float, dict[str, str]]], tol: float,
             index: list[int] | None = None) -> Neighbours:
    index = list(range(len(results))) if index is None else index
    finite = [d for d, _ in results if d < INF]
    if not finite:
        return Neighbours(INF, (), ())
    best = min(finite)
    hits = [(index[k], m) for k, (d, m) in enumerate(results) if d <= best + tol]
    hits.sort(key=lambda h: h[0])
    return Neighbours(best, tuple(k for k, _ in hits), tuple(m for _, m in hits))
