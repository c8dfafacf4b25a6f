"""PRADA's core: sample action sequences, propagate their marginals, score them, shorten the best.

PRADA (Lang & Toussaint 2010) samples many action sequences, each action drawn with weight
"probability that a manipulating rule of it applies", propagates the marginals along each sequence
(:mod:`planners.prada.frontier`), scores it by the discounted expected reward
``sum_t gamma^t E_t[R]`` (:mod:`planners.prada.rewards`) and runs the first action of the best
sequence. A-PRADA then deletes actions from the best sequence while that raises its value.

All random draws of a decision come from the planner's one generator, in a fixed order: per
sampling round, one uniform per sample and step (:func:`sample_rows`), then one choice among tied
best sequences (:meth:`PradaCore.best`). A result made with a seed depends on that order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from groundsym.logic import Atom

from .frontier import RULE_MIN_PROB, action_weights, rule_probabilities, transition
from .grounding import Grounding, subgrounding
from .rewards import RewardFn


@dataclass(frozen=True)
class Plan:
    """The best sampled sequence, its value, and what it was compared with."""

    actions: tuple[Atom, ...]
    value: float
    noop_value: float
    samples: int


class PradaCore:
    """PRADA over one grounding and reward: sample, propagate, evaluate, shorten."""

    def __init__(self, g: Grounding, reward: RewardFn, horizon: int, samples: int, gamma: float,
                 choice: str = "max", restricted: bool = False, min_prob: float = RULE_MIN_PROB,
                 threshold: float = 0.0, max_runs: int = 1, transition_mode: str = "auto"):
        self.g, self.reward = g, reward
        self.transition_mode = transition_mode
        self.horizon, self.samples, self.gamma, self.choice = horizon, samples, gamma, choice
        self.min_prob, self.threshold, self.max_runs = min_prob, threshold, max_runs
        self.discounts = gamma ** np.arange(horizon + 1)
        self.restricted = restricted
        self._static = np.asarray(g.touched.getnnz(axis=0) == 0) if not restricted else None
        if self._static is not None:
            self._static[g.derived_cols] = False       # derived atoms change with their base atoms
        self._subs: dict[bytes, PradaCore] = {}

    def restrict(self, b0: np.ndarray) -> "PradaCore":
        """The core over the ground rules that can fire from ``b0``: a rule whose context needs a
        static atom (one no rule changes) that is false in ``b0`` never fires (``road l-1-1 l-5-3``
        that is not there), and leaving it out changes no probability. Triangle-tireworld p03
        keeps 4% of its ground rules. Cached by the static atoms' values."""
        if self.restricted or not len(self.g.rule_group):
            return self
        static = self._static
        lit = b0[self.g.ctx]
        lit = np.where(self.g.sign, lit, 1.0 - lit)
        dead = (static[self.g.ctx] & (lit <= 0.0)).any(axis=1)
        if not dead.any():
            return self
        key = b0[:-1][static[:-1]].tobytes()
        if key not in self._subs:
            self._subs[key] = PradaCore(subgrounding(self.g, ~dead), self.reward, self.horizon, self.samples,
                                        self.gamma, self.choice, True, self.min_prob, self.threshold,
                                        self.max_runs, self.transition_mode)
        return self._subs[key]

    def sample(self, b0: np.ndarray, rng: np.random.Generator, banned: Sequence[Atom] = ()
               ) -> tuple[np.ndarray, np.ndarray]:
        """N sequences of ground-action indices (-1 after a sequence ends) and their values;
        no sequence starts with an action in ``banned``."""
        g, N, T = self.g, self.samples, self.horizon
        B = np.repeat(b0[None, :], N, axis=0)
        seqs = np.full((N, T), -1, dtype=np.int64)
        value = self.reward(B) * self.discounts[0]
        banned = set(banned)
        ban = [i for i, a in enumerate(g.actions) if a in banned]
        for t in range(T):
            U = rule_probabilities(g, B, self.min_prob)
            W = action_weights(g, U)
            if t == 0 and ban:
                W[:, ban] = 0.0
            chosen = sample_rows(W, rng)
            seqs[:, t] = chosen
            B = transition(g, B, U, chosen, self.transition_mode)
            value = value + self.discounts[t + 1] * self.reward(B)
        return seqs, value

    def evaluate(self, b0: np.ndarray, seqs: np.ndarray) -> np.ndarray:
        """Values of fixed sequences (rows of action indices, -1 = do nothing), all at once."""
        B = np.repeat(b0[None, :], len(seqs), axis=0)
        value = self.reward(B) * self.discounts[0]
        for t in range(self.horizon):
            col = seqs[:, t] if t < seqs.shape[1] else np.full(len(seqs), -1)
            U = rule_probabilities(self.g, B, self.min_prob)
            B = transition(self.g, B, U, col, self.transition_mode)
            value = value + self.discounts[t + 1] * self.reward(B)
        return value

    def best(self, seqs: np.ndarray, values: np.ndarray, rng: np.random.Generator | None = None) -> int:
        """Row of the chosen sequence: the best one, or the best of the best first action (top10).

        Sequences the model cannot tell apart (interchangeable objects give equal values up to
        rounding) are chosen among at random: taking the first would always favour the same object
        through floating-point order, and a robot would retry a cube that physically cannot be
        grasped for the rest of the episode.
        """
        if self.choice == "max":
            top = float(values.max())
            tied = np.flatnonzero(values >= top - 1e-9 * max(1.0, abs(top)))
            return int(tied[0] if rng is None or len(tied) == 1 else rng.choice(tied))
        firsts = np.unique(seqs[:, 0])
        best_row, best_mean = 0, -np.inf
        for a in firsts:
            rows = np.flatnonzero(seqs[:, 0] == a)
            top = rows[np.argsort(-values[rows], kind="stable")[:10]]
            if values[top].mean() > best_mean:
                best_mean, best_row = values[top].mean(), int(top[0])
        return best_row

    def shorten(self, b0: np.ndarray, seq: np.ndarray, value: float) -> tuple[np.ndarray, float]:
        """A-PRADA: delete actions while that raises the value; later actions move one step up."""
        seq = seq[seq >= 0]
        t = 0
        while t < len(seq) - 1 and len(seq) > 1:
            cand = np.delete(seq, t)
            vc = float(self.evaluate(b0, _pad(cand[None, :], self.horizon))[0])
            if vc > value:
                seq, value = cand, vc
            else:
                t += 1
        return seq, value

    def plan(self, b0: np.ndarray, rng: np.random.Generator, shorten: bool, banned: Sequence[Atom] = ()) -> Plan:
        core = self.restrict(b0)
        if core is not self:
            return core.plan(b0, rng, shorten, banned)
        noop = float(self.evaluate(b0, np.full((1, self.horizon), -1))[0])
        for _ in range(self.max_runs):      # libPRADA: sample again while no sequence beats doing
            seqs, values = self.sample(b0, rng, banned)   # nothing by the threshold ("no sensible action")
            row = self.best(seqs, values, rng)
            if float(values[row]) > noop + self.threshold:
                break
        seq, value = seqs[row], float(values[row])
        if shorten:
            seq, value = self.shorten(b0, seq, value)
        seq = seq[seq >= 0]
        return Plan(tuple(self.g.actions[i] for i in seq), value, noop, self.samples)


def sample_rows(W: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One column index per row with probability proportional to ``W``; -1 where the row is all 0."""
    if not W.shape[1]:
        return np.full(W.shape[0], -1, dtype=np.int64)
    cum = np.cumsum(W, axis=1)
    total = cum[:, -1]
    r = rng.random(W.shape[0]) * total
    idx = (cum <= r[:, None]).sum(axis=1)
    idx = np.minimum(idx, W.shape[1] - 1)
    return np.where(total > 0, idx, -1)


def _pad(seqs: np.ndarray, horizon: int) -> np.ndarray:
    out = np.full((seqs.shape[0], horizon), -1, dtype=np.int64)
    out[:, :seqs.shape[1]] = seqs[:, :horizon]
    return out
