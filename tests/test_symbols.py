"""Symbols: RBF truth (Eq. 4), vectorised abstraction, symbols.json, descriptions and grounding scores."""

import json
import math
import re

import numpy as np
import pytest

from groundsym.describe import deciding_dimensions, describe_symbol, intervals
from groundsym.errors import UserError
from groundsym.grounding import grounded, match_symbols, scores
from groundsym.logic import Atom
from groundsym.symbols import Symbol, SymbolSet, load_symbols, save_symbols, share_true
from groundsym.traces import Dataset, Trace
from groundsym.world import Scene
from tests.test_loss import intended_symbols, kinematic_tower

NAMES = ("x", "y", "z", "size")


def test_truth_is_activation_above_one_half():
    s = Symbol("u1", 1, np.array([1.0, 2.0]), np.array([0.5, 2.0]))
    rng = np.random.default_rng(0)
    y = rng.normal([1, 2], [1, 3], size=(500, 2))
    g = np.exp(-(((y[:, 0] - 1) / 0.5) ** 2 + ((y[:, 1] - 2) / 2.0) ** 2))  # Eq. (4) written out
    assert np.array_equal(s.holds(y), g > 0.5)
    assert s.activation(np.array([1.0, 2.0])) == 1.0
    edge = np.array([1.0 + 0.5 * math.sqrt(math.log(2)) * 0.999, 2.0])
    assert s.holds(edge) and not s.holds(edge + [0.01, 0])


def test_abstraction_of_a_scene_by_hand():
    objs = ("a", "b", "c")
    feats = np.array([[0.0, 0.0, 0.05, 0.05], [0.0, 0.0, 0.0, 0.05], [0.5, 0.5, 0.4, 0.05]])
    syms = SymbolSet(tuple(intended_symbols()), NAMES)
    # u1: centre (0.3, 0, 0.45) widths 0.1: c is 0.2 away in x -> not in hand; move c to the hand
    feats[2] = [0.3, 0.02, 0.46, 0.05]
    state = syms.abstract_scene(Scene(objs, feats))
    assert state == frozenset({Atom("u1", ("c",)), Atom("b1", ("a", "b"))})
    assert syms.predicates == {"u1": 1, "b1": 2}


def test_binary_symbols_never_hold_on_the_diagonal():
    s = Symbol("b1", 2, np.zeros(4), np.full(4, 10.0))  # true for every pair
    syms = SymbolSet((s,), NAMES)
    state = syms.abstract_scene(Scene(("a", "b"), np.zeros((2, 4))))
    assert state == frozenset({Atom("b1", ("a", "b")), Atom("b1", ("b", "a"))})


def test_dataset_abstraction_matches_scene_by_scene():
    ds = kinematic_tower(3, seed=2)
    syms = SymbolSet(tuple(intended_symbols()), NAMES)
    sds = syms.to_symbolic_dataset(ds)
    assert sds.predicates == {"u1": 1, "b1": 2} and sds.n_transitions == ds.n_transitions
    for tr, st in zip(ds.traces, sds.traces):
        assert st.states == [syms.abstract_scene(s) for s in tr.scenes]
        assert st.rewards == [s.reward for s in tr.scenes[:-1]] and st.final_reward == tr.scenes[-1].reward
        # the fixture's truth: u1 is inhand, b1 is on
        for s, state in zip(tr.scenes, st.states):
            assert {a.predicate for a in state} <= {"u1", "b1"}
            assert {Atom({"u1": "inhand", "b1": "on"}[a.predicate], a.args) for a in state} == set(s.truth)


def test_symbols_file_round_trip(tmp_path):
    syms = SymbolSet(tuple(intended_symbols()), NAMES)
    path = tmp_path / "symbols.json"
    save_symbols(path, syms, shares={"u1": 0.1}, extra={"loss": {"total": 1.0}})
    back = load_symbols(path, NAMES)
    assert back.predicates == syms.predicates and back.meta["loss"] == {"total": 1.0}
    for a, b in zip(back.symbols, syms.symbols):
        assert np.array_equal(a.centre, b.centre) and np.array_equal(a.widths, b.widths)
    doc = json.loads(path.read_text())
    assert doc["schema"] == "groundsym.symbols/1" and doc["symbols"][0]["share"] == 0.1
    syms.save_symbols(tmp_path / "again.json")
    assert load_symbols(tmp_path / "again.json").predicates == syms.predicates


@pytest.mark.parametrize("edit, field", [
    (lambda d: d.update(schema="other"), "schema"),
    (lambda d: d["symbols"][0].update(widths=[1, -1, 1, 1]), "symbols[0].widths"),
    (lambda d: d["symbols"][1].update(centre=[0, 0]), "symbols[1].centre"),
    (lambda d: d["symbols"][1].update(arity=3), "symbols[1].arity"),
    (lambda d: d["symbols"][1].update(name="u1"), "symbols[1].name"),
    (lambda d: d["symbols"][0].update(centre=[0, 0, "x", 0]), "symbols[0].centre"),
])
def test_bad_symbols_files_name_the_field(tmp_path, edit, field):
    path = tmp_path / "symbols.json"
    save_symbols(path, SymbolSet(tuple(intended_symbols()), NAMES))
    doc = json.loads(path.read_text())
    edit(doc)
    path.write_text(json.dumps(doc))
    with pytest.raises(UserError, match=re.escape(f"symbols.json: {field}:")):
        load_symbols(path)


def test_feature_names_must_match(tmp_path):
    path = tmp_path / "symbols.json"
    save_symbols(path, SymbolSet(tuple(intended_symbols()), NAMES))
    with pytest.raises(UserError, match="do not match the symbols' feature space"):
        load_symbols(path, ("x", "y", "z", "mass"))


def test_share_true_counts_objects_and_ordered_pairs():
    syms = SymbolSet((Symbol("u1", 1, np.zeros(4), np.full(4, 0.1)), Symbol("b1", 2, np.zeros(4), np.full(4, 10.0))),
                     NAMES)
    feats = np.zeros((2, 3, 4))
    feats[0, 0, 0] = 5.0
    pairs = feats[:, :, None, :] - feats[:, None, :, :]
    shares = share_true(syms, feats, pairs)
    assert shares["u1"] == pytest.approx(5 / 6) and shares["b1"] == 1.0


def test_describe_in_words():
    on = intended_symbols()[1]
    text = describe_symbol(on, ("dx", "dy", "dz", "dsize"))
    assert text.startswith("b1(X,Y): X above Y")
    assert "|dx| under 1.7 cm" in text and "dz between 3.3 and 6.7 cm" in text
    data = np.random.default_rng(0).uniform(-0.1, 0.1, (200, 4))
    assert "dsize" not in describe_symbol(on, ("dx", "dy", "dz", "dsize"), data)  # 100 cm wide: unconstraining


def test_grounding_scores_both_argument_orders():
    assert scores(np.array([1, 1, 0, 0], bool), np.array([1, 0, 1, 0], bool)) == (0.5, 0.5, 0.5)
    ds = kinematic_tower(4, seed=5)
    under = SymbolSet(tuple(intended_symbols(swap=True)), NAMES)
    m = {x.arity: x for x in match_symbols(under, ds)}
    assert (m[1].best_match, m[1].f1) == ("inhand", 1.0)
    assert (m[2].best_match, m[2].argument_order, m[2].f1) == ("on", "swapped", 1.0)


def test_grounding_needs_truth():
    ds = kinematic_tower(1, seed=5)
    bare = Dataset([Trace(t.objects, [Scene(s.objects, s.features, s.reward) for s in t.scenes], t.actions)
                    for t in ds.traces], ds.feature_names, ds.primitives)
    with pytest.raises(UserError, match="no ground-truth"):
        match_symbols(SymbolSet(tuple(intended_symbols()), NAMES), bare)


def test_relations_fitted_as_rbf_symbols_match_them():
    """The yardstick for learned symbols: ground-truth relations written as RBFs reproduce them."""
    from groundsym.errors import UserError
    from groundsym.grounding import fit_relation_symbol, match_symbols
    from tests.test_loss import kinematic_tower

    ds = kinematic_tower(8, seed=3)
    u = fit_relation_symbol("u1", "inhand", ds)
    on = fit_relation_symbol("b1", "on", ds)
    under = fit_relation_symbol("b2", "on", ds, swapped=True)
    got = {m.symbol: m for m in match_symbols(SymbolSet((u, on, under), ("x", "y", "z", "size")), ds)}
    assert got["u1"].best_match == "inhand" and got["u1"].f1 >= 0.95
    assert got["b1"].best_match == "on" and got["b1"].argument_order == "same" and got["b1"].f1 >= 0.9
    assert got["b2"].best_match == "on" and got["b2"].argument_order == "swapped" and got["b2"].f1 >= 0.9
    # "under" is "on" mirrored: the same widths, the centre negated
    np.testing.assert_allclose(under.centre, -on.centre)
    with pytest.raises(UserError, match="nonsense: not a ground-truth relation"):
        fit_relation_symbol("u9", "nonsense", ds)


def test_describe_keeps_dimensions_that_decide_jointly_and_drops_constant_ones():
    """Balls (size 4.5 cm) on the table among cubes of 4 and 5 cm, and objects lifted to 40 cm."""
    rng = np.random.default_rng(0)
    size = rng.choice([0.04, 0.045, 0.05], 3000)
    z = np.where(rng.random(3000) < 0.1, 0.4, size / 2)
    x = rng.uniform(0.2, 0.8, 3000)
    data = np.column_stack([x, np.zeros(3000), z, size])
    # an ellipsoid whose size interval alone spans every size, but which keeps only the balls on
    # the table, and whose far, wide x adds about 0.2 to every point's distance
    ball = Symbol("u1", 1, np.array([-5.0, 0.0, 0.02, 0.045]), np.array([12.0, 10.0, 0.5, 0.00674]))
    holds = ball.holds(data)
    assert np.array_equal(holds, np.isclose(size, 0.045) & (z < 0.1))
    text = describe_symbol(ball, ("x", "y", "z", "size"), data)
    assert "size between" in text and "x between" not in text and "y between" not in text
    assert intervals(ball)[3, 0] < 0.04 and intervals(ball)[3, 1] > 0.05   # alone, size spans all sizes
    keep, offset = deciding_dimensions(ball, data)
    assert keep.tolist() == [False, False, True, True] and 0.18 < offset < 0.24
    lo, hi = intervals(ball, offset)[3]
    assert 0.040 < lo < 0.045 < hi < 0.050   # allowing for x's constant: the balls' size only


def test_grounding_names_the_relation_a_negated_symbol_matches():
    """A symbol learned as "not in the hand" (z below 35 cm; the hand holds at 45 cm)."""
    ds = kinematic_tower(4, seed=5)
    not_held = Symbol("u1", 1, np.array([0.3, 0.0, 0.0, 0.05]), np.array([100.0, 100.0, 0.35 / np.sqrt(np.log(2)), 100.0]))
    m = match_symbols(SymbolSet((not_held,), NAMES), ds)[0]
    assert m.f1 == 0.0 and (m.negation_of, m.negation_f1) == ("inhand", 1.0)
    assert "its negation ~ inhand: F1 1.000" in str(m)
    doc = m.to_doc()
    assert (doc["negation_match"], doc["negation_f1"]) == ("inhand", 1.0)
    assert grounded(doc, 0.8) == {"inhand": 1.0}        # the negation grounds inhand
    held = match_symbols(SymbolSet(tuple(intended_symbols()[:1]), NAMES), ds)[0]
    assert held.best_match == "inhand" and held.negation_of is None
    assert (held.to_doc()["negation_match"], held.to_doc()["negation_f1"]) == (None, None)
    assert grounded(held.to_doc(), 0.8) == {"inhand": 1.0}


def test_a_negation_grounds_a_relation_only_at_f1_0_9():
    doc = {"best_match": "ontable", "f1": 0.5, "negation_match": "inhand", "negation_f1": 0.85}
    assert grounded(doc, 0.8) == {}
    assert grounded({**doc, "negation_f1": 0.9}, 0.8) == {"inhand": 0.9}
    assert grounded({**doc, "f1": 0.8}, 0.8) == {"ontable": 0.8}
