"""EXTERNAL: classical planners on a determinised domain, replanning on surprise (FF-Replan).

The PPDDL domain is determinised once (all-outcomes by default, or most-likely;
docs/ppddl.md) and parsed by unified-planning once per planner (one episode). Every plan found is kept by
state: each state the plan passes through (as the determinised domain predicts it) maps to the
rest of the plan from there. At each step the current state's kept plan is followed; only a
state no plan passes through calls a classical planner through unified-planning
(``external:fast-downward`` by default; ``external:NAME`` picks any installed unified-planning
engine) (Yoon, Fern & Givan 2007). After a failed ``pick-tower`` the state is one seen before,
so its plan is reused rather than planned again.

When the planner proves on the all-outcomes determinisation that no plan exists, the goal is
unreachable in the PPDDL domain too (every trajectory of the domain is a plan there), so the
decision says ``dead_end`` and the episode stops. Most-likely drops outcomes, so there a proof
says nothing about the domain: the state is remembered as planless and a seeded random
applicable primitive is run, without calling the planner again for that state.

A planner that is not installed, or cannot take the domain's features, is refused in one line
before the first step.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from groundsym.errors import UserError
from groundsym.logic import Atom
from groundsym.options import Option, one_of, parse_options, positive
from groundsym.planner import Decision, Observation, PlanningModel


class ExternalPlanner:
    """FF-Replan through unified-planning on a PPDDL domain and problem."""

    name = "external"
    NEEDS = frozenset({"ppddl"})
    OPTIONS = (
        Option("engine", str, "fast-downward", "unified-planning engine (also: --planner external:NAME)"),
        Option("determinize", one_of("all-outcomes", "most-likely"), "all-outcomes", "all-outcomes (FFR-a) or most-likely (FFR-s)"),
        Option("timeout", positive(float), 60.0, "seconds per planner call"),
    )

    def __init__(self, model: PlanningModel, options: Mapping[str, Any], seed: int):
        from groundsym.ppddl.determinize import Solver, determinize
        from groundsym.ppddl.simulate import Task

        self.opts = parse_options("--planner-opt", "planner", self.name, self.OPTIONS, options)
        domain, problem = model.ppddl
        if problem is None or problem.goal is None:
            raise UserError("--planner external: the problem has no goal to plan for")
        _check_engine(self.opts["engine"])
        self.domain = domain
        self.plain, self.plain_problem = determinize(domain, problem, self.opts["determinize"])
        self.task = Task(self.plain, self.plain_problem)
        self.solver = Solver(self.plain, self.plain_problem, self.opts["engine"])
        self.rng = np.random.default_rng(seed)
        self.plans: dict[frozenset, list[Atom]] = {}     # state -> the rest of a plan from there
        self.planless: set[frozenset] = set()            # states where the planner found no plan
        self.calls = 0

    def _replan(self, state: frozenset) -> bool:
        """Call the planner on ``state``, keep its plan by state; True when it proved there is none."""
        self.calls += 1
        try:
            found, proven = self.solver.solve(state, self.opts["timeout"])
        except UserError:
            raise
        except Exception as exc:  # the engine itself failed: say so in one line, not a traceback
            raise UserError(f"--planner external:{self.opts['engine']}: the planner failed on domain "
                            f"{self.plain.name}: {type(exc).__name__}: {exc}") from None
        if found is None:
            self.planless.add(state)
            return proven
        s = state
        for i, step in enumerate(found):
            self.plans.setdefault(s, found[i:])
            nxt = self.task.outcomes(s, step)
            if not nxt:
                break
            s = nxt[0].state
        return False

    def choose(self, observation: Observation) -> Decision:
        from groundsym.ppddl.determinize import primitive_plan

        state = observation.state
        replanned = state not in self.plans and state not in self.planless
        proven = self._replan(state) if replanned else False
        info = {"replanned": replanned, "planner_calls": self.calls}
        plan = self.plans.get(state, [])
        if not plan:           # no plan from here in the determinised domain
            if proven and self.opts["determinize"] == "all-outcomes":
                return Decision(observation.actions[0], 0.0, {**info, "plan": [], "dead_end": True})
            action = observation.actions[int(self.rng.integers(len(observation.actions)))]
            return Decision(action, 0.0, {**info, "plan": [], "plan_length": 0})
        action = primitive_plan(self.domain, [plan[0]])[0]
        return Decision(action, float("nan"), {**info, "plan_length": len(plan), "plan": [str(x) for x in plan]})

    def observe(self, action: Atom, observation: Observation) -> None:
        """Plans are kept by state; :meth:`choose` looks the new state up."""


def _check_engine(engine: str) -> None:
    """One line if unified-planning has no such engine (before any work)."""
    import unified_planning.shortcuts as ups

    factory = ups.get_environment().factory
    if engine not in factory.engines:
        raise UserError(f"--planner external:{engine}: not installed (unified-planning engines here: "
                        f"{', '.join(sorted(factory.engines))})")
