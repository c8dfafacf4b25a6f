"""PRADA's rewards: the expected reward of every row of a belief matrix at once.

A PPDDL goal is scored as the probability that its literals hold (:func:`goal_reward`); a learned
reward model as exactly as its interface allows (:func:`model_reward`): batched arrays, linear
weights, row by row, or Monte Carlo over states drawn from the factored belief.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from groundsym.logic import Atom
from groundsym.planner import Goal

from .grounding import Grounding


class RewardFn:
    """Expected reward under factored marginals, for every row of a belief matrix at once."""

    def __call__(self, B: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError


@dataclass(frozen=True, eq=False)
class LinearReward(RewardFn):
    """``w0 + sum_i w_i P(atom_i)``: exact for rewards linear in atom indicators."""

    w0: float
    w: np.ndarray   # (V+1,) with 0 on the constant column

    def __call__(self, B: np.ndarray) -> np.ndarray:
        return self.w0 + B @ self.w


@dataclass(frozen=True, eq=False)
class GoalReward(RewardFn):
    """``R_goal * prod P(literal)``: a conjunctive goal under independent marginals (Lang & Toussaint 2010).

    ``share > 0`` adds ``share * R_goal * mean P(literal)``, the expected share of the goal's
    literals that hold: a goal further away than the horizon then still orders the sequences (one
    more goal literal is worth more), where the product is 0 for all of them and the choice is
    blind (blocksworld p02, reversing a tower of five, needs at least 8 primitives)."""

    index: np.ndarray      # (L,) variable index of each goal literal (V = outside the grounding)
    positive: np.ndarray   # (L,)
    value: float
    share: float = 0.0

    def __call__(self, B: np.ndarray) -> np.ndarray:
        lit = B[:, self.index]
        p = np.where(self.positive, lit, 1.0 - lit)
        out = self.value * p.prod(axis=1)
        return out + self.share * self.value * p.mean(axis=1) if self.share else out


@dataclass(frozen=True, eq=False)
class ModelReward(RewardFn):
    """A learned reward model's own ``expected(marginals, objects)``, called row by row."""

    model: Any
    g: Grounding

    def __call__(self, B: np.ndarray) -> np.ndarray:
        return np.array([float(self.model.expected(self.g.marginals(row), self.g.objects)) for row in B])


@dataclass(frozen=True, eq=False)
class ArrayReward(RewardFn):
    """A model with batched ``expected_arrays(arrays, n_objects)`` (groundsym.reward.RewardModel).

    ``columns[p]`` maps every cell of predicate ``p``'s M x ... x M array to a belief column; cells
    outside the grounding (e.g. ``on(x, x)``) read an appended column of zeros.
    """

    model: Any
    columns: Mapping[str, np.ndarray]
    n_objects: int

    def __call__(self, B: np.ndarray) -> np.ndarray:
        ext = np.hstack([B, np.zeros((B.shape[0], 1))])
        m, N = self.n_objects, B.shape[0]
        arrays = {p: ext[:, idx].reshape((N,) + (m,) * idx.ndim) for p, idx in self.columns.items()}
        return np.asarray(self.model.expected_arrays(arrays, m), dtype=float)


def array_reward(model: Any, g: Grounding) -> ArrayReward:
    m, zero = len(g.objects), g.n_vars + 1
    columns = {}
    for p, k in dict(model.predicates).items():
        idx = np.full((m,) * k, zero, dtype=np.int64)
        for cell in np.ndindex(*idx.shape):
            i = g.index.get(Atom(p, tuple(g.objects[c] for c in cell)))
            if i is not None:
                idx[cell] = i
        columns[p] = idx
    return ArrayReward(model, columns, m)


@dataclass(frozen=True, eq=False)
class SampledReward(RewardFn):
    """A model that only scores states (``predict(state, objects)``): Monte Carlo over states drawn
    from the factored belief, with one fixed set of uniforms for every row and step (common random
    numbers, so sequences are compared on the same draws) (docs/algorithms.md, PRADA and A-PRADA)."""

    model: Any
    g: Grounding
    uniforms: np.ndarray   # (M, V)

    def __call__(self, B: np.ndarray) -> np.ndarray:
        out = np.empty(B.shape[0])
        for n, row in enumerate(B):
            draws = self.uniforms < row[None, :self.g.n_vars]
            out[n] = np.mean([self.model.predict(frozenset(a for a, on in zip(self.g.atoms, d) if on),
                                                 self.g.objects) for d in draws])
        return out


def goal_reward(goal: Goal, g: Grounding, share: float = 0.0) -> GoalReward:
    idx, pos = [], []
    for lit in goal.literals:
        i = g.index.get(lit.atom)
        if i is None:               # an atom nobody can make true: P = 0 (or 1 when negated)
            i = g.n_vars
            pos.append(not lit.positive)
        else:
            pos.append(lit.positive)
        idx.append(i)
    return GoalReward(np.array(idx, dtype=np.int64), np.array(pos, dtype=bool), goal.reward, share)


def model_reward(model: Any, g: Grounding, rng: np.random.Generator) -> RewardFn:
    """Batched arrays for a groundsym RewardModel; Monte Carlo for a model with only ``predict``;
    for any other model with ``expected``: linear weights when the model's expectation is linear in the marginals, else row by row.

    Probing ``expected`` at the empty belief and at each unit vector gives the weights a linear
    model must have; three random beliefs then confirm linearity (a tree or product model fails
    and is used exactly, row by row).
    """
    if hasattr(model, "expected_arrays") and hasattr(model, "predicates"):
        return array_reward(model, g)
    if not hasattr(model, "expected"):
        return SampledReward(model, g, np.random.default_rng(0).random((32, g.n_vars)))
    full = ModelReward(model, g)
    V = g.n_vars
    probes = np.zeros((V + 1, V + 1))
    probes[:, -1] = 1.0
    probes[np.arange(V), np.arange(V)] = 1.0
    vals = full(probes)
    w0 = vals[-1]
    w = np.append(vals[:V] - w0, 0.0)
    check = np.hstack([rng.random((3, V)), np.ones((3, 1))])
    lin = LinearReward(w0, w)
    scale = 1e-9 * max(1.0, float(np.abs(vals).max()))
    if np.allclose(lin(check), full(check), atol=scale, rtol=1e-9):
        return lin
    return full
