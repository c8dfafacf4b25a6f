"""IPPC domains as NID rules: every construct of the 18 competition files converted, exactly.

Independent truth: the PPDDL simulator's outcome distributions (which tests/test_ppddl_simulate.py
checks against plado and by hand), compared over every reachable state and every ground action of a
small exploding-blocksworld problem."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest

from groundsym.errors import UserError
from groundsym.logic import Atom, parse_atom
from groundsym.ppddl.ast import Action, ForallEffect, Or, Probabilistic, Problem, Typed, When
from groundsym.ppddl.to_rules import action_to_rules, domain_to_rules
from groundsym.ppddl.parser import load
from groundsym.ppddl.simulate import Task

DATA = Path(__file__).parent / "data" / "ippc"
FILES = sorted(DATA.glob("*/*/p*.pddl"))


def load_ippc(path: Path):
    """IPPC 2006 problems name a separate domain file; 2008 problem files carry theirs."""
    return load(path.parent / "domain.pddl", path) if "ippc2006" in str(path) else load(path)


@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.parent.name}/{p.parent.name}/{p.name}")
def test_every_ippc_file_converts(path):
    domain, _ = load_ippc(path)
    assert domain_to_rules(domain).rules


def _rule_distribution(rules, state: frozenset, action: Atom, objects) -> dict[frozenset, float] | None:
    rule, binding = rules.covering(state, action, objects)
    if rule is None:
        return None
    out: dict[frozenset, float] = {}
    for o, p in zip(rule.outcomes, rule.probs):
        s2 = o.apply(state, binding)
        out[s2] = out.get(s2, 0.0) + p
    if rule.noise > 0:      # the plain subset reads unassigned mass as noise; with no noise_changes
        assert rule.noise_changes == 0.0       # it changes nothing (PRADA spreads noise_changes only)
        out[state] = out.get(state, 0.0) + rule.noise
    return out


def _small_problem(domain, init: list[str], with_detonation: bool) -> Problem:
    blocks = ("b1", "b2", "b3")
    atoms = [parse_atom(a) for a in init]
    if with_detonation:
        atoms += [parse_atom("(no-destroyed-table)")]
        atoms += [Atom(p, (b,)) for b in blocks for p in ("no-detonated", "no-destroyed")]
    return Problem("small", domain.name, tuple(Typed(b, "block") for b in blocks), tuple(atoms))


SMALL = [("ippc2008/ex-blocksworld/p01.pddl", True), ("ippc2006/blocksworld/domain.pddl", False)]


@pytest.mark.parametrize("path,exploding", SMALL, ids=["ex-blocksworld-2008", "blocksworld-2006"])
def test_rules_give_the_simulators_distributions_on_every_state_action_pair(path, exploding):
    """Every reachable state x every ground move the simulator offers, repeated arguments included
    (``(put-on-block b1 b1)``: the repeated-variable rules cover those)."""
    domain, _ = load(DATA / path)
    init = ["(emptyhand)", "(on-table b1)", "(on b2 b1)", "(on-table b3)", "(clear b2)", "(clear b3)"]
    task = Task(domain, _small_problem(domain, init, exploding))
    blocks = ("b1", "b2", "b3")
    rules = domain_to_rules(domain)
    ground = task.primitive_actions()
    assert any(len(set(a.args)) < len(a.args) for a in ground)
    seen, frontier, pairs, repeated = {task.initial_state}, [task.initial_state], 0, 0
    while frontier:
        state = frontier.pop()
        for action in ground:
            mine = {s.state: s.prob for s in task.distribution(state, action)}
            theirs = _rule_distribution(rules, state, action, blocks)
            assert (theirs is None) == (not mine), (state, action)
            if mine:
                assert mine.keys() == theirs.keys(), (state, action)
                assert all(abs(mine[k] - theirs[k]) < 1e-12 for k in mine), (state, action)
                pairs += 1
                repeated += len(set(action.args)) < len(action.args)
            for s2 in mine:
                if s2 not in seen:
                    seen.add(s2)
                    frontier.append(s2)
    assert len(seen) > 100 and pairs > 200 and repeated > 20
    assert any(Atom("on", ("b1", "b1")) in s for s in seen)          # a block put on itself
    if exploding:          # the walk reached detonations and destroyed blocks
        assert any(Atom("no-destroyed-table", ()) not in s for s in seen)


def test_when_inside_probabilistic_becomes_two_rules():
    domain, _ = load(DATA / "ippc2008/ex-blocksworld/p01.pddl")
    rules = action_to_rules(domain.action("put-down"), domain.name)
    assert len(rules) == 2
    on, off = sorted(rules, key=lambda r: not any(l.positive and l.atom.predicate == "no-detonated"
                                                  for l in r.context))
    assert sorted(on.probs) == [0.4, 0.6] and off.probs == (1.0,)


def test_refusals_name_the_construct_and_the_action():
    lit = parse_atom("(p ?x)")
    from groundsym.logic import Literal
    bad_when = Action("act", (Typed("?x"),), lit, When(Or((lit, parse_atom("(q ?x)"))), Literal(lit, False)))
    with pytest.raises(UserError, match="action act: a when condition .* not a conjunction of literals"):
        action_to_rules(bad_when, "d")
    bad_forall = Action("move", (Typed("?x"),), lit,
                        Probabilistic(((Fraction(1, 2), ForallEffect((Typed("?y"),), Literal(parse_atom("(q ?y)"), True))),)))
    with pytest.raises(UserError, match="action move: .*forall"):
        action_to_rules(bad_forall, "d")
