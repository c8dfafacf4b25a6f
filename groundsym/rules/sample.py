"""Drawing successors and whole traces from a rule set: a known domain as a data source.

A hand-written :class:`~groundsym.rules.model.RuleSet` is a genuine stochastic domain; sampling
from it gives symbolic data with known dynamics, so a learner can be checked against the truth
(docs/rules.md, Does learning recover known dynamics?). The noise outcome has no distribution of its own; here it changes nothing,
which is how PRADA's sampling planners read it too.
"""

from __future__ import annotations

from itertools import permutations
from typing import Sequence

import numpy as np

from ..logic import Atom
from ..symbolic_traces import SymbolicDataset, SymbolicTrace
from .model import RuleSet


def sample_successor(rules: RuleSet, state: frozenset, action: Atom, rng: np.random.Generator,
                     objects: Sequence[str] | None = None) -> frozenset:
    """One successor of ``(state, action)``: the covering rule's outcome drawn by its probabilities."""
    rule, binding = rules.covering(state, action, objects)
    if rule is None:
        return state            # the default rule: no change (its noise changes nothing here either)
    probs = np.array([*rule.probs, rule.noise])
    k = int(rng.choice(len(probs), p=probs / probs.sum()))
    return state if k == len(rule.outcomes) else rule.outcomes[k].apply(state, binding)


def ground_actions(primitives: dict[str, int], objects: Sequence[str]) -> list[Atom]:
    return [Atom(name, args) for name, k in sorted(primitives.items()) for args in permutations(objects, k)]


def sample_traces(rules: RuleSet, starts: Sequence[tuple[tuple[str, ...], frozenset]],
                  primitives: dict[str, int], predicates: dict[str, int], length: int,
                  rng: np.random.Generator, inapplicable: float = 0.25) -> SymbolicDataset:
    """Random walks from each start: an applicable action (one some rule covers) or, with
    probability ``inapplicable``, one no rule covers (nothing happens), as a robot may try."""
    traces = []
    for objects, s in starts:
        acts = ground_actions(primitives, objects)
        states, actions = [s], []
        for _ in range(length):
            cov = [rules.covering(s, a, objects)[0] is not None for a in acts]
            good = [a for a, c in zip(acts, cov) if c]
            bad = [a for a, c in zip(acts, cov) if not c]
            pool = bad if (bad and (not good or rng.random() < inapplicable)) else good
            if not pool:
                break
            a = pool[int(rng.integers(len(pool)))]
            s = sample_successor(rules, s, a, rng, objects)
            actions.append(a)
            states.append(s)
        traces.append(SymbolicTrace(tuple(objects), states, actions, [0.0] * len(actions)))
    return SymbolicDataset(traces, dict(predicates), dict(primitives))
