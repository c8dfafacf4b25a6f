"""Permutation-invariant distances between relational states (the paper's Appendix kernel).

``d(s, s') = min over object permutations pi of |s - pi(s')|^2``; for state-action pairs the
permutation must also map the action's arguments onto each other (and the primitive must be the
same, otherwise the distance is infinite). The paper enumerates all ``M!`` permutations; that is kept
here as the reference (:func:`naive_state_distance`, :func:`naive_scene_distance`) and the same exact
minimum is computed fast:

* continuous unary features: a linear assignment (Hungarian, ``linear_sum_assignment``), with the
  action arguments pinned to each other;
* symbolic states with binary relations (a quadratic assignment): branch and bound over partial
  assignments, bounded below by a linear assignment of unary mismatches, exact edge mismatches to
  the objects already placed and half the in/out-degree differences among the rest; the first upper
  bound is that assignment improved by pairwise swaps, and interchangeable objects (same bits, same
  relations) of the second state are tried in one order only.

Public API (used by the nearest-neighbour planners and the symbol-learning loss):

* :func:`scene_distance` -- two continuous scenes, optionally constrained by a pair of actions.
* :func:`state_distance` -- two symbolic states (frozensets of atoms) over given object lists.
* :func:`nearest` -- the nearest candidates of one state(-action) among a list, all ties returned.

Each returns the distance and the permutation as a dict mapping the first (query) state's objects
onto the second's. States with different numbers of objects are padded with empty objects
(symbolic: no atoms true); padded objects do not appear in the mapping.

Encoded symbolic states (:class:`Encoded`, built by :func:`encode_state`) hold the truth values as
arrays: unary ``M x K``, binary ``M x M x L`` (zero diagonal) and nullary bits, plus an action
``label`` and a per-object ``lock`` (bit mask of the action argument positions it fills). Two objects
may be matched only when their locks are equal, which is how an action constraint is imposed.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from .canonical import canonical_forms, twin_groups_of  # noqa: F401 (re-exported for the loss)
from .logic import Atom
from .world import Scene

INF = math.inf
_FORBID = 1e9  # cost of a forbidden match inside a linear assignment


# ----------------------------------------------------------------------------- encoding

@dataclass(frozen=True, eq=False)
class Encoded:
    """One symbolic state(-action) as arrays (see the module docstring)."""

    unary: np.ndarray     # (M, K) uint8
    binary: np.ndarray    # (M, M, L) uint8, zero diagonal
    nullary: np.ndarray   # (P0,) uint8
    lock: np.ndarray      # (M,) int64: bit k set if the object is the action's k-th argument
    label: int = -1       # primitive id, -1 when no action constrains the match

    @property
    def n_objects(self) -> int:
        return self.unary.shape[0]

    def __repr__(self) -> str:
        return (f"Encoded(M={self.n_objects}, unary={int(self.unary.sum())}, binary={int(self.binary.sum())}, "
                f"nullary={int(self.nullary.sum())}, label={self.label})")


def _lock_vector(objects: Sequence[str], action: Atom | None, size: int) -> np.ndarray:
    lock = np.zeros(size, dtype=np.int64)
    if action is not None:
        index = {o: i for i, o in enumerate(objects)}
        for k, arg in enumerate(action.args):
            if arg not in index:
                raise ValueError(f"action argument {arg!r} of {action} is not one of the objects")
            lock[index[arg]] |= 1 << k
    return lock


def encode_state(state: frozenset, objects: Sequence[str], predicates: dict[str, int],
                 action: Atom | None = None, labels: dict[str, int] | None = None,
                 size: int | None = None) -> Encoded:
    """Encode a symbolic state over ``objects`` (padded with empty objects up to ``size``).

    ``predicates`` fixes the column order (name -> arity, arities 0, 1 or 2); atoms of other
    predicates raise ValueError. ``labels`` maps primitive names to ids (default: ``{name: 0}``
    for the given action).
    """
    size = len(objects) if size is None else size
    order = {a: sorted(p for p, n in predicates.items() if n == a) for a in (0, 1, 2)}
    col = {a: {p: k for k, p in enumerate(order[a])} for a in (0, 1, 2)}
    unary = np.zeros((size, len(order[1])), dtype=np.uint8)
    binary = np.zeros((size, size, len(order[2])), dtype=np.uint8)
    nullary = np.zeros(len(order[0]), dtype=np.uint8)
    index = {o: i for i, o in enumerate(objects)}
    for atom in state:
        arity = predicates.get(atom.predicate)
        if arity is None or arity != atom.arity or arity > 2:
            raise ValueError(f"atom {atom} does not fit the predicates {predicates}")
        idx = [index[a] for a in atom.args]
        if arity == 0:
            nullary[col[0][atom.predicate]] = 1
        elif arity == 1:
            unary[idx[0], col[1][atom.predicate]] = 1
        elif idx[0] != idx[1]:  # diagonals stay zero: binary symbols hold for distinct objects only
            binary[idx[0], idx[1], col[2][atom.predicate]] = 1
    label = -1
    if action is not None:
        label = (labels or {action.predicate: 0})[action.predicate]
    return Encoded(unary, binary, nullary, _lock_vector(objects, action, size), label)


def _predicates_of(*states: frozenset) -> dict[str, int]:
    preds: dict[str, int] = {}
    for s in states:
        for a in s:
            if preds.setdefault(a.predicate, a.arity) != a.arity:
                raise ValueError(f"predicate {a.predicate} used with arities {preds[a.predicate]} and {a.arity}")
    return preds


# ----------------------------------------------------------------------------- exact symbolic distance

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
        self.c0 = unary + np.where(self.forbid, _FORBID, 0.0)
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
        if lb >= _FORBID or lb >= self.threshold:
            return (INF if lb >= _FORBID else lb), None
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
    cost += 0.5 * (do + di) + np.where(a.lock[None, :, None] != cl[:, None, :], _FORBID, 0.0)
    const = np.array([float(np.sum(a.nullary != c.nullary)) for c in cands])
    lb, perms = np.empty(n), np.empty((n, m), dtype=np.int64)
    for k in range(n):
        r, c = linear_sum_assignment(cost[k])
        perms[k, r] = c
        lb[k] = const[k] + cost[k][r, c].sum()
    rows = np.arange(n)[:, None]
    ub = (const + np.abs(au[None] - cu[rows, perms]).sum((1, 2))
          + np.abs(ab[None] - cb[rows[:, :, None], perms[:, :, None], perms[:, None, :]]).sum((1, 2, 3)))
    bad = (lb >= _FORBID) | np.array([c.label != a.label for c in cands])
    lb[bad], ub[bad] = INF, INF
    return lb, ub.astype(float)


ENUMERATE_MAX = 7  # up to this many objects, a query is compared with all candidates bit-parallel


_ALL_PERMS: dict[int, np.ndarray] = {}


def all_permutations(m: int) -> np.ndarray:
    """(m!, m) every permutation of range(m), in itertools order (memoised)."""
    if m not in _ALL_PERMS:
        _ALL_PERMS[m] = np.array(list(itertools.permutations(range(m))), dtype=np.int64).reshape(-1, m)
    return _ALL_PERMS[m]


_POSITIONS: dict[int, np.ndarray] = {}


def permutation_positions(m: int) -> np.ndarray:
    """(m!, m) inverse of :func:`all_permutations`: where each object lands (memoised)."""
    if m not in _POSITIONS:
        _POSITIONS[m] = np.argsort(all_permutations(m), axis=1)
    return _POSITIONS[m]


def _words(bits: np.ndarray) -> np.ndarray:
    """Pack rows of 0/1 into 64-bit words: (N, W) -> (N, ceil(W / 64)) uint64."""
    packed = np.packbits(bits.astype(np.uint8), axis=1)
    pad = (-packed.shape[1]) % 8
    if pad:
        packed = np.concatenate([packed, np.zeros((len(packed), pad), np.uint8)], axis=1)
    return np.ascontiguousarray(packed).view(np.uint64)


_BIT_INDEX: dict[tuple[int, int, int], np.ndarray] = {}


def _bit_index(m: int, k: int, l: int) -> np.ndarray:
    """(m!, W) positions in a flat (unary, binary) bit vector of each permuted state's bits."""
    key = (m, k, l)
    if key not in _BIT_INDEX:
        sig = all_permutations(m)
        u = (sig[:, :, None] * k + np.arange(k)[None, None, :]).reshape(len(sig), -1)
        b = m * k + ((sig[:, :, None, None] * m + sig[:, None, :, None]) * l
                     + np.arange(l)[None, None, None, :]).reshape(len(sig), -1)
        _BIT_INDEX[key] = np.concatenate([u, b], axis=1)
    return _BIT_INDEX[key]


def _flat_bits(e: Encoded) -> np.ndarray:
    return np.concatenate([e.unary.ravel(), e.binary.ravel()])


_BIT_DEST: dict[tuple[int, int, int], tuple[np.ndarray, np.ndarray]] = {}


def _bit_destinations(m: int, k: int, l: int) -> tuple[np.ndarray, np.ndarray]:
    """(n_bits, m!) the word, and its value as that word, at which each bit of a flat state lands
    under each permutation (memoised); the values are those :func:`_words` packs."""
    key = (m, k, l)
    if key not in _BIT_DEST:
        idx = _bit_index(m, k, l)                    # permuted position p takes source bit idx[s, p]
        n = idx.shape[1]
        dest = np.argsort(idx, axis=1)               # source bit j lands at dest[s, j]
        unit = _words(np.eye(n, dtype=np.uint8))     # the packed pattern of a lone bit at each position
        word = np.argmax(unit != 0, axis=1)
        value = unit[np.arange(n), word]
        _BIT_DEST[key] = (np.ascontiguousarray(word[dest].T), np.ascontiguousarray(value[dest].T))
    return _BIT_DEST[key]


def permuted_words(q: Encoded, which: np.ndarray | None = None) -> np.ndarray:
    """Permutations of ``q`` (all, or the indices ``which``) packed into 64-bit words (for enumeration).

    Built from the bits that are set, each placed where the permutation sends it: states are
    sparse, so this beats gathering every bit of every permuted state.
    """
    m, k, l = q.n_objects, q.unary.shape[1], q.binary.shape[2]
    word, value = _bit_destinations(m, k, l)
    cols = np.arange(word.shape[1]) if which is None else np.asarray(which)
    out = np.zeros((len(cols), -(-word.shape[0] // 64)), dtype=np.uint64)
    bits = np.flatnonzero(_flat_bits(q))
    if len(bits):
        v = value[bits[:, None], cols[None, :]]      # (set bits, permutations)
        if out.shape[1] == 1:
            out[:, 0] = np.bitwise_or.reduce(v, axis=0)
        else:
            w = word[bits[:, None], cols[None, :]]
            for j in range(out.shape[1]):
                out[:, j] = np.bitwise_or.reduce(np.where(w == j, v, np.uint64(0)), axis=0)
    return out


def naive_state_distance(a: Encoded, b: Encoded) -> tuple[float, np.ndarray | None]:
    """Reference: enumerate every permutation (the paper's kernel); exact, ``O(M!)``."""
    if a.label != b.label:
        return INF, None
    m = a.n_objects
    best, best_perm = INF, None
    ea, eb = a.binary.astype(np.int8), b.binary.astype(np.int8)
    const = int(np.sum(a.nullary != b.nullary))
    unary = (a.unary[:, None, :] != b.unary[None, :, :]).sum(-1)
    forbid = a.lock[:, None] != b.lock[None, :]
    rows = np.arange(m)
    gen = itertools.permutations(range(m))
    while True:
        chunk = np.array(list(itertools.islice(gen, 20000)), dtype=np.int64).reshape(-1, m)
        if len(chunk) == 0:
            break
        ok = ~forbid[rows[None], chunk].any(1)
        if not ok.any():
            continue
        chunk = chunk[ok]
        cost = const + unary[rows[None], chunk].sum(1) + \
            np.abs(ea[None] - eb[chunk[:, :, None], chunk[:, None, :]]).sum(axis=(1, 2, 3))
        k = int(np.argmin(cost))
        if cost[k] < best:
            best, best_perm = float(cost[k]), chunk[k].copy()
    return best, best_perm


# ----------------------------------------------------------------------------- continuous scenes

def _pins(objects_a: Sequence[str], action_a: Atom | None, objects_b: Sequence[str],
          action_b: Atom | None) -> list[tuple[int, int]] | None:
    """Index pairs forced by the action constraint; None if the actions cannot correspond."""
    if (action_a is None) != (action_b is None):
        raise ValueError("give both actions or neither")
    if action_a is None:
        return []
    if action_a.predicate != action_b.predicate or action_a.arity != action_b.arity:
        return None
    la = _lock_vector(objects_a, action_a, len(objects_a))
    lb = _lock_vector(objects_b, action_b, len(objects_b))
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


# ----------------------------------------------------------------------------- symbolic API

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
    preds = predicates or _predicates_of(a, b)
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
    preds = dict(predicates or _predicates_of(query, *(s for s, _ in candidates)))
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
