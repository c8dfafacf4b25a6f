"""PRADA / A-PRADA: factored-frontier inference against hand-computed and enumerated truth, and
planning on a noisy blocks world written as NID rules (its dynamics sampled by the rule set)."""

from __future__ import annotations

from itertools import permutations

import numpy as np
import pytest

from groundsym.episode import SymbolicEnv, run_episode
from groundsym.logic import Atom, parse_atom, parse_literal
from groundsym.planner import Goal, Observation, PlanningModel
from groundsym.rules.model import Outcome, Rule, RuleSet
from groundsym.rules.sample import ground_actions, sample_successor
from planners.prada import (GoalReward, LinearReward, ModelReward, PradaPlanner, ground_rules,
                            model_reward, rule_probabilities, transition)
from planners.random import RandomPlanner

L = parse_literal
A = parse_atom


def rule(action, context, outcomes, noise=0.0, noise_changes=0.0):
    outs = tuple(Outcome(tuple(L(c) for c in o)) for o, _ in outcomes)
    return Rule(A(action), tuple(L(c) for c in context), outs, tuple(p for _, p in outcomes), noise, noise_changes)


PICK = rule("(pick ?x)", ["(on ?x ?y)"], [(["(inhand ?x)", "(not (on ?x ?y))"], 0.7), ([], 0.2)], noise=0.1)


def blocks_world(p: float = 0.9) -> RuleSet:
    """A noisy blocks world: grasps and puts succeed with probability p, else nothing happens."""
    return RuleSet((
        rule("(pickup ?x)", ["(clear ?x)", "(ontable ?x)", "(handempty)"],
             [(["(inhand ?x)", "(not (clear ?x))", "(not (ontable ?x))", "(not (handempty))"], p), ([], 1 - p)]),
        rule("(unstack ?x)", ["(clear ?x)", "(on ?x ?y)", "(handempty)"],
             [(["(inhand ?x)", "(clear ?y)", "(not (on ?x ?y))", "(not (clear ?x))", "(not (handempty))"], p),
              ([], 1 - p)]),
        rule("(puton ?x)", ["(clear ?x)", "(inhand ?y)"],
             [(["(on ?y ?x)", "(not (inhand ?y))", "(not (clear ?x))", "(clear ?y)", "(handempty)"], p),
              ([], 1 - p)]),
        rule("(putdown ?x)", ["(inhand ?x)"],
             [(["(ontable ?x)", "(not (inhand ?x))", "(clear ?x)", "(handempty)"], 1.0)]),
    ))


PRIMS = {"pickup": 1, "unstack": 1, "puton": 1, "putdown": 1}
PREDS = {"on": 2, "ontable": 1, "clear": 1, "inhand": 1, "handempty": 0}


def on_table(objects) -> frozenset:
    return frozenset([A("(handempty)")] + [Atom(p, (o,)) for o in objects for p in ("clear", "ontable")])


def test_one_rule_one_step_by_hand():
    """P(on a b)=0.6, P(on a c)=0.5: the two referents exclude each other (u = 0.3 and 0.2)."""
    g = ground_rules(RuleSet((PICK,)), ("a", "b", "c"), {"on": 2, "inhand": 1}, noise_softener=0.0)
    b = g.belief(frozenset())
    b[g.index[A("(on a b)")]], b[g.index[A("(on a c)")]] = 0.6, 0.5
    U = rule_probabilities(g, b[None])
    u = {tuple(sorted(bind.items())): U[0, k] for k, (_, bind) in enumerate(g.source) if U[0, k] > 0}
    assert u == pytest.approx({(("?x", "a"), ("?y", "b")): 0.6 * 0.5, (("?x", "a"), ("?y", "c")): 0.5 * 0.4})
    B = transition(g, b[None], U, np.array([g.actions.index(A("(pick a)"))]))[0]
    assert B[g.index[A("(inhand a)")]] == pytest.approx(0.7 * (0.3 + 0.2))
    assert B[g.index[A("(on a b)")]] == pytest.approx(0.6 * (1 - 0.3 * 0.7))
    assert B[g.index[A("(on a c)")]] == pytest.approx(0.5 * (1 - 0.2 * 0.7))
    assert B[g.index[A("(on b c)")]] == 0.0 and B[-1] == 1.0


def test_noise_spreads_over_changeable_atoms_by_hand():
    """noise 0.1, 2 noise changes over 9 changeable atoms (on: 6, inhand: 3), softener 0.5."""
    r = rule("(pick ?x)", ["(on ?x ?y)"], [(["(inhand ?x)", "(not (on ?x ?y))"], 0.9)], noise=0.1, noise_changes=2)
    g = ground_rules(RuleSet((r,)), ("a", "b", "c"), {"on": 2, "inhand": 1}, noise_softener=0.5)
    q = 2 / 9 * 0.5
    b = g.belief(frozenset({A("(on a b)")}))
    U = rule_probabilities(g, b[None])
    B = transition(g, b[None], U, np.array([g.actions.index(A("(pick a)"))]))[0]
    assert B[g.index[A("(inhand a)")]] == pytest.approx(0.9 + 0.1 * q)
    assert B[g.index[A("(inhand b)")]] == pytest.approx(0.1 * q)
    assert B[g.index[A("(on a b)")]] == pytest.approx(0.1 * q + (1 - 0.9 - 2 * 0.1 * q))


def exact_marginals(rules: RuleSet, state: frozenset, action: Atom, objects, atoms) -> np.ndarray:
    """Enumerate the covering rule's outcomes (RuleSet semantics) and sum their probabilities."""
    r, bind = rules.covering(state, action, objects)
    dist = [(state, 1.0)] if r is None else [(o.apply(state, bind), p) for o, p in zip(r.outcomes, r.probs)]
    return np.array([sum(p for s, p in dist if a in s) for a in atoms])


def test_one_step_from_a_known_state_is_exact():
    """From a point-mass state, factored frontier gives the exact successor marginals, for every
    action in many random blocks-world states (including rival and ambiguous coverings)."""
    rng = np.random.default_rng(0)
    objects = ("a", "b", "c", "d")
    rules = blocks_world(0.8)
    g = ground_rules(rules, objects, PREDS)
    for _ in range(15):
        s = on_table(objects)
        for _ in range(int(rng.integers(0, 8))):
            acts = ground_actions(PRIMS, objects)
            s = sample_successor(rules, s, acts[int(rng.integers(len(acts)))], rng, objects)
        b = g.belief(s)[None]
        U = rule_probabilities(g, b)
        for a in ground_actions(PRIMS, objects):
            idx = g.actions.index(a)
            got = transition(g, b, U, np.array([idx]))[0, :-1]
            np.testing.assert_allclose(got, exact_marginals(rules, s, a, objects, g.atoms), atol=1e-12)


def test_rule_probabilities_are_a_distribution_per_action():
    rng = np.random.default_rng(1)
    g = ground_rules(blocks_world(), ("a", "b", "c"), PREDS)
    B = np.hstack([rng.random((50, g.n_vars)), np.ones((50, 1))])
    U = rule_probabilities(g, B)
    per_action = np.add.reduceat(U, g.starts, axis=1)
    assert (U >= 0).all() and (per_action <= 1 + 1e-12).all()
    nxt = transition(g, B, U, rng.integers(-1, len(g.actions), 50))
    assert (nxt >= -1e-12).all() and (nxt <= 1 + 1e-12).all()


def goal_env(objects, goal, p=0.9):
    rules = blocks_world(p)
    return rules, SymbolicEnv(objects, on_table(objects), lambda s: ground_actions(PRIMS, objects),
                              lambda s, a, rng: (sample_successor(rules, s, a, rng, objects), 0.0), goal, gamma=1.0)


TOWER3 = Goal((L("(on a b)"), L("(on b c)")), 1.0)


def test_prada_decision_is_the_first_step_of_the_optimal_plan():
    rules, env = goal_env(("a", "b", "c"), TOWER3, p=1.0)
    planner = PradaPlanner(PlanningModel(PRIMS, rules=rules, goal=TOWER3), {"horizon": "4"}, seed=3)
    d = planner.choose(env.reset(0))
    assert d.action == A("(pickup b)")
    assert d.info["plan"] == ["(pickup b)", "(puton c)", "(pickup a)", "(puton b)"]
    assert d.expected_value == pytest.approx(0.95 ** 4)  # the goal holds from t = 4 on, reward 1, gamma 0.95
    planner2 = PradaPlanner(PlanningModel(PRIMS, rules=rules, goal=TOWER3), {"horizon": "4"}, seed=3)
    assert planner2.choose(env.reset(0)) == d           # same seed, same decision


@pytest.mark.parametrize("variant", ["prada", "a-prada"])
def test_prada_builds_the_tower_far_more_often_than_random(variant):
    objects = ("a", "b", "c")
    rules, env = goal_env(objects, TOWER3, p=0.8)
    model = PlanningModel(PRIMS, rules=rules, goal=TOWER3)
    wins = {"prada": 0, "random": 0}
    for ep in range(12):
        p = PradaPlanner(model, {"variant": variant}, seed=ep)
        wins["prada"] += bool(run_episode(env, p, 10, seed=ep).success)
        wins["random"] += bool(run_episode(env, RandomPlanner(model, {}, ep), 10, seed=ep).success)
    assert wins["prada"] >= 9 and wins["random"] <= 4, wins


def test_a_prada_never_lengthens_a_plan_and_keeps_its_value():
    objects = ("a", "b", "c")
    rules, env = goal_env(objects, Goal((L("(on a b)"),), 1.0))
    model = PlanningModel(PRIMS, rules=rules, goal=Goal((L("(on a b)"),), 1.0))
    for seed in range(3):
        p = PradaPlanner(model, {"samples": "50", "horizon": "5"}, seed)
        core = p.core(objects, on_table(objects))
        b0 = core.g.belief(on_table(objects))
        full = core.plan(b0, np.random.default_rng(seed), shorten=False)
        short = core.plan(b0, np.random.default_rng(seed), shorten=True)
        assert len(short.actions) <= len(full.actions) and short.value >= full.value - 1e-12
        assert short.actions[:2] == (A("(pickup a)"), A("(puton b)"))


class Linear:
    """A reward that counts stacked pairs (linear in the indicators)."""

    def expected(self, marginals, objects):
        return 0.5 + sum(p for a, p in marginals.items() if a.predicate == "on")


class Product:
    """A reward that needs a conjunction (not linear): exact under independence as a product."""

    def expected(self, marginals, objects):
        return marginals[A("(on a b)")] * marginals[A("(on b c)")]


def test_learned_reward_is_read_linearly_when_it_is_linear():
    g = ground_rules(blocks_world(), ("a", "b", "c"), PREDS)
    rng = np.random.default_rng(0)
    B = np.hstack([rng.random((5, g.n_vars)), np.ones((5, 1))])
    lin = model_reward(Linear(), g, rng)
    assert isinstance(lin, LinearReward)
    np.testing.assert_allclose(lin(B), ModelReward(Linear(), g)(B))
    prod = model_reward(Product(), g, rng)
    assert isinstance(prod, ModelReward)
    goal = GoalReward(np.array([g.index[A("(on a b)")], g.index[A("(on b c)")]]), np.array([True, True]), 1.0)
    np.testing.assert_allclose(prod(B), goal(B))


def test_planner_uses_a_learned_reward_model():
    objects = ("a", "b", "c")
    rules, env = goal_env(objects, None, p=1.0)
    planner = PradaPlanner(PlanningModel(PRIMS, rules=rules, reward=Product()), {}, seed=0)
    d = planner.choose(env.reset(0))
    assert d.info["plan"] == ["(pickup b)", "(puton c)", "(pickup a)", "(puton b)"]


def test_batched_reward_model_matches_its_own_expectation():
    """groundsym's relational reward model, read through PRADA's belief columns, equals its own
    ``expected`` on random marginals (pair and chain count features included)."""
    from groundsym.reward import RewardModel, candidate_features

    rng = np.random.default_rng(2)
    preds = {"on": 2, "inhand": 1}
    feats = tuple(candidate_features(preds))
    model = RewardModel(feats, tuple(rng.normal(size=len(feats))), 0.3, tuple(sorted(preds.items())))
    objects = ("a", "b", "c", "d")
    g = ground_rules(RuleSet((PICK,)), objects, preds)
    fn = model_reward(model, g, rng)
    B = np.hstack([rng.random((4, g.n_vars)), np.ones((4, 1))])
    want = [model.expected(g.marginals(row), objects) for row in B]
    np.testing.assert_allclose(fn(B), want, rtol=1e-10)


class OnlyPredict:
    """A nonlinear reward that can only score whole states: 1 if a is on b and b on c."""

    def predict(self, state, objects):
        return float(A("(on a b)") in state and A("(on b c)") in state)


def test_a_state_only_reward_is_estimated_by_sampling_the_belief():
    g = ground_rules(blocks_world(), ("a", "b", "c"), PREDS)
    fn = model_reward(OnlyPredict(), g, np.random.default_rng(0))
    b = g.belief(frozenset())
    b[g.index[A("(on a b)")]], b[g.index[A("(on b c)")]] = 0.5, 0.5
    point = g.belief(frozenset({A("(on a b)"), A("(on b c)")}))
    est = fn(np.vstack([b, point, g.belief(frozenset())]))
    assert est[1] == 1.0 and est[2] == 0.0
    assert abs(est[0] - 0.25) < 3 * np.sqrt(0.25 * 0.75 / 32)      # 32 draws, within 3 sigma


def test_rule_min_prob_prunes_contexts_below_it():
    """The hand case above with the pruning at 0.55: the referent c (0.5) no longer applies, so the
    rule with b applies alone (0.6, nobody to exclude it)."""
    g = ground_rules(RuleSet((PICK,)), ("a", "b", "c"), {"on": 2, "inhand": 1}, noise_softener=0.0)
    b = g.belief(frozenset())
    b[g.index[A("(on a b)")]], b[g.index[A("(on a c)")]] = 0.6, 0.5
    U = rule_probabilities(g, b[None], min_prob=0.55)
    u = {tuple(sorted(bind.items())): U[0, k] for k, (_, bind) in enumerate(g.source) if U[0, k] > 0}
    assert u == pytest.approx({(("?x", "a"), ("?y", "b")): 0.6})
    planner = PradaPlanner(PlanningModel(PRIMS, rules=blocks_world(), goal=TOWER3), {"rule_min_prob": "0.55"}, 0)
    assert planner.core(("a", "b", "c"), frozenset()).min_prob == 0.55


def test_goal_share_scores_the_expected_share_of_goal_literals():
    """P = (1, 0.5, 0.2) for three positive literals: the product 0.1, the mean 0.5667."""
    r = GoalReward(np.array([0, 1, 2]), np.ones(3, dtype=bool), 2.0, share=0.1)
    B = np.array([[1.0, 0.5, 0.2, 1.0]])
    assert r(B)[0] == pytest.approx(2.0 * 0.1 + 0.1 * 2.0 * (1.7 / 3))
    assert GoalReward(np.array([0, 1, 2]), np.ones(3, dtype=bool), 2.0)(B)[0] == pytest.approx(0.2)


def test_goal_share_approaches_a_goal_beyond_the_horizon():
    """Horizon 2 cannot reach the three-block tower (4 steps): by the product every sequence is worth
    0; scored by the share, PRADA puts one block where the goal wants it."""
    rules, env = goal_env(("a", "b", "c"), TOWER3, p=1.0)
    model = PlanningModel(PRIMS, rules=rules, goal=TOWER3)
    blind = PradaPlanner(model, {"horizon": "2"}, seed=0).choose(env.reset(0))
    assert blind.expected_value == 0.0
    d = PradaPlanner(model, {"horizon": "2", "goal_share": "0.01"}, seed=0).choose(env.reset(0))
    assert d.info["plan"] in (["(pickup a)", "(puton b)"], ["(pickup b)", "(puton c)"])
    assert d.expected_value == pytest.approx(0.95 ** 2 * 0.01 * 0.5)   # half the goal from t = 2 on, gamma 0.95


def test_threshold_samples_again_until_a_sequence_beats_doing_nothing():
    """Nothing beats doing nothing by 10 (the goal is worth 1): all ``max_runs`` rounds are sampled;
    with the threshold at 0 one round is enough."""
    rules, env = goal_env(("a", "b", "c"), TOWER3, p=1.0)
    model = PlanningModel(PRIMS, rules=rules, goal=TOWER3)
    for opts, rounds in (({"threshold": "10", "max_runs": "3"}, 3), ({"max_runs": "3"}, 1)):
        planner = PradaPlanner(model, opts, seed=0)
        core = planner.core(("a", "b", "c"), on_table(("a", "b", "c")))
        calls = []
        sample = core.sample
        core.sample = lambda b0, rng, banned=(): calls.append(1) or sample(b0, rng, banned)
        planner.choose(env.reset(0))
        assert len(calls) == rounds


def test_derived_atoms_follow_their_base_atoms_through_inference():
    """The tower over inhand/on with derived predicates (tests/data): from point-mass states the
    successor marginals are exact, derived atoms included (computed from the exact successors);
    from a mixed belief a derived atom is the product of its base atoms' complements."""
    from conftest import DATA
    from groundsym.rules.io import read_rules
    from groundsym.rules.model import with_derived

    rules, meta = read_rules(DATA / "nid_tower_derived.rules.json")
    objects = ("a", "b", "c", "d")
    g = ground_rules(rules, objects, meta["predicates"])
    assert {a.predicate for a in (g.atoms[i] for i in g.derived_cols)} == {"no-inhand", "no-on-1", "no-on-2"}
    rng = np.random.default_rng(3)
    acts = ground_actions(meta["primitives"], objects)
    for _ in range(15):
        s = frozenset()
        for _ in range(int(rng.integers(0, 10))):
            s = sample_successor(rules, s, acts[int(rng.integers(len(acts)))], rng, objects)
        b = g.belief(with_derived(s, rules.derived, objects))[None]
        U = rule_probabilities(g, b)
        for a in acts:
            got = transition(g, b, U, np.array([g.actions.index(a)]))[0, :-1]
            r, bind = rules.covering(s, a, objects)
            dist = [(s, 1.0)] if r is None else [(o.apply(s, bind), p) for o, p in zip(r.outcomes, r.probs)]
            want = [sum(p for s2, p in dist if atom in with_derived(s2, rules.derived, objects)) for atom in g.atoms]
            np.testing.assert_allclose(got, want, atol=1e-12)
    b = g.belief(frozenset())
    b[g.index[A("(on a b)")]], b[g.index[A("(on a c)")]], b[g.index[A("(inhand d)")]] = 0.6, 0.5, 0.3
    out = g.derive(b[None].copy())[0]
    assert out[g.index[A("(no-on-1 a)")]] == pytest.approx(0.4 * 0.5)
    assert out[g.index[A("(no-on-2 b)")]] == pytest.approx(0.4)
    assert out[g.index[A("(no-inhand)")]] == pytest.approx(0.7)
    assert out[g.index[A("(no-on-1 b)")]] == 1.0 and out[-1] == 1.0


def test_prada_grasps_the_free_cube_not_the_top_of_its_tower():
    """With the grasp rule that lifts a cube off the one below (a derived context), lifting the top
    of a tower of two loses its ``on`` pair in PRADA's model, so with a reward that counts ``on``
    pairs PRADA grasps the free cube (to stack it) instead, whatever the seed."""
    from conftest import DATA
    from groundsym.rules.io import read_rules

    rules, meta = read_rules(DATA / "nid_tower_derived.rules.json")
    model = PlanningModel(meta["primitives"], predicates=meta["predicates"], rules=rules, reward=Linear(), gamma=0.8)
    objects = ("a", "b", "c")
    obs = Observation(objects, tuple(ground_actions(meta["primitives"], objects)), frozenset({A("(on a b)")}))
    for seed in range(5):
        d = PradaPlanner(model, {}, seed).choose(obs)
        assert d.action == A("(closeHandAround c)"), d


def test_retries_bans_a_first_action_that_keeps_changing_nothing_in_the_same_state():
    """retries=1: after the chosen grasp left the state unchanged twice, the next decision in that
    state starts with another action; a new episode (t = 0) forgets."""
    from conftest import DATA
    from groundsym.rules.io import read_rules

    rules, meta = read_rules(DATA / "nid_tower_derived.rules.json")
    model = PlanningModel(meta["primitives"], predicates=meta["predicates"], rules=rules, reward=Linear(), gamma=0.8)
    objects = ("a", "b", "c")
    acts = tuple(ground_actions(meta["primitives"], objects))
    s = frozenset({A("(on a b)")})
    planner = PradaPlanner(model, {"retries": "1"}, 0)
    chosen = [planner.choose(Observation(objects, acts, s, None, t)) for t in range(4)]
    assert [d.action for d in chosen[:2]] == [A("(closeHandAround c)")] * 2
    assert all(d.action != A("(closeHandAround c)") and d.info["banned"] == ["(closeHandAround c)"]
               for d in chosen[2:])
    assert planner.choose(Observation(objects, acts, s, None, 0)).action == A("(closeHandAround c)")
    assert PradaPlanner(model, {}, 0).opts["retries"] is None
