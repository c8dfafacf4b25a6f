"""Learned symbols as observations: a model from `groundsym learn` wrapping the tower environment,
checked against the RBF rule of Eq. (4) evaluated by hand on the simulator's features."""

from __future__ import annotations

import json
import math
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from groundsym.cli import main
from groundsym.errors import UserError
from groundsym.gym import AbstractStates
from groundsym.logic import Atom
from groundsym.symbols import Symbol, SymbolSet

from conftest import DATA

TOWER = {"cubes": 3, "big": 1, "noise": 0.0}
ACTIONS = [0, 4, 1]          # grasp o1, release it over o2, grasp o2


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """A model directory learned from the tower fixture traces with a small budget (the first
    seed whose search keeps a symbol: a search that prunes every symbol leaves nothing to observe)."""
    for seed in range(3):
        out = tmp_path_factory.mktemp(f"model{seed}")
        assert main(["learn", str(DATA / "tower_small.json"), "-o", str(out), "--evals", "400",
                     "--restarts", "2", "--workers", "1", "--seed", str(seed), "--quiet"]) == 0
        if json.loads((out / "symbols.json").read_text())["symbols"]:
            return out
    pytest.fail("groundsym learn kept no symbol in 3 seeds")


def by_hand(symbols: list[dict], objects: tuple[str, ...], features: np.ndarray) -> dict[tuple, int]:
    """Eq. (4): a symbol holds where sum(((y - centre) / widths)^2) < ln 2; binary ones on y_i - y_j
    of distinct objects. Keys are (name, args) tuples, which sort as the atoms do."""
    out = {}
    for s in symbols:
        c, w = np.array(s["centre"]), np.array(s["widths"])
        holds = lambda y: int((((y - c) / w) ** 2).sum() < math.log(2))   # noqa: E731
        if s["arity"] == 1:
            out.update({(s["name"], (o,)): holds(features[i]) for i, o in enumerate(objects)})
        else:
            out.update({(s["name"], (a, b)): holds(features[i] - features[j])
                        for i, a in enumerate(objects) for j, b in enumerate(objects) if i != j})
    return out


def test_learned_model_observations_follow_its_symbols(model):
    symbols = json.loads((model / "symbols.json").read_text())["symbols"]
    env = AbstractStates(gymnasium.make("groundsym/Tower-v0", **TOWER), model)
    both = gymnasium.make("groundsym/Tower-v0", model=str(model), **TOWER)   # features + atoms
    try:
        objects = env.unwrapped.objects
        truth = by_hand(symbols, objects, np.zeros((3, 4)))
        assert env.atoms == tuple(Atom(n, a) for n, a in sorted(truth))
        assert env.observation_space == gymnasium.spaces.MultiBinary(len(truth))
        assert both.observation_space["atoms"] == env.observation_space
        obs, _ = env.reset(seed=2)
        full, _ = both.reset(seed=2)
        for k in range(len(ACTIONS) + 1):
            features = np.stack([full[o] for o in objects])
            expect = by_hand(symbols, objects, features)
            assert obs in env.observation_space
            assert list(obs) == [expect[key] for key in sorted(expect)]
            np.testing.assert_array_equal(full["atoms"], obs)
            assert env.decode(obs) == {Atom(*key) for key, v in expect.items() if v}
            if k < len(ACTIONS):
                obs = env.step(ACTIONS[k])[0]
                full = both.step(ACTIONS[k])[0]
    finally:
        env.close()
        both.close()


def test_constructed_symbols_give_the_known_abstract_state():
    """Symbols centred on one object's features and on one pair's difference, with narrow widths:
    exactly those atoms hold (the objects of the cell lie at least 13 cm apart)."""
    env = gymnasium.make("groundsym/Tower-v0", **TOWER)
    try:
        env.reset(seed=1)
        y = env.unwrapped.current_scene().features
        narrow = np.full(4, 0.01)
        syms = SymbolSet((Symbol("here", 1, y[1].copy(), narrow), Symbol("near", 2, y[2] - y[0], narrow)),
                         ("x", "y", "z", "size"))
        wrapped = AbstractStates(env, syms, keep_features=True)
        obs, _ = wrapped.reset(seed=1)
        assert wrapped.decode(obs) == {Atom("here", ("o2",)), Atom("near", ("o3", "o1"))}
        assert len(wrapped.atoms) == 3 + 6 and set(obs) == {"o1", "o2", "o3", "atoms"}
    finally:
        env.close()


def test_bad_models_are_one_line(model, tmp_path):
    env = gymnasium.make("groundsym/Bowling-v0", pins=2)
    try:
        with pytest.raises(UserError, match=r"feature_names \['x', 'y', 'z', 'size'\] do not match|"
                                            r"do not match the symbols"):
            AbstractStates(env, model)
        with pytest.raises(UserError, match="model directory without symbols.json"):
            AbstractStates(env, tmp_path)
        with pytest.raises(UserError, match="no such model directory or symbols file"):
            AbstractStates(env, tmp_path / "missing")
    finally:
        env.close()


@pytest.mark.slow
def test_abstract_observations_pass_the_gymnasium_checker(model):
    for env in (AbstractStates(gymnasium.make("groundsym/Tower-v0", **TOWER), model),
                gymnasium.make("groundsym/Tower-v0", model=str(model), **TOWER).unwrapped):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env)
        messages = [str(w.message) for w in caught]
        assert all("infinity" in m or "different from the unwrapped" in m for m in messages), messages
        env.close()


def test_example_q_update_and_masked_greedy_choice():
    from examples.gym_abstract import QTable

    table = QTable(3, gamma=0.8, alpha=0.5)
    s, s2 = np.array([1, 0], np.int8), np.array([0, 1], np.int8)
    table.update(s2, 2, 2.0, s, np.array([1, 1, 1]), True)       # Q(s2, 2) = 0.5 * 2 = 1
    table.update(s, 0, 1.0, s2, np.array([1, 1, 1]), False)      # Q(s, 0) = 0.5 * (1 + 0.8 * 1) = 0.9
    assert table.values(s)[0] == pytest.approx(0.9)
    table.update(s, 1, 1.0, s2, np.array([1, 1, 0]), False)      # action 2 masked in s2: max over 0, 1 is 0
    assert table.values(s)[1] == pytest.approx(0.5)
    assert table.greedy(s, np.array([1, 1, 0])) == 0 and table.greedy(s, np.array([0, 1, 1])) == 1


@pytest.mark.slow
def test_example_runs_on_a_learned_model(model, tmp_path, capsys):
    from examples.gym_abstract import main as example

    plot = tmp_path / "q.png"
    assert example(["--model", str(model), "--cubes", "2", "--episodes", "2", "--test", "1",
                    "--plot", str(plot)]) == 0
    out = capsys.readouterr().out
    assert "greedy Q policy: mean value" in out and "random policy:" in out
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
