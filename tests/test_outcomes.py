"""Outcome probabilities (EM) and outcome induction (InduceOutcomes) against hand-computed optima."""

from __future__ import annotations

import numpy as np
import pytest

from groundsym.logic import Atom, parse_atom, parse_literal
from groundsym.rules.coverage import Example, ExampleTable
from groundsym.rules.outcomes import fit_outcome_probs, induce_outcomes, log_likelihood

P_MIN = 1e-8


def test_no_overlap_gives_weighted_counts():
    C = np.array([[1, 0], [1, 0], [0, 1], [0, 0], [1, 0]], dtype=bool)
    w = np.array([1, 2, 3, 1, 1], dtype=float)                 # 3 for outcome 0 ... weights 1+2+1
    p, noise = fit_outcome_probs(C, P_MIN, w)
    assert p == pytest.approx([4 / 8, 3 / 8]) and noise == pytest.approx(1 / 8)


def test_no_overlap_everything_explained_keeps_a_positive_noise_floor():
    p, noise = fit_outcome_probs(np.array([[1, 0], [0, 1], [0, 1]], dtype=bool), P_MIN)
    assert 0 < noise <= 1e-6 and p.sum() + noise == pytest.approx(1)
    assert p == pytest.approx([1 / 3, 2 / 3], abs=1e-6)


def grid_optimum(C, w, step):
    """Brute force: the best point of a simplex grid (K outcomes + noise)."""
    k = C.shape[1]
    best, arg = -np.inf, None
    ticks = np.arange(0, 1 + 1e-12, step)
    for point in np.stack(np.meshgrid(*[ticks] * k, indexing="ij"), -1).reshape(-1, k):
        noise = 1 - point.sum()
        if noise < -1e-12:
            continue
        ll = log_likelihood(C, point, max(noise, 0.0), P_MIN, w)
        if ll > best:
            best, arg = ll, point
    return best, arg


@pytest.mark.parametrize("case", range(4))
def test_overlap_matches_brute_force_optimum_on_a_simplex_grid(case):
    rng = np.random.default_rng(case)
    n, k = 30, 3 if case < 2 else 2
    C = rng.random((n, k)) < 0.45
    C[:4] = True                                                 # rows every outcome explains: overlap
    C[4] = False                                                 # one example only noise explains
    w = rng.integers(1, 4, size=n).astype(float)
    p, noise = fit_outcome_probs(C, P_MIN, w)
    assert p.min() >= 0 and noise > 0 and p.sum() + noise == pytest.approx(1)
    ours = log_likelihood(C, p, noise, P_MIN, w)
    best, arg = grid_optimum(C, w, 0.02 if k == 3 else 0.005)
    assert ours >= best - 1e-6                                   # concave: EM reaches the optimum
    # and it sits next to the grid's best point (the objective is strictly concave here)
    assert np.abs(p - arg).max() < 0.05


def test_overlap_hand_computed():
    # e1 is explained by both outcomes, e2 by outcome 0 only: maximise log(p0+p1) + log(p0) -> p0 = 1
    p, noise = fit_outcome_probs(np.array([[1, 1], [1, 0]], dtype=bool), P_MIN)
    assert p[0] == pytest.approx(1, abs=1e-5) and p[1] == pytest.approx(0, abs=1e-5)


# ----------------------------------------------------------------------------- InduceOutcomes
def s(*atoms):
    return frozenset(parse_atom(a) for a in atoms)


def pickup_examples():
    """pickup(a) from the table: 6 successes, 3 failures (no change), 1 where c falls too (noise)."""
    objs = ("a", "b", "c")
    start = s("(ontable a)", "(clear a)", "(handempty)", "(ontable b)", "(clear b)", "(on c b)")
    ok = s("(inhand a)", "(ontable b)", "(clear b)", "(on c b)")
    odd = s("(inhand a)", "(ontable b)", "(clear b)", "(ontable c)")      # c (unreferenced) moved
    return objs, [Example(start, parse_atom("(pickup a)"), ok, objs, 6.0),
                  Example(start, parse_atom("(pickup a)"), start, objs, 3.0),
                  Example(start, parse_atom("(pickup a)"), odd, objs, 1.0)]


def induce(alpha):
    objs, ex = pickup_examples()
    preds = {"ontable": 1, "clear": 1, "handempty": 0, "inhand": 1, "on": 2}
    t = ExampleTable(ex, preds)
    cov = t.cover(Atom("pickup", ("?x",)), (parse_literal("(ontable ?x)"), parse_literal("(clear ?x)")))
    assert len(cov) == 3
    return induce_outcomes(t, cov, alpha, P_MIN)


def test_induce_outcomes_finds_the_observed_changes_with_count_probabilities():
    f = induce(0.5)
    got = {str(o): p for o, p in zip(f.outcomes, f.probs)}
    success = "(not (clear ?x)) (not (handempty)) (inhand ?x) (not (ontable ?x))"
    assert set(got) == {success, "(no change)"}
    assert got[success] == pytest.approx(0.6) and got["(no change)"] == pytest.approx(0.3)
    assert f.noise == pytest.approx(0.1)
    assert f.noise_changes == pytest.approx(6.0)          # the odd example changed 6 atoms
    assert f.loglik == pytest.approx(6 * np.log(0.6) + 3 * np.log(0.3) + np.log(0.1 * P_MIN))


def test_induce_outcomes_removes_costly_outcomes_when_alpha_is_large():
    # explaining the 6 successes is worth 6 * log(0.6 / (0.7 * p_min)) ~ 110 nats over calling them
    # noise; the 4-literal outcome costs 4 * alpha: kept at alpha 10 (40), dropped at alpha 30 (120)
    assert len(induce(10.0).outcomes) == 2
    f = induce(30.0)
    assert [str(o) for o in f.outcomes] == ["(no change)"]
    assert f.probs[0] == pytest.approx(0.3) and f.noise == pytest.approx(0.7)
