"""Directed exploration (groundsym/explore.py, ``groundsym collect --explore``): the least-known
choice against counts set by hand, round 0 equal to random collection, same seed same file, and an
interrupted run resumed to the same file."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from groundsym.cli import main
from groundsym.collect import collect_traces
from groundsym.explore import ExploreConfig, RoundModel, experience_key, explore_traces, least_known, local_signature
from groundsym.logic import Atom, Literal
from groundsym.rules.model import Outcome, Rule, RuleSet
from groundsym.symbols import SymbolSet
from groundsym.traces import read_traces
from sims.tower import TowerSim

CELL = {"cubes": "3", "big": "1", "noise": "0"}
CFG = ExploreConfig(rounds=2, round_traces=2, length=3, evals=200, restarts=1)


def A(p: str, *args: str) -> Atom:
    return Atom(p, tuple(args))


def grab_rules() -> RuleSet:
    rule = Rule(A("grab", "?x"), (Literal(A("clear", "?x")),), (Outcome((Literal(A("held", "?x")),)),), (1.0,), 0.0)
    return RuleSet((rule,))


def test_the_least_known_primitive_is_chosen_and_ties_are_drawn():
    rules = grab_rules()
    state = frozenset({A("clear", "a"), A("clear", "b"), A("on", "c", "a")})
    actions = [A("grab", o) for o in "abc"]
    known = experience_key(rules, state, actions[0], ("a", "b", "c"))
    assert known == ("rule", 0) == experience_key(rules, state, actions[1], ("a", "b", "c"))
    unknown = experience_key(rules, state, actions[2], ("a", "b", "c"))   # c is not clear: no rule
    assert unknown == ("none", "grab", 1, (("on", ("#0", "*")),)) and unknown[1:] == local_signature(state, actions[2])
    model = RoundModel(SymbolSet((), ("x",)), rules, {known: 5})
    rng = np.random.default_rng(0)
    assert {least_known(model, state, actions, ("a", "b", "c"), rng, 3)[0] for _ in range(20)} == {actions[2]}
    model.counts[unknown] = 2                     # still unknown (below 3): still the only choice
    assert {least_known(model, state, actions, ("a", "b", "c"), rng, 3)[0] for _ in range(20)} == {actions[2]}
    model.counts[known] = 1                       # now a and b have the smallest count: both get drawn
    picks = [least_known(model, state, actions, ("a", "b", "c"), rng, 3)[0] for _ in range(200)]
    assert set(picks) == {actions[0], actions[1]} and 60 < picks.count(actions[0]) < 140
    model.counts[known], model.counts[unknown] = 3, 7       # all known: uniformly at random
    picks = [least_known(model, state, actions, ("a", "b", "c"), rng, 3)[0] for _ in range(300)]
    assert all(60 < picks.count(a) < 140 for a in actions)


@pytest.fixture(scope="module")
def explored(tmp_path_factory):
    d = tmp_path_factory.mktemp("explore")
    with TowerSim(**CELL) as sim:
        ds = explore_traces(sim, CFG, 5, d / "work", progress=False)
        random = collect_traces(sim, 4, 3, 5, progress=False)
    return d, ds, random


def same_traces(a, b) -> bool:
    return all(x.actions == y.actions and all(np.array_equal(s.features, t.features) for s, t in zip(x.scenes, y.scenes))
               for x, y in zip(a.traces, b.traces)) and len(a.traces) == len(b.traces)


def test_round_zero_is_random_collection_and_later_rounds_use_the_model(explored):
    d, ds, random = explored
    assert len(ds.traces) == 4 and ds.meta["explore"]["rounds"] == 2
    assert same_traces(type(ds)(ds.traces[:2], ds.feature_names, ds.primitives),
                       type(ds)(random.traces[:2], ds.feature_names, ds.primitives))
    assert (d / "work" / "round-0" / "rules.json").exists() and (d / "work" / "round-0" / "symbols.json").exists()
    assert not (d / "work" / "round-1").exists()          # no model after the last round


def test_same_seed_same_file_and_an_interrupted_run_resumes_to_it(explored, tmp_path):
    _, ds, _ = explored
    with TowerSim(**CELL) as sim:
        again = explore_traces(sim, CFG, 5, tmp_path / "w", progress=False)
        assert same_traces(ds, again)
        (tmp_path / "w" / "round-1.json").unlink()     # stopped after round 0 and its model
        shutil.rmtree(tmp_path / "w" / "round-0")      # ... or even before the model was written
        resumed = explore_traces(sim, CFG, 5, tmp_path / "w", progress=False)
    assert same_traces(ds, resumed)


def test_cli_checks_exploration_options_before_work(tmp_path, capsys):
    base = ["collect", "--sim", "tower", "--sim-opt", "cubes=3", "--traces", "4", "--length", "2", "--quiet",
            "-o", str(tmp_path / "t.json")]
    for extra, msg in ((["--explore", "counts"], "needs --rounds and --work"),
                       (["--rounds", "2"], "only with --explore"),
                       (["--explore", "counts", "--rounds", "3", "--work", str(tmp_path / "w")], "does not divide")):
        assert main(base + extra) == 2
        err = capsys.readouterr().err
        assert msg in err and "Traceback" not in err
    (tmp_path / "w").mkdir()
    (tmp_path / "w" / "explore.json").write_text(json.dumps({"seed": 99}))
    assert main(base + ["--explore", "counts", "--rounds", "2", "--work", str(tmp_path / "w")]) == 2
    assert "made with other options" in capsys.readouterr().err
    assert not (tmp_path / "t.json").exists()


@pytest.mark.slow
def test_cli_explore_writes_every_round_and_the_whole_file(tmp_path):
    out, work = tmp_path / "t.json", tmp_path / "w"
    argv = ["collect", "--sim", "tower", "--sim-opt", "cubes=3", "--traces", "4", "--length", "3", "--seed", "2",
            "--quiet", "-o", str(out), "--explore", "counts", "--rounds", "2", "--work", str(work),
            "--explore-evals", "400"]
    assert main(argv) == 0
    ds = read_traces(out)
    assert len(ds.traces) == 4 and ds.meta["explore"]["evals"] == 400
    assert sorted(p.name for p in work.iterdir()) == ["explore.json", "round-0", "round-0.json", "round-1.json"]
