"""PRADA's transition over the chosen action's rules (planners/prada/segments.py): the same bits
as the product with the whole sparse tables (the code before), and the same decisions."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import DATA
from groundsym.planner import Observation, PlanningModel
from groundsym.rules.io import read_rules
from groundsym.rules.model import with_derived
from groundsym.rules.sample import ground_actions, sample_successor
from planners.prada import PradaPlanner, ground_rules
from planners.prada.frontier import rule_probabilities, transition
from tests.test_prada import Linear


def _sparse_grounding(objects, select_columns: bool):
    """The derived tower rules grounded over ``objects``, with the tables forced into the sparse
    form the large groundings take (optionally on the touched columns only)."""
    rules, meta = read_rules(DATA / "nid_tower_derived.rules.json")
    g = ground_rules(rules, objects, meta["predicates"])
    touched, set_true = g.touched, g.set_true
    cols = np.unique(touched.indices) if select_columns else None
    if cols is not None:
        touched, set_true = touched[:, cols], set_true[:, cols]
    g.__dict__["changing"] = (cols, touched.tocsc(), set_true.tocsc())
    return g, rules, meta


def _beliefs(g, rules, meta, objects, n, seed):
    """Point-mass beliefs of random reachable states, then mixed by averaging pairs of them."""
    rng = np.random.default_rng(seed)
    acts = ground_actions(meta["primitives"], objects)
    rows = []
    for _ in range(n):
        s = frozenset()
        for _ in range(int(rng.integers(0, 12))):
            s = sample_successor(rules, s, acts[int(rng.integers(len(acts)))], rng, objects)
        rows.append(g.belief(with_derived(s, rules.derived, objects)))
    B = np.array(rows)
    mix = rng.random(n) < 0.5
    B[mix] = 0.5 * (B[mix] + B[rng.permutation(n)][mix])
    return B, rng


@pytest.mark.parametrize("select_columns", [False, True])
def test_segments_give_the_bits_of_the_whole_table_product(select_columns):
    objects = tuple("abcdefg")
    g, rules, meta = _sparse_grounding(objects, select_columns)
    B, rng = _beliefs(g, rules, meta, objects, 300, 1)
    U = rule_probabilities(g, B)
    chosen = rng.integers(-1, len(g.actions), len(B))
    whole = transition(g, B, U, chosen, "tables")
    assert np.array_equal(transition(g, B, U, chosen), whole)
    assert np.array_equal(transition(g, B, U, chosen, "segments"), whole)
    # and against a loop over each sample's own rules (an independent reference of the values)
    cols, touched, set_true = g.changing
    t, s = touched.toarray(), set_true.toarray()
    for n in range(0, len(B), 7):
        rows = np.flatnonzero(g.rule_group == chosen[n])
        off, on = U[n, rows] @ t[rows], U[n, rows] @ s[rows]
        want = B[n].copy()
        idx = slice(None) if cols is None else cols
        want[idx] = B[n, idx] * (1.0 - off) + on
        np.testing.assert_allclose(whole[n, :-1][~np.isin(np.arange(g.n_vars), g.derived_cols)],
                                   want[:-1][~np.isin(np.arange(g.n_vars), g.derived_cols)], atol=1e-12)


def test_a_decision_is_the_same_with_segments_and_with_the_whole_tables(monkeypatch):
    """Nine cubes, the derived tower rules, a linear reward, tables sparse (as past 2e6 entries):
    PRADA's decisions at seeds 0-2 are identical (action, value, plan) with the per-action
    transition and with the whole-table one."""
    from groundsym.logic import Atom
    import planners.prada.grounding as grounding

    rules, meta = read_rules(DATA / "nid_tower_derived.rules.json")
    model = PlanningModel(meta["primitives"], predicates=meta["predicates"], rules=rules, reward=Linear(), gamma=0.8)
    objects = tuple(f"c{i}" for i in range(9))
    obs = Observation(objects, (), frozenset({Atom("on", ("c0", "c1")), Atom("on", ("c2", "c3"))}))
    monkeypatch.setattr(grounding, "DENSE_MAX_ENTRIES", 0)

    def decisions(mode: str):
        out = []
        for seed in range(3):
            planner = PradaPlanner(model, {"samples": "200", "transition": mode}, seed)
            d = planner.choose(obs)
            assert not isinstance(planner.core(objects, obs.state).g.changing[1], np.ndarray)
            out.append((d.action, d.expected_value, d.info))
        return out
    assert decisions("auto") == decisions("tables") == decisions("segments")


@pytest.mark.parametrize("min_prob", [0.0, 0.03, 0.5])
def test_context_probabilities_give_numpys_bits(min_prob):
    """The compiled context probabilities against numpy's gather, where and product (the code
    before), on mixed beliefs over the derived tower rules, with some literals made negative."""
    from planners.prada.contexts import context_probabilities

    objects = tuple("abcdef")
    g, rules, meta = _sparse_grounding(objects, False)
    B, rng = _beliefs(g, rules, meta, objects, 200, 2)
    sign = g.sign ^ (rng.random(g.sign.shape) < 0.3)      # negative literals too (these rules have none)
    lit = B[:, g.ctx]
    lit = np.where(sign, lit, 1.0 - lit)
    want = lit.prod(axis=2)
    want[want < min_prob] = 0.0
    assert np.array_equal(context_probabilities(B, g.ctx, sign, min_prob), want)


@pytest.mark.parametrize("share", [0.05, 0.3, 0.9])
def test_rule_probabilities_over_the_live_contexts_give_the_bits_of_all(share):
    """``frontier._alone`` (logarithms and exponentials where a context can hold) against
    ``phi * _none_of_the_others(phi)`` over every entry (the code before), with certain rivals
    (probability 1) among them."""
    from planners.prada.frontier import _alone, _none_of_the_others

    objects = tuple("abcdefg")
    g, _, _ = _sparse_grounding(objects, False)
    rng = np.random.default_rng(4)
    phi = rng.random((150, len(g.rule_group))) * (rng.random((150, len(g.rule_group))) < share)
    phi[rng.random(phi.shape) < 0.02] = 1.0
    assert np.array_equal(_alone(phi, g.starts, g.rule_group), phi * _none_of_the_others(phi, g.starts, g.rule_group))


def test_segments_on_dense_tables_differ_from_blas_in_the_last_bit_at_most():
    """``transition=segments`` on dense tables (what ``auto`` leaves to BLAS): the same marginals
    up to rounding (BLAS fuses multiplications and additions), and ``auto`` keeps BLAS's bits there."""
    objects = tuple("abcde")
    rules, meta = read_rules(DATA / "nid_tower_derived.rules.json")
    g = ground_rules(rules, objects, meta["predicates"])
    assert isinstance(g.changing[1], np.ndarray)
    B, rng = _beliefs(g, rules, meta, objects, 200, 3)
    U = rule_probabilities(g, B)
    chosen = rng.integers(-1, len(g.actions), len(B))
    tables = transition(g, B, U, chosen, "tables")
    assert np.array_equal(transition(g, B, U, chosen), tables)
    np.testing.assert_allclose(transition(g, B, U, chosen, "segments"), tables, rtol=0, atol=1e-15)
