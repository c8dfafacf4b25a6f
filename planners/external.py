"""EXTERNAL: classical planners on a determinised domain, replanning on surprise (FF-Replan).

The PPDDL domain is determinised once (all-outcomes by default, or most-likely; ALGORITHMS.md
C.4), then at each step: if there is no plan, or the observed state differs from the state the
plan predicted, a classical planner is called through unified-planning on the current state
(``external:fast-downward`` by default; ``external:NAME`` picks any installed unified-planning
engine); the first step of the plan is run as its robot primitive, and the state the
determinised action predicts is remembered for the next comparison (Yoon, Fern & Givan 2007).

A planner that is not installed, or cannot take the domain's features, is refused in one line
before the first step.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, Mapping

import numpy as np

from groundsym.errors import UserError
from groundsym.logic import Atom
from groundsym.planner import Decision, Observation, PlannerOption, PlanningModel, parse_planner_options, positive


def _mode(text: str) -> str:
    if text not in ("all-outcomes", "most-likely"):
        raise ValueError("expected all-outcomes or most-likely")
    return text


class ExternalPlanner:
    """FF-Replan through unified-planning on a PPDDL domain and problem."""

    name = "external"
    NEEDS = frozenset({"ppddl"})
    OPTIONS = (
        PlannerOption("engine", str, "fast-downward", "unified-planning engine (also: --planner external:NAME)"),
        PlannerOption("determinize", _mode, "all-outcomes", "all-outcomes (FFR-a) or most-likely (FFR-s)"),
        PlannerOption("timeout", positive(float), 60.0, "seconds per planner call"),
    )

    def __init__(self, model: PlanningModel, options: Mapping[str, Any], seed: int):
        from groundsym.ppddl.determinize import determinize
        from groundsym.ppddl.simulate import Task

        self.opts = parse_planner_options(self.name, self.OPTIONS, options)
        domain, problem = model.ppddl
        if problem is None or problem.goal is None:
            raise UserError("--planner external: the problem has no goal to plan for")
        _check_engine(self.opts["engine"])
        self.domain = domain
        self.plain, self.plain_problem = determinize(domain, problem, self.opts["determinize"])
        self.task = Task(self.plain, self.plain_problem)
        self.rng = np.random.default_rng(seed)
        self.plan: list[Atom] = []
        self.predicted: frozenset | None = None
        self.calls = 0

    def _replan(self, state: frozenset) -> None:
        from groundsym.ppddl.determinize import solve

        problem = replace(self.plain_problem, init=tuple(sorted(state)))
        self.calls += 1
        try:
            found = solve(self.plain, problem, self.opts["engine"], self.opts["timeout"])
        except UserError:
            raise
        except Exception as exc:  # the engine itself failed: say so in one line, not a traceback
            raise UserError(f"--planner external:{self.opts['engine']}: the planner failed on domain "
                            f"{self.plain.name}: {type(exc).__name__}: {exc}") from None
        self.plan = list(found or [])

    def choose(self, observation: Observation) -> Decision:
        from groundsym.ppddl.determinize import primitive_plan

        state = observation.state
        surprised = self.predicted is None or state != self.predicted or not self.plan
        if surprised:
            self._replan(state)
        info = {"replanned": surprised, "planner_calls": self.calls, "plan_length": len(self.plan)}
        if not self.plan:      # no plan from here (dead end for the determinised domain)
            self.predicted = None
            action = observation.actions[int(self.rng.integers(len(observation.actions)))]
            return Decision(action, 0.0, {**info, "plan": []})
        step = self.plan.pop(0)
        nxt = self.task.outcomes(state, step)
        self.predicted = nxt[0].state if nxt else state
        action = primitive_plan(self.domain, [step])[0]
        return Decision(action, float("nan"), {**info, "plan": [str(step), *map(str, self.plan)]})

    def observe(self, action: Atom, observation: Observation) -> None:
        """The comparison with the predicted state happens in :meth:`choose`."""


def _check_engine(engine: str) -> None:
    """One line if unified-planning has no such engine (before any work)."""
    import unified_planning.shortcuts as ups

    factory = ups.get_environment().factory
    if engine not in factory.engines:
        raise UserError(f"--planner external:{engine}: not installed (unified-planning engines here: "
                        f"{', '.join(sorted(factory.engines))})")
