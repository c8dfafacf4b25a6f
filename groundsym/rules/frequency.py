"""How often a context literal must hold to be kept, when observations may be flipped.

A literal that holds in (nearly) every example of an action is a precondition, as SAM's safe
preconditions (Juba, Le & Stern 2021, KR); under observation noise a true precondition is seen
false now and then, so literals are kept by *frequency* with a threshold, as NOLAM's model of
noisy traces does (Lamanna & Serafini 2024, ICAPS).

Choosing the threshold: the examples are split (seeded) into a training and a held-out part. For
each threshold the literals at or above it are the *precondition group*, modelled as true except
for one noise rate shared by the whole group (noise is the same for every atom); every other
literal is modelled by its own frequency. The held-out log-likelihood of the literal observations
rises while true preconditions (seen true at one common rate) join the group and falls once a
literal that is merely often true joins. Held-out data cannot tell a true precondition seen at the
noise rate from a literal that merely happens to hold as often, so among the thresholds within
``slack`` nats of the best the lowest (the most specific context, the safe side) is taken.

The noise rate itself comes from the data: an atom over the action's arguments that is no effect
keeps its value from state to successor, so where it differs an observation was flipped. On
noise-free data it is 0 and the threshold is SAM's 1.0 (no choice to make); with noise, a literal
is also kept when its false observations are as many as flips at that rate give with chance at
least ``NOISE_LEVEL`` (the exact binomial tail: an action seen a few times can see a true
precondition flipped more often than the rate, and a dropped precondition makes false plans).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.stats import binom

from .coverage import Example
from .language import types_of

#: unchanged pseudo-observations in the noise estimate: a few examples of a small problem say little
PRIOR_UNCHANGED = 20.0
#: the chance below which an action's false observations of a literal are more than noise explains:
#: three standard errors of a normal variable, one-sided; the binomial tail itself is used
NOISE_LEVEL = 0.00135
THRESHOLDS = (1.0, 0.995, 0.99, 0.98, 0.97, 0.96, 0.95, 0.93, 0.9, 0.85, 0.8)


def context_mask(truth: np.ndarray, w: np.ndarray, theta: float) -> np.ndarray:
    """Mask of the literals that hold in at least ``theta`` of the examples (by weight)."""
    if w.sum() <= 0:
        return np.zeros(truth.shape[1], dtype=bool)
    return (w @ truth) / w.sum() >= theta - 1e-12


def choose_threshold(samples: Sequence[tuple[np.ndarray, np.ndarray]], thresholds: Sequence[float], holdout: float,
                     slack: float, rng: np.random.Generator) -> tuple[float, dict[str, float]]:
    """The threshold whose precondition group best predicts held-out literal observations (module
    docstring): ``samples`` holds each action's literal observations (examples x literals) and
    example weights; ``holdout`` the share held out, ``slack`` the nats a lower threshold may lose.
    1.0 when nothing is held out."""
    parts = []
    for truth, weights in samples:
        held = rng.random(len(weights)) < holdout
        parts.append((truth[~held], weights[~held], truth[held], weights[held]))
    if not any(wh.sum() > 0 for *_, wh in parts):
        return 1.0, {}
    curve, chosen = {}, {}
    for theta in thresholds:
        groups = [context_mask(tt, wt, theta) for tt, wt, _, _ in parts]
        chosen[theta] = tuple(np.flatnonzero(g).tobytes() for g in groups)
        miss = sum(float((wt @ ~tt[:, g]).sum()) if g.any() else 0.0
                   for (tt, wt, _, _), g in zip(parts, groups))
        seen = sum(float(wt.sum() * g.sum()) for (_, wt, _, _), g in zip(parts, groups))
        eps = (miss + 0.5) / (seen + 1.0)
        ll = 0.0
        for (tt, wt, th, wh), g in zip(parts, groups):
            n, k = wt.sum(), wt @ tt
            f = (k + 0.5) / (n + 1.0)
            h = wh @ th
            m = wh.sum()
            p = np.where(g, 1.0 - eps, f)
            ll += float(np.sum(h * np.log(p) + (m - h) * np.log1p(-p)))
        curve[f"{theta:g}"] = ll
    best = max(curve.values())
    theta = min(t for t in thresholds if curve[f"{t:g}"] >= best - slack)
    return max(t for t in thresholds if chosen[t] == chosen[theta]), curve   # same contexts: the higher


def noise_rate(examples: Sequence[Example], types: frozenset, sig: dict, constants: tuple[str, ...] = ()
                ) -> float:
    """The observation noise: in STRIPS an action changes only atoms over its own arguments, so
    an atom over other objects that differs between state and successor had an observation
    flipped; with flip rate ``r`` that happens to each well-typed atom with probability
    ``2 r (1 - r)``. The atoms counted are those the types allow (``sig``). Noise-free data: 0."""
    arity: dict[str, int] = {}
    for p, k in sig:
        arity[p] = max(arity.get(p, 0), k + 1)
    universe: dict[tuple, int] = {}      # per object set: the well-typed atoms over it

    def atoms(objects: tuple[str, ...], kinds: dict[str, set[str]]) -> int:
        if objects not in universe:
            counts: dict[tuple[str, int], int] = {}
            for o in objects:
                k = frozenset(kinds.get(o, {"object"}))
                for key, allowed in sig.items():
                    counts[key] = counts.get(key, 0) + (k in allowed)
            universe[objects] = sum(int(np.prod([counts.get((p, k), 0) for k in range(n)]))
                                    for p, n in arity.items())
        return universe[objects]

    changed = seen = 0.0
    for e in examples:
        kinds = types_of(e.state, types)
        args = set(e.action.args) | set(constants)
        seen += e.weight * (atoms(e.objects, kinds) - atoms(tuple(sorted(args)), kinds))
        changed += e.weight * sum(1 for a in e.state ^ e.succ
                                  if a.predicate not in types and a.args and not set(a.args) <= args)
    if seen <= 0 or changed <= 0:
        return 0.0
    q = min(changed / (seen + PRIOR_UNCHANGED), 0.5)
    return float((1.0 - np.sqrt(1.0 - 2.0 * q)) / 2.0)


def accept_frequency(theta: float, eps: float, w: np.ndarray, level: float = NOISE_LEVEL) -> float:
    """The frequency an action's literal needs: ``theta``, lowered where the action's false
    observations of a true precondition could be noise: to ``1 - k / n`` for the most false
    observations ``k`` among its ``n`` examples that flips at rate ``eps`` give with chance at
    least ``level`` (the exact binomial tail, so an action seen 8 times keeps a literal seen false
    once at 1% noise; the normal approximation's three standard errors dropped it, and the
    operator then applied where the reference's does not). Noise-free data (``eps = 0``): ``theta``."""
    if eps <= 0:
        return theta
    n = max(int(round(float(w.sum()))), 1)
    return max(0.51, min(theta, 1.0 - noise_count(n, eps, level) / n))


def noise_count(n: int, p: float, level: float = NOISE_LEVEL) -> int:
    """The most of ``n`` observations that noise hitting each with probability ``p`` makes with
    chance at least ``level`` (the exact binomial tail): more than that is evidence, not noise."""
    ks = np.arange(n + 1)
    return int(ks[binom.sf(ks - 1, n, p) >= level].max())
