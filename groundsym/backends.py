"""The loss's kernels, chosen once by name: numpy (the reference) or numba (compiled, the same bits).

Every step of the loss that has compiled twins (a symbol's truth on the data, canonical forms,
the neighbourhood pass, the two predictive terms' mixtures) is a method of a *backend*, and
:data:`BACKENDS` is the one table from a name to a backend, as pynndescent keeps its distance
kernels in one table by name: the loss asks for a backend once (:func:`new_backend`) and never
tests the name again. Both backends give the same terms bit for bit (docs/symbols.md,
``tests/test_compiled.py``).

A backend holds the memos of one loss (canonical forms of states, class-to-class distances,
interned class keys): each is keyed by what its values depend on, so what ran before changes
the work, never the result.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from functools import cache
from typing import ClassVar

import numpy as np

from . import compiled
from .mixtures import mixture_finish, mixture_ll, reward_entries, transition_entries
from .neighbourhood import Neighbourhood, NeighbourhoodEngine
from .reward_term import count_features
from .relational import canonical_forms
from .symbols import Symbol, binary_truth, unary_truth


class Backend(ABC):
    """What the loss computes through its kernels; one backend object per loss (it owns the
    loss's memos). Subclasses implement the steps; the neighbourhood pass defaults to the numpy
    engine (:class:`NeighbourhoodEngine`) with this backend's canonical forms."""

    name: ClassVar[str]

    def __init__(self) -> None:
        self._canon_cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self.engine = NeighbourhoodEngine(self.canonical_forms)

    @staticmethod
    def available() -> bool:
        """Whether these kernels can run here."""
        return True

    @abstractmethod
    def canonical_forms(self, u: np.ndarray, b: np.ndarray, lock: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Canonical forms and orders of a batch of states (``relational.canonical_forms``)."""

    def neighbours(self, u: np.ndarray, b: np.ndarray, lock: np.ndarray, label: np.ndarray) -> Neighbourhood:
        """Leave-one-out nearest neighbours of every item, by class (:mod:`groundsym.neighbourhood`)."""
        return self.engine.neighbours(u, b, lock, label)

    @abstractmethod
    def symbol_truth(self, s: Symbol, space: np.ndarray) -> np.ndarray:
        """``s`` on every object (S, M) or ordered pair (S, M, M) of the data (``space``: the
        features or pair features), bool; a binary symbol never holds on the diagonal."""

    @abstractmethod
    def transition_ll(self, u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray, nb: Neighbourhood,
                      changes: bool, log_eps: float, log_ok: float, n_lit: int) -> np.ndarray:
        """Per transition, ``log P(s_t+1 | s_t, a_t)`` under its neighbours' predictions: each of
        ``n_lit`` literals wrong with ``log_eps``, right with ``log_ok`` (see
        :func:`groundsym.mixtures.transition_entries`)."""

    @abstractmethod
    def count_features(self, u: np.ndarray, b: np.ndarray) -> np.ndarray:
        """The linear reward term's relational counts of states ``u``, ``b`` (:mod:`groundsym.reward_term`)."""

    @abstractmethod
    def reward_ll(self, nb: Neighbourhood, reward: np.ndarray, c0: float, two_s2: float) -> np.ndarray:
        """Per transition, ``log P(r_t | s_t)``: the mixture of the Gaussians ``c0 - (r_t - r_j)^2 /
        two_s2`` around its neighbours' rewards (see :func:`groundsym.mixtures.reward_entries`)."""


class NumpyBackend(Backend):
    """The reference: every step in numpy."""

    name = "numpy"

    def canonical_forms(self, u: np.ndarray, b: np.ndarray, lock: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return canonical_forms(u, b, lock, self._canon_cache)

    def symbol_truth(self, s: Symbol, space: np.ndarray) -> np.ndarray:
        return (unary_truth if s.arity == 1 else binary_truth)([s], space)[..., 0]

    def transition_ll(self, u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray, nb: Neighbourhood,
                      changes: bool, log_eps: float, log_ok: float, n_lit: int) -> np.ndarray:
        item, mis, weight = transition_entries(u, b, pre, post, nb, changes)
        lp = mis * log_eps + (n_lit - mis) * log_ok
        return mixture_ll(item, lp, weight, len(pre))

    def count_features(self, u: np.ndarray, b: np.ndarray) -> np.ndarray:
        return count_features(u, b)

    def reward_ll(self, nb: Neighbourhood, reward: np.ndarray, c0: float, two_s2: float) -> np.ndarray:
        item, other = reward_entries(nb)
        lp = c0 - (reward[item] - reward[other]) ** 2 / two_s2
        return mixture_ll(item, lp, np.ones(len(item)), len(reward))


class NumbaBackend(Backend):
    """The compiled kernels of :mod:`groundsym.compiled`: a whole neighbourhood pass in one call
    up to :data:`~groundsym.compiled.nearest.MAX_OBJECTS` objects (the numpy engine beyond), and
    per-state and per-pair memos in numba's typed containers, started afresh when they grow too
    large (same results)."""

    name = "numba"

    def __init__(self) -> None:
        super().__init__()
        self._state_memo = compiled.new_state_memo()
        self._intern = compiled.new_intern()
        self._pair_memo = compiled.new_memo()
        self._memo_sizes = (0, 0, 0, 0)
        self._column_cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

    @staticmethod
    def available() -> bool:
        return compiled.AVAILABLE

    def canonical_forms(self, u: np.ndarray, b: np.ndarray, lock: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if u.shape[1] <= 255:     # a lock is a byte in the memo's keys
            if len(self._state_memo) > 200_000:
                self._state_memo = compiled.new_state_memo()
            return compiled.canonical_batch(u, b, lock.astype(np.int64, copy=False), self._state_memo)
        return canonical_forms(u, b, lock, self._canon_cache, compiled.COMPILED_CANONICAL)

    def neighbours(self, u: np.ndarray, b: np.ndarray, lock: np.ndarray, label: np.ndarray) -> Neighbourhood:
        if u.shape[1] <= compiled.MAX_OBJECTS:
            return self._whole_pass(u, b, lock, label)
        return self.engine.neighbours(u, b, lock, label)

    def _whole_pass(self, u: np.ndarray, b: np.ndarray, lock: np.ndarray, label: np.ndarray) -> Neighbourhood:
        """The neighbourhood in one compiled call (:func:`compiled.neighbourhood`): the same
        classes, hits and permutations as the engine, without the array glue between the steps."""
        states, classes, pairs, orders = self._memo_sizes   # bounded memory: memos start afresh (same results)
        if states > 200_000:
            self._state_memo = compiled.new_state_memo()
        if classes > 500_000 or pairs > 4_000_000 or orders > 1 << 28:    # (offsets of orders: below the flag bits, 30 bits)
            self._intern, self._pair_memo = compiled.new_intern(), compiled.new_memo()
        *fields, self._memo_sizes = compiled.neighbourhood(
            u, b, np.asarray(lock, dtype=np.int64), np.asarray(label, dtype=np.int64),
            self._state_memo, *self._intern, *self._pair_memo)
        return Neighbourhood(*fields)

    def symbol_truth(self, s: Symbol, space: np.ndarray) -> np.ndarray:
        col = compiled.rbf_holds_columns(self._columns(space), s.centre, s.widths).reshape(space.shape[:-1])
        if s.arity == 2:
            col &= _off_diagonal(space.shape[1])
        return col

    def _columns(self, space: np.ndarray) -> np.ndarray:
        """``space``'s points by dimension (n, P), kept for the spaces a loss asks about again and
        again (its features and pair features): :func:`compiled.rbf_holds_columns` reads them so."""
        key = (id(space), space.shape)
        hit = self._column_cache.get(key)
        if hit is None or hit[0] is not space:
            if len(self._column_cache) >= 4:
                self._column_cache.clear()
            hit = (space, np.ascontiguousarray(space.reshape(-1, space.shape[-1]).T))
            self._column_cache[key] = hit
        return hit[1]

    def transition_ll(self, u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray, nb: Neighbourhood,
                      changes: bool, log_eps: float, log_ok: float, n_lit: int) -> np.ndarray:
        item, weight, diff, top = compiled.transition_mixture(
            u, b, pre, post, nb.perms, nb.cls, nb.lone, nb.hit_query, nb.hit_class, nb.hit_sigma, changes,
            log_eps, log_ok, n_lit)
        return mixture_finish(top, *compiled.mixture_sums(item, np.exp(diff), weight, len(pre)))

    def count_features(self, u: np.ndarray, b: np.ndarray) -> np.ndarray:
        return compiled.count_features(np.ascontiguousarray(u), np.ascontiguousarray(b))

    def reward_ll(self, nb: Neighbourhood, reward: np.ndarray, c0: float, two_s2: float) -> np.ndarray:
        item, diff, top = compiled.reward_mixture(nb.cls, nb.lone, nb.hit_query, nb.hit_class, reward, c0, two_s2)
        return mixture_finish(top, *compiled.mixture_sums(item, np.exp(diff), np.ones(len(item)), len(reward)))


@cache
def _off_diagonal(m: int) -> np.ndarray:
    """(M, M) True but on the diagonal: a binary symbol never holds for an object with itself."""
    return ~np.eye(m, dtype=bool)


#: The kernels by name; the first available one is the default.
BACKENDS: dict[str, type[Backend]] = {backend.name: backend for backend in (NumbaBackend, NumpyBackend)}
KERNELS = tuple(BACKENDS)


def default_kernels() -> str:
    """The name of the kernels a loss uses unless told: numba where it is installed."""
    return next(name for name, backend in BACKENDS.items() if backend.available())


def new_backend(kernels: str | None = None) -> Backend:
    """A fresh backend (empty memos) of the kernels named ``kernels`` (None: :func:`default_kernels`);
    ValueError for an unknown name or kernels that cannot run here."""
    if kernels is None:
        kernels = default_kernels()
    if kernels not in KERNELS or not BACKENDS[kernels].available():
        raise ValueError(f"kernels must be one of {', '.join(KERNELS)} (numba installed), got {kernels!r}")
    return BACKENDS[kernels]()
