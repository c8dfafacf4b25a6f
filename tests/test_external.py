"""The external FF-Replan bridge: determinise, plan with Fast Downward through unified-planning,
execute, replan only in a state no kept plan passes through."""

from __future__ import annotations

import pytest

from conftest import ROOT
from groundsym.episode import ppddl_model, ppddl_world, run_episode
from groundsym.errors import UserError
from groundsym.planner import make_planner
from groundsym.ppddl.parser import load

BW = ROOT / "domains" / "reference" / "blocksworld"


def world(problem="p01"):
    domain, prob = load(BW / "domain.ppddl", BW / f"{problem}.ppddl")
    env, task = ppddl_world(domain, prob)
    return env, task, ppddl_model(domain, prob, task, need_rules=False)


def test_ff_replan_reaches_the_goal_and_replans_only_on_surprise():
    env, task, model = world()
    for seed in range(2):
        planner = make_planner("external", model, {}, seed)
        ep = run_episode(env, planner, 30, seed)
        assert ep.success
        for k, (prev, step) in enumerate(zip(ep.steps, ep.steps[1:]), 1):
            # without a new call, a step follows the rest of a plan found before (plans are kept
            # by every state they pass through)
            if not step.info["replanned"]:
                assert step.info["planner_calls"] == prev.info["planner_calls"]
                assert any(step.info["plan"] == s.info["plan"][j:] for s in ep.steps[:k]
                           for j in range(len(s.info["plan"])))
        # every primitive run is one the PPDDL task can run in that state
        assert {s.action.split()[0].strip("(") for s in ep.steps} <= set(task.primitives)


def test_most_likely_determinisation_also_solves_the_four_blocks():
    env, _, model = world()
    planner = make_planner("external", model, {"determinize": "most-likely"}, 0)
    assert run_episode(env, planner, 30, 0).success


def test_external_engine_by_name_and_clear_refusals():
    env, _, model = world()
    planner = make_planner("external:fast-downward", model, {}, 0)
    assert planner.opts["engine"] == "fast-downward"
    with pytest.raises(UserError, match="not installed"):
        make_planner("external:no-such-planner", model, {}, 0)
    with pytest.raises(UserError, match="determinize"):
        make_planner("external", model, {"determinize": "sometimes"}, 0)
