"""docs/byo.md runs as a reader would copy it, and what it shows holds against independent truth:
the adapter's scenes are the environment's own object features, its step count is the controller's
steps worked out by hand, a seed gives the same trace, the symbols learned in the example world
match ``inhand`` (F1), and a recorded episode reads back as the arrays it was built from."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from groundsym.grounding import match_symbols
from groundsym.logic import Atom
from groundsym.symbols import load_symbols
from groundsym.traces import read_traces

PAGE = Path(__file__).resolve().parents[1] / "docs" / "byo.md"


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    """The page's Python blocks, run in order in one namespace, in a temporary folder."""
    import os

    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(), re.S)
    assert len(blocks) >= 5
    where = tmp_path_factory.mktemp("byo")
    old = os.getcwd()
    os.chdir(where)
    try:
        ns: dict = {"__name__": "byo_page"}
        for block in blocks:
            exec(compile(block, str(PAGE), "exec"), ns)
    finally:
        os.chdir(old)
    ns["_dir"] = where
    return ns


def test_scenes_are_the_environments_object_features(page):
    sim = page["RailSim"]()
    scene = sim.reset(seed=5)
    env_objs = sim.env.unwrapped.objs if hasattr(sim.env, "unwrapped") else sim.env.objs
    assert scene.objects == ("box0", "box1", "box2")
    want = [[env_objs[b]["x"], env_objs[b]["z"]] for b in scene.objects]
    assert scene.features.tolist() == want
    assert len(sim.actions()) == 6           # pick and putOn, each of 3 boxes
    assert scene.reward == 0.0 and scene.truth == frozenset()


def test_a_primitive_runs_its_controller_and_counts_every_env_step(page):
    sim = page["RailSim"]()
    scene = sim.reset(seed=3)
    x0 = scene.features[0, 0]
    offset = np.random.default_rng([3, 1]).uniform(-0.05, 0.05)   # the primitive's parameter, same stream
    scene = sim.step(Atom("pick", ("box0",)))
    assert sim.env_steps == math.ceil(abs(np.clip(x0 + offset, 0, 4) - 2.0) / 0.5) + 1    # moves of at most 0.5, then grip
    assert Atom("inhand", ("box0",)) in scene.truth and scene.features[0, 1] == 2.0
    before = sim.env_steps
    target = next(o for o in scene.objects if o != "box0")
    scene = sim.step(Atom("putOn", (target,)))
    assert Atom("on", ("box0", target)) in scene.truth and scene.reward == 1.0
    assert sim.env_steps > before


def test_same_seed_same_trace(page):
    from groundsym.collect import collect_traces

    a = collect_traces(page["RailSim"](), 3, 4, seed=7, progress=False)
    b = collect_traces(page["RailSim"](), 3, 4, seed=7, progress=False)
    for ta, tb in zip(a.traces, b.traces):
        assert ta.actions == tb.actions
        assert all(np.array_equal(x.features, y.features) for x, y in zip(ta.scenes, tb.scenes))


def test_learned_unary_symbol_is_inhand(page):
    where = page["_dir"]
    ds = read_traces(where / "rail.json")
    symbols = load_symbols(where / "rail-model" / "symbols.json", ds.feature_names)
    best = {m.best_match: m.f1 for m in match_symbols(symbols, ds) if m.arity == 1}
    assert best.get("inhand", 0.0) >= 0.9


def test_recorded_episode_reads_back_as_its_arrays(page):
    ep = page["episode"]
    ds = read_traces(page["_dir"] / "recorded.json")
    (trace,) = ds.traces
    assert ds.primitives == {"pick": 1, "putOn": 1} and ds.meta["sim"] is None
    assert [str(a) for a in trace.actions] == ["(pick box0)", "(putOn box1)"]
    assert np.array_equal(np.stack([s.features for s in trace.scenes]), np.asarray(ep.features, float))
    assert [s.reward for s in trace.scenes] == list(ep.rewards)
    assert [sorted(map(str, s.truth)) for s in trace.scenes] == [[], ["(inhand box0)"], ["(on box0 box1)"]]
    assert not (page["_dir"] / "bad.json").exists()


def _episode(**change):
    from groundsym.recorded import RecordedEpisode

    base = dict(objects=["a", "b"], features=np.zeros((3, 2, 2)), actions=["(pick a)", "(putOn b)"],
                rewards=[0.0, 0.0, 1.0])
    base.update(change)
    return RecordedEpisode(**base)


@pytest.mark.parametrize("change, message", [
    (dict(features=np.zeros((3, 2, 3))), "log.npz: episodes[0].features: expected shape 3 x 2 x 2, got 3 x 2 x 3"),
    (dict(features=np.full((3, 2, 2), np.nan)), "log.npz: episodes[0].features: contains NaN"),
    (dict(rewards=[0.0, 1.0]), "log.npz: episodes[0].rewards: expected shape 3, got 2"),
    (dict(actions=["(pick a)", "(putOn c)"]), "log.npz: episodes[0].actions[1]: unknown object 'c'"),
    (dict(actions=["(pick a)", "(pick a b)"]), "log.npz: episodes[0].actions[1]: pick takes 1 arguments elsewhere"),
    (dict(actions=["(pick a)", 7]), "log.npz: episodes[0].actions[1]: expected"),
    (dict(objects=["a", "a"]), "log.npz: episodes[0].objects: object names must be distinct"),
    (dict(truth=[[], [], ["(on a zz)"]]), "log.npz: episodes[0].truth[2]: unknown object 'zz'"),
    (dict(truth=[[]]), "log.npz: episodes[0].truth: expected one list of atoms per scene (3)"),
])
def test_bad_recorded_input_is_one_line_naming_the_field(change, message):
    from groundsym.errors import UserError
    from groundsym.recorded import dataset_from_arrays

    with pytest.raises(UserError) as err:
        dataset_from_arrays([_episode(**change)], ["x", "z"], source="log.npz")
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


def test_declared_primitives_are_checked_against_the_actions():
    from groundsym.errors import UserError
    from groundsym.recorded import dataset_from_arrays

    with pytest.raises(UserError, match=r"episodes\[0\].actions\[1\]: unknown name 'putOn'"):
        dataset_from_arrays([_episode()], ["x", "z"], primitives={"pick": 1}, source="log.npz")


def test_the_adapter_refuses_unknown_primitives_and_objects(page):
    sim = page["RailSim"]()
    sim.reset(seed=1)
    with pytest.raises(ValueError, match="unknown primitive"):
        sim.step(Atom("push", ("box0",)))
    with pytest.raises(ValueError, match="names an object not in the scene"):
        sim.step(Atom("pick", ("gripper",)))
    assert sim.env_steps == 0
