"""The symbol-learning loss of the paper's Eq. (1), with leave-one-out nearest-neighbour predictors.

``L = w_effect * L_effect + w_transition * L_prediction + w_reward * L_reward + w_reg * |Sigma|^2``

* **Effect discrimination.** The printed Eq. (2) *adds* ``sum |s_t - s_t+1|_1`` to a loss that is
  minimised, yet the text says the term *rewards* symbols that change when a primitive acts
  ("motor primitives always change object configurations ... learned symbols shall reflect these
  changes"). We follow the text: each transition whose geometry changed (some feature moved by
  more than ``change_tol`` of its spread, so physics jitter does not count) while its abstract
  state did not costs 1. (Rewarding raw Hamming flips instead gives dense, flickering symbols.)
* **Prediction.** ``-sum_t log P(s_t+1 | s_t, a_t)``: the nearest neighbour of ``(s_t, a_t)`` among
  the *other* transitions (same primitive, arguments mapped onto each other) predicts the
  successor, mapped through the best permutation; each literal is wrong with probability
  ``noise``. A neighbour at distance > 0 predicts its *changes* (``predict="changes"``, the
  default): the literals its primitive changed take the neighbour's new values, the others keep
  ``s_t``'s. Copying its whole successor (``predict="successor"``, the paper's words read
  literally) charges every literal in which the two states differ as a misprediction, so any
  symbol that splits the data (a static ``ball``) costs prediction accuracy even where it
  predicts nothing wrong (docs/symbols.md has the figures). Literals are counted over all
  candidate symbols (``K M + L M (M-1)``), so a symbol pays for its mispredictions, not for
  existing. Ties at the minimal distance form an equal mixture. A transition with no comparable
  neighbour is predicted to change nothing.
* **Reward.** ``-sum_t log P(r_t | s_t)``: a Gaussian around the leave-one-out nearest neighbour's
  reward (a mixture over ties). Its ``sigma`` is set from the data: ``sigma_factor`` times the median
  size of the reward changes between consecutive scenes (about one stacked cube in the tower), so
  that one more stacked cube is worth several sigma; a 3x wider sigma lost the binary symbol.
* **Regulariser.** For every symbol that is neither never nor always true on the data, the squared
  log of its widths relative to the data's spread per feature dimension, the ratio capped at
  ``width_cap`` (a dimension the symbol ignores costs ``ln(width_cap)^2``, not more the wider it
  is). Symbols never or always true carry no information; they are left out of every term
  (pruned), so an unneeded symbol is cheapest switched off.

Distances are exact (:mod:`groundsym.relational`); the pass is fast because isomorphic state(-action)
pairs are grouped by canonical form (a query with an isomorphic partner has distance 0 and needs no
search), other queries visit candidate classes in order of a count bound, and exact class-to-class
distances are cached across evaluations (learned abstract states repeat a lot).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, Sequence

import numpy as np

from . import compiled
from .errors import UserError
from .relational import (ENUMERATE_MAX, INF, Encoded, _words, all_permutations, canonical_forms,
                         exact_state_distance, permutation_positions, permuted_words, root_bounds, twin_groups, twin_groups_of)
from .symbols import Symbol, binary_truth, dataset_arrays, unary_truth
from .traces import Dataset


PREDICT_MODES = ("changes", "successor")
KERNELS = ("numba", "numpy")


@dataclass(frozen=True)
class LossConfig:
    """Weights and model parameters of the loss (defaults: docs/symbols.md)."""

    effect_weight: float = 1.0
    transition_weight: float = 1.0
    reward_weight: float = 1.0
    reg_weight: float = 1.0
    noise: float = 0.05            # per-literal probability that the NN prediction is wrong
    sigma_factor: float = 0.5      # reward sigma = this x the median reward step in the data
    change_tol: float = 0.05       # geometry changed: some feature moved > this x its spread
    reward_sigma: float | None = None  # fixed sigma instead (None: from the data)
    predict: str = "changes"       # what a neighbour at distance > 0 predicts: its "changes" or its "successor"
    width_cap: float = 3.0         # widths beyond this x the spread cost as at it (0: no cap)

    def __post_init__(self) -> None:
        if self.predict not in PREDICT_MODES:
            raise ValueError(f"predict must be one of {', '.join(PREDICT_MODES)}, got {self.predict!r}")
        if not 0 < self.noise < 0.5:
            raise ValueError(f"noise must be in (0, 0.5), got {self.noise}")
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, (int, float)) and not math.isfinite(v):
                raise ValueError(f"{f.name} must be a finite number, got {v}")
            if f.name == "sigma_factor" and v <= 0:   # sigma 0: the reward term takes the log of 0
                raise ValueError(f"sigma_factor must be positive, got {v}")
            if isinstance(v, (int, float)) and v < 0:
                raise ValueError(f"{f.name} must be non-negative, got {v}")

    def to_doc(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class LossTerms:
    """The weighted terms of one evaluation; ``total`` is their sum."""

    effect: float
    transition: float
    reward: float
    regulariser: float

    @property
    def total(self) -> float:
        return self.effect + self.transition + self.reward + self.regulariser

    def __str__(self) -> str:
        return (f"loss {self.total:.2f} (effect {self.effect:.1f}, transition {self.transition:.1f}, "
                f"reward {self.reward:.1f}, reg {self.regulariser:.2f})")

    def to_doc(self) -> dict[str, float]:
        return {"total": self.total, "effect": self.effect, "transition": self.transition,
                "reward": self.reward, "regulariser": self.regulariser}


@dataclass(frozen=True, eq=False)
class LossData:
    """Everything the loss needs from a continuous dataset, as arrays (built once)."""

    features: np.ndarray      # (S, M, n) all scenes
    pairs: np.ndarray         # (S, M, M, n')
    pre: np.ndarray           # (T,) scene index of s_t
    post: np.ndarray          # (T,) scene index of s_t+1
    label: np.ndarray         # (T,) primitive id
    lock: np.ndarray          # (T, M) action-argument masks
    reward: np.ndarray        # (T,) r_t
    changed: np.ndarray       # (T,) bool: the geometry changed
    sigma: float              # reward sigma from the data
    unary_scale: np.ndarray   # (n,) spread of the unary features
    pair_scale: np.ndarray    # (n',) spread of the pair features (distinct pairs)
    change_tol: float = LossConfig.change_tol  # the setting ``changed`` was computed with

    @property
    def n_transitions(self) -> int:
        return len(self.pre)


def reward_sigma(ds: Dataset, factor: float) -> float:
    """``factor`` x the median size of the reward changes between consecutive scenes.

    Changes smaller than 5% of the largest are physics jitter and ignored; without any change the
    reward term is constant, and sigma is 1.
    """
    steps = np.concatenate([np.abs(np.diff([s.reward for s in tr.scenes])) for tr in ds.traces] or [np.zeros(0)])
    if steps.size == 0 or steps.max() <= 0:
        return 1.0
    return float(factor * np.median(steps[steps > 0.05 * steps.max()]))


def prepare(ds: Dataset, config: LossConfig = LossConfig(), path: str = "<traces>") -> LossData:
    """Arrays of a dataset for the loss; UserError for data symbol learning cannot use."""
    if ds.n_transitions < 2:
        raise UserError(f"{path}: traces: {ds.n_transitions} transitions, need at least 2 to learn symbols")
    features, pairs = dataset_arrays(ds)
    prims = sorted(ds.primitives)
    pre, post, label, locks, reward = [], [], [], [], []
    base = 0
    for tr in ds.traces:
        index = {o: i for i, o in enumerate(tr.objects)}
        for t, a in enumerate(tr.actions):
            pre.append(base + t)
            post.append(base + t + 1)
            label.append(prims.index(a.predicate))
            lock = np.zeros(len(tr.objects), dtype=np.int64)
            for k, arg in enumerate(a.args):
                lock[index[arg]] |= 1 << k
            locks.append(lock)
            reward.append(tr.scenes[t].reward)
        base += len(tr.scenes)
    m = features.shape[1]
    off = ~np.eye(m, dtype=bool)
    spread = lambda x: np.maximum(x.std(0), 1e-9)  # noqa: E731
    unary_scale = spread(features.reshape(-1, features.shape[-1]))
    pre_a, post_a = np.array(pre), np.array(post)
    # physics jitters: a transition changed the geometry when some feature of some object moved by
    # more than change_tol of that feature's spread (a failed grasp moves cubes by fractions of a mm)
    moved = np.abs(features[post_a] - features[pre_a]) / unary_scale
    changed = moved.max(axis=(1, 2)) > config.change_tol
    if not changed.any():
        raise UserError(f"{path}: traces: no transition changes the geometry; there is nothing to learn symbols from")
    sigma = config.reward_sigma or reward_sigma(ds, config.sigma_factor)
    return LossData(features, pairs, pre_a, post_a, np.array(label), np.array(locks),
                    np.array(reward, dtype=float), changed, sigma,
                    unary_scale, spread(pairs[:, off].reshape(-1, pairs.shape[-1])), config.change_tol)


@dataclass(frozen=True, eq=False)
class _SymbolTruth:
    """One symbol on the data: its truth (S, M) or (S, M, M) as uint8 (diagonal false), whether it
    is neither never nor always true (``active``: only those enter the loss), its truth packed as
    bytes (part of the abstraction's cache key), which transitions leave it unchanged, and its
    regulariser."""

    truth: np.ndarray
    active: bool
    packed: bytes
    unchanged: np.ndarray
    reg: float

    @staticmethod
    def of(col: np.ndarray, reg: float, data: LossData) -> "_SymbolTruth":
        truth = np.ascontiguousarray(col, dtype=np.uint8)
        changes = truth[data.pre] != truth[data.post]
        unchanged = ~changes.reshape(len(changes), -1).any(axis=1)
        return _SymbolTruth(truth, varies(col), np.packbits(truth).tobytes(), unchanged, reg)


class Loss:
    """``loss(symbols) -> LossTerms`` on one dataset; caches class distances across calls."""

    def __init__(self, data: LossData, config: LossConfig = LossConfig(), kernels: str | None = None):
        """``kernels``: "numba" (compiled, :mod:`groundsym.compiled`; the default where numba is
        installed) or "numpy" (the reference). Both give the same terms, bit for bit."""
        if kernels is None:
            kernels = "numba" if compiled.AVAILABLE else "numpy"
        if kernels not in KERNELS or (kernels == "numba" and not compiled.AVAILABLE):
            raise ValueError(f"kernels must be one of {', '.join(KERNELS)} (numba installed), got {kernels!r}")
        self.kernels = kernels
        self.data = data
        self.config = config
        self.sigma = config.reward_sigma or data.sigma
        self._pair_cache: dict[tuple[bytes, bytes], tuple[float, np.ndarray | None]] = {}
        self._groups: dict[bytes, np.ndarray] = {}
        self._canon_cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self._abstraction_cache: dict[tuple, tuple[float, float, float]] = {}
        self._symbols: dict[tuple, _SymbolTruth] = {}
        self._off_diagonal = ~np.eye(data.features.shape[1], dtype=bool)
        self._qwords: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self._orders: dict[tuple[bytes, bytes], np.ndarray] = {}
        self._pair_memo = compiled.new_memo() if kernels == "numba" else None
        self._state_memo = compiled.new_state_memo() if kernels == "numba" else None
        self._intern = compiled.new_intern() if kernels == "numba" else None
        self._memo_sizes = (0, 0, 0)
        n = data.n_transitions           # the passes' locks and labels (transition; reward: none)
        self._lock, self._label = data.lock.astype(np.int64), data.label.astype(np.int64)
        self._no_lock, self._no_label = np.zeros_like(self._lock), np.zeros(n, dtype=np.int64)
        self.evaluations = 0

    def __call__(self, symbols: Sequence[Symbol]) -> LossTerms:
        self.evaluations += 1
        d, c = self.data, self.config
        unary = [self._symbol(s) for s in symbols if s.arity == 1]
        binary = [self._symbol(s) for s in symbols if s.arity == 2]
        au = [e for e in unary if e.active]
        ab = [e for e in binary if e.active]
        reg = sum(e.reg for e in au)
        reg += sum(e.reg for e in ab)
        # the other terms depend on the abstraction only: annealing moves often leave it unchanged
        key = (len(unary), len(binary), tuple(e.packed for e in au), tuple(e.packed for e in ab))
        terms = self._abstraction_cache.get(key)
        if terms is None:
            same = d.changed.copy()
            for e in au + ab:
                same &= e.unchanged
            u = np.stack([e.truth for e in au], axis=-1) if au else np.zeros(d.features.shape[:-1] + (0,), np.uint8)
            b = np.stack([e.truth for e in ab], axis=-1) if ab else np.zeros(d.pairs.shape[:-1] + (0,), np.uint8)
            up, bp = u[d.pre], b[d.pre]
            terms = (float(np.sum(same)), self._transition_nll(u, b, up, bp, len(unary), len(binary)),
                     self._reward_nll(up, bp))
            if len(self._abstraction_cache) >= 20_000:
                self._abstraction_cache.clear()
            self._abstraction_cache[key] = terms
        effect, trans, rew = terms
        return LossTerms(c.effect_weight * effect, c.transition_weight * trans, c.reward_weight * rew,
                         c.reg_weight * reg)

    def _symbol(self, s: Symbol) -> "_SymbolTruth":
        """What the loss needs of one symbol, memoised: an annealing move changes one symbol of a
        candidate, so the others come from here."""
        key = (s.arity, s.centre.tobytes(), s.widths.tobytes())
        entry = self._symbols.get(key)
        if entry is None:
            d = self.data
            space, scale = (d.features, d.unary_scale) if s.arity == 1 else (d.pairs, d.pair_scale)
            if self.kernels == "numba":
                col = compiled.rbf_holds(space.reshape(-1, space.shape[-1]), s.centre, s.widths).reshape(space.shape[:-1])
                if s.arity == 2:
                    col &= self._off_diagonal
            else:
                col = (unary_truth if s.arity == 1 else binary_truth)([s], space)[..., 0]
            entry = _SymbolTruth.of(col, width_penalty(s.widths, scale, self.config.width_cap), d)
            if len(self._symbols) >= 512:
                self._symbols.pop(next(iter(self._symbols)))
            self._symbols[key] = entry
        return entry

    # -- nearest neighbours
    def neighbours(self, u: np.ndarray, b: np.ndarray, lock: np.ndarray, label: np.ndarray) -> "Neighbourhood":
        """Leave-one-out nearest neighbours of every item (exact, all ties), by class.

        Items with the same canonical form (isomorphic state-action pairs) form a class; a member
        of a class with others has those others as its neighbours at distance 0. A lone item's
        neighbours are all members of the nearest other classes, found by branch and bound.
        """
        if self.kernels == "numba" and u.shape[1] <= ENUMERATE_MAX:
            return self._neighbours_compiled(u, b, lock, label)
        if self.kernels == "numba" and u.shape[1] <= 255:
            if len(self._state_memo) > 200_000:
                self._state_memo = compiled.new_state_memo()
            lock64 = lock.astype(np.int64, copy=False)
            forms, perms = compiled.canonical_batch(u, b, lock64, self._state_memo)
        else:
            forms, perms = canonical_forms(u, b, lock, self._canon_cache, self.kernels)
        keys = np.concatenate([forms, label.astype(np.uint8)[:, None]], axis=1)
        first, cls = group_rows(keys)
        members = class_members(cls, len(first))
        reps = [self._encoded(u, b, lock, label, perms, int(first[k])) for k in range(len(first))]
        rep_keys = [keys[first[k]].tobytes() for k in range(len(first))]
        profile = _profiles(u, b, first)
        lock_sig = [tuple(sorted(e.lock.tolist())) for e in reps]
        hits = {}
        lone = [k for k, group in enumerate(members) if len(group) == 1]
        if lone and u.shape[1] <= ENUMERATE_MAX:
            hits = self._nearest_enumerated(lone, _ClassTable(reps, rep_keys, profile, lock_sig))
        else:
            for k in lone:
                hits[k] = self._nearest_class(k, reps, rep_keys, profile, lock_sig)
        return Neighbourhood.from_hits(cls, perms, hits)

    def _neighbours_compiled(self, u: np.ndarray, b: np.ndarray, lock: np.ndarray,
                             label: np.ndarray) -> "Neighbourhood":
        """:meth:`neighbours` in one compiled call (:func:`compiled.neighbourhood`): the same
        classes, hits and permutations, without the array glue between the steps."""
        states, classes, pairs = self._memo_sizes      # bounded memory: memos start afresh (same results)
        if states > 200_000:
            self._state_memo = compiled.new_state_memo()
        if classes > 500_000 or pairs > 4_000_000:
            self._intern, self._pair_memo = compiled.new_intern(), compiled.new_memo()
        *fields, self._memo_sizes = compiled.neighbourhood(
            u, b, np.asarray(lock, dtype=np.int64), np.asarray(label, dtype=np.int64),
            self._state_memo, *self._intern, self._pair_memo)
        return Neighbourhood(*fields)

    def _nearest_enumerated(self, lone: list[int], t: "_ClassTable") -> dict[int, tuple[float, list[tuple[int, np.ndarray]]]]:
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
        hits: dict[int, tuple[float, list[tuple[int, np.ndarray]]]] = {}
        for i, k in enumerate(lone):
            if best[i] >= INF:
                hits[k] = (INF, [])
                continue
            tied = np.sort(order[i, dist[i] == best[i]])        # ties, by class index
            first = _first_permutation(words[i], t.words[tied], best[i])
            hits[k] = (float(best[i]), [(int(c), np.argsort(sig[keeps[i][a]])) for c, a in zip(tied, first)])
        return hits

    def _query_words(self, lone: list[int], t: "_ClassTable") -> tuple[list[np.ndarray], list[np.ndarray]]:
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

    def _encoded(self, u, b, lock, label, perms, i) -> Encoded:
        p = perms[i]
        return Encoded(u[i][p], b[i][p][:, p], np.zeros(0, np.uint8), lock[i][p], int(label[i]))

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
        return best, sorted(hits, key=lambda h: h[0])   # by class, as the enumeration gives them

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

    # -- the two predictive terms
    def _transition_nll(self, u: np.ndarray, b: np.ndarray, up: np.ndarray, bp: np.ndarray,
                        n_unary: int, n_binary: int) -> float:
        """``up``, ``bp``: the states before each transition (``u[pre]``, ``b[pre]``)."""
        d = self.data
        m = u.shape[1]
        # literals of every candidate symbol, pruned ones included (those are predicted right for
        # sure): a symbol must not pay for merely existing, only for its mispredictions
        n_lit = m * n_unary + m * (m - 1) * n_binary
        if n_lit == 0:
            return 0.0
        nb = self.neighbours(up, bp, self._lock, self._label)
        changes = self.config.predict == "changes"
        log_eps, log_ok = math.log(self.config.noise), math.log1p(-self.config.noise)
        if self.kernels == "numba":
            item, weight, diff, top = compiled.transition_mixture(
                u, b, d.pre, d.post, nb.perms, nb.cls, nb.lone, nb.hit_query, nb.hit_class, nb.hit_sigma, changes,
                log_eps, log_ok, n_lit)
            return float(-mixture_finish(top, *compiled.mixture_sums(item, np.exp(diff), weight, len(d.pre))).sum())
        item, mis, weight = transition_entries(u, b, d.pre, d.post, nb, changes)
        lp = mis * log_eps + (n_lit - mis) * log_ok
        return float(-mixture_ll(item, lp, weight, len(d.pre)).sum())

    def _reward_nll(self, up: np.ndarray, bp: np.ndarray) -> float:
        d = self.data
        n = len(d.pre)
        nb = self.neighbours(up, bp, self._no_lock, self._no_label)
        s2 = self.sigma ** 2
        c0 = -0.5 * math.log(2 * math.pi * s2)
        if self.kernels == "numba":
            item, diff, top = compiled.reward_mixture(nb.cls, nb.lone, nb.hit_query, nb.hit_class, d.reward, c0, 2 * s2)
            return float(-mixture_finish(top, *compiled.mixture_sums(item, np.exp(diff), np.ones(len(item)), n)).sum())
        item, other = reward_entries(nb)
        lp = c0 - (d.reward[item] - d.reward[other]) ** 2 / (2 * s2)
        return float(-mixture_ll(item, lp, np.ones(len(item)), n).sum())


def _sorted_entries(columns: list[list[int]], n: int) -> tuple[np.ndarray, ...]:
    """Entry columns (item, partner, values...) as arrays, sorted by item, then partner."""
    arrays = [np.array(c, dtype=np.int64) for c in columns]
    order = np.argsort(arrays[0] * (n + 1) + arrays[1], kind="stable")
    return tuple(a[order] for a in arrays)


def transition_entries(u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray, nb: "Neighbourhood",
                       changes: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What predicts each transition's successor: entries ``(item, mispredicted literals, weight)``,
    sorted by item, then the predicting transition (the reference of ``compiled.transition_entries``).

    A member of a class with others is predicted by each other member through the identity (one
    entry per distinct successor pattern, weighted by how many others have it); a lone item by
    every member of its nearest classes, through the hit's permutation (with ``changes``: the
    literals the neighbour's primitive changed take its values, the others keep the item's own);
    a lone item without a comparable neighbour is predicted to change nothing.
    """
    n, m = nb.perms.shape
    idx = np.arange(n)[:, None]
    perms = nb.perms
    succ_u = u[post][idx, perms]                                   # successors, canonical order
    succ_b = b[post][idx[:, :, None], perms[:, :, None], perms[:, None, :]]
    flat = np.concatenate([succ_u.reshape(n, -1), succ_b.reshape(n, -1)], axis=1)
    item: list[int] = []
    partner: list[int] = []
    mis: list[int] = []
    weight: list[int] = []
    hits, members = nb.hits, nb.members
    for k, group in enumerate(members):
        if len(group) > 1:
            first, pattern = group_rows(flat[group])
            counts = np.bincount(pattern, minlength=len(first))
            for a, i in enumerate(group.tolist()):
                for q in range(len(first)):
                    w = int(counts[q]) - int(pattern[a] == q)   # the other members with pattern q
                    if w > 0:
                        item.append(i)
                        partner.append(int(group[first[q]]))
                        mis.append(int((flat[i] != flat[group[first[q]]]).sum()))
                        weight.append(w)
            continue
        i = int(group[0])
        if not hits[k][1]:             # no comparable neighbour: predict no change
            item.append(i)
            partner.append(i)
            mis.append(int((u[pre[i]] != u[post[i]]).sum() + (b[pre[i]] != b[post[i]]).sum()))
            weight.append(1)
            continue
        own, now = perms[i], pre[i]
        for c, sigma in hits[k][1]:
            for j in members[c].tolist():
                obj = perms[j][sigma]                      # neighbour objects in the item's canonical order
                pred_u = u[post[j]][obj]
                pred_b = b[post[j]][obj[:, None], obj[None, :]]
                if changes:  # the literals the neighbour's primitive changed take its values; the rest stay
                    was_u, was_b = u[pre[j]][obj], b[pre[j]][obj[:, None], obj[None, :]]
                    pred_u = np.where(was_u != pred_u, pred_u, u[now][own])
                    pred_b = np.where(was_b != pred_b, pred_b, b[now][own[:, None], own[None, :]])
                item.append(i)
                partner.append(j)
                mis.append(int((pred_u != succ_u[i]).sum() + (pred_b != succ_b[i]).sum()))
                weight.append(1)
    item_a, _, mis_a, weight_a = _sorted_entries([item, partner, mis, weight], n)
    return item_a, mis_a, weight_a


def reward_entries(nb: "Neighbourhood") -> tuple[np.ndarray, np.ndarray]:
    """Who predicts each transition's reward: entries ``(item, neighbour)`` sorted by item, then
    neighbour (the reference of ``compiled.reward_entries``): the other members of its class,
    or, for a lone item, every member of its nearest classes."""
    item: list[int] = []
    other: list[int] = []
    members = nb.members
    hits = nb.hits
    for k, group in enumerate(members):
        if len(group) > 1:
            for i in group.tolist():
                for j in group.tolist():
                    if i != j:
                        item.append(i)
                        other.append(j)
            continue
        for c, _ in hits[k][1]:
            for j in members[c].tolist():
                item.append(int(group[0]))
                other.append(j)
    return _sorted_entries([item, other], len(nb.cls))


class _ClassTable:
    """The class representatives of one pass as arrays, for bit-parallel enumeration."""

    def __init__(self, reps: list[Encoded], keys: list[bytes], profile: np.ndarray, lock_sig: list[tuple]):
        self.reps, self.keys, self.profile = reps, keys, profile
        self.unary = np.stack([e.unary for e in reps])          # (C, M, K), canonical order
        self.binary = np.stack([e.binary for e in reps])        # (C, M, M, L)
        self.lock = np.stack([e.lock for e in reps])            # (C, M)
        n = len(reps)
        self.words = _words(np.concatenate([self.unary.reshape(n, -1), self.binary.reshape(n, -1)], axis=1))
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
    def hits(self) -> dict[int, tuple[float, list[tuple[int, np.ndarray]]]]:
        """``hits[k] = (distance, [(class, sigma), ...])`` for each lone class ``k``."""
        out: dict[int, tuple[float, list[tuple[int, np.ndarray]]]] = {
            int(k): (float(d), []) for k, d in zip(self.lone.tolist(), self.best.tolist())}
        for qi, c, sigma in zip(self.hit_query.tolist(), self.hit_class.tolist(), self.hit_sigma):
            out[int(self.lone[qi])][1].append((int(c), sigma))
        return out

    @staticmethod
    def from_hits(cls: np.ndarray, perms: np.ndarray,
                  hits: dict[int, tuple[float, list[tuple[int, np.ndarray]]]]) -> "Neighbourhood":
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


def mixture_ll(item: np.ndarray, lp: np.ndarray, weight: np.ndarray, n: int) -> np.ndarray:
    """Per item ``0..n-1``: ``log(sum_e weight_e exp(lp_e) / sum_e weight_e)`` over its entries.

    Entries come sorted by item and accumulate in that order (``np.add.at`` is sequential), so
    the result is a function of the entries alone, whichever kernels produced them. An item
    without entries gets 0.
    """
    top = np.full(n, -np.inf)
    np.maximum.at(top, item, lp)
    acc = np.zeros(n)
    np.add.at(acc, item, weight * np.exp(lp - top[item]))
    cnt = np.zeros(n)
    np.add.at(cnt, item, weight)
    return mixture_finish(top, acc, cnt)


def mixture_finish(top: np.ndarray, acc: np.ndarray, cnt: np.ndarray) -> np.ndarray:
    """The last step of :func:`mixture_ll` (shared with the compiled path): ``top + log(acc / cnt)``
    per item, 0 for an item without entries."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ll = top + np.log(acc) - np.log(cnt)
    ll[cnt == 0] = 0.0
    return ll


def group_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ids of equal rows (in sorted order of the rows): (index of each group's first row, id per row)."""
    rows = np.ascontiguousarray(rows)
    if rows.shape[1] == 0:                # zero-width rows are all equal
        return np.zeros(min(len(rows), 1), dtype=np.int64), np.zeros(len(rows), dtype=np.int64)
    void = rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
    _, first, inv = np.unique(void, return_index=True, return_inverse=True)
    return first, inv.ravel()


def _profiles(u: np.ndarray, b: np.ndarray, reps: np.ndarray) -> np.ndarray:
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


def width_penalty(widths: np.ndarray, scale: np.ndarray, cap: float = 0.0) -> float:
    """``sum ln(w / spread)^2`` over the dimensions, with ``w / spread`` capped at ``cap`` (when > 0).

    A width several times the data's spread no longer shapes the symbol's region on the data: the
    symbol ignores that dimension. Without the cap, ignoring costs more the wider the width, so a
    symbol that holds by size alone (``ball``, at every position) pays ~6 nats per ignored dimension
    and loses to symbols that say less; with it, ignoring costs ``ln(cap)^2`` (1.2 nats at 3).
    """
    ratio = widths / scale
    if cap > 0:
        ratio = np.minimum(ratio, cap)
    return float(np.sum(np.log(ratio) ** 2))


def varies(truth: np.ndarray) -> bool:
    """A symbol's truth, (S, M) unary or (S, M, M) binary, is neither never nor always true (a
    binary symbol's diagonal excluded): only such symbols carry information, the others are pruned."""
    flat = truth if truth.ndim == 2 else truth[:, ~np.eye(truth.shape[1], dtype=bool)]
    return bool(flat.any() and not flat.all())


def active_columns(u: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which unary / binary symbols (last axis of ``u`` / ``b``) vary (:func:`varies`)."""
    return (np.array([varies(u[..., k]) for k in range(u.shape[-1])], dtype=bool),
            np.array([varies(b[..., k]) for k in range(b.shape[-1])], dtype=bool))
