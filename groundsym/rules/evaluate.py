"""How well a transition model explains symbolic data: mean log-likelihood per transition.

Used by ``groundsym score`` and by the rule-recovery experiment. A model is anything with
``probability(state, action, succ, objects) -> (p, rule_key)``; ``rule_key`` names what covered
the transition (a rule index, or None for a default rule or an action without a matching rule).
A transition the model gives probability 0 is counted as ``impossible`` and priced with ``p_min``,
so the mean stays finite and comparable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Hashable

from ..symbolic_traces import SymbolicDataset
from .model import P_MIN, RuleSet

ProbabilityFn = Callable[[frozenset, Any, frozenset, tuple[str, ...]], tuple[float, Hashable | None]]


@dataclass(frozen=True)
class ScoreReport:
    mean_log_likelihood: float
    transitions: int
    impossible: int
    covers: dict = field(default_factory=dict)     # rule key -> transitions it covered
    default_covered: int = 0

    def __str__(self) -> str:
        return (f"mean log-likelihood {self.mean_log_likelihood:.4f} nats per transition over "
                f"{self.transitions} transitions ({self.impossible} impossible, "
                f"{self.default_covered} covered by default rules)")


def score_dataset(probability: ProbabilityFn, ds: SymbolicDataset, p_min: float = P_MIN) -> ScoreReport:
    total, n, impossible, default = 0.0, 0, 0, 0
    covers: dict = {}
    for tr in ds.traces:
        for s, a, s2 in tr.transitions():
            p, key = probability(s, a, s2, tr.objects)
            if not p > 0:
                impossible += 1
                p = p_min
            total += math.log(p)
            n += 1
            if key is None:
                default += 1
            else:
                covers[key] = covers.get(key, 0) + 1
    return ScoreReport(total / n if n else 0.0, n, impossible, covers, default)


def ruleset_probability(rs: RuleSet) -> ProbabilityFn:
    """``probability`` for a NID rule set; the key is the covering rule's index in ``rs.rules``."""
    index = {id(r): i for i, r in enumerate(rs.rules)}

    def prob(s: frozenset, a, s2: frozenset, objects: tuple[str, ...]) -> tuple[float, int | None]:
        r, b = rs.covering(s, a, objects)
        if r is None:
            return rs.default_for(a.predicate).likelihood(s, s2, rs.p_min_default), None
        return r.likelihood(s, b, s2, rs.p_min), index[id(r)]

    return prob


def score_ruleset(rs: RuleSet, ds: SymbolicDataset) -> ScoreReport:
    return score_dataset(ruleset_probability(rs), ds, rs.p_min)
