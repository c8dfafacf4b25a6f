"""The local distance (``LossConfig.distance = local:K``, groundsym/relational/local.py): which
literals it keeps, that the loss around it is the exact machinery on those states, and that it is
offered and refused as an option should be."""

from __future__ import annotations

import json
from collections import deque

import numpy as np
import pytest

from groundsym.cli import main
from groundsym.loss import Loss, LossConfig, prepare
from groundsym.profile_neighbours import profile_neighbours
from groundsym.relational import local
from groundsym.relational.local import AUTO_EXACT_MAX, Distance, kept_pairs
from groundsym.symbols import Symbol
from groundsym.traces import write_traces
from tests.test_loss import intended_symbols, kinematic_tower


def _random_graphs(seed: int, t: int = 40, m: int = 9, l: int = 2, density: float = 0.12):
    rng = np.random.default_rng(seed)
    binary = (rng.random((t, m, m, l)) < density).astype(np.uint8)
    binary[:, np.arange(m), np.arange(m)] = 0
    lock = np.zeros((t, m), dtype=np.int64)
    for row in range(t):
        for k, obj in enumerate(rng.choice(m, rng.integers(0, 3), replace=False)):
            lock[row, obj] |= 1 << k
    return binary, lock


def kept_pairs_reference(binary: np.ndarray, lock: np.ndarray, steps: int) -> np.ndarray:
    """groundsym.relational.local.kept_pairs by a breadth-first search per transition (the reference)."""
    t_count, m = lock.shape
    out = np.zeros((t_count, m, m), dtype=bool)
    for t in range(t_count):
        depth = {i: 0 for i in range(m) if lock[t, i]}
        todo = deque(depth)
        while todo:
            i = todo.popleft()
            for j in range(m):
                related = binary[t, i, j].any() or binary[t, j, i].any()
                if related and j not in depth and depth[i] + 1 <= steps - 1:
                    depth[j] = depth[i] + 1
                    todo.append(j)
        for i in depth:
            out[t, i, :] = True
            out[t, :, i] = True
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("steps", [1, 2, 3, 5])
def test_kept_pairs_match_a_breadth_first_search(seed, steps):
    binary, lock = _random_graphs(seed)
    assert np.array_equal(kept_pairs(binary, lock, steps), kept_pairs_reference(binary, lock, steps))


def test_kept_pairs_on_a_chain():
    """on(0,1), on(1,2), on(2,3), on(3,4), the action's argument is object 0: one step keeps the
    literals of object 0, two steps those of objects 0 and 1, and so on (hand-computed)."""
    m = 5
    binary = np.zeros((1, m, m, 1), dtype=np.uint8)
    for i in range(m - 1):
        binary[0, i, i + 1, 0] = 1
    lock = np.array([[1, 0, 0, 0, 0]])
    kept_edges = [sorted((i, j) for i, j in zip(*np.nonzero(binary[0, :, :, 0])) if kept_pairs(binary, lock, k)[0, i, j])
                  for k in (1, 2, 3, 4)]
    assert kept_edges == [[(0, 1)], [(0, 1), (1, 2)], [(0, 1), (1, 2), (2, 3)], [(0, 1), (1, 2), (2, 3), (3, 4)]]
    assert not kept_pairs(binary, np.zeros((1, m), dtype=np.int64), 3).any()   # no argument: no relation kept


def test_the_distance_setting_parses_and_refuses():
    assert Distance.parse("exact").steps_for(40) is None
    assert Distance.parse("local").steps_for(5) == 1
    assert Distance.parse("local:3").steps_for(5) == 3
    assert Distance.parse("auto").steps_for(AUTO_EXACT_MAX) is None
    assert Distance.parse("auto").steps_for(AUTO_EXACT_MAX + 1) == 1
    for bad in ("local:0", "local:x", "exact:2", "nearest", "local:63", ""):
        with pytest.raises(ValueError, match="distance"):
            Distance.parse(bad)
    assert "distance" not in LossConfig().to_doc()           # the default's files read as before
    doc = LossConfig(distance="local:2").to_doc()
    assert doc["distance"] == "local:2" and LossConfig(**doc) == LossConfig(distance="local:2")


def _candidates(data, n: int, seed: int) -> list[list[Symbol]]:
    rng = np.random.default_rng(seed)
    out = [intended_symbols()]
    m = data.features.shape[1]
    for _ in range(n):
        s = data.features[rng.integers(len(data.features)), rng.integers(m)]
        p = data.pairs[rng.integers(len(data.pairs)), 0, 1]
        out.append([Symbol("u1", 1, s, data.unary_scale * rng.uniform(0.1, 1.5, 4)),
                    Symbol("b1", 2, p, data.pair_scale * rng.uniform(0.1, 1.5, 4))])
    return out


def test_a_mask_that_keeps_everything_gives_the_exact_loss(monkeypatch):
    """The local loss is the exact loss on the masked states: with a mask that keeps every literal
    its effect, prediction and regulariser are the exact loss's bit for bit (the per-transition
    scenes change nothing else), and its reward term is the mixture over profile neighbours."""
    data = prepare(kinematic_tower(8, seed=3, n_cubes=7))
    exact_loss = Loss(data)
    exact, by_profile = [], []
    for c in _candidates(data, 30, 0):
        exact.append(exact_loss(c))
        u = np.stack([exact_loss._symbol(s).truth for s in c if s.arity == 1], axis=-1)
        b = np.stack([exact_loss._symbol(s).truth for s in c if s.arity == 2], axis=-1)
        by_profile.append(exact_loss._reward_nll(profile_neighbours(u[data.pre], b[data.pre])))
    monkeypatch.setattr(local, "kept_pairs", lambda b, lock, steps: np.ones(b.shape[:3], dtype=bool))
    got = [Loss(data, LossConfig(distance="local:1"))(c) for c in _candidates(data, 30, 0)]
    assert [(t.effect, t.transition, t.regulariser) for t in got] == [(t.effect, t.transition, t.regulariser)
                                                                     for t in exact]
    assert [t.reward for t in got] == by_profile


def _profile_distance(u1, b1, u2, b2) -> float:
    """By hand: unary counts, then half the L1 of the sorted out- and in-degree sequences."""
    d = float(np.abs(u1.sum(0).astype(int) - u2.sum(0).astype(int)).sum())
    for axis in (1, 0):
        s1, s2 = np.sort(b1.sum(axis).astype(int), axis=0), np.sort(b2.sum(axis).astype(int), axis=0)
        d += 0.5 * float(np.abs(s1 - s2).sum())
    return d


@pytest.mark.parametrize("seed", [0, 1])
def test_profile_neighbours_are_the_nearest_others_by_profile(seed):
    rng = np.random.default_rng(seed)
    n, m = 30, 6
    u = (rng.random((n, m, 2)) < 0.3).astype(np.uint8)
    b = (rng.random((n, m, m, 1)) < 0.15).astype(np.uint8)
    b[:, np.arange(m), np.arange(m)] = 0
    u[5], b[5] = u[4][::-1], b[4][::-1, ::-1]            # an isomorphic pair: same profile
    nb = profile_neighbours(u, b)
    members, hits = nb.members, nb.hits
    for i in range(n):
        d = np.array([_profile_distance(u[i], b[i], u[j], b[j]) if j != i else np.inf for j in range(n)])
        want = set(np.flatnonzero(d == d.min()).tolist())
        k = int(nb.cls[i])
        got = (set(members[k].tolist()) - {i} if len(members[k]) > 1
               else {int(j) for c, _ in hits[k][1] for j in members[c]})
        assert got == want, i


def test_one_step_keeps_exactly_the_literals_of_the_arguments():
    """``local:1`` on the fixture's intended ``on``: in both states of each transition it keeps the
    literals with an end at the action's argument and clears every other one (the truth computed
    here from the locks, not by the module's reach)."""
    data = prepare(kinematic_tower(8, seed=3, n_cubes=9))
    sym = intended_symbols()
    config = LossConfig(distance="local:1")
    base = Loss(data, config)(sym)
    # every transition's local view keeps only literals with an end within 0 steps of its argument
    u = np.zeros(data.features.shape[:2] + (0,), np.uint8)
    b = Loss(data)._symbol(sym[1]).truth[..., None]
    _, b_view, pre, post = local.local_view(u, b, data.pre, data.post, data.lock, 1)
    args = data.lock != 0
    touching = args[:, :, None] | args[:, None, :]
    assert not (b_view[pre][..., 0] & ~touching).any() and not (b_view[post][..., 0] & ~touching).any()
    assert np.array_equal(b_view[pre][..., 0], b[data.pre][..., 0] & touching)
    assert base == Loss(data, config)(sym) != Loss(data)(sym)


@pytest.mark.parametrize("cubes", [8])
def test_compiled_and_numpy_kernels_agree_on_the_local_loss(cubes):
    data = prepare(kinematic_tower(6, seed=2, n_cubes=cubes))
    config = LossConfig(distance="local:2")
    compiled, numpy = Loss(data, config, kernels="numba"), Loss(data, config, kernels="numpy")
    for c in _candidates(data, 40, 1):
        assert compiled(c) == numpy(c)


def test_learn_takes_the_distance_and_refuses_a_bad_one(tmp_path, capsys):
    traces = tmp_path / "t.json"
    write_traces(traces, kinematic_tower(4, seed=1, n_cubes=8))
    assert main(["learn", str(traces), "-o", str(tmp_path / "m"), "--evals", "200", "--restarts", "1",
                 "--workers", "1", "--loss", "distance=local:2", "--quiet"]) == 0
    assert json.loads((tmp_path / "m" / "symbols.json").read_text())["config"]["loss"]["distance"] == "local:2"
    capsys.readouterr()
    assert main(["learn", str(traces), "-o", str(tmp_path / "x"), "--loss", "distance=local:0"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--loss" in err and "distance" in err and "Traceback" not in err
