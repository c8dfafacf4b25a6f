"""The PPDDL writer and the NID rule <-> PPDDL conversion.

Truth used: printing then parsing gives the same tree; an exported rule set parses back to the
same rules; and the exported domain, run by the PPDDL simulator, has exactly the NID rule-set
semantics of NID rules (docs/rules.md: (unique covering rule, else the default: no change).
"""

from __future__ import annotations

import random
from fractions import Fraction
from pathlib import Path

import pytest

from groundsym.logic import Atom, Literal, parse_atom, parse_literal
from groundsym.ppddl.ast import Domain, Probabilistic, number
from groundsym.ppddl.compare import rules_equal
from groundsym.ppddl.from_rules import probability, rules_to_domain
from groundsym.ppddl.rule_actions import NOISE_PREDICATE, primitive_of
from groundsym.ppddl.to_rules import domain_to_rules
from groundsym.ppddl.parser import load, parse_domain, parse_text
from groundsym.ppddl.simulate import Task
from groundsym.rules.model import Outcome, Rule, RuleSet

DATA = Path(__file__).parent / "data" / "ippc"
REF = Path(__file__).parent.parent / "domains" / "reference"
FILES = sorted(DATA.glob("*/*/*.pddl")) + sorted(REF.glob("*/*.ppddl"))


def L(text: str) -> Literal:
    return parse_literal(text)


def rule(action: str, context: list[str], outcomes: list[tuple[float, list[str]]], noise: float) -> Rule:
    return Rule(parse_atom(action), tuple(map(L, context)), tuple(Outcome(tuple(map(L, ch))) for _, ch in outcomes),
                tuple(p for p, _ in outcomes), noise)


# The tower cell as NID rules, with deictic references (?y: the held object) and a blocking rule
# (closeHandAround with a full hand covers together with r1/r2, so the default rule: no change).
TOWER_RULES = RuleSet((
    rule("(closeHandAround ?x)", ["(clear ?x)", "(ontable ?x)"],
         [(0.9, ["(inhand ?x)", "(not (ontable ?x))"])], 0.1),
    rule("(closeHandAround ?x)", ["(clear ?x)", "(on ?x ?y)"],
         [(0.85, ["(inhand ?x)", "(not (on ?x ?y))", "(clear ?y)"]), (0.1, [])], 0.05),
    rule("(closeHandAround ?x)", ["(inhand ?y)"], [(1.0, [])], 0.0),
    rule("(openHandOver ?x)", ["(inhand ?y)", "(clear ?x)"],
         [(0.7, ["(on ?y ?x)", "(not (inhand ?y))", "(not (clear ?x))"]),
          (0.2, ["(ontable ?y)", "(not (inhand ?y))"])], 0.1),
    rule("(openHandOver ?x)", ["(inhand ?y)", "(not (clear ?x))", "(on ?z ?x)"],
         [(0.6, ["(ontable ?y)", "(not (inhand ?y))"]), (0.3, ["(on ?y ?z)", "(not (inhand ?y))"])], 0.1),
), ())
PREDICATES = {"clear": 1, "inhand": 1, "on": 2, "ontable": 1}

# domains/reference/tower/domain.ppddl as NID rules (the true rules PRADA can plan with); the file
# domains/reference/tower/rules.ppddl is exactly their export, and must behave as domain.ppddl does.
TOWER_RULES_HEADER = (
    "The tower cell (domain.ppddl beside this file) as NID rules, exported by\n"
    "groundsym.ppddl.from_rules from TOWER_REFERENCE_RULES in tests/test_ppddl_writer.py; a test\n"
    "checks that it gives the same distributions as domain.ppddl on every state the cell can reach.\n"
    "closeHandAround_r3 (a held object) only blocks: with it, a full hand makes two rules cover, so\n"
    "nothing happens.")
TOWER_REFERENCE_RULES = RuleSet((
    rule("(closeHandAround ?x)", ["(clear ?x)", "(ontable ?x)"],
         [(0.9, ["(inhand ?x)", "(not (ontable ?x))"]), (0.1, [])], 0.0),
    rule("(closeHandAround ?x)", ["(clear ?x)", "(on ?x ?y)"],
         [(0.9, ["(inhand ?x)", "(not (on ?x ?y))", "(clear ?y)"]), (0.1, [])], 0.0),
    rule("(closeHandAround ?x)", ["(inhand ?y)"], [(1.0, [])], 0.0),
    rule("(openHandOver ?x)", ["(inhand ?x)"], [(1.0, ["(not (inhand ?x))", "(ontable ?x)"])], 0.0),
    rule("(openHandOver ?x)", ["(inhand ?y)", "(clear ?x)"],
         [(0.8, ["(on ?y ?x)", "(not (inhand ?y))", "(not (clear ?x))"]),
          (0.2, ["(ontable ?y)", "(not (inhand ?y))"])], 0.0),
    rule("(openHandOver ?x)", ["(inhand ?y)", "(not (clear ?x))"],
         [(1.0, ["(ontable ?y)", "(not (inhand ?y))"])], 0.0),
), ())


@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_print_then_parse_is_identity(path):
    is_domain = path.stem in ("domain", "rules")
    domain, problem = load(path if is_domain else path.parent / ("domain" + path.suffix), None if is_domain else path)
    d2 = parse_domain(str(domain))
    assert d2 == domain
    if problem is not None:
        _, (p2,) = parse_text(str(problem), domains={domain.name: domain})
        assert p2 == problem
        assert str(p2) == str(problem)
    assert str(d2) == str(domain)


def test_output_is_sorted_and_independent_of_input_order():
    text = (DATA / "ippc2006/blocksworld/domain.pddl").read_text()
    domain = parse_domain(text)
    shuffled = Domain(domain.name, tuple(reversed(domain.requirements)), domain.types, domain.constants,
                      tuple(reversed(domain.predicates)), tuple(reversed(domain.actions)))
    assert str(shuffled) == str(domain)
    names = [line.split()[1] for line in str(domain).splitlines() if line.strip().startswith("(:action")]
    assert names == sorted(names)


def test_numbers_print_exactly():
    assert number(Fraction(3, 4)) == "0.75"
    assert number(Fraction(1, 3)) == "1/3"
    assert number(Fraction(-5, 2)) == "-2.5"
    assert number(Fraction(7)) == "7"
    assert number(Fraction(1, 80)) == "0.0125"
    for p in (0.1, 0.7 / 3, 1e-6, 0.999999, 2.0 ** -30):
        assert float(probability(p)) == p                 # shortest decimal, same float


def test_nested_fractional_probabilities_parse_exactly():
    d = parse_domain("""(define (domain n) (:requirements :probabilistic-effects)
      (:predicates (a) (b) (c))
      (:action go :parameters () :effect
        (probabilistic 1/3 (probabilistic 0.5 (a) 1/4 (b)) 2/3 (c))))""")
    eff = d.actions[0].effect
    assert isinstance(eff, Probabilistic) and eff.branches[0][0] == Fraction(1, 3)
    dist = {tuple(sorted(map(str, s))): p for p, s, _ in
            ((x.prob, x.state, x.reward) for x in Task(d, []).outcomes(frozenset(), Atom("go")))}
    assert dist == {("(a)",): pytest.approx(1 / 6), ("(b)",): pytest.approx(1 / 12), ("(c)",): pytest.approx(2 / 3),
                    (): pytest.approx(1 / 12)}


@pytest.mark.parametrize("noise", ["no-change", "pessimistic"])
def test_exported_rules_parse_back_to_the_same_rules(noise):
    domain = rules_to_domain(TOWER_RULES, PREDICATES, "tower-rules", noise)
    back = parse_domain(str(domain))
    assert back == domain
    names = {a.name: a for a in back.actions}
    assert sorted(names) == ["closeHandAround_r1", "closeHandAround_r2", "closeHandAround_r3",
                             "openHandOver_r1", "openHandOver_r2"]
    count: dict[str, int] = {}
    from groundsym.ppddl.to_rules import action_to_rule
    for r in TOWER_RULES.rules:
        count[r.action.predicate] = count.get(r.action.predicate, 0) + 1
        again = action_to_rule(names[f"{r.action.predicate}_r{count[r.action.predicate]}"])
        assert rules_equal(r, again), (r, again)
    assert primitive_of(names["openHandOver_r2"]) == ("openHandOver", 1)
    req = set(domain.requirements)
    assert {":probabilistic-effects", ":negative-preconditions", ":equality", ":universal-preconditions",
            ":existential-preconditions"} <= req
    assert ":rewards" not in req and ":typing" not in req and ":conditional-effects" not in req


def _ruleset_distribution(rs: RuleSet, state: frozenset, action: Atom, objects, noise: str) -> dict:
    r, b = rs.covering(state, action, objects)
    if r is None:
        return {state: 1.0}
    out: dict = {}
    for o, p in zip(r.outcomes, r.probs):
        s2 = o.apply(state, b)
        out[s2] = out.get(s2, 0.0) + p
    if r.noise > 0:
        s2 = state | {Atom(NOISE_PREDICATE)} if noise == "pessimistic" else state
        out[s2] = out.get(s2, 0.0) + r.noise
    return out


@pytest.mark.parametrize("noise", ["no-change", "pessimistic"])
def test_exported_domain_has_the_rule_set_semantics(noise):
    domain = rules_to_domain(TOWER_RULES, PREDICATES, "tower-rules", noise)
    objects = ["o1", "o2", "o3", "o4"]
    task = Task(domain, objects)
    ground = sorted({Atom(p, tuple(args)) for p, k in PREDICATES.items()
                     for args in __import__("itertools").product(objects, repeat=k)})
    rng = random.Random(0)
    covered = ambiguous = 0
    for _ in range(300):
        density = rng.choice([0.1, 0.2, 0.35])
        state = frozenset(a for a in ground if rng.random() < density)
        for prim in task.primitive_actions():
            want = _ruleset_distribution(TOWER_RULES, state, prim, objects, noise)
            got: dict = {}
            for s in task.distribution(state, prim):
                got[s.state] = got.get(s.state, 0.0) + s.prob
            if not got:
                got = {state: 1.0}
            assert got.keys() == want.keys(), (sorted(state), prim)
            for k in got:
                assert got[k] == pytest.approx(want[k], abs=1e-12)
            r, _ = TOWER_RULES.covering(state, prim, objects)
            covered += r is not None
            ambiguous += r is None and any(x.bindings(state, prim, objects=objects) for x in
                                           TOWER_RULES.rules_for(prim.predicate))
    assert covered > 300 and ambiguous > 100       # both kinds of case were exercised


def test_reference_blocksworld_reads_as_its_true_rules():
    domain, _ = load(REF / "blocksworld/domain.ppddl")
    rs = domain_to_rules(domain)
    by = {r.action.predicate: r for r in rs.rules}
    assert set(by) == {"pickup", "unstack", "putdown", "stack"}
    assert set(by["unstack"].context) == {L("(handempty)"), L("(clear ?x)"), L("(on ?x ?y)")}
    assert by["unstack"].probs == (0.7, 0.2, 0.1) and by["unstack"].outcomes[2].is_empty
    assert by["putdown"].noise == 0.0 and by["pickup"].noise == 0.0
    assert all(d.p_noise == 0.0 for _, d in rs.defaults)


def test_outside_the_rule_subset_is_refused_in_one_line():
    from groundsym.errors import UserError
    domain, _ = load(REF / "tower/domain.ppddl")
    with pytest.raises(UserError, match="outside the rule subset"):
        domain_to_rules(domain)


def test_tower_rules_file_is_the_export_of_the_reference_rules():
    text = (REF / "tower/rules.ppddl").read_text()
    want = rules_to_domain(TOWER_REFERENCE_RULES, PREDICATES, "tower-cell", comment=TOWER_RULES_HEADER)
    assert text == str(want)
    rs = domain_to_rules(parse_domain(text))
    assert len(rs.rules) == len(TOWER_REFERENCE_RULES.rules)


def test_tower_rules_behave_as_the_tower_domain_on_reachable_states():
    import numpy as np
    from groundsym.ppddl.simulate import simulate_traces

    natural, problem = load(REF / "tower/domain.ppddl", REF / "tower/p02.ppddl")
    as_rules, _ = load(REF / "tower/rules.ppddl", REF / "tower/p02.ppddl")
    a, b = Task(natural, problem), Task(as_rules, problem)
    states = {s for tr in simulate_traces(a, 40, 25, np.random.default_rng(1), 0.2).traces for s in tr.states}
    assert len(states) > 200
    for s in states:
        for prim in a.primitive_actions():
            da = {x.state: x.prob for x in a.distribution(s, prim)} or {s: 1.0}
            db = {x.state: x.prob for x in b.distribution(s, prim)} or {s: 1.0}
            assert da.keys() == db.keys() and all(da[k] == pytest.approx(db[k]) for k in da), (sorted(s), prim)
