"""``groundsym plan`` end to end: PPDDL episodes with their success rate, the episode file,
determinism, and one-line errors (exit status 2) for what a user can get wrong."""

from __future__ import annotations

import json

import pytest

from conftest import ROOT
from groundsym.cli import main

BW = ROOT / "domains" / "reference" / "blocksworld"
TOWER = ROOT / "domains" / "reference" / "tower"


def plan(*argv):
    return main(["plan", *map(str, argv)])


def test_prada_on_the_reference_blocks_world_reaches_the_goal(tmp_path, capsys):
    out = tmp_path / "ep.json"
    assert plan("--domain", BW / "domain.ppddl", "--problem", BW / "p01.ppddl", "--planner", "prada",
                "--episodes", 4, "--seed", 0, "-o", out) == 0
    text = capsys.readouterr().out
    doc = json.loads(out.read_text())
    assert doc["schema"] == "groundsym.episodes/1" and len(doc["episodes"]) == 4
    rate = doc["summary"]["success_rate"]
    assert rate >= 0.75 and f"success rate {rate:.2f}" in text
    ep = doc["episodes"][0]
    if ep["success"]:
        # the last step reached the goal: (on a b) and (on b c) hold in the final state
        assert {"(on a b)", "(on b c)"} <= set(ep["final_state"]) and ep["steps"][-1]["reward"] == 1.0
    assert all(s["action"].split()[0].strip("(") in {"pickup", "unstack", "putdown", "stack"} for s in ep["steps"])
    again = tmp_path / "again.json"
    plan("--domain", BW / "domain.ppddl", "--problem", BW / "p01.ppddl", "--planner", "prada",
         "--episodes", 4, "--seed", 0, "-o", again)
    assert json.loads(again.read_text())["episodes"] == doc["episodes"]      # same seed, same episodes


def test_random_in_the_tower_sim_without_a_model(tmp_path, capsys):
    out = tmp_path / "ep.json"
    assert plan("--sim", "tower", "--planner", "random", "--steps", 2, "--seed", 1, "-o", out) == 0
    ep = json.loads(out.read_text())["episodes"][0]
    assert len(ep["steps"]) == 2 and ep["gamma"] == 0.8
    assert ep["value"] == pytest.approx(ep["steps"][0]["reward"] + 0.8 * ep["steps"][1]["reward"])


def test_random_episodes_each_draw_from_their_own_seed(tmp_path):
    """Each episode's choices come from its own seed (derived from --seed and the episode's index):
    from the same start, the first primitive of 40 episodes is spread over the 4 pickups as
    uniform draws are (a binomial(40, 1/4) count lies in 4..18 with probability 0.99); the same
    --seed gives the same episodes, and a run of 2 episodes is the first 2 of a run of 40."""
    from collections import Counter

    base = ["--domain", BW / "domain.ppddl", "--problem", BW / "p01.ppddl", "--planner", "random", "--steps", 3,
            "--seed", 7, "--quiet"]
    runs = {}
    for name, n in (("forty", 40), ("again", 40), ("two", 2)):
        assert plan(*base, "--episodes", n, "-o", tmp_path / f"{name}.json") == 0
        runs[name] = json.loads((tmp_path / f"{name}.json").read_text())["episodes"]
    eps = runs["forty"]
    firsts = Counter(e["steps"][0]["action"] for e in eps)
    assert set(firsts) == {f"(pickup {b})" for b in "abcd"} and all(4 <= c <= 18 for c in firsts.values()), firsts
    assert len({e["seed"] for e in eps}) == 40 and len({tuple(s["action"] for s in e["steps"]) for e in eps}) > 20
    assert runs["again"] == eps and runs["two"] == eps[:2]


@pytest.mark.parametrize("argv, message", [
    (["--sim", "tower", "--domain", "x"], "either --sim"),
    (["--domain", BW / "domain.ppddl", "--problem", BW / "p01.ppddl", "--planner", "nosuch"], "unknown planner"),
    (["--domain", BW / "domain.ppddl", "--problem", BW / "p01.ppddl", "--planner-opt", "horizon=0"], "horizon=0"),
    (["--domain", BW / "domain.ppddl", "--problem", BW / "p01.ppddl", "--planner-opt", "depth=3"], "unknown option"),
    (["--domain", BW / "domain.ppddl"], "no problem given"),
    (["--domain", TOWER / "domain.ppddl", "--problem", TOWER / "p01.ppddl"], "needs the domain as NID rules"),
    (["--sim", "tower", "--planner", "continuous-nn"], "continuous training traces"),
    (["--domain", BW / "p01.ppddl"], "p01.ppddl"),
])
def test_user_errors_are_one_line(argv, message, capsys):
    assert plan(*argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "Traceback" not in err[0]


@pytest.mark.slow
def test_the_whole_loop_in_the_tower_sim_with_a_learned_model(tmp_path, capsys):
    """collect -> learn (small budget) -> plan with every model-based planner in the real sim."""
    traces, model = tmp_path / "traces.json", tmp_path / "model"
    assert main(["collect", "--sim", "tower", "--traces", "3", "--length", "10", "--seed", "2", "-o", str(traces),
                 "--quiet"]) == 0
    assert main(["learn", str(traces), "-o", str(model), "--evals", "400", "--restarts", "2", "--workers", "1",
                 "--quiet"]) == 0
    for planner in ("prada", "symbolic-nn", "continuous-nn"):
        out = tmp_path / f"{planner}.json"
        assert plan("--sim", "tower", "--model", model, "--planner", planner, "--steps", 3, "--seed", 4,
                    "-o", out) == 0
        ep = json.loads(out.read_text())["episodes"][0]
        assert len(ep["steps"]) == 3
        preds = {s["name"] for s in json.loads((model / "symbols.json").read_text())["symbols"]}
        for s in ep["steps"]:
            assert s["state"] is not None and all(a.split()[0].strip("(") in preds for a in s["state"])
    assert "expected value" in capsys.readouterr().out


def test_an_episode_ends_at_a_dead_end():
    """IPPC-2006 tireworld: a flat tire where no spare lies leaves nothing to run; the episode stops."""
    from groundsym.episode import ppddl_model, ppddl_world, run_episode
    from groundsym.planner import make_planner
    from groundsym.ppddl.parser import load

    tw = ROOT / "tests" / "data" / "ippc" / "ippc2006" / "tireworld"
    domain, problem = load(tw / "domain.pddl", tw / "p01.pddl")
    env, task = ppddl_world(domain, problem)
    model = ppddl_model(domain, problem, task)
    ended_early = 0
    for seed in range(8):
        ep = run_episode(env, make_planner("random", model, {}, seed), 40, seed)
        final = frozenset(env.state)
        stuck = not [a for a in task.primitive_actions() if task.is_applicable(final, a)]
        assert ep.success or stuck or len(ep.steps) == 40
        ended_early += (not ep.success) and stuck and len(ep.steps) < 40
    assert ended_early >= 1
