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
  predicts nothing wrong (docs/symbols-results.md has the figures). Literals are counted over all
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

The nearest neighbours come from :mod:`groundsym.neighbourhood` (exact distances; isomorphic
state(-action) pairs grouped by canonical form, class-to-class distances cached across
evaluations), the two predictive terms' mixtures from :mod:`groundsym.mixtures`; both, and the
symbols' truth on the data, run on the kernels the loss was given (:mod:`groundsym.backends`:
numba, or the numpy reference, the same bits).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, Sequence

import numpy as np

from .backends import new_backend
from .errors import UserError
from .neighbourhood import Neighbourhood
from .profile_neighbours import profile_neighbours
from .relational.local import Distance, local_view
from .signature_neighbours import MAX_SIGNATURE_BITS, argument_view, signature_bits, signature_neighbours
from .reward_term import linear_reward_nll
from .sparse_effects import sparse_effects_nll
from .symbols import Symbol, dataset_arrays
from .traces import Dataset


PREDICT_MODES = ("changes", "successor")
REWARD_MODELS = ("neighbour", "linear")
STATIC_MODES = ("split", "backoff")


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
    distance: str = "exact"        # the neighbours' distance: exact, local[:K], signature or auto (groundsym/relational/local.py)
    reward_model: str = "neighbour"  # the reward term's predictor: "neighbour" or "linear" (groundsym/reward_term.py)
    static: str = "split"          # static symbols in the prediction term's classes: "split" them, or "backoff"
    sparse_effects: float = 0.0    # nats per literal of a symbol a transition changes beyond its first (groundsym/sparse_effects.py; 0: off)

    def __post_init__(self) -> None:
        Distance.parse(self.distance)
        for name, allowed in (("predict", PREDICT_MODES), ("reward_model", REWARD_MODELS), ("static", STATIC_MODES)):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name} must be one of {', '.join(allowed)}, got {getattr(self, name)!r}")
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
        """The settings as JSON; the settings added later (``distance``, ``reward_model``,
        ``static``, ``sparse_effects``) only when they differ from what a file without them means."""
        doc = asdict(self)
        for name, before in _LATER_SETTINGS.items():
            if doc[name] == before:
                del doc[name]
        return doc


# settings added after files were first written, with the value a file without them means: left
# out of a file at that value, so such files read as before the settings existed (and a file of
# another value always names it, whatever the current default)
_LATER_SETTINGS = {"distance": "exact", "reward_model": "neighbour", "static": "split", "sparse_effects": 0.0}


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
    static: bool

    @staticmethod
    def of(col: np.ndarray, reg: float, data: LossData) -> "_SymbolTruth":
        truth = np.ascontiguousarray(col, dtype=np.uint8)
        changes = truth[data.pre] != truth[data.post]
        unchanged = ~changes.reshape(len(changes), -1).any(axis=1)
        return _SymbolTruth(truth, varies(col), np.packbits(truth).tobytes(), unchanged, reg, bool(unchanged.all()))


class Loss:
    """``loss(symbols) -> LossTerms`` on one dataset; caches the terms of each abstraction, and its
    backend the canonical forms and class distances, across calls."""

    def __init__(self, data: LossData, config: LossConfig = LossConfig(), kernels: str | None = None):
        """``kernels``: "numba" (compiled, :mod:`groundsym.compiled`; the default where numba is
        installed) or "numpy" (the reference). Both give the same terms, bit for bit; the
        ``backend`` of those kernels holds this loss's memos (:mod:`groundsym.backends`)."""
        self.backend = new_backend(kernels)
        self.data = data
        self.config = config
        self.sigma = config.reward_sigma or data.sigma
        self._abstraction_cache: dict[tuple, tuple[float, float, float]] = {}
        self._symbols: dict[tuple, _SymbolTruth] = {}
        n = data.n_transitions           # the passes' locks and labels (transition; reward: none)
        self._lock, self._label = data.lock.astype(np.int64), data.label.astype(np.int64)
        self._no_lock, self._no_label = np.zeros_like(self._lock), np.zeros(n, dtype=np.int64)
        self.local_steps = Distance.parse(config.distance).steps_for(data.features.shape[1])  # None: exact
        self._by_signature = Distance.parse(config.distance).by_signature(data.features.shape[1])  # local:1 views, assignment kernel
        self.evaluations = 0

    def __call__(self, symbols: Sequence[Symbol]) -> LossTerms:
        self.evaluations += 1
        c = self.config
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
            terms = self._terms(au, ab, len(unary), len(binary))
            if len(self._abstraction_cache) >= 20_000:
                self._abstraction_cache.clear()
            self._abstraction_cache[key] = terms
        effect, trans, rew = terms
        return LossTerms(c.effect_weight * effect, c.transition_weight * trans, c.reward_weight * rew,
                         c.reg_weight * reg)

    def _terms(self, au: list["_SymbolTruth"], ab: list["_SymbolTruth"], n_unary: int,
               n_binary: int) -> tuple[float, float, float]:
        """The effect, prediction and reward terms (unweighted) of the active symbols ``au``, ``ab``
        out of ``n_unary`` + ``n_binary`` candidates."""
        d = self.data
        same = d.changed.copy()
        for e in au + ab:
            same &= e.unchanged
        u, b = self._stack(au, ab)
        up, bp = u[d.pre], b[d.pre]
        if self.config.static == "backoff" and any(e.static for e in au + ab):
            cu, cb = self._stack([e for e in au if not e.static], [e for e in ab if not e.static])
            ll = self._transition_ll_backoff(u, b, cu, cb, n_unary, n_binary)
        else:
            ll = self._transition_ll(u, b, n_unary, n_binary)[0]
        trans = 0.0 - float(ll.sum())     # 0.0, not -0.0, without literals
        if self.config.sparse_effects:
            trans += sparse_effects_nll(u, b, d.pre, d.post, self.config.sparse_effects)
        if self.config.reward_model == "linear":
            rew = linear_reward_nll(self.backend.count_features(up, bp), d.reward, self.sigma)
        elif self.local_steps is None:
            rew = self._reward_nll(self.backend.neighbours(up, bp, self._no_lock, self._no_label))
        else:   # the reward's neighbours under the local distance: whole states, by profile
            rew = self._reward_nll(profile_neighbours(up, bp))
        return float(np.sum(same)), trans, rew

    def _stack(self, au: list["_SymbolTruth"], ab: list["_SymbolTruth"]) -> tuple[np.ndarray, np.ndarray]:
        """The truth of the symbols ``au``, ``ab`` as (S, M, K) and (S, M, M, L) arrays."""
        d = self.data
        u = np.stack([e.truth for e in au], axis=-1) if au else np.zeros(d.features.shape[:-1] + (0,), np.uint8)
        b = np.stack([e.truth for e in ab], axis=-1) if ab else np.zeros(d.pairs.shape[:-1] + (0,), np.uint8)
        return u, b

    def _transition_ll(self, u: np.ndarray, b: np.ndarray, n_unary: int,
                       n_binary: int) -> tuple[np.ndarray, Neighbourhood | None]:
        """Per transition ``log P(s_t+1 | s_t, a_t)`` and the neighbourhood it came from (None
        when no literal exists), under the exact or the local distance."""
        d = self.data
        if self.local_steps is None:
            return self._transition_ll_on(u, b, u[d.pre], b[d.pre], d.pre, d.post, n_unary, n_binary)
        if self._by_signature and (self.config.distance == "signature"     # auto: local:1 past a word's bits
                                   or signature_bits(u.shape[2], b.shape[3], d.lock) <= MAX_SIGNATURE_BITS):
            # local:1's views as object bits, matched by signature assignment
            su, sb, pre, post = argument_view(u, b, d.pre, d.post, d.lock)
            return self._transition_ll_on(su, sb, su[pre], sb[pre], pre, post, n_unary, n_binary, signature_neighbours)
        # prediction: each transition's states under its local mask
        lu, lb, pre, post = local_view(u, b, d.pre, d.post, d.lock, self.local_steps)
        return self._transition_ll_on(lu, lb, lu[pre], lb[pre], pre, post, n_unary, n_binary)

    def _transition_ll_backoff(self, u: np.ndarray, b: np.ndarray, cu: np.ndarray, cb: np.ndarray,
                               n_unary: int, n_binary: int) -> np.ndarray:
        """The prediction term with static symbols as a back-off refinement (``static="backoff"``).

        A static symbol (it never changes on the data: cube size) is never mispredicted; what it
        changes is the neighbours. Splitting the classes of isomorphic states by it leaves many
        transitions without an exact twin, predicted by a farther state. Here a transition whose
        class under *all* symbols holds another member is predicted by those members (they agree
        with it in everything); any other is predicted by its neighbours under the symbols that
        change (``cu``, ``cb``), which keep the static literals as they are. That is Katz's
        back-off for sparse counts (Katz 1987, *Estimation of probabilities from sparse data*,
        IEEE TASSP 35) applied to the nearest-neighbour classes."""
        full, nb = self._transition_ll(u, b, n_unary, n_binary)
        coarse, _ = self._transition_ll(cu, cb, n_unary, n_binary)
        if nb is None:
            return coarse
        sizes = np.bincount(nb.cls)
        return np.where(sizes[nb.cls] > 1, full, coarse)

    def _symbol(self, s: Symbol) -> "_SymbolTruth":
        """What the loss needs of one symbol, memoised: an annealing move changes one symbol of a
        candidate, so the others come from here."""
        key = (s.arity, s.centre.tobytes(), s.widths.tobytes())
        entry = self._symbols.get(key)
        if entry is None:
            d = self.data
            space, scale = (d.features, d.unary_scale) if s.arity == 1 else (d.pairs, d.pair_scale)
            col = self.backend.symbol_truth(s, space)
            entry = _SymbolTruth.of(col, width_penalty(s.widths, scale, self.config.width_cap), d)
            if len(self._symbols) >= 512:
                self._symbols.pop(next(iter(self._symbols)))
            self._symbols[key] = entry
        return entry

    # -- the two predictive terms
    def _transition_ll_on(self, u: np.ndarray, b: np.ndarray, up: np.ndarray, bp: np.ndarray,
                          pre: np.ndarray, post: np.ndarray, n_unary: int,
                          n_binary: int, search=None) -> tuple[np.ndarray, Neighbourhood | None]:
        """``up``, ``bp``: the states before each transition (``u[pre]``, ``b[pre]``); ``search``:
        the neighbour search if not the backend's (``signature_neighbours``)."""
        m = u.shape[1]
        # literals of every candidate symbol, pruned ones included (those are predicted right for
        # sure): a symbol must not pay for merely existing, only for its mispredictions
        n_lit = m * n_unary + m * (m - 1) * n_binary
        if n_lit == 0:
            return np.zeros(len(pre)), None
        nb = (search or self.backend.neighbours)(up, bp, self._lock, self._label)
        changes = self.config.predict == "changes"
        log_eps, log_ok = math.log(self.config.noise), math.log1p(-self.config.noise)
        return self.backend.transition_ll(u, b, pre, post, nb, changes, log_eps, log_ok, n_lit), nb

    def _reward_nll(self, nb: Neighbourhood) -> float:
        """``nb``: the neighbours of the states before each transition (exact: the backend's pass
        without locks and with one label, since a neighbour's primitive and arguments do not matter
        for the reward; local distance: by profile, :mod:`groundsym.profile_neighbours`)."""
        s2 = self.sigma ** 2
        c0 = -0.5 * math.log(2 * math.pi * s2)
        return float(-self.backend.reward_ll(nb, self.data.reward, c0, 2 * s2).sum())


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
