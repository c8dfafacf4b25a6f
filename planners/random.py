"""RANDOM: the paper's lower baseline, a uniformly random primitive among those that can be run."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from groundsym.options import parse_options
from groundsym.planner import Decision, Observation, PlanningModel


class RandomPlanner:
    """Uniform over ``observation.actions``; independent of any learned model."""

    name = "random"
    NEEDS: frozenset[str] = frozenset()
    OPTIONS = ()

    def __init__(self, model: PlanningModel | None, options: Mapping[str, Any], seed: int):
        parse_options("--planner-opt", "planner", self.name, self.OPTIONS, options)
        self.rng = np.random.default_rng(seed)

    def choose(self, observation: Observation) -> Decision:
        if not observation.actions:
            raise ValueError("no primitive can be run in this state")
        k = int(self.rng.integers(len(observation.actions)))
        return Decision(observation.actions[k], float("nan"), {})

    def observe(self, action: Any, observation: Observation) -> None:
        """Random needs no memory."""
