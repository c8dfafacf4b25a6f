"""The loss's linear reward term and the static back-off of its prediction term, against
independent references: the learned reward model's own feature evaluation (groundings enumerated
one by one), explicit leave-one-out refits, and the numpy back-off of examples/size_symbol_terms.py."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from groundsym.backends import new_backend
from groundsym.loss import Loss, LossConfig, prepare
from groundsym.reward import candidate_features
from groundsym.reward_term import count_features, linear_reward_nll, loo_residuals
from groundsym.symbols import Symbol

from test_loss import intended_symbols, kinematic_tower

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SIZE = Symbol("u2", 1, np.array([0.3, 0.0, 0.2, 0.06]), np.array([1e3, 1e3, 1e3, 0.012]))   # the big cubes


def _random_states(rng: np.random.Generator, t: int, m: int, k: int, n_bin: int) -> tuple[np.ndarray, np.ndarray]:
    u = (rng.random((t, m, k)) < 0.4).astype(np.uint8)
    b = (rng.random((t, m, m, n_bin)) < 0.3).astype(np.uint8)
    b[:, np.arange(m), np.arange(m)] = 0
    return u, b


def _closure_reference(u: np.ndarray, b: np.ndarray) -> list[np.ndarray]:
    """Per binary symbol, the pairs joined by a path (found by depth-first search from each object),
    then those pairs with each unary symbol on the first object, then on the second."""
    t, m, k = u.shape
    n_bin = b.shape[-1]
    total = np.zeros((n_bin, t))
    first = np.zeros((n_bin, k, t))
    second = np.zeros((n_bin, k, t))
    for s in range(t):
        for p in range(n_bin):
            for a in range(m):
                seen, stack = set(), [a]
                while stack:
                    x = stack.pop()
                    for y in range(m):
                        if b[s, x, y, p] and y not in seen:
                            seen.add(y)
                            stack.append(y)
                for c in seen - {a}:
                    total[p, s] += 1
                    first[p, :, s] += u[s, a]
                    second[p, :, s] += u[s, c]
    return [total[p] for p in range(n_bin)] + [first[p, i] for p in range(n_bin) for i in range(k)] + \
        [second[p, i] for p in range(n_bin) for i in range(k)]


@pytest.mark.parametrize("k,n_bin", [(1, 1), (2, 2), (0, 2), (3, 0)])
def test_count_features_are_the_reward_models_features(k, n_bin):
    """The same family of counts as the learned reward model, each feature's groundings enumerated
    by :meth:`groundsym.reward.Feature.evaluate`, plus the path counts by depth-first search: equal
    as sets of columns."""
    rng = np.random.default_rng(k * 10 + n_bin)
    u, b = _random_states(rng, 40, 5, k, n_bin)
    preds = {**{f"u{i}": 1 for i in range(k)}, **{f"b{j}": 2 for j in range(n_bin)}}
    arrays = {**{f"u{i}": u[..., i].astype(float) for i in range(k)},
              **{f"b{j}": b[..., j].astype(float) for j in range(n_bin)}}
    ref = np.stack([f.evaluate(arrays, 5) for f in candidate_features(preds)]
                   + _closure_reference(u, b), axis=1)
    ours = count_features(u, b)
    assert ours.shape == ref.shape
    as_set = lambda X: sorted(map(tuple, X.T.tolist()))   # noqa: E731
    assert as_set(ours) == as_set(ref)
    assert np.array_equal(new_backend("numba").count_features(u, b), ours)   # the compiled twin, column by column


def test_loo_residuals_equal_explicit_refits():
    """PRESS residuals against refitting without each row (same design, same penalty)."""
    rng = np.random.default_rng(3)
    X = rng.normal(size=(30, 4))
    X[:, 3] = 7.0                                          # a constant column is dropped
    y = X[:, 0] * 2 - X[:, 1] + rng.normal(0, 0.1, 30)
    got = loo_residuals(X, y, ridge=0.05)
    Z = X[:, :3]
    Z = (Z - Z.mean(0)) / Z.std(0)
    D = np.hstack([np.ones((30, 1)), Z])
    P = np.diag([0.0] + [0.05 * 30] * 3)
    for i in range(30):
        keep = np.arange(30) != i
        beta = np.linalg.solve(D[keep].T @ D[keep] + P, D[keep].T @ y[keep])
        assert got[i] == pytest.approx(y[i] - D[i] @ beta, rel=1e-9, abs=1e-12)


def test_without_features_the_model_is_the_leave_one_out_mean():
    y = np.array([1.0, 2.0, 4.0, 7.0])
    got = loo_residuals(np.zeros((4, 0)), y)
    assert got == pytest.approx([y[i] - np.delete(y, i).mean() for i in range(4)])


def test_a_reward_linear_in_the_counts_is_predicted_exactly():
    """Reward = 0.3 x (number of b0 pairs) - 0.1 x (objects with u0): the leave-one-out residuals
    vanish, and the term is the Gaussian's normaliser alone."""
    rng = np.random.default_rng(5)
    u, b = _random_states(rng, 60, 6, 1, 1)
    r = 0.3 * b.sum(axis=(1, 2, 3)) - 0.1 * u.sum(axis=(1, 2)) + 2.0
    assert np.abs(loo_residuals(count_features(u, b), r, ridge=1e-12)).max() < 1e-6
    sigma = 0.5        # the default ridge leaves a bias of a few thousandths of a nat
    assert linear_reward_nll(count_features(u, b), r, sigma) == pytest.approx(60 * 0.5 * math.log(2 * math.pi * sigma ** 2), abs=1e-2)


@pytest.fixture(scope="module")
def fixture_data():
    ds = kinematic_tower(16, seed=4)
    return ds, prepare(ds)


def test_linear_reward_term_prefers_the_intended_symbols(fixture_data):
    """The fixture's reward is the cubes' mean lowest point: linear in `on` pairs (and cube size),
    so the intended symbols earn more reward likelihood than `inhand` alone or none."""
    _, d = fixture_data
    cfg = LossConfig(reward_model="linear")
    loss = Loss(d, cfg)
    inhand, on = intended_symbols()
    full, hand, none = loss([inhand, on]), loss([inhand]), loss([])
    assert full.reward < hand.reward <= none.reward
    # the other terms do not depend on the reward model
    assert Loss(d, cfg, kernels="numpy")([inhand, on]) == full      # both kernels, bit for bit
    base = Loss(d)([inhand, on])
    assert (full.effect, full.transition, full.regulariser) == (base.effect, base.transition, base.regulariser)


def test_backoff_without_static_symbols_is_the_split(fixture_data):
    _, d = fixture_data
    a = Loss(d, LossConfig(static="backoff"))(intended_symbols())
    b = Loss(d)(intended_symbols())
    assert a == b


def test_backoff_equals_the_examples_numpy_backoff(fixture_data, monkeypatch):
    """With a static size symbol, the back-off's prediction term equals the independent entries-based
    back-off of examples/size_symbol_terms.py, and both kernels agree bit for bit."""
    sys.path.insert(0, str(EXAMPLES))
    try:
        import size_symbol_terms as sst
    finally:
        sys.path.remove(str(EXAMPLES))
    _, d = fixture_data
    inhand, on = intended_symbols()
    monkeypatch.setattr(sst, "INHAND", inhand)
    monkeypatch.setattr(sst, "ON", on)
    off_b = Symbol("b2", 2, np.full(4, 1e3), np.full(4, 1e-3))
    cfg = LossConfig(static="backoff")
    numpy_loss = Loss(d, cfg, kernels="numpy")
    got = numpy_loss([inhand, SIZE, on, off_b])
    ref_transition, _ = sst.backoff_terms(Loss(d, LossConfig(), kernels="numpy"), [SIZE])
    assert got.transition == pytest.approx(ref_transition, rel=1e-12)
    split = Loss(d, LossConfig(), kernels="numpy")([inhand, SIZE, on, off_b])
    assert got.transition < split.transition          # the split's lost twins are back
    assert Loss(d, cfg)([inhand, SIZE, on, off_b]) == got


def test_evaluation_folders_keep_their_fingerprint_and_tell_losses_apart():
    """A folder made with the default loss keeps its fingerprint (its files name no later setting);
    another reward model is another evaluation."""
    from groundsym.evaluation.config import EvalConfig

    base = EvalConfig(sim="tower", methods=("prada",), symbol_data=(160,), model_traces=(9,))
    assert base.key()["loss"] == {k: v for k, v in LossConfig().to_doc().items()}
    assert "reward_model" not in base.key()["loss"] and "static" not in base.key()["loss"]
    other = EvalConfig(sim="tower", methods=("prada",), symbol_data=(160,), model_traces=(9,),
                       loss=LossConfig(reward_model="linear", static="backoff", sigma_factor=0.1))
    assert other.key()["loss"]["reward_model"] == "linear" and other.fingerprint() != base.fingerprint()
