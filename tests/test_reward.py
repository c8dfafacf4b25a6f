"""The relational reward model: exact counts, exact expectations, recovery of a known reward."""

from __future__ import annotations

import json
from itertools import permutations, product

import numpy as np
import pytest

from groundsym.errors import UserError
from groundsym.logic import Atom, parse_atom
from groundsym.reward import RewardModel, candidate_features, doc_to_reward, fit_reward, read_reward, write_reward
from groundsym.symbolic_traces import SymbolicDataset, SymbolicTrace

PREDS = {"u1": 1, "b1": 2, "z": 0}


def st(*atoms):
    return frozenset(parse_atom(a) for a in atoms)


def model_with(weights: dict[str, float], intercept=0.0):
    feats = {str(f): f for f in candidate_features(PREDS)}
    return RewardModel(tuple(feats[k] for k in weights), tuple(weights.values()), intercept, tuple(sorted(PREDS.items())))


def test_counts_are_numbers_of_injective_groundings():
    objs = ("a", "b", "c", "d")
    s = st("(u1 a)", "(u1 c)", "(b1 a b)", "(b1 b c)", "(b1 c d)", "(b1 d c)", "(z)")
    m = model_with({"#(?a): (u1 ?a)": 1.0})
    assert m.predict(s, objs) == 2
    assert model_with({"#(?a ?b): (b1 ?a ?b)": 1.0}).predict(s, objs) == 4
    assert model_with({"#(?a ?b ?c): (b1 ?a ?b) (b1 ?b ?c)": 1.0}).predict(s, objs) == 2   # a-b-c, b-c-d
    assert model_with({"#(?a ?b): (b1 ?a ?b) (b1 ?b ?a)": 1.0}).predict(s, objs) == 2      # c-d both ways
    assert model_with({"#(?a ?b): (b1 ?a ?b) (u1 ?a)": 1.0}).predict(s, objs) == 2         # a->b, c->d
    assert model_with({"#(): (z)": 1.5}, intercept=0.25).predict(s, objs) == 1.75
    assert model_with({"#(?a ?b ?c ?d): (b1 ?a ?b) (b1 ?b ?c) (b1 ?c ?d)": 1.0}).predict(s, objs) == 1


def test_longer_chains_count_paths_of_that_many_atoms():
    """A tower of 6 (o1 on o2 on ... on o6) has 6 - n chains of n ``on`` atoms; ``chain`` sets the longest."""
    objs = tuple(f"o{i}" for i in range(1, 8))
    s = frozenset(Atom("on", (objs[i], objs[i + 1])) for i in range(5))
    feats = {len(f.atoms): f for f in candidate_features({"on": 2}, chain=5) if len({a.args for a in f.atoms}) ==
             len(f.atoms) and all(x.args[1] == y.args[0] for x, y in zip(f.atoms, f.atoms[1:]))}
    assert sorted(feats) == [1, 2, 3, 4, 5]
    for n, f in feats.items():
        model = RewardModel((f,), (1.0,), 0.0, (("on", 2),))
        assert model.predict(s, objs) == 6 - n
    assert max(len(f.atoms) for f in candidate_features({"on": 2})) == 3       # the default: chains of 3


def test_expected_reward_is_exact_under_independent_marginals():
    """Against brute force: enumerate every joint state of all ground atoms of 3 objects."""
    rng = np.random.default_rng(0)
    objs = ("a", "b", "c")
    atoms = [Atom(p, args) for p, k in sorted(PREDS.items()) for args in permutations(objs, k)]
    feats = candidate_features(PREDS)
    m = RewardModel(tuple(feats), tuple(rng.normal(size=len(feats))), 0.3, tuple(sorted(PREDS.items())))
    marg = {a: float(rng.random()) for a in atoms}
    brute = 0.0
    for bits in product((0, 1), repeat=len(atoms)):
        prob = np.prod([marg[a] if b else 1 - marg[a] for a, b in zip(atoms, bits)])
        brute += prob * m.predict(frozenset(a for a, b in zip(atoms, bits) if b), objs)
    assert m.expected(marg, objs) == pytest.approx(brute, rel=1e-9)
    # and with 0/1 marginals it is the reward of that state
    s = frozenset(a for a in atoms if rng.random() < 0.5)
    assert m.expected({a: 1.0 for a in s}, objs) == pytest.approx(m.predict(s, objs))


def random_dataset(rng, reward_fn, n_traces=30, length=8):
    traces = []
    for _ in range(n_traces):
        objs = tuple(f"o{i}" for i in range(int(rng.integers(3, 7))))
        atoms = [Atom(p, args) for p, k in PREDS.items() for args in permutations(objs, k)]
        states = [frozenset(a for a in atoms if rng.random() < 0.25) for _ in range(length + 1)]
        traces.append(SymbolicTrace(objs, states, [Atom("act", ())] * length,
                                    [reward_fn(s, objs) for s in states[:-1]]))
    return SymbolicDataset(traces, dict(PREDS), {"act": 0})


def test_fit_recovers_a_known_relational_reward_and_reports_held_out_fit(tmp_path):
    truth = model_with({"#(?a ?b): (b1 ?a ?b)": 0.5, "#(?a ?b ?c): (b1 ?a ?b) (b1 ?b ?c)": 0.25,
                        "#(?a): (u1 ?a)": -1.0}, intercept=2.0)
    ds = random_dataset(np.random.default_rng(1), truth.predict)
    m = fit_reward(ds, seed=0)
    assert m.fit["heldout"]["r2"] > 0.999 and m.fit["heldout"]["rmse"] < 0.01
    assert m.fit["heldout"]["baseline_rmse"] > 1.0
    fresh = random_dataset(np.random.default_rng(2), truth.predict, n_traces=5)
    for tr in fresh.traces:          # other objects, other counts: it generalises over identities
        for s in tr.states:
            assert m.predict(s, tr.objects) == pytest.approx(truth.predict(s, tr.objects), abs=0.02)
    write_reward(tmp_path / "reward.json", m, {"seed": 0})
    back = read_reward(tmp_path / "reward.json")
    assert back.features == m.features and back.weights == pytest.approx(m.weights)
    assert back.fit["heldout"]["r2"] == m.fit["heldout"]["r2"]


def test_constant_reward_is_an_intercept():
    ds = random_dataset(np.random.default_rng(3), lambda s, o: 0.5, n_traces=4)
    m = fit_reward(ds, seed=0)
    assert m.features == () and m.intercept == 0.5 and m.fit["note"] == "constant reward"


def test_bad_reward_files_name_the_field():
    good = model_with({"#(?a): (u1 ?a)": 1.0}).to_doc()
    for edit, want in [(lambda d: d["terms"][0].update(weight="x"), "terms[0].weight"),
                       (lambda d: d["terms"][0].update(atoms=["(u9 ?a)"]), "terms[0].atoms[0]"),
                       (lambda d: d["terms"][0].update(atoms=["(u1 a)"]), "terms[0].atoms[0]"),
                       (lambda d: d.update(schema="x"), "schema"),
                       (lambda d: d.update(intercept=float("nan")), "intercept")]:
        doc = json.loads(json.dumps(good))
        edit(doc)
        with pytest.raises(UserError) as exc:
            doc_to_reward(doc, "m/reward.json")
        assert str(exc.value).startswith(f"m/reward.json: {want}:")


def above_pairs(s: frozenset) -> int:
    """Pairs (x, y) with x somewhere above y in its tower: the tower reward's shape."""
    below = {a.args[0]: a.args[1] for a in s if a.predicate == "on"}
    n = 0
    for x in below:
        y = x
        while y in below:
            y, n = below[y], n + 1
    return n


def test_tied_chains_value_taller_towers_the_data_never_showed():
    """Reward 0.01 per above-pair; training towers hold at most two cubes, so chains of two and
    three never occur. The path column (pairs + chains, one weight) predicts towers of three and
    four exactly; without tying a chain is worth nothing and a tower of four is undervalued."""
    rng = np.random.default_rng(0)
    objs = tuple(f"c{i}" for i in range(6))
    traces = []
    for _ in range(8):
        states = []
        for _ in range(10):
            perm = rng.permutation(objs)
            k = int(rng.integers(0, 4))              # k towers of two
            s = frozenset(Atom("on", (perm[2 * i], perm[2 * i + 1])) for i in range(k))
            states.append(s)
        traces.append(SymbolicTrace(objs, states, [Atom("noop", ())] * 9, [0.01 * above_pairs(s) for s in states[:-1]]))
    ds = SymbolicDataset(traces, {"on": 2}, {"noop": 0})
    tall = [frozenset({Atom("on", ("c0", "c1")), Atom("on", ("c1", "c2"))}),
            frozenset({Atom("on", ("c0", "c1")), Atom("on", ("c1", "c2")), Atom("on", ("c2", "c3"))})]
    tied = fit_reward(ds, seed=0)
    plain = fit_reward(ds, seed=0, tie_chains=False)
    for s in tall:
        assert tied.predict(s, objs) == pytest.approx(0.01 * above_pairs(s), abs=2e-4)
        assert plain.predict(s, objs) < 0.01 * above_pairs(s) - 0.005
    assert tied.fit["path_columns"] == 1


def test_chain_counts_by_matrix_products_equal_the_enumerated_groundings():
    """Chains of two and three atoms are counted by matrix products (inclusion-exclusion of walks
    that visit an object twice); the count equals the sum over injective groundings, for random
    marginals (cycles and a non-zero diagonal included) and 2-7 objects."""
    from groundsym.reward import _chain_count

    rng = np.random.default_rng(0)
    for m in (2, 3, 4, 5, 7):
        P = rng.random((4, m, m))
        for n in (2, 3):
            want = [sum(np.prod([P[k, t[i], t[i + 1]] for i in range(n)]) for t in permutations(range(m), n + 1))
                    for k in range(4)]
            np.testing.assert_allclose(_chain_count(P, n), want, rtol=1e-10, atol=1e-12)
    feats = {str(f): f for f in candidate_features(PREDS)}
    s = st("(b1 a b)", "(b1 b c)", "(b1 c d)", "(b1 d a)")          # a 4-cycle: 4 chains of 3
    assert model_with({"#(?a ?b ?c ?d): (b1 ?a ?b) (b1 ?b ?c) (b1 ?c ?d)": 1.0}).predict(s, ("a", "b", "c", "d")) == 4
    assert "#(?a ?b ?c): (b1 ?a ?b) (b1 ?b ?c)" in feats
