"""Determinisation: plain PDDL that unified-planning reads and Fast Downward solves; plans that are
possible in the probabilistic domain; planners that cannot take a domain refused in one line."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest

from groundsym.errors import UserError
from groundsym.logic import Atom, Literal
from groundsym.ppddl.ast import AndEffect, Probabilistic
from groundsym.ppddl.requirements import requirements
from groundsym.ppddl.determinize import determinize, outcomes, primitive_plan, solve
from groundsym.ppddl.parser import load, parse_domain
from groundsym.ppddl.simulate import Task

DATA = Path(__file__).parent / "data" / "ippc"
REF = Path(__file__).parent.parent / "domains" / "reference"


def _run(task: Task, plan: list[Atom]) -> frozenset:
    """Execute a plan in a deterministic domain; every step must be applicable with one outcome."""
    s = task.initial_state
    for step in plan:
        dist = task.distribution(s, step)
        assert len(dist) == 1 and dist[0].prob == pytest.approx(1.0), step
        s = dist[0].state
    return s


def test_outcomes_of_an_effect_multiply_out():
    d, _ = load(DATA / "ippc2006/ex-blocksworld/domain.pddl")
    alts = outcomes(d.action("put-on-block").effect)
    assert sorted(p for p, _ in alts) == [Fraction(1, 10), Fraction(9, 10)]
    assert sum(p for p, _ in outcomes(d.action("pick-up").effect)) == 1


@pytest.mark.parametrize("mode", ["all-outcomes", "most-likely"])
@pytest.mark.parametrize("domain_file,problem_file", [
    (DATA / "ippc2006/blocksworld/domain.pddl", DATA / "ippc2006/blocksworld/p02.pddl"),
    (DATA / "ippc2008/ex-blocksworld/domain.pddl", DATA / "ippc2008/ex-blocksworld/p01.pddl"),
    (REF / "blocksworld/domain.ppddl", REF / "blocksworld/p02.ppddl"),
    (REF / "tower/domain.ppddl", REF / "tower/p01.ppddl"),
    (REF / "tower/rules.ppddl", REF / "tower/p02.ppddl"),
], ids=lambda p: f"{p.parent.name}/{p.name}")
def test_fast_downward_solves_the_determinisation(domain_file, problem_file, mode):
    domain, problem = load(domain_file, problem_file)
    plain, plain_problem = determinize(domain, problem, mode)
    assert not {":probabilistic-effects", ":rewards"} & set(plain.requirements)
    assert set(plain.requirements) - {":strips"} == set(requirements(plain))
    assert plain_problem.goal_reward is None and plain_problem.metric is None
    plan = solve(plain, plain_problem)                 # unified-planning's PDDLReader + Fast Downward
    assert plan, "Fast Downward found no plan"
    task = Task(plain, plain_problem)
    assert task.goal_holds(_run(task, plan))           # the plan reaches the goal in the plain domain
    # ... and each step is possible (probability > 0) in the probabilistic domain
    real = Task(domain, problem)
    s = real.initial_state
    for step, prim in zip(plan, primitive_plan(domain, plan)):
        succ = task.distribution(s, step)[0].state
        assert real.probability(s, prim, succ) > 0, step
        s = succ


def test_most_likely_keeps_the_most_probable_outcome():
    d, _ = load(DATA / "ippc2006/blocksworld/domain.pddl")
    plain, _ = determinize(d, None, "most-likely")
    pick = plain.action("pick-up")
    assert Literal(Atom("holding", ("?b1",))) in pick.effect.effects       # the 3/4 outcome
    assert plain.action("pick-tower") is None                               # 1/10 success: no change wins
    all_out, _ = determinize(d, None, "all-outcomes")
    assert {a.name for a in all_out.actions} >= {"pick-up_o1", "pick-up_o2", "put-on-block_o1", "put-down"}
    assert all(not isinstance(a.effect, Probabilistic) for a in all_out.actions)


def test_planners_that_cannot_take_the_domain_are_refused():
    domain, problem = load(REF / "tower/domain.ppddl", REF / "tower/p01.ppddl")
    plain, plain_problem = determinize(domain, problem)
    with pytest.raises(UserError) as exc:
        solve(plain, plain_problem, planner="fast-downward-opt")
    msg = str(exc.value)
    assert "\n" not in msg and "cannot take domain tower-cell" in msg and "conditional-effects" in msg
    with pytest.raises(UserError, match="unknown planner 'no-such-planner'"):
        solve(plain, plain_problem, planner="no-such-planner")
    with pytest.raises(UserError, match="planner 'pyperplan' cannot take domain tower-cell: .*negative-conditions"):
        solve(plain, plain_problem, planner="pyperplan")     # STRIPS only
    # the STRIPS-like blocks world is fine for the optimal configuration
    bw, bwp = determinize(*load(REF / "blocksworld/domain.ppddl", REF / "blocksworld/p01.ppddl"))
    assert solve(bw, bwp, planner="fast-downward-opt")


def test_unsolvable_problem_gives_none():
    d = parse_domain("(define (domain u) (:requirements :probabilistic-effects) (:predicates (a) (b))"
                     " (:action go :parameters () :precondition (a) :effect (probabilistic 0.5 (b))))")
    from groundsym.ppddl.parser import parse_problem
    p = parse_problem("(define (problem p) (:domain u) (:init) (:goal (b)))", d)
    plain, plain_p = determinize(d, p)
    assert solve(plain, plain_p) is None
