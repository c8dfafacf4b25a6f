"""PRADA's ``references=unique``: a rule with deictic references covers only when exactly one
binding of them holds (NID's semantics, Pasula, Zettlemoyer & Kaelbling 2007), checked by hand and
against the rule model's own ``covering`` (the semantics the rule learner scores with) on random
states; ``references=rivals`` (the default) is left as it was."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from groundsym.logic import parse_atom, parse_literal
from groundsym.planner import Observation, PlanningModel
from groundsym.reward import Feature, RewardModel
from groundsym.rules.io import read_rules
from groundsym.rules.model import Outcome, Rule, RuleSet, with_derived
from planners.prada import PradaPlanner, ground_rules, rule_probabilities

A, L = parse_atom, parse_literal
DATA = Path(__file__).parent / "data"


def rule(action, context, outcome):
    return Rule(A(action), tuple(L(c) for c in context), (Outcome(tuple(L(c) for c in outcome)),), (1.0,), 0.0, 0.0)


# (act ?x) has a plain rule and one whose reference ?y must be the one q-object
PLAIN = rule("(act ?x)", ["(p ?x)"], ["(e1 ?x)"])
REFERRING = rule("(act ?x)", ["(q ?y)"], ["(e2 ?x)"])
PREDS = {"p": 1, "q": 1, "e1": 1, "e2": 1}


def _u(rules: RuleSet, state: frozenset, marginals: dict[str, float], unique: bool):
    g = ground_rules(rules, ("a", "b", "c"), PREDS, noise_softener=0.0, unique_references=unique)
    b = g.belief(state)
    for atom, p in marginals.items():
        b[g.index[A(atom)]] = p
    U = rule_probabilities(g, b[None])[0]
    return {(str(g.actions[g.rule_group[k]]), g.source[k][0] is REFERRING, g.source[k][1].get("?y")): float(U[k])
            for k in range(len(U))}


def test_two_matching_references_mean_the_referring_rule_does_not_cover_by_hand():
    rules = RuleSet((PLAIN, REFERRING))
    state = frozenset({A("(p a)"), A("(q b)"), A("(q c)")})
    unique = _u(rules, state, {}, True)
    assert unique[("(act a)", False, None)] == 1.0                    # q names two objects: PLAIN applies
    assert unique[("(act a)", True, "b")] == unique[("(act a)", True, "c")] == 0.0
    assert _u(rules, state, {}, False)[("(act a)", False, None)] == 0.0   # rivals: every binding silences it
    # uncertain: P(p a) = 0.4, P(q b) = 0.6, P(q c) = 0.5: the reference is unique with b
    # 0.6 * 0.5 = 0.3, with c 0.5 * 0.4 = 0.2, so the referring rule covers 0.5; a rule applies when
    # it covers and the other does not: plain 0.4 * 0.5, referring 0.3 * 0.6 and 0.2 * 0.6
    soft = _u(rules, frozenset(), {"(p a)": 0.4, "(q b)": 0.6, "(q c)": 0.5}, True)
    assert soft[("(act a)", False, None)] == pytest.approx(0.2)
    assert soft[("(act a)", True, "b")] == pytest.approx(0.18)
    assert soft[("(act a)", True, "c")] == pytest.approx(0.12)


def test_unique_references_agree_with_the_rule_models_covering_on_random_states():
    rules, meta = read_rules(DATA / "nid_blocks.rules.json")
    objects = ("a", "b", "c", "d")
    g = ground_rules(rules, objects, meta["predicates"], noise_softener=0.0, unique_references=True)
    rng = np.random.default_rng(3)
    checked = differ = 0
    for _ in range(60):
        state = frozenset(a for a in g.atoms if rng.random() < 0.5)
        U = rule_probabilities(g, g.belief(with_derived(state, rules.derived, objects))[None])[0]
        rivals = rule_probabilities(ground_rules(rules, objects, meta["predicates"], 0.0),
                                    g.belief(with_derived(state, rules.derived, objects))[None])[0]
        for a, action in enumerate(g.actions):
            seg = range(g.starts[a], g.starts[a + 1] if a + 1 < len(g.actions) else len(U))
            want, binding = rules.covering(state, action, objects)
            got = [k for k in seg if U[k] > 0]
            if want is None:
                assert got == []
            else:
                assert len(got) == 1 and U[got[0]] == 1.0
                assert g.source[got[0]][0] is want and g.source[got[0]][1] == binding
            differ += any(U[k] != rivals[k] for k in seg)
            checked += 1
    assert checked > 200 and differ > 0      # the two semantics part on some of these states


def test_legal_actions_only_are_planned_with():
    """``actions=legal``: every action of the best sequence is one the observation offers (with
    ``all``, sequences go through the others)."""
    rules, meta = read_rules(DATA / "nid_blocks.rules.json")
    objects = ("a", "b", "c")
    state = frozenset({A("(handempty)"), A("(clear a)"), A("(on a b)"), A("(on b c)"), A("(ontable c)")})
    legal = (A("(pickup a)"), A("(putdown)"))
    reward = RewardModel((Feature((A("(ontable ?a)"),)),), (1.0,), 0.0, (("ontable", 1),))
    model = PlanningModel(meta["primitives"], predicates=meta["predicates"], rules=rules, reward=reward)
    for opts, inside in (({"actions": "legal"}, True), ({"actions": "all"}, False)):
        plans = []
        for seed in range(5):
            d = PradaPlanner(model, {"samples": "100", **opts}, seed).choose(
                Observation(objects, legal, state, None, 0, 10))
            plans += d.info["plan"]
        assert all(a in map(str, legal) for a in plans) == inside
