"""Leave-one-out nearest neighbours of every transition, by classes of isomorphic items: the
engine under the loss's two predictive terms (docs/symbols.md, docs/algorithms.md).

The loss needs, at every evaluation, the exact nearest neighbours (all ties) of each state-action
pair among all the others. Items with the same canonical form
(:mod:`groundsym.relational.canonical`: equal encodings if and only if isomorphic) form a class;
a member of a class with others has those others as its neighbours at distance 0 and needs no
search. A class with one member (a *lone* class) has as neighbours every member of its nearest
other classes: up to :data:`ENUMERATE_MAX` objects found by bit-parallel enumeration of the
permutations worth trying, all queries of a pass at once; above that by branch and bound
(:mod:`groundsym.relational`). Candidates are visited in order of a count-and-degree lower bound
(:func:`profile_bound`), and exact class-to-class distances are cached across evaluations
(learned abstract states repeat a lot).

:class:`NeighbourhoodEngine` is the numpy reference and owns the caches of that search; the
compiled kernels (:mod:`groundsym.compiled`) compute the same :class:`Neighbourhood` in one call
up to :data:`ENUMERATE_MAX` objects, and :mod:`groundsym.backends` chooses between them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .relational import (ENUMERATE_MAX, INF, Encoded, all_permutations, exact_state_distance, first_minimiser,
                         pack_words, permutation_positions, permuted_words, root_bounds, twin_groups, twin_groups_of)

#: ``canonical(unary, binary, lock) -> (forms, perms)``: canonical forms of a batch of states, as
#: :func:`groundsym.relational.canonical_forms` returns them (with whatever memo the caller keeps).
CanonicalForms = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]

#: Nearest classes per lone class ``k``: ``hits[k] = (distance, [(class, sigma), ...])``.
Hits = dict[int, tuple[float, list[tuple[int, np.ndarray]]]]


def enumerates(n_objects: int) -> bool:
    """Whether the nearest classes of states with ``n_objects`` objects are found by enumerating
    permutations (bit-parallel in numpy, depth first in the compiled kernels) rather than by
    branch and bound: up to :data:`ENUMERATE_MAX` objects, for both kernels."""
    return n_objects <= ENUMERATE_MAX


@dataclass(frozen=True, eq=False)
class Neighbourhood:
    """Classes of isomorphic items and, for lone items, their nearest classes.

    ``cls`` (N,) class per item (classes numbered in sorted order of their canonical keys) and
    ``perms`` (N, M) each item's canonical order. Lone classes (one member) are ``lone`` (Q,) with
    their nearest distance ``best`` (Q,) and the hits as parallel arrays sorted by query, then
    class: ``hit_query`` (index into ``lone``), ``hit_class`` and ``hit_sigma`` (H, M), which maps
    canonical positions of the query onto canonical positions of the hit's class.
    """

    cls: np.ndarray
    perms: np.ndarray
    lone: np.ndarray
    best: np.ndarray
    hit_query: np.ndarray
    hit_class: np.ndarray
    hit_sigma: np.ndarray

    @property
    def members(self) -> list[np.ndarray]:
        """Members of each class, in increasing item order."""
        return class_members(self.cls, int(self.cls.max()) + 1 if len(self.cls) else 0)

    @property
    def hits(self) -> Hits:
        """``hits[k] = (distance, [(class, sigma), ...])`` for each lone class ``k``."""
        out: Hits = {int(k): (float(d), []) for k, d in zip(self.lone.tolist(), self.best.tolist())}
        for qi, c, sigma in zip(self.hit_query.tolist(), self.hit_class.tolist(), self.hit_sigma):
            out[int(self.lone[qi])][1].append((int(c), sigma))
        return out

    @staticmethod
    def from_hits(cls: np.ndarray, perms: np.ndarray, hits: Hits) -> "Neighbourhood":
        lone = np.array(sorted(hits), dtype=np.int64)
        best = np.array([hits[k][0] for k in lone.tolist()], dtype=float)
        rows = [(qi, c, sigma) for qi, k in enumerate(lone.tolist()) for c, sigma in hits[k][1]]
        m = perms.shape[1]
        return Neighbourhood(cls, perms, lone, best, np.array([r[0] for r in rows], dtype=np.int64),
                             np.array([r[1] for r in rows], dtype=np.int64),
                             np.array([r[2] for r in rows], dtype=np.int64).reshape(len(rows), m))


def class_members(cls: np.ndarray, n: int) -> list[np.ndarray]:
    """Items of each class ``0..n-1``, in increasing item order."""
    order = np.argsort(cls, kind="stable")
    bounds = np.searchsorted(cls[order], np.arange(n + 1))
    return [order[bounds[k]:bounds[k + 1]] for k in range(n)]


def group_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ids of equal rows (in sorted order of the rows): (index of each group's first row, id per row)."""
    rows = np.ascontiguousarray(rows)
    if rows.shape[1] == 0:                # zero-width rows are all equal
        return np.zeros(min(len(rows), 1), dtype=np.int64), np.zeros(len(rows), dtype=np.int64)
    void = rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
    _, first, inv = np.unique(void, return_index=True, return_inverse=True)
    return first, inv.ravel()


def class_profiles(u: np.ndarray, b: np.ndarray, reps: np.ndarray) -> np.ndarray:
    """Per class: unary counts, then sorted out-degrees and sorted in-degrees per binary symbol."""
    u, b = u[reps].astype(np.int64), b[reps].astype(np.int64)
    n = len(reps)
    out_deg = np.sort(b.sum(2), axis=1).reshape(n, -1)   # (n, M*L)
    in_deg = np.sort(b.sum(1), axis=1).reshape(n, -1)
    return np.concatenate([u.sum(1), out_deg, in_deg], axis=1)


def profile_bound(profile: np.ndarray, k: int | np.ndarray, n_unary: int) -> np.ndarray:
    """A lower bound on the distance of class ``k`` (or of each class in an array ``k``: one row
    each) to every class, from the profiles.

    Unary: per-symbol count differences. Binary: each mismatched ordered pair is charged to the
    out-degree of its first and the in-degree of its second object, so half the L1 difference of
    the degree sequences (sorted, which is the best 1-D matching) is admissible.
    """
    diff = np.abs(profile[None, :, :] - profile[np.atleast_1d(k)][:, None, :]).astype(float)
    bound = diff[..., :n_unary].sum(-1) + 0.5 * diff[..., n_unary:].sum(-1)
    return bound if np.ndim(k) else bound[0]


class _ClassTable:
    """The class representatives of one pass as arrays, for bit-parallel enumeration."""

    def __init__(self, reps: list[Encoded], keys: list[bytes], profile: np.ndarray, lock_sig: list[tuple]):
        self.reps, self.keys, self.profile = reps, keys, profile
        self.unary = np.stack([e.unary for e in reps])          # (C, M, K), canonical order
        self.binary = np.stack([e.binary for e in reps])        # (C, M, M, L)
        self.lock = np.stack([e.lock for e in reps])            # (C, M)
        n = len(reps)
        self.words = pack_words(np.concatenate([self.unary.reshape(n, -1), self.binary.reshape(n, -1)], axis=1))
        self.labels = np.array([e.label for e in reps])
        _, self.lock_group = np.unique(np.array([str(s) for s in lock_sig]), return_inverse=True)


_CHUNK = 16          # candidates per query and round of the enumeration
_BLOCK_ROWS = 1 << 15  # permuted query rows per array operation (bounds the memory of one round)


def _row_blocks(queries: np.ndarray, rows: list[int]) -> list[np.ndarray]:
    """Split ``queries`` into consecutive blocks of at most ``_BLOCK_ROWS`` rows (at least one query each)."""
    blocks, cur, n = [], [], 0
    for qi, r in zip(queries.tolist(), rows):
        if cur and n + r > _BLOCK_ROWS:
            blocks.append(np.array(cur))
            cur, n = [], 0
        cur.append(qi)
        n += r
    if cur:
        blocks.append(np.array(cur))
    return blocks


def _chunk_distances(qwords: list[np.ndarray], cwords: np.ndarray) -> np.ndarray:
    """Hamming distances of each query's permutations to its own candidates, minimised per query.

    ``qwords[i]`` (P_i, W): query i's permuted words; ``cwords`` (Q, C, W): its candidates' words.
    Returns (Q, C) the smallest distance over each query's permutations.
    """
    sizes = np.array([len(w) for w in qwords])
    rows = np.concatenate(qwords)                                   # (R, W)
    x = np.bitwise_count(rows[:, None, :] ^ cwords[np.repeat(np.arange(len(qwords)), sizes)])  # (R, C, W)
    dist = x[..., 0] if x.shape[-1] == 1 else x[..., 0].astype(np.uint16)
    for w in range(1, x.shape[-1]):   # (a reduction over a short last axis is slow in numpy)
        dist += x[..., w]
    return np.minimum.reduceat(dist, np.concatenate([[0], np.cumsum(sizes)[:-1]]), axis=0).astype(float)


def _first_permutation(qwords: np.ndarray, cwords: np.ndarray, d: float) -> np.ndarray:
    """Per candidate (rows of ``cwords``), the first of the query's permutations at distance ``d``."""
    dist = np.bitwise_count(qwords[:, None, :] ^ cwords[None]).sum(-1)
    return np.argmax(dist == d, axis=0)


class NeighbourhoodEngine:
    """The numpy reference of one loss's neighbourhood passes, with the caches they keep across
    evaluations: class-to-class distances (branch and bound), the twin groups of classes, the
    enumerated permutations of queries and the orders worth enumerating. Each cache is keyed by
    what its values depend on (class encodings, a query's structure), so what ran before changes
    the work, never the result.

    ``canonical`` computes the canonical forms of a batch (the caller chooses the kernels and
    keeps their memo).
    """

    def __init__(self, canonical: CanonicalForms):
        self.canonical = canonical
        self._pair_cache: dict[tuple[bytes, bytes], tuple[float, np.ndarray | None]] = {}
        self._groups: dict[bytes, np.ndarray] = {}
        self._qwords: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self._orders: dict[tuple[bytes, bytes], np.ndarray] = {}
        self._first: dict[tuple[bytes, bytes], np.ndarray] = {}

    def neighbours(self, u: np.ndarray, b: np.ndarray, lock: np.ndarray, label: np.ndarray) -> Neighbourhood:
        """Leave-one-out nearest neighbours of every item (exact, all ties), by class.

        Items with the same canonical form (isomorphic state-action pairs) form a class; a member
        of a class with others has those others as its neighbours at distance 0. A lone item's
        neighbours are all members of the nearest other classes, found by enumeration or branch
        and bound (:func:`enumerates`).
        """
        forms, perms = self.canonical(u, b, lock)
        keys = np.concatenate([forms, label.astype(np.uint8)[:, None]], axis=1)
        first, cls = group_rows(keys)
        members = class_members(cls, len(first))
        reps = [_encoded(u, b, lock, label, perms, int(first[k])) for k in range(len(first))]
        rep_keys = [keys[first[k]].tobytes() for k in range(len(first))]
        profile = class_profiles(u, b, first)
        lock_sig = [tuple(sorted(e.lock.tolist())) for e in reps]
        hits = {}
        lone = [k for k, group in enumerate(members) if len(group) == 1]
        if lone and enumerates(u.shape[1]):
            hits = self.nearest_enumerated(lone, _ClassTable(reps, rep_keys, profile, lock_sig))
        else:
            for k in lone:
                hits[k] = self._nearest_class(k, reps, rep_keys, profile, lock_sig)
        return Neighbourhood.from_hits(cls, perms, hits)

    def nearest_enumerated(self, lone: list[int], t: _ClassTable) -> Hits:
        """Nearest classes of every lone class by bit-parallel enumeration, all queries at once.

        Each query visits its candidates in chunks of 16 in order of the profile bound and stops
        once the next bound exceeds its best distance. A round compares every active query's
        permutations with its own chunk in one array operation: a Python loop per query cost more
        than the arithmetic. Compatible candidates hold the action's arguments at the same
        canonical positions, so only the permutations that bring the query's arguments there are
        enumerated, and one order of each group of interchangeable objects.
        """
        q = np.asarray(lone, dtype=np.int64)
        bound = profile_bound(t.profile, q, t.unary.shape[2])
        bound[~((t.labels[q][:, None] == t.labels[None]) & (t.lock_group[q][:, None] == t.lock_group[None]))] = INF
        bound[np.arange(len(q)), q] = INF
        order = np.argsort(bound, axis=1, kind="stable")
        sbound = np.take_along_axis(bound, order, 1)
        words, keeps = self._query_words(lone, t)
        best = np.full(len(q), INF)
        dist = np.full(bound.shape, INF)          # distance to each candidate, in bound order, where visited
        active = np.flatnonzero(sbound[:, 0] < INF)
        for start in range(0, order.shape[1], _CHUNK):
            if not len(active):
                break
            cols = slice(start, start + _CHUNK)
            for block in _row_blocks(active, [len(words[i]) for i in active]):
                d = _chunk_distances([words[i] for i in block], t.words[order[block, cols]])
                d[sbound[block, cols] >= INF] = INF
                dist[block, cols] = d
                best[block] = np.minimum(best[block], d.min(1))
            nxt = start + _CHUNK
            if nxt >= order.shape[1]:
                break
            active = active[(sbound[active, nxt] < INF) & (sbound[active, nxt] <= best[active])]
        sig = all_permutations(t.unary.shape[1])
        hits: Hits = {}
        for i, k in enumerate(lone):
            if best[i] >= INF:
                hits[k] = (INF, [])
                continue
            tied = np.sort(order[i, dist[i] == best[i]])        # ties, by class index
            first = _first_permutation(words[i], t.words[tied], best[i])
            hits[k] = (float(best[i]), [(int(c), np.argsort(sig[keeps[i][a]])) for c, a in zip(tied, first)])
        return hits

    def _query_words(self, lone: list[int], t: _ClassTable) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """Per lone class: its enumerated permutations packed into words, and their indices.

        Memoised by class encoding (learned abstract states repeat across evaluations).
        """
        miss = [k for k in lone if t.keys[k] not in self._qwords]
        if len(self._qwords) + len(miss) > 4096:
            self._qwords.clear()
            miss = list(lone)
        if miss:
            groups = twin_groups_of(t.unary[miss], t.binary[miss], t.lock[miss])
            for k, g in zip(miss, groups):
                keep = self._enumerated_orders(g, t.lock[k])
                self._qwords[t.keys[k]] = (permuted_words(t.reps[k], keep), keep)
        pairs = [self._qwords[t.keys[k]] for k in lone]
        return [w for w, _ in pairs], [kp for _, kp in pairs]

    def _enumerated_orders(self, groups: np.ndarray, lock: np.ndarray) -> np.ndarray:
        """Indices of the permutations worth enumerating for a query (memoised by its structure).

        Interchangeable objects stay in increasing order (swapping two leaves the permuted
        encoding unchanged, so one order of each group gives the same minima; table cubes in the
        tower mostly are), and the action's arguments go to the front, where every compatible
        candidate holds them (canonical order).
        """
        key = (groups.tobytes(), lock.tobytes())
        keep = self._orders.get(key)
        if keep is None:
            m = len(groups)
            pos = permutation_positions(m)               # where each object of the query lands
            mask = np.ones(len(pos), dtype=bool)
            for g in np.unique(groups):
                objs = np.flatnonzero(groups == g)
                for a, b in zip(objs[:-1], objs[1:]):
                    mask &= pos[:, a] < pos[:, b]
            keep = np.flatnonzero(mask)
            keep = keep[(lock[all_permutations(m)[keep]] == np.sort(lock)[::-1]).all(1)]
            self._orders[key] = keep
        return keep

    def _nearest_class(self, k: int, reps: list[Encoded], rep_keys: list[bytes], profile: np.ndarray,
                       lock_sig: list[tuple]) -> tuple[float, list[tuple[int, np.ndarray]]]:
        q = reps[k]
        bound = profile_bound(profile, k, q.unary.shape[1])
        for c in range(len(reps)):
            if c == k or reps[c].label != q.label or lock_sig[c] != lock_sig[k]:
                bound[c] = INF
        # stage 1: candidates in order of the profile bound, each with its root bounds, which give
        # an upper bound on the nearest distance; stage 2: exact searches where the root bound allows
        order = [int(c) for c in np.argsort(bound, kind="stable") if bound[c] < INF]
        best, low = INF, []
        for start in range(0, len(order), 8):
            chunk = order[start:start + 8]
            if bound[chunk[0]] > best:
                break
            lb, ub = root_bounds(q, [reps[c] for c in chunk])
            best = min(best, float(ub.min()))
            low += [(max(float(lb[i]), float(bound[c])), c) for i, c in enumerate(chunk)]
        keep = [(lo, c) for lo, c in low if lo <= best]
        hits = []
        for low, c in sorted(keep):
            if low > best:
                break
            d, perm = self._class_distance(rep_keys[k], rep_keys[c], q, reps[c], best + 0.5)
            if perm is None or d > best:  # (a cached exact distance may exceed the threshold)
                continue
            if d < best:
                best, hits = d, []
            hits.append((int(c), perm))
        hits = [(c, self._first_order(rep_keys[k], rep_keys[c], q, reps[c], best, perm)) for c, perm in hits]
        return best, sorted(hits, key=lambda h: h[0])   # by class, as the enumeration gives them

    def _first_order(self, ka: bytes, kb: bytes, a: Encoded, b: Encoded, d: float, perm: np.ndarray) -> np.ndarray:
        """The minimising order the enumeration (and the compiled kernels) would return for the
        pair (:func:`~groundsym.relational.first_minimiser`), memoised by the two encodings."""
        got = self._first.get((ka, kb))
        if got is None:
            if len(self._first) > 200_000:
                self._first.clear()
            got = self._first[(ka, kb)] = first_minimiser(a, b, d, perm)
        return got

    def _class_distance(self, ka: bytes, kb: bytes, a: Encoded, b: Encoded,
                        threshold: float) -> tuple[float, np.ndarray | None]:
        if kb < ka:  # search each unordered pair in one orientation only; swapped roles: inverse perm
            d, perm = self._class_distance(kb, ka, b, a, threshold)
            return d, (None if perm is None else np.argsort(perm))
        hit = self._pair_cache.get((ka, kb))
        if hit is not None and (hit[1] is not None or hit[0] >= threshold):
            return hit
        groups = self._groups.get(kb)
        if groups is None:
            groups = self._groups[kb] = twin_groups(b)
        d, perm = exact_state_distance(a, b, threshold, groups)
        if len(self._pair_cache) > 200_000:
            self._pair_cache.clear()
            self._groups.clear()
        if hit is None or perm is not None or d > hit[0]:
            self._pair_cache[(ka, kb)] = (d, perm)
        return d, perm


def _encoded(u: np.ndarray, b: np.ndarray, lock: np.ndarray, label: np.ndarray, perms: np.ndarray,
             i: int) -> Encoded:
    """Item ``i`` in its canonical order, as its class's representative."""
    p = perms[i]
    return Encoded(u[i][p], b[i][p][:, p], np.zeros(0, np.uint8), lock[i][p], int(label[i]))
