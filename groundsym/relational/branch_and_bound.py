"""The exact distance of two symbolic states by branch and bound over partial assignments
(:func:`exact_state_distance`), its cost function and the root bounds of many candidates at once."""

from __future__ import annotations

import itertools
from typing import Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from .canonical import twin_groups_of
from .encoding import FORBIDDEN_COST, INF, Encoded


def permutation_cost(a: Encoded, b: Encoded, perm: np.ndarray) -> float:
    """``|a - perm(b)|_1`` where object ``i`` of ``a`` is matched with ``perm[i]`` of ``b``."""
    if a.label != b.label or np.any(a.lock != b.lock[perm]):
        return INF
    cost = int(np.sum(a.unary != b.unary[perm])) + int(np.sum(a.nullary != b.nullary))
    return float(cost + int(np.sum(a.binary != b.binary[perm][:, perm])))


def twin_groups(e: Encoded) -> np.ndarray:
    """Group id per object: objects in one group are interchangeable (swapping any two leaves e)."""
    return twin_groups_of(e.unary[None], e.binary[None], e.lock[None])[0]


class _Search:
    """Branch and bound for one pair (a, b); see :func:`exact_state_distance`."""

    def __init__(self, a: Encoded, b: Encoded, threshold: float, groups: np.ndarray | None):
        self.a, self.b = a, b
        m = a.n_objects
        self.m = m
        self.ea = a.binary.astype(np.int16)
        self.eb = b.binary.astype(np.int16)
        unary = (a.unary[:, None, :] != b.unary[None, :, :]).sum(-1).astype(float)
        self.forbid = a.lock[:, None] != b.lock[None, :]
        self.c0 = unary + np.where(self.forbid, FORBIDDEN_COST, 0.0)
        self.const = float(np.sum(a.nullary != b.nullary))
        self.groups = twin_groups(b) if groups is None else groups
        self.best = INF
        self.best_perm: np.ndarray | None = None
        self.threshold = threshold
        # objects of a: most constrained first (locked, then by total degree)
        deg = self.ea.sum(axis=(1, 2)) + self.ea.sum(axis=(0, 2)) + a.unary.sum(1)
        self.order = sorted(range(m), key=lambda i: (-int(a.lock[i] != 0), -int(deg[i]), i))

    def bound_matrix(self, rows: list[int], cols: list[int], assigned: list[tuple[int, int]]) -> np.ndarray:
        """Lower-bound cost of matching each remaining a-object with each remaining b-object."""
        ea, eb = self.ea, self.eb
        r, c = np.array(rows)[:, None], np.array(cols)[:, None]
        cost = self.c0[r, c.T]
        if assigned:
            ka = np.array([k for k, _ in assigned])[None, :]
            kb = np.array([p for _, p in assigned])[None, :]
            out_a, out_b = ea[r, ka], eb[c, kb]            # (r, d, L), (c, d, L)
            in_a, in_b = ea[ka.T, r.T].transpose(1, 0, 2), eb[kb.T, c.T].transpose(1, 0, 2)
            cost = cost + np.abs(out_a[:, None] - out_b[None]).sum(axis=(2, 3)) \
                + np.abs(in_a[:, None] - in_b[None]).sum(axis=(2, 3))
        if len(rows) > 1:
            sub_a, sub_b = ea[r, r.T], eb[c, c.T]
            do = np.abs(sub_a.sum(1)[:, None] - sub_b.sum(1)[None]).sum(-1)
            di = np.abs(sub_a.sum(0)[:, None] - sub_b.sum(0)[None]).sum(-1)
            cost = cost + 0.5 * (do + di)
        return cost

    def full_cost(self, perm: np.ndarray) -> float:
        return self.const + float(self.c0[np.arange(self.m), perm].sum()) + \
            float(np.abs(self.ea - self.eb[perm][:, perm]).sum())

    def improve(self, perm: np.ndarray) -> tuple[float, np.ndarray]:
        """Pairwise-swap local search from ``perm`` (an upper bound for the search)."""
        cost = self.full_cost(perm)
        pairs = list(itertools.combinations(range(self.m), 2))
        if not pairs:
            return cost, perm
        improved = True
        while improved:
            improved = False
            cands = np.repeat(perm[None], len(pairs), axis=0)
            idx = np.arange(len(pairs))
            i, j = np.array(pairs).T
            cands[idx, i], cands[idx, j] = perm[j], perm[i]
            costs = (self.const + self.c0[np.arange(self.m)[None], cands].sum(1)
                     + np.abs(self.ea[None] - self.eb[cands[:, :, None], cands[:, None, :]]).sum(axis=(1, 2, 3)))
            k = int(np.argmin(costs))
            if costs[k] < cost - 1e-9:
                cost, perm, improved = float(costs[k]), cands[k].copy(), True
        return cost, perm

    def run(self) -> tuple[float, np.ndarray | None]:
        m = self.m
        if m == 0:
            return self.const, np.zeros(0, dtype=np.int64)
        root = self.bound_matrix(list(range(m)), list(range(m)), [])
        r, c = linear_sum_assignment(root)
        lb = self.const + float(root[r, c].sum())
        if lb >= FORBIDDEN_COST or lb >= self.threshold:
            return (INF if lb >= FORBIDDEN_COST else lb), None
        perm = np.empty(m, dtype=np.int64)
        perm[r] = c
        self.best, self.best_perm = self.full_cost(perm), perm
        if self.best > lb + 1e-9:
            self.best, self.best_perm = self.improve(perm)
        if self.best > lb + 1e-9:
            self.descend(0, self.const, [], np.zeros(m, dtype=bool), lb)
        if self.best >= self.threshold:
            # the best found is only an upper bound; the pruned part of the tree only proves that
            # nothing there is below the threshold
            return max(lb, self.threshold), None
        return self.best, self.best_perm

    def descend(self, depth: int, cost: float, assigned: list[tuple[int, int]], used: np.ndarray,
                node_lb: float) -> None:
        if node_lb >= self.best - 1e-9 or node_lb >= self.threshold:
            return
        if depth == self.m:
            perm = np.empty(self.m, dtype=np.int64)
            for i, j in assigned:
                perm[i] = j
            self.best, self.best_perm = cost, perm
            return
        i = self.order[depth]
        rows = self.order[depth:]
        cols = [j for j in range(self.m) if not used[j]]
        seen_groups: set[int] = set()
        children = []
        for j in cols:
            g = int(self.groups[j])
            if self.forbid[i, j] or g in seen_groups:
                continue
            seen_groups.add(g)  # interchangeable b-objects: try one of them only
            inc = self.c0[i, j] + self._edge_cost(i, j, assigned)
            rest = self._rest_bound(rows[1:], [x for x in cols if x != j], assigned + [(i, j)]) if len(rows) > 1 else 0.0
            children.append((cost + inc + rest, inc, j))
        for bound, inc, j in sorted(children):
            if bound >= self.best - 1e-9 or bound >= self.threshold:
                break
            used[j] = True
            self.descend(depth + 1, cost + inc, assigned + [(i, j)], used, bound)
            used[j] = False

    def _edge_cost(self, i: int, j: int, assigned: list[tuple[int, int]]) -> float:
        if not assigned:
            return 0.0
        ka = [k for k, _ in assigned]
        kb = [p for _, p in assigned]
        return float(np.abs(self.ea[i, ka] - self.eb[j, kb]).sum() + np.abs(self.ea[ka, i] - self.eb[kb, j]).sum())

    def _rest_bound(self, rows: list[int], cols: list[int], assigned: list[tuple[int, int]]) -> float:
        mat = self.bound_matrix(rows, cols, assigned)
        r, c = linear_sum_assignment(mat)
        return float(mat[r, c].sum())


def exact_state_distance(a: Encoded, b: Encoded, threshold: float = INF,
                         groups: np.ndarray | None = None) -> tuple[float, np.ndarray | None]:
    """Exact ``min_pi |a - pi(b)|_1`` and a minimising ``perm`` (``a``'s object i -> ``perm[i]`` of b).

    With a finite ``threshold`` the search stops early: a returned perm of None means only that the
    distance is at least the returned value (which is then ``>= threshold``, or inf when the
    primitives or argument locks cannot match). ``groups`` may pass ``twin_groups(b)`` when cached.
    """
    if a.n_objects != b.n_objects:
        raise ValueError("pad both states to the same number of objects first")
    if a.label != b.label or sorted(a.lock.tolist()) != sorted(b.lock.tolist()):
        return INF, None
    return _Search(a, b, threshold, groups).run()


def root_bounds(a: Encoded, cands: Sequence[Encoded]) -> tuple[np.ndarray, np.ndarray]:
    """Cheap exact bounds on ``d(a, c)`` for many candidates of the same size at once.

    Lower bound: the linear assignment of unary mismatches plus half the in/out-degree differences
    (the branch-and-bound root). Upper bound: the true cost of that assignment. Candidates whose
    primitive or argument locks cannot match get (inf, inf).
    """
    n = len(cands)
    if n == 0:
        return np.zeros(0), np.zeros(0)
    m = a.n_objects
    cu = np.stack([c.unary for c in cands]).astype(np.int16)             # (C, M, K)
    cb = np.stack([c.binary for c in cands]).astype(np.int16)            # (C, M, M, L)
    cl = np.stack([c.lock for c in cands])
    au, ab = a.unary.astype(np.int16), a.binary.astype(np.int16)
    cost = np.abs(au[None, :, None, :] - cu[:, None, :, :]).sum(-1).astype(float)
    do = np.abs(ab.sum(1)[None, :, None, :] - cb.sum(2)[:, None, :, :]).sum(-1)
    di = np.abs(ab.sum(0)[None, :, None, :] - cb.sum(1)[:, None, :, :]).sum(-1)
    cost += 0.5 * (do + di) + np.where(a.lock[None, :, None] != cl[:, None, :], FORBIDDEN_COST, 0.0)
    const = np.array([float(np.sum(a.nullary != c.nullary)) for c in cands])
    lb, perms = np.empty(n), np.empty((n, m), dtype=np.int64)
    for k in range(n):
        r, c = linear_sum_assignment(cost[k])
        perms[k, r] = c
        lb[k] = const[k] + cost[k][r, c].sum()
    rows = np.arange(n)[:, None]
    ub = (const + np.abs(au[None] - cu[rows, perms]).sum((1, 2))
          + np.abs(ab[None] - cb[rows[:, :, None], perms[:, :, None], perms[:, None, :]]).sum((1, 2, 3)))
    bad = (lb >= FORBIDDEN_COST) | np.array([c.label != a.label for c in cands])
    lb[bad], ub[bad] = INF, INF
    return lb, ub.astype(float)


def first_minimiser(a: Encoded, b: Encoded, d: float, perm: np.ndarray) -> np.ndarray:
    """The first order (in lexicographic order of the query object at candidate position 0, 1,
    ...) among those at the exact distance ``d`` of ``a`` (the query) to ``b``; ``perm`` is some
    minimiser (``a``'s object i -> position ``perm[i]`` of ``b``), as :func:`exact_state_distance`
    returns it.

    Which of several minimising orders predicts matters to the loss, so it must not depend on the
    search that found the distance: this is the order the bit-parallel enumeration returns (it
    walks the orders in that order). Position by position, the smallest object that still admits
    a completion at ``d`` is fixed, each test an exact search with the objects fixed so far pinned
    to their positions (a lock bit of their own on both sides); the known minimiser answers
    without a search where it already puts that object there. Objects interchangeable with a
    smaller unplaced one are skipped (swapping them leaves the cost and an earlier order).
    """
    m = a.n_objects
    lock_a, lock_b = a.lock.copy(), b.lock.copy()
    base = int(max(a.lock.max(initial=0), b.lock.max(initial=0))).bit_length()
    groups = twin_groups(a)
    placed = np.zeros(m, dtype=bool)
    perm = np.asarray(perm, dtype=np.int64).copy()
    for p in range(m):
        seen: set[int] = set()
        for o in range(m):
            if placed[o] or a.lock[o] != b.lock[p] or int(groups[o]) in seen:
                continue
            seen.add(int(groups[o]))
            if perm[o] != p:
                pin = 1 << (base + p)
                trial_a, trial_b = lock_a.copy(), lock_b.copy()
                trial_a[o] |= pin
                trial_b[p] |= pin
                dist, found = exact_state_distance(Encoded(a.unary, a.binary, a.nullary, trial_a, a.label),
                                                   Encoded(b.unary, b.binary, b.nullary, trial_b, b.label), d + 0.5)
                if found is None or dist > d:
                    continue
                perm = found
            lock_a[o] |= 1 << (base + p)
            lock_b[p] |= 1 << (base + p)
            placed[o] = True
            break
    return perm
