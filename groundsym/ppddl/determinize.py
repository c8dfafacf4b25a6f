"""Determinise a PPDDL domain for classical planners (docs/ppddl.md, Determinisation), and solve it.

* ``all-outcomes`` (FF-Replan's FFR-a): one action ``<name>_o<i>`` per outcome of the action's
  effect (the product of its ``probabilistic`` blocks); the planner picks outcomes
  optimistically. Outcomes that change nothing are left out: a classical planner never needs them.
* ``most-likely`` (FFR-s): each action keeps only its most probable outcome. Equally probable
  outcomes are told apart by a rule that does not depend on the order they are written in: the
  one that changes fewer atoms wins, then the one whose sorted changes print first. (Taking the
  first written would make the determinisation depend on the file's layout: on triangle-tireworld
  it alone decides whether a move "keeps" the tyre.)

Actions (or outcomes) that change nothing are left out in both modes.

Reward effects, ``:goal-reward`` and ``:metric`` have no place in plain PDDL and are dropped.
A ``probabilistic`` under ``forall`` is expanded as if all objects drew the same outcome, exact
when at most one object meets the condition (the tower cell's one held object), optimistic else.

:func:`solve` runs a classical planner through unified-planning (Fast Downward by default) and
refuses, in one line, a planner that cannot take the domain's features.
"""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from dataclasses import replace
from fractions import Fraction
from pathlib import Path
from typing import Iterator

from ..errors import UserError
from ..logic import Atom, Literal
from .ast import (NO_EFFECT, Action, AndEffect, Domain, Effect, ForallEffect, Probabilistic, Problem, RewardEffect,
                  When)
from .requirements import requirements
from .rule_actions import primitive_of

MODES = ("all-outcomes", "most-likely")
_PROBABILISTIC_FLAGS = {":probabilistic-effects", ":rewards", ":mdp"}


def outcomes(e: Effect) -> list[tuple[Fraction, Effect]]:
    """The effect's deterministic alternatives with their probabilities (they sum to 1)."""
    if isinstance(e, Literal):
        return [(Fraction(1), e)]
    if isinstance(e, RewardEffect):
        return [(Fraction(1), NO_EFFECT)]
    if isinstance(e, AndEffect):
        out: list[tuple[Fraction, list[Effect]]] = [(Fraction(1), [])]
        for part in e.effects:
            out = [(p * q, acc + [x]) for p, acc in out for q, x in outcomes(part)]
        return [(p, _and(parts)) for p, parts in out]
    if isinstance(e, Probabilistic):
        res = [(p * q, x) for p, sub in e.branches for q, x in outcomes(sub)]
        if e.rest > 0:
            res.append((e.rest, NO_EFFECT))
        return res
    if isinstance(e, When):
        return [(p, When(e.condition, x) if not _empty(x) else NO_EFFECT) for p, x in outcomes(e.effect)]
    if isinstance(e, ForallEffect):
        return [(p, ForallEffect(e.params, x) if not _empty(x) else NO_EFFECT) for p, x in outcomes(e.effect)]
    raise TypeError(f"not an effect: {e!r}")


def _empty(e: Effect) -> bool:
    return isinstance(e, AndEffect) and all(_empty(x) for x in e.effects)


def _and(parts: list[Effect]) -> Effect:
    flat: list[Effect] = []
    for x in parts:
        if isinstance(x, AndEffect):
            flat += [y for y in x.effects if not _empty(y)]
        elif not _empty(x):
            flat.append(x)
    return flat[0] if len(flat) == 1 else AndEffect(tuple(flat))


def _merged(e: Effect) -> list[tuple[Fraction, Effect]]:
    """Outcomes with equal effects merged, in first-seen order."""
    table: dict[Effect, Fraction] = {}
    for p, x in outcomes(e):
        table[x] = table.get(x, Fraction(0)) + p
    return list((p, x) for x, p in table.items())


def determinize_action(a: Action, mode: str) -> list[Action]:
    """The action's deterministic versions; none when they would change nothing (a no-op never
    helps a classical planner, and Fast Downward through unified-planning fails on some)."""
    alts = _merged(a.effect)
    if mode == "most-likely":
        p, best = min(alts, key=lambda px: (-px[0], *_canonical(px[1])))
        if _empty(best):
            return []
        return [replace(a, effect=best, comment=f"most likely outcome, p = {float(p):.4g}" if p < 1 else "")]
    useful = [(p, x) for p, x in alts if p > 0 and not _empty(x)]
    if len(alts) == 1:
        return [replace(a, effect=alts[0][1])] if useful else []
    return [replace(a, name=f"{a.name}_o{i}", effect=x, comment=f"outcome {i}, p = {float(p):.4g}")
            for i, (p, x) in enumerate(useful, 1)]


def _canonical(e: Effect) -> tuple[int, tuple[str, ...]]:
    """(number of changes, the changes printed and sorted): an outcome's key independent of the
    order its parts were written in."""
    parts = [str(x) for x in (e.effects if isinstance(e, AndEffect) else (e,)) if not _empty(x)]
    return len(parts), tuple(sorted(parts))


def determinize(domain: Domain, problem: Problem | None, mode: str = "all-outcomes") -> tuple[Domain, Problem | None]:
    """Plain PDDL versions of ``domain`` and ``problem`` (see the module docstring)."""
    if mode not in MODES:
        raise UserError(f"--determinize: expected one of {', '.join(MODES)}, got {mode!r}")
    actions = tuple(x for a in domain.actions for x in determinize_action(a, mode))
    plain = replace(domain, actions=actions, requirements=(),
                    comment=f"{mode} determinisation of the PPDDL domain {domain.name}")
    flags = set(requirements(plain)) | {":strips"}
    plain = replace(plain, requirements=tuple(sorted(flags - _PROBABILISTIC_FLAGS)), functions=())
    if problem is None:
        return plain, None
    return plain, replace(problem, goal_reward=None, metric=None,
                          requirements=tuple(r for r in problem.requirements if r not in _PROBABILISTIC_FLAGS))


def primitive_plan(domain: Domain, steps: list[Atom]) -> list[Atom]:
    """The robot primitives of a plan over determinised actions: outcome suffixes and deictic
    parameters dropped (``stack_r1_o2 a b c`` -> ``stack a b``)."""
    out = []
    for s in steps:
        name = s.predicate
        base = next((a for a in domain.actions if a.name == name), None)
        if base is None and "_o" in name:
            base = next((a for a in domain.actions if a.name == name.rsplit("_o", 1)[0]), None)
        if base is None:
            raise UserError(f"plan step {s} names no action of domain {domain.name}")
        prim, n = primitive_of(base)
        out.append(Atom(prim, s.args[:n]))
    return out


# Exported rule domains have negated quantified preconditions, which Fast Downward compiles into
# axioms. With its default axiom relaxation (approximate_negative_cycles) the FF heuristic did not
# finish in 2 minutes on a 6-cube tower domain that blind search solves in 0.01 s; with
# approximate_negative the same search takes 0.03 s. (No spaces: up-fast-downward splits on them.)
_PARAMS = {"fast-downward": {"fast_downward_search_config":
                             "let(hff,ff(axioms=approximate_negative),lazy_greedy([hff],preferred=[hff]))"}}


@contextmanager
def _private_cwd() -> Iterator[None]:
    """Fast Downward's driver writes ``output.sas`` into the working directory: two planners run
    from one directory at once read each other's task. Each run gets a directory of its own."""
    old = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="groundsym-fd-") as tmp:
        os.chdir(tmp)
        try:
            yield
        finally:
            os.chdir(old)


def solve(domain: Domain, problem: Problem, planner: str = "fast-downward",
          timeout: float | None = 60.0) -> list[Atom] | None:
    """A plan (ground PPDDL action atoms of the plain domain) or None when the planner finds none.

    ``domain`` and ``problem`` must be deterministic (see :func:`determinize`).
    """
    return Solver(domain, problem, planner).solve(frozenset(problem.init), timeout)[0]


class Solver:
    """A classical planner on one determinised domain and problem, asked from many initial states.

    The PDDL text is parsed by unified-planning once; each call only sets the initial state (that
    parse was about a third of each call's time when FF-Replan parsed again at every replanning).
    """

    def __init__(self, domain: Domain, problem: Problem, planner: str = "fast-downward") -> None:
        import unified_planning.shortcuts as ups
        from unified_planning.io import PDDLReader

        if problem.goal is None:
            raise UserError(f"problem {problem.name}: has no goal, nothing to plan for")
        ups.get_environment().credits_stream = None
        with tempfile.TemporaryDirectory() as tmp:
            dpath, ppath = Path(tmp) / "domain.pddl", Path(tmp) / "problem.pddl"
            dpath.write_text(str(domain))
            ppath.write_text(str(problem))
            self.up_problem = PDDLReader().parse_problem(str(dpath), str(ppath))
        factory = ups.get_environment().factory
        if planner not in factory.engines:
            raise UserError(f"unknown planner {planner!r} (installed: {', '.join(sorted(factory.engines))})")
        engine_cls = factory.engine(planner)
        if not getattr(engine_cls, "is_oneshot_planner", lambda: False)():
            raise UserError(f"{planner!r} is not a planner (a unified-planning engine of another kind)")
        if not engine_cls.supports(self.up_problem.kind):
            missing = sorted(set(self.up_problem.kind.features) - set(engine_cls.supported_kind().features))
            raise UserError(f"planner {planner!r} cannot take domain {domain.name}: it lacks "
                            f"{', '.join(f.lower().replace('_', '-') for f in missing)}")
        self.planner, self.domain, self.problem = planner, domain, problem
        self.start = frozenset(problem.init)
        # unified-planning lower-cases names: give them back their case
        self.names = {a.name.lower(): a.name for a in domain.actions}
        self.objs = {o.name.lower(): o.name for o in (*problem.objects, *domain.constants)}
        self._fluents = {f.name: f for f in self.up_problem.fluents}
        self._expr = ups.get_environment().expression_manager

    def _fnode(self, atom: Atom):
        fluent = self._fluents.get(atom.predicate) or self._fluents.get(atom.predicate.lower())
        if fluent is None:
            return None
        return self._expr.FluentExp(fluent, [self.up_problem.object(a.lower()) if not self.up_problem.has_object(a)
                                              else self.up_problem.object(a) for a in atom.args])

    def solve(self, state: frozenset, timeout: float | None = 60.0) -> tuple[list[Atom] | None, bool]:
        """(plan or None, proven): ``proven`` says the planner proved that no plan exists."""
        import unified_planning.shortcuts as ups
        from unified_planning.engines import PlanGenerationResultStatus as Status

        up_problem = self.up_problem
        if state != self.start:
            up_problem = self.up_problem.clone()
            for atom in self.start - state:
                node = self._fnode(atom)
                if node is not None:
                    up_problem.set_initial_value(node, False)
            for atom in state - self.start:
                node = self._fnode(atom)
                if node is not None:
                    up_problem.set_initial_value(node, True)
        with _private_cwd(), ups.OneshotPlanner(name=self.planner, params=_PARAMS.get(self.planner)) as engine:
            result = engine.solve(up_problem, timeout=timeout)
        if result.status not in (Status.SOLVED_SATISFICING, Status.SOLVED_OPTIMALLY) or result.plan is None:
            proven = result.status == Status.UNSOLVABLE_PROVEN
            return None, proven
        return [Atom(self.names.get(str(ai.action.name), str(ai.action.name)),
                     tuple(self.objs.get(str(p), str(p)) for p in ai.actual_parameters))
                for ai in result.plan.actions], False
