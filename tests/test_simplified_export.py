"""The simplified, rounded rule export (what ``export-domain`` writes) against the raw one.

Truth used: the raw export (exact probabilities, every exclusion as built) has the NID rule-set
semantics (tests/test_ppddl_writer.py checks that against the rule set itself); on every state of
a small problem the simplified domain must give the same successor states with probabilities
within the rounding, every step the reward model's reward within the documented reward rounding,
and a reader must get back rules with the same semantics.
"""

from __future__ import annotations

import itertools
import re

from pathlib import Path

import pytest

from groundsym.export import DECIMALS, reward_effect, with_reward
from groundsym.logic import Atom, parse_atom, parse_literal
from groundsym.modeldir import Model
from groundsym.ppddl.ast import And, Not, Or, TRUE
from groundsym.ppddl.from_rules import RulesWriter, rules_to_domain
from groundsym.ppddl.parser import parse_domain
from groundsym.ppddl.simplify import FALSE, simplify
from groundsym.ppddl.simulate import Task
from groundsym.ppddl.to_rules import domain_to_rules
from groundsym.reward import Feature, RewardModel, state_arrays
from groundsym.rules.model import Outcome, Rule, RuleSet

PREDICATES = {"clear": 1, "inhand": 1, "on": 2, "ontable": 1}


def rule(action, context, outcomes, noise):
    return Rule(parse_atom(action), tuple(map(parse_literal, context)),
                tuple(Outcome(tuple(map(parse_literal, ch))) for _, ch in outcomes), tuple(p for p, _ in outcomes),
                noise)


# A learned-looking rule set with every case the simplifier meets: an always-covering rule
# (closeHandAround r1) that makes the blocking rule r2 never apply (left out); a one-literal
# negative context (openHandOver r3), whose exclusion in r1 reads (ontable ?x) after removing the
# double negation; deictic references; probabilities with many digits.
RULES = RuleSet((
    rule("(closeHandAround ?x)", [], [(0.7169274534051522, ["(inhand ?x)"]), (0.2409672826697016, [])],
         0.0421052639251462),
    rule("(closeHandAround ?x)", ["(inhand ?y)"], [(0.999999052631579, [])], 9.47368421e-07),
    rule("(openHandOver ?x)", ["(inhand ?y)", "(clear ?x)"],
         [(0.77192982456, ["(on ?y ?x)", "(not (inhand ?y))", "(not (clear ?x))"]),
          (0.10526315789, ["(ontable ?y)", "(not (inhand ?y))"])], 0.12280701755),
    rule("(openHandOver ?x)", ["(inhand ?y)", "(not (clear ?x))"],
         [(0.6666666666, ["(ontable ?y)", "(not (inhand ?y))"])], 0.3333333334),
    rule("(openHandOver ?x)", ["(not (ontable ?x))"], [(0.33333333333, ["(ontable ?x)"]), (0.6, [])],
         0.06666666667),
), ())


def _dist(task: Task, state: frozenset, prim: Atom, successors: list | None = None) -> dict:
    out: dict = {}
    for s in task.distribution(state, prim) if successors is None else successors:
        out[s.state] = out.get(s.state, 0.0) + s.prob
    return out or {state: 1.0}


# A fitted-looking reward model: weights with many digits (4 significant digits change them), two
# terms below 1/1000 of the largest (the intercept, 1.2346): 0.00031 * #ontable and
# -0.0009 * #(clear and inhand); and a term over "on", which the states compared never hold.
_A, _B = "?a", "?b"
REWARD = RewardModel(
    (Feature((Atom("inhand", (_A,)),)), Feature((Atom("clear", (_A,)), Atom("ontable", (_A,)))),
     Feature((Atom("ontable", (_A,)),)), Feature((Atom("clear", (_A,)), Atom("inhand", (_A,)))),
     Feature((Atom("on", (_A, _B)),))),
    (-0.0123456789, 0.876543219, 0.00031, -0.0009, 0.5),
    1.23456789, tuple(sorted(PREDICATES.items())))


def _reward_tolerance(rm: RewardModel, state: frozenset, objects: list[str]) -> float:
    """The rounding rule as documented, applied to one state: a kept term (at least 1/1000 of the
    largest |term|, intercept included) is rounded to 4 significant digits, so it is off by at most
    half a unit in its 4th digit, 5e-4 of itself; a left-out term is off by all of itself. Each
    term counts as often as its feature has groundings in ``state``."""
    big = max(abs(rm.intercept), *map(abs, rm.weights))
    arrays = state_arrays([state], objects, dict(rm.predicates))
    counts = [1.0] + [float(f.evaluate(arrays, len(objects))[0]) for f in rm.features]
    return sum(c * (abs(w) if abs(w) < 1e-3 * big else 5e-4 * abs(w))
               for c, w in zip(counts, (rm.intercept, *rm.weights))) + 1e-12


@pytest.mark.parametrize("noise", ["no-change", pytest.param("pessimistic", marks=pytest.mark.slow)])
def test_simplified_domain_has_the_raw_domains_distributions_and_rewards_on_every_state(noise):
    """What ``export-domain`` writes for a model (rounded, simplified rules; rounded reward effects
    on every action) against the raw domain's distributions and the reward model's exact reward
    (read in the state the action is taken in), on every state of a 3-object problem."""
    raw = rules_to_domain(RULES, PREDICATES, "raw", noise)
    model = Model(Path("unused"), RULES, REWARD, {"predicates": PREDICATES})
    domain, dropped = RulesWriter(RULES, noise, decimals=DECIMALS, simple=True).domain(PREDICATES, "simple")
    text = str(with_reward(domain, reward_effect(model)))
    simple = parse_domain(text)
    assert dropped == ("closeHandAround_r2",) and simple.action("closeHandAround_r2") is None
    assert "0.8765" in text and "0.00031" not in text and "9/10000" not in text   # rounded; two left out
    objects = ["o1", "o2", "o3"]
    a, b = Task(raw, objects), Task(simple, objects)
    atoms = [Atom(p, (o,)) for p in ("clear", "inhand", "ontable") for o in objects]
    states = [frozenset(x for x, keep in zip(atoms, bits) if keep)
              for bits in itertools.product((0, 1), repeat=len(atoms))]
    compared = changed = rewarded = left_out = 0
    for s in states:
        exact, tol = REWARD.predict(s, objects), _reward_tolerance(REWARD, s, objects)
        for prim in a.primitive_actions():
            want, got = a.distribution(s, prim), b.distribution(s, prim)
            assert bool(want) == bool(got), (sorted(s), prim)          # an action applies in both or neither
            da, db = _dist(a, s, prim, want), _dist(b, s, prim, got)
            assert da.keys() == db.keys(), (sorted(s), prim)
            for k in da:
                assert abs(da[k] - db[k]) <= 1e-4, (sorted(s), prim, k)
            for succ in got:
                assert abs(succ.reward - exact) <= tol, (sorted(s), prim, succ.reward, exact, tol)
                assert succ.reward != exact                  # the rounding is not vacuous here
                rewarded += 1
                left_out += any(x.predicate == "ontable" for x in s)
            compared += 1
            changed += any(k != s for k in da)
    assert compared == len(states) * 6 and changed > 500 and rewarded > 1000 and left_out > 0


def test_simplified_export_reads_back_with_the_same_semantics():
    """The reader gets the kept rules back, and the left-out rule as a blocking rule, so a rule-set
    planner (PRADA) sees the distributions the domain has."""
    simple = parse_domain(str(rules_to_domain(RULES, PREDICATES, "simple", decimals=4, simple=True)))
    back = domain_to_rules(simple)
    objects = ["o1", "o2", "o3"]
    task = Task(simple, objects)
    atoms = [Atom(p, (o,)) for p in ("clear", "inhand", "ontable") for o in objects]
    for bits in itertools.product((0, 1), repeat=len(atoms)):
        s = frozenset(x for x, keep in zip(atoms, bits) if keep)
        for prim in task.primitive_actions():
            r, binding = back.covering(s, prim, objects)
            want = _dist(task, s, prim)
            if r is None:
                assert want == {s: 1.0}, (sorted(s), prim)
                continue
            got: dict = {}
            for o, p in zip(r.outcomes, r.probs):
                s2 = o.apply(s, binding)
                got[s2] = got.get(s2, 0.0) + p
            got[s] = got.get(s, 0.0) + r.noise
            got = {k: v for k, v in got.items() if v > 0}
            assert got.keys() == want.keys() and all(got[k] == pytest.approx(want[k]) for k in got), (sorted(s), prim)


def test_simplified_text_is_short():
    text = str(rules_to_domain(RULES, PREDICATES, "simple", decimals=4, simple=True))
    assert "(not (and (not" not in text and "(not (not" not in text and "(not (and))" not in text
    assert "(ontable ?x)))" in text                     # r3's exclusion in r1, without the double negation
    numbers = re.findall(r"(?<![\w?-])\d+\.\d+", text)
    assert numbers and all(len(n.split(".")[1]) <= 4 for n in numbers)
    assert max(map(len, text.splitlines())) <= 100


def test_simplify_by_hand():
    a, b = parse_atom("(a ?x)"), parse_atom("(b ?x)")
    assert simplify(Not(And((Not(a),)))) == a
    assert simplify(And((a, a, And((b, TRUE))))) == And((a, b))
    assert simplify(And((a, Not(a)))) == FALSE and simplify(Or((a, Not(a)))) == TRUE
    assert simplify(Not(And(()))) == FALSE
    assert simplify(Atom("=", ("?x", "?x"))) == TRUE and simplify(Atom("=", ("o1", "o2"))) == FALSE
