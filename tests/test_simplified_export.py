"""The simplified, rounded rule export (what ``export-domain`` writes) against the raw one.

Truth used: the raw export (exact probabilities, every exclusion as built) has the NID rule-set
semantics (tests/test_ppddl_writer.py checks that against the rule set itself); on every state of
a small problem the simplified domain must give the same successor states with probabilities
within the rounding, and a reader must get back rules with the same semantics.
"""

from __future__ import annotations

import itertools
import re

import pytest

from groundsym.logic import Atom, parse_atom, parse_literal
from groundsym.ppddl.ast import And, Not, Or, TRUE
from groundsym.ppddl.convert import domain_to_rules, rules_to_domain
from groundsym.ppddl.parser import parse_domain
from groundsym.ppddl.simplify import FALSE, simplify
from groundsym.ppddl.simulate import Task
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


def _dist(task: Task, state: frozenset, prim: Atom) -> dict:
    out: dict = {}
    for s in task.distribution(state, prim):
        out[s.state] = out.get(s.state, 0.0) + s.prob
    return out or {state: 1.0}


@pytest.mark.parametrize("noise", ["no-change", pytest.param("pessimistic", marks=pytest.mark.slow)])
def test_simplified_domain_has_the_raw_domains_distributions_on_every_state(noise):
    raw = rules_to_domain(RULES, PREDICATES, "raw", noise)
    dropped: list[str] = []
    simple = parse_domain(str(rules_to_domain(RULES, PREDICATES, "simple", noise, decimals=4, simple=True,
                                              dropped=dropped)))
    assert dropped == ["closeHandAround_r2"] and simple.action("closeHandAround_r2") is None
    objects = ["o1", "o2", "o3"]
    a, b = Task(raw, objects), Task(simple, objects)
    atoms = [Atom(p, (o,)) for p in ("clear", "inhand", "ontable") for o in objects]
    states = [frozenset(x for x, keep in zip(atoms, bits) if keep)
              for bits in itertools.product((0, 1), repeat=len(atoms))]
    compared = changed = 0
    for s in states:
        for prim in a.primitive_actions():
            da, db = _dist(a, s, prim), _dist(b, s, prim)
            assert da.keys() == db.keys(), (sorted(s), prim)
            for k in da:
                assert abs(da[k] - db[k]) <= 1e-4, (sorted(s), prim, k)
            compared += 1
            changed += any(k != s for k in da)
    assert compared == len(states) * 6 and changed > 500


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
