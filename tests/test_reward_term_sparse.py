"""The loss's sparse-effects option (``LossConfig.sparse_effects``, groundsym/sparse_effects.py):
changed literals counted against a hand-computed release and an independent loop over the data,
the default left bit-identical, and `above` charged more than `on` on the same data."""

from __future__ import annotations

import numpy as np
import pytest

from groundsym.commands.learn import loss_config
from groundsym.errors import UserError
from groundsym.loss import Loss, LossConfig, prepare
from groundsym.sparse_effects import changed_literals, excess_changes, sparse_effects_nll
from groundsym.symbols import Symbol

from test_loss import intended_symbols, kinematic_tower

# a second binary candidate: pairs of objects near each other (a lifted cube leaves several)
NEAR = Symbol("b2", 2, np.array([0.0, 0.0, 0.0, 0.0]), np.array([0.15, 0.15, 0.15, 1.0]))


def _release_onto_a_tower() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Cubes 0, 1, 2: 1 stands on 0 (a tower of two), 2 is in the hand and is released onto 1.
    Returns inhand (S, M, 1), on and above (S, M, M, 1), pre, post."""
    inhand = np.zeros((2, 3, 1), np.uint8)
    inhand[0, 2, 0] = 1
    on = np.zeros((2, 3, 3, 1), np.uint8)
    on[:, 1, 0, 0] = 1
    on[1, 2, 1, 0] = 1
    above = on.copy()
    above[1, 2, 0, 0] = 1          # after the release 2 is above 1 and above 0
    return inhand, on, above, np.array([0]), np.array([1])


def test_a_release_onto_a_tower_changes_more_above_literals_than_on_literals():
    """By hand: the release makes `inhand(2)` false and `on(2,1)` true (2 literals, one per symbol:
    no excess); with `above` it also makes `above(2,0)` true (3 literals, one beyond `above`'s
    first): the height of the tower below."""
    inhand, on, above, pre, post = _release_onto_a_tower()
    assert changed_literals(inhand, on, pre, post) == 2
    assert changed_literals(inhand, above, pre, post) == 3
    assert excess_changes(inhand, on, pre, post) == 0
    assert excess_changes(inhand, above, pre, post) == 1
    assert changed_literals(inhand[..., :0], above[..., :0], pre, post) == 0
    assert sparse_effects_nll(inhand, above, pre, post, 1.5) == 1.5
    assert sparse_effects_nll(inhand, on, pre, post, 1.5) == 0.0
    assert sparse_effects_nll(inhand, above, pre, post, 0.0) == 0.0


@pytest.fixture(scope="module")
def fixture_data():
    ds = kinematic_tower(16, seed=4)
    return ds, prepare(ds)


def _changes_by_loop(loss: Loss, symbols: list[Symbol], excess: bool = False) -> int:
    """Changed literals of the active symbols (with ``excess``, beyond the first of each symbol in
    each transition), counted transition by transition and literal by literal."""
    d, count = loss.data, 0
    for s in symbols:
        truth = loss._symbol(s)
        if not truth.active:
            continue
        for t in range(d.n_transitions):
            before, after = truth.truth[d.pre[t]], truth.truth[d.post[t]]
            n = sum(int(x != y) for x, y in zip(before.ravel().tolist(), after.ravel().tolist()))
            count += max(n - 1, 0) if excess else n
    return count


def test_the_option_adds_beta_per_changed_literal_to_the_prediction_term(fixture_data):
    _, d = fixture_data
    symbols = intended_symbols() + [NEAR]
    base = Loss(d)(symbols)
    beta = 0.75
    got = Loss(d, LossConfig(sparse_effects=beta))(symbols)
    n = _changes_by_loop(Loss(d), symbols, excess=True)
    assert n > 0
    assert got.transition == pytest.approx(base.transition + beta * n, rel=1e-12)
    assert (got.effect, got.reward, got.regulariser) == (base.effect, base.reward, base.regulariser)
    assert Loss(d, LossConfig(sparse_effects=beta), kernels="numpy")(symbols) == got    # both kernels


def test_off_by_default_and_files_read_as_before(fixture_data):
    _, d = fixture_data
    assert LossConfig().sparse_effects == 0.0
    assert "sparse_effects" not in LossConfig().to_doc()
    assert LossConfig(sparse_effects=2.0).to_doc()["sparse_effects"] == 2.0
    assert Loss(d, LossConfig(sparse_effects=0.0))(intended_symbols()) == Loss(d)(intended_symbols())


def _closure(b: np.ndarray) -> np.ndarray:
    """`above` from `on` (S, M, M, 1): pairs joined by a chain of `on`, by repeated squaring."""
    reach = b[..., 0].astype(bool)
    for _ in range(b.shape[1]):
        reach = reach | np.einsum("sij,sjk->sik", reach, reach).astype(bool)
    return reach[..., None].astype(np.uint8)


def test_above_changes_more_literals_than_on_on_the_fixture():
    """`above` (on's transitive closure) changes the literals `on` changes, and more wherever a
    tower of three or more is built or taken apart (the fixture world's seed 1 has such towers)."""
    d = prepare(kinematic_tower(16, seed=1))
    inhand, on = intended_symbols()
    loss = Loss(d)
    u, b = loss._symbol(inhand).truth[..., None], loss._symbol(on).truth[..., None]
    above = _closure(b)
    n_on, n_above = changed_literals(u, b, d.pre, d.post), changed_literals(u, above, d.pre, d.post)
    assert n_on == _changes_by_loop(loss, [inhand, on])
    assert n_above > n_on
    assert excess_changes(u, above, d.pre, d.post) > excess_changes(u, b, d.pre, d.post)


@pytest.mark.parametrize("text", ["sparse_effects=-1", "sparse_effects=nan", "sparse_effects=x"])
def test_bad_values_are_one_line_errors(text):
    with pytest.raises(UserError, match="sparse_effects"):
        loss_config([text])
