"""The simulator's ground-truth relations as the abstraction: an oracle, for diagnosis only.

``evaluate --truth-symbols inhand,on`` plans on these instead of learned symbols, which separates
planning failures from symbol-learning failures (docs/planning.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from ..symbolic_traces import SymbolicDataset, SymbolicTrace


@dataclass(frozen=True)
class TruthSymbols:
    """The simulator's ground-truth relations as the abstraction (an oracle, for diagnosis only:
    it separates planning from symbol learning)."""

    names: tuple[str, ...]
    arities: Mapping[str, int]

    @property
    def predicates(self) -> dict[str, int]:
        return {p: self.arities[p] for p in self.names}

    def abstract_scene(self, scene: Any) -> frozenset:
        return frozenset(a for a in scene.truth if a.predicate in self.names)

    def to_symbolic_dataset(self, ds: Any) -> SymbolicDataset:
        traces = []
        for tr in ds.traces:
            states = [self.abstract_scene(s) for s in tr.scenes]
            rewards = [float(s.reward) for s in tr.scenes]
            traces.append(SymbolicTrace(tr.objects, states, list(tr.actions), rewards[:-1], rewards[-1]))
        return SymbolicDataset(traces, self.predicates, dict(ds.primitives), {"truth_symbols": list(self.names)})
