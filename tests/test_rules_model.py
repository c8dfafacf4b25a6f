"""NID rule semantics (Pasula et al. 2007; docs/rules.md): coverage, likelihood, and the rules files."""

from __future__ import annotations

import json
from itertools import permutations

import numpy as np
import pytest

from groundsym.errors import UserError
from groundsym.logic import Atom, Literal, parse_atom, parse_literal
from groundsym.rules.coverage import Example, ExampleTable
from groundsym.rules.io import doc_to_rules, read_rules, rules_to_text, write_rules
from groundsym.rules.model import DefaultRule, Derived, Outcome, Rule, RuleSet, with_derived

from conftest import DATA


def state(*atoms: str) -> frozenset:
    return frozenset(parse_atom(a) for a in atoms)


def rule(action: str, context: list[str], outcomes=(), probs=(), noise=1.0) -> Rule:
    return Rule(parse_atom(action), tuple(parse_literal(c) for c in context),
                tuple(Outcome(tuple(parse_literal(x) for x in o)) for o in outcomes), tuple(probs), noise)


def table_cover(r: Rule, s: frozenset, a: str, objects=None, injective=True):
    """Coverage through the vectorised engine, as a name binding (or None)."""
    act = parse_atom(a)
    objs = tuple(objects or sorted({x for at in s for x in at.args} | set(act.args)))
    preds = {p.predicate: p.arity for p in s} | {l.atom.predicate: l.atom.arity for l in r.context}
    t = ExampleTable([Example(s, act, s, objs)], preds)
    cov = t.cover(r.action, r.context, injective)
    return cov.names(t, 0) if len(cov) else None


PUTON = rule("(puton ?x)", ["(block ?x)", "(inhand ?y)"])


@pytest.mark.parametrize("cover", [lambda r, s, a: r.covers(s, parse_atom(a)), table_cover])
def test_puton_ambiguity_example(cover):
    # the libPRADA guide's example: a unique deictic reference covers, an ambiguous one does not
    assert cover(PUTON, state("(block a)", "(inhand b)"), "(puton a)") == {"?x": "a", "?y": "b"}
    assert cover(PUTON, state("(block a)", "(inhand b)", "(inhand c)"), "(puton a)") is None


@pytest.mark.parametrize("cover", [lambda r, s, a: r.covers(s, parse_atom(a)), table_cover])
def test_deictic_reference_with_zero_one_two_matches(cover):
    r = rule("(grab ?x)", ["(on ?y ?x)"])
    assert cover(r, state("(on b c)"), "(grab a)") is None                       # no match
    assert cover(r, state("(on b a)", "(on c d)"), "(grab a)") == {"?x": "a", "?y": "b"}
    assert cover(r, state("(on b a)", "(on c a)"), "(grab a)") is None           # two matches


@pytest.mark.parametrize("cover", [lambda r, s, a: r.covers(s, parse_atom(a)), table_cover])
def test_negated_literals_use_the_closed_world(cover):
    r = rule("(grab ?x)", ["(clear ?x)", "(not (ball ?x))"])
    assert cover(r, state("(clear a)"), "(grab a)") == {"?x": "a"}
    assert cover(r, state("(clear a)", "(ball a)"), "(grab a)") is None


def test_bindings_are_injective_unless_turned_off():
    r = rule("(look ?x)", ["(near ?x ?y)"])
    s = state("(near a a)")
    assert r.covers(s, parse_atom("(look a)")) is None
    assert table_cover(r, s, "(look a)") is None
    assert r.covers(s, parse_atom("(look a)"), injective=False) == {"?x": "a", "?y": "a"}
    assert table_cover(r, s, "(look a)", injective=False) == {"?x": "a", "?y": "a"}


def random_state(rng, objs, preds):
    atoms = [Atom(p, args) for p, k in preds.items() for args in permutations(objs, k)]
    return frozenset(a for a in atoms if rng.random() < 0.3)


def test_vectorised_coverage_agrees_with_the_reference_backtracking():
    """Property: ExampleTable.cover == Rule.covers on random states and random contexts."""
    rng = np.random.default_rng(1)
    preds = {"p": 1, "q": 1, "r": 2, "s": 2, "z": 0}
    variables = ["?x1", "?y1", "?y2"]
    for trial in range(60):
        examples = []
        for _ in range(12):
            objs = tuple(f"o{i}" for i in range(int(rng.integers(2, 6))))
            s = random_state(rng, objs, preds)
            examples.append(Example(s, Atom("act", (objs[int(rng.integers(len(objs)))],)), s, objs))
        lits = set()
        for _ in range(int(rng.integers(1, 4))):
            p = str(rng.choice(list(preds)))
            args = tuple(rng.choice(variables, size=preds[p], replace=False))
            lits.add(Literal(Atom(p, args), bool(rng.random() < 0.7)))
        pos_vars = {a for l in lits if l.positive for a in l.atom.args}
        if any(a not in pos_vars and a != "?x1" for l in lits for a in l.atom.args):
            continue                                        # negated-only references are not learned
        r = Rule(Atom("act", ("?x1",)), tuple(sorted(lits)), (), (), 1.0)
        t = ExampleTable(examples, preds)
        cov = t.cover(r.action, r.context)
        got = {int(i): cov.names(t, k) for k, i in enumerate(cov.index)}
        want = {i: b for i, e in enumerate(examples) if (b := r.covers(e.state, e.action, True, e.objects))}
        assert got == want, f"trial {trial}: {r.context}"


def test_vectorised_outcome_check_agrees_with_applying_the_outcome():
    rng = np.random.default_rng(2)
    preds = {"p": 1, "r": 2, "z": 0}
    objs = ("a", "b", "c")
    cands = [Outcome(()), Outcome((parse_literal("(p ?x1)"),)), Outcome((parse_literal("(not (r ?x1 ?y1))"),)),
             Outcome((parse_literal("(p ?y1)"), parse_literal("(z)"))),
             Outcome((parse_literal("(not (p ?x1))"), parse_literal("(r ?y1 ?x1)")))]
    examples = []
    for _ in range(300):
        s = random_state(rng, objs, preds) | {Atom("r", ("a", "b"))}
        s2 = random_state(rng, objs, preds) if rng.random() < 0.5 else \
            cands[int(rng.integers(len(cands)))].apply(s, {"?x1": "a", "?y1": "b"})
        examples.append(Example(s, Atom("act", ("a",)), s2, objs))
    t = ExampleTable(examples, preds)
    ctx = (parse_literal("(r ?x1 ?y1)"),)
    cov = t.cover(Atom("act", ("?x1",)), ctx)
    assert len(cov) > 0
    for o in cands:
        got = t.outcome_covers(o.changes, cov)
        want = [o.apply(examples[i].state, cov.names(t, k)) == examples[i].succ for k, i in enumerate(cov.index)]
        assert got.tolist() == want


def test_likelihood_sums_overlapping_outcomes_plus_noise_times_p_min():
    r = rule("(puton ?x)", ["(clear ?x)", "(inhand ?y)"],
             outcomes=[[], ["(on ?y ?x)"], ["(not (inhand ?y))"]], probs=[0.3, 0.5, 0.1], noise=0.1)
    s = state("(clear a)", "(inhand b)", "(on b a)")          # on(b,a) already holds
    b = r.covers(s, parse_atom("(puton a)"))
    # s' = s: explained by "no change" and by (on ?y ?x), which sets an atom already true
    assert r.likelihood(s, b, s, p_min=1e-8) == pytest.approx(0.3 + 0.5 + 0.1 * 1e-8)
    s2 = state("(clear a)", "(on b a)")
    assert r.likelihood(s, b, s2, p_min=1e-8) == pytest.approx(0.1 + 0.1 * 1e-8)
    assert r.likelihood(s, b, state("(clear b)"), p_min=1e-8) == pytest.approx(0.1 * 1e-8)


def test_ruleset_falls_back_to_default_when_two_rules_cover():
    r1 = rule("(go ?x)", ["(p ?x)"], [["(q ?x)"]], [1.0], 0.0)
    r2 = rule("(go ?x)", ["(r ?x)"], [["(not (r ?x))"]], [1.0], 0.0)
    rs = RuleSet((r1, r2), (("go", DefaultRule(0.25)),), p_min=1e-8, p_min_default=1e-9)
    both = state("(p a)", "(r a)")
    assert rs.covering(both, parse_atom("(go a)")) == (None, None)
    assert rs.likelihood(both, parse_atom("(go a)"), both) == pytest.approx(0.75 + 0.25e-9)
    one = state("(p a)")
    assert rs.likelihood(one, parse_atom("(go a)"), state("(p a)", "(q a)")) == pytest.approx(1.0)


# ------------------------------------------------------------------------------------ rule files
def test_rules_json_round_trip_and_text(tmp_path):
    rs, meta = read_rules(DATA / "nid_blocks.rules.json")
    path = tmp_path / "rules.json"
    write_rules(path, rs, predicates=meta["predicates"], primitives=meta["primitives"], covers={0: 7})
    back, meta2 = read_rules(path)
    assert back.rules == rs.rules and back.defaults == rs.defaults and back.p_min == rs.p_min
    assert meta2["covers"][0] == 7
    text = rules_to_text(back, {0: 7})
    blocks = [b for b in text.split("\n\n") if b.startswith("rule ")]
    assert len(blocks) == len(rs.rules)
    first = blocks[0]
    assert "(pickup ?x1)" in first and "context:" in first and "(handempty)" in first
    assert "0.800" in first and "0.200" in first and "noise" in first and "7 training transitions" in first


def bad(doc_edit) -> str:
    doc = json.loads((DATA / "nid_blocks.rules.json").read_text())
    doc_edit(doc)
    with pytest.raises(UserError) as exc:
        doc_to_rules(doc, "m/rules.json")
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith("m/rules.json: ")
    return msg


def test_rules_json_validation_names_the_field():
    def over(d):
        d["rules"][0]["outcomes"][0]["probability"] = 0.9
    assert "rules[0].outcomes: probabilities and noise sum to 1.1" in bad(over)

    def unbound(d):
        d["rules"][0]["outcomes"][0]["changes"].append("(on ?x1 ?z)")
    assert "rules[0].outcomes[0].changes[4]: ?z is neither" in bad(unbound)

    def undeclared(d):
        d["rules"][1]["context"][0] = "(top ?x1)"
    assert "rules[1].context[0]: unknown name 'top'" in bad(undeclared)

    def garbage(d):
        d["rules"][2]["action"] = "puton ?x1"
    assert "rules[2].action: not an atom" in bad(garbage)

    def negative(d):
        d["defaults"][0]["p_noise"] = -0.5
    assert "defaults[0].p_noise: expected a probability" in bad(negative)

    def schema(d):
        d["schema"] = "groundsym.rules/0"
    assert "schema: expected 'groundsym.rules/1'" in bad(schema)


# ------------------------------------------------------------------------------- derived predicates
def test_derived_atoms_follow_their_definition_in_random_states():
    """``no-on-1(x)``: no (on x _); ``no-on-2(x)``: no (on _ x); ``no-inhand``: no (inhand _); the
    vectorised table computes the same atoms as ``with_derived``, by brute force over random states."""
    derived = Derived.for_predicates({"on": 2, "inhand": 1})
    assert [d.name for d in derived] == ["no-inhand", "no-on-1", "no-on-2"]
    rng = np.random.default_rng(0)
    objs = ("a", "b", "c", "d")
    states = []
    for _ in range(40):
        s = {Atom("on", p) for p in permutations(objs, 2) if rng.random() < 0.2}
        s |= {Atom("inhand", (o,)) for o in objs if rng.random() < 0.15}
        states.append(frozenset(s))
    table = ExampleTable([Example(s, parse_atom("(grasp a)"), s, objs) for s in states], {"on": 2, "inhand": 1}, derived)
    for i, s in enumerate(states):
        full = with_derived(s, derived, objs)
        want = {Atom("no-inhand")} if not any(a.predicate == "inhand" for a in s) else set()
        want |= {Atom("no-on-1", (x,)) for x in objs if not any(Atom("on", (x, y)) in s for y in objs)}
        want |= {Atom("no-on-2", (x,)) for x in objs if not any(Atom("on", (y, x)) in s for y in objs)}
        assert full - s == want
        assert table.full_state(i) == full
        assert bool(table.before["no-inhand"][i]) == (Atom("no-inhand") in full)
        for k, x in enumerate(objs):
            assert bool(table.before["no-on-1"][i, k]) == (Atom("no-on-1", (x,)) in full)
            assert bool(table.before["no-on-2"][i, k]) == (Atom("no-on-2", (x,)) in full)


def test_a_rule_set_computes_derived_atoms_before_coverage():
    rs, _ = read_rules(DATA / "nid_tower_derived.rules.json")
    grasp_table, grasp_stacked = rs.rules[0], rs.rules[1]
    s = state("(on a b)")
    objs = ("a", "b", "c")
    assert rs.covering(s, parse_atom("(closeHandAround a)"), objs) == (grasp_stacked, {"?x1": "a", "?y1": "b"})
    assert rs.covering(s, parse_atom("(closeHandAround c)"), objs) == (grasp_table, {"?x1": "c"})
    assert rs.covering(s, parse_atom("(closeHandAround b)"), objs) == (None, None)      # covered
    assert rs.covering(s | state("(inhand c)"), parse_atom("(closeHandAround a)"), objs) == (None, None)
    # the likelihood compares base atoms only: lifting a off b
    assert rs.likelihood(s, parse_atom("(closeHandAround a)"), state("(inhand a)"), objs) == pytest.approx(0.8)


def test_derived_predicates_round_trip_and_are_validated(tmp_path):
    rs, meta = read_rules(DATA / "nid_tower_derived.rules.json")
    path = tmp_path / "rules.json"
    write_rules(path, rs, predicates=meta["predicates"], primitives=meta["primitives"])
    back, _ = read_rules(path)
    assert back == rs and [d.name for d in back.derived] == ["no-inhand", "no-on-1", "no-on-2"]
    assert "derived: (no-on-1 ?x) holds when no (on ?x _) does" in rules_to_text(back)
    doc = json.loads((DATA / "nid_tower_derived.rules.json").read_text())
    doc["derived"][1]["holds_when_no"] = "(under ?x _)"
    with pytest.raises(UserError, match=r"^m/rules.json: derived\[1\].holds_when_no: 'under' is not a declared predicate"):
        doc_to_rules(doc, "m/rules.json")
    doc = json.loads((DATA / "nid_tower_derived.rules.json").read_text())
    doc["derived"][2]["holds_when_no"] = "(on ?x ?x)"
    with pytest.raises(UserError, match=r"derived\[2\].holds_when_no: expected an atom over \?x \(at most once\)"):
        doc_to_rules(doc, "m/rules.json")


def test_renaming_a_base_predicate_renames_its_derived_predicates(tmp_path):
    """``groundsym rename`` rewrites atom texts: the derived definitions are atom texts too."""
    from groundsym.ppddl.names import write_renamed

    src = tmp_path / "m"
    src.mkdir()
    (src / "rules.json").write_text((DATA / "nid_tower_derived.rules.json").read_text())
    write_renamed(src, tmp_path / "r", {"on": "stacked"})
    rs, _ = read_rules(tmp_path / "r" / "rules.json")
    assert {d.base for d in rs.derived} == {"inhand", "stacked"}
    # the derived predicates are renamed with their base, in the rules' contexts too
    assert [d.name for d in rs.derived] == ["no-inhand", "no-stacked-1", "no-stacked-2"]
    assert not any("no-on" in str(l) for r in rs.rules for l in r.context)
    assert rs.covering(state("(stacked a b)"), parse_atom("(closeHandAround a)"), ("a", "b", "c"))[0] is rs.rules[1]
    # so the renamed model's PPDDL export reads back as its rules (it read back as no-stacked-1
    # while the rules said no-on-1)
    from groundsym.ppddl.from_rules import rules_to_domain
    from groundsym.ppddl.to_rules import domain_to_rules
    from groundsym.ppddl.parser import parse_domain

    back = domain_to_rules(parse_domain(str(rules_to_domain(rs, {"inhand": 1, "stacked": 2})), "<export>"))
    assert back.derived == rs.derived
    assert {(r.action, r.context) for r in rs.rules} <= {(r.action, r.context) for r in back.rules}


def test_derived_literals_export_to_ppddl_with_the_rule_set_semantics():
    """A derived literal is written as (not (exists ...)); the exported domain, run by the PPDDL
    simulator, gives every random state and primitive the rule set's successor distribution."""
    from groundsym.ppddl.from_rules import rules_to_domain
    from groundsym.ppddl.simulate import Task

    rs, meta = read_rules(DATA / "nid_tower_derived.rules.json")
    domain = rules_to_domain(rs, meta["predicates"], "tower-derived")
    objects = ["o1", "o2", "o3", "o4"]
    task = Task(domain, objects)
    ground = sorted(Atom(p, args) for p, k in meta["predicates"].items() for args in permutations(objects, k))
    rng = np.random.default_rng(0)
    covered = 0
    for _ in range(150):
        s = frozenset(a for a in ground if rng.random() < rng.choice([0.1, 0.2, 0.35]))
        for prim in task.primitive_actions():
            r, b = rs.covering(s, prim, objects)
            want = {s: 1.0} if r is None else {}
            for o, p in zip(r.outcomes, r.probs) if r is not None else ():
                want[o.apply(s, b)] = want.get(o.apply(s, b), 0.0) + p
            got: dict = {}
            for x in task.distribution(s, prim):
                got[x.state] = got.get(x.state, 0.0) + x.prob
            got = got or {s: 1.0}
            assert got.keys() == want.keys() and all(got[k] == pytest.approx(want[k], abs=1e-12) for k in got), \
                (sorted(map(str, s)), prim)
            covered += r is not None
    assert covered > 150
    # and read back: the same contexts, the derived literals and their definitions included
    from groundsym.ppddl.to_rules import domain_to_rules
    from groundsym.ppddl.parser import parse_domain

    back = domain_to_rules(parse_domain(str(domain), "<export>"))
    assert {(r.action, r.context) for r in rs.rules} <= {(r.action, r.context) for r in back.rules}
    assert back.derived == rs.derived
    assert "(no-on-1" not in str(domain) and "(not (exists (?derived-z1) (on ?x1 ?derived-z1)))" in str(domain)
