"""Goal-literal babbling (groundsym/glib.py, ``collect --explore glib``): the goal space counted by
hand, novelty against hand-made transitions, the joint-sampling check against a conjunction no
state can hold (which PRADA's factored frontier still scores), a babbled goal pursued along the
hand-computed shortest plan, and the whole exploration: same seed same file, resumed to it."""

from __future__ import annotations

import shutil
from types import SimpleNamespace

import numpy as np
import pytest

from groundsym.cli import main
from groundsym.explore import ExploreConfig, explore_traces
from groundsym.glib import (GlibModel, GlibOptions, candidate_goals, goal_counts, holds, next_action,
                            plan_reach, planned)
from groundsym.logic import Atom, Literal
from groundsym.planner import Goal, Observation, make_planner
from groundsym.rules.model import Outcome, Rule, RuleSet
from groundsym.rules.sample import sample_successor
from groundsym.traces import read_traces
from sims.tower import TowerSim


def A(p: str, *args: str) -> Atom:
    return Atom(p, tuple(args))


def test_goal_space_counted_by_hand():
    # one binary predicate, extra variables ?e0 ?e1, up to renaming them: singles on(a,e), on(e,a),
    # on(e0,e1); pairs through ?a0 only: a cycle, two below, two above, a chain (4); one through
    # ?a0 and one between the extras (4); both between the extras (1)
    assert len(candidate_goals({"grab": 1}, {"on": 2}, size=1, extra=2)) == 3
    assert len(candidate_goals({"grab": 1}, {"on": 2}, size=2, extra=1)) == 3
    assert len(candidate_goals({"grab": 1}, {"on": 2}, size=2, extra=2)) == 12
    grab = A("grab", "?a0")
    assert candidate_goals({"grab": 1}, {"p": 1}, size=2, extra=1) == sorted(
        [(grab, (A("p", "?a0"),)), (grab, (A("p", "?e0"),)), (grab, (A("p", "?a0"), A("p", "?e0")))])


def test_novelty_counts_the_transitions_that_ran_each_goal():
    goals = candidate_goals({"grab": 1}, {"on": 2}, size=2, extra=2)
    under_two = (A("grab", "?a0"), (A("on", "?e0", "?a0"), A("on", "?e1", "?e0")))   # grab the base of a 3-tower
    assert under_two in goals
    tower = frozenset({A("on", "b", "a"), A("on", "c", "b")})
    assert holds(under_two, tower, A("grab", "a"), "abc") and not holds(under_two, tower, A("grab", "b"), "abc")
    counts = goal_counts(goals, iter([(tower, A("grab", "a"), "abc"), (tower, A("grab", "c"), "abc")]))
    # grab(a): on(b,a) [one above], on(b,a)+on(c,b) [base of three];
    # grab(c): on(c,b) [one below], on(c,b)+on(b,a) [top of three]; both: a stack apart from it
    top_of_three = (A("grab", "?a0"), (A("on", "?a0", "?e0"), A("on", "?e0", "?e1")))
    assert counts == {(A("grab", "?a0"), (A("on", "?e0", "?a0"),)): 1, under_two: 1,
                      (A("grab", "?a0"), (A("on", "?a0", "?e0"),)): 1, top_of_three: 1,
                      (A("grab", "?a0"), (A("on", "?e0", "?e1"),)): 2}


def pick_put() -> RuleSet:
    """pick(x) holds x; put(x) sets what is held onto x."""
    pick = Rule(A("pick", "?x"), (), (Outcome((Literal(A("holding", "?x")),)),), (1.0,), 0.0)
    put = Rule(A("put", "?x"), (Literal(A("holding", "?y")),),
               (Outcome((Literal(A("on", "?y", "?x")), Literal(A("holding", "?y"), False))),), (1.0,), 0.0)
    return RuleSet((pick, put))


def model_of(rules: RuleSet, counts: dict) -> GlibModel:
    preds = {"holding": 1, "on": 2}
    goals = candidate_goals({"pick": 1, "put": 1}, preds, size=1, extra=1)
    return GlibModel(SimpleNamespace(predicates=preds), rules, goals, counts, {"pick": 1, "put": 1})


def toggle() -> RuleSet:
    """push(x) turns a down x up, pull(x) an up x down, each half of the time: never both up and down."""
    push = Rule(A("push", "?x"), (Literal(A("down", "?x")),),
                (Outcome((Literal(A("up", "?x")), Literal(A("down", "?x"), False))), Outcome()), (0.5, 0.5), 0.0)
    pull = Rule(A("pull", "?x"), (Literal(A("up", "?x")),),
                (Outcome((Literal(A("down", "?x")), Literal(A("up", "?x"), False))), Outcome()), (0.5, 0.5), 0.0)
    return RuleSet((push, pull))


def test_sampling_rejects_a_conjunction_the_factored_frontier_scores():
    rules, start = toggle(), frozenset({A("down", "a")})
    both = Goal((Literal(A("up", "a")), Literal(A("down", "a"))))
    symbols = SimpleNamespace(predicates={"up": 1, "down": 1})
    model = GlibModel(symbols, rules, [], {}, {"push": 1, "pull": 1})
    planner = make_planner("prada", model.planning_model(both), {"samples": "300"}, 0)
    decision = planner.choose(Observation(("a",), (A("push", "a"), A("pull", "a")), start))
    assert planned(decision, 1e-3)          # the product of marginals is positive (1/2 x 1/2 after a push)...
    rng = np.random.default_rng(0)
    for plan in ([A("push", "a")], [A("push", "a"), A("pull", "a"), A("push", "a")]):
        assert plan_reach(rules, start, "a", plan, both, rng, 200) == 0.0      # ...jointly never
    up = Goal((Literal(A("up", "a")),))
    assert abs(plan_reach(rules, start, "a", [A("push", "a")], up, rng, 400) - 0.5) < 0.08


def test_a_babbled_goal_is_reached_along_the_shortest_plan_then_its_action_runs():
    rules = pick_put()
    model = model_of(rules, {})
    lift_stacked = (A("pick", "?a0"), (A("on", "?a0", "?e0"),))        # never tried: pick what stands on another
    model.counts.update({g: 5 for g in model.goals if g != lift_stacked})
    rng = np.random.default_rng(3)
    state, objects, run, pursuit = frozenset(), ("a", "b"), [], None
    actions = (A("pick", "a"), A("pick", "b"), A("put", "a"), A("put", "b"))
    for t in range(3):
        obs = Observation(objects, actions, state, None, t, 3 - t)
        action, pursuit = next_action(model, GlibOptions(), pursuit, obs, rng)
        run.append(action)
        state = sample_successor(rules, state, action, rng, objects)
    x, y = run[0].args[0], run[1].args[0]
    assert run == [A("pick", x), A("put", y), A("pick", x)] and x != y       # pick x, put it on y, pick x
    assert model.stats["planned"] >= 1 and model.stats["reached"] == 1 and model.stats["fallback"] == 0


CELL = {"cubes": "3", "big": "1", "noise": "0"}
CFG = ExploreConfig(rounds=2, round_traces=2, length=4, evals=200, restarts=1, mode="glib")


def same_traces(a, b) -> bool:
    return len(a.traces) == len(b.traces) and all(
        x.actions == y.actions and all(np.array_equal(s.features, t.features) for s, t in zip(x.scenes, y.scenes))
        for x, y in zip(a.traces, b.traces))


def test_glib_same_seed_same_file_and_an_interrupted_run_resumes_to_it(tmp_path):
    with TowerSim(**CELL) as sim:
        first = explore_traces(sim, CFG, 4, tmp_path / "w1", progress=False)
        (tmp_path / "w1" / "round-1.json").unlink()
        shutil.rmtree(tmp_path / "w1" / "round-0")
        resumed = explore_traces(sim, CFG, 4, tmp_path / "w1", progress=False)
        again = explore_traces(sim, CFG, 4, tmp_path / "w2", progress=False)
    assert same_traces(first, resumed) and same_traces(first, again)
    assert first.meta["explore"]["mode"] == "glib" and first.meta["explore"]["glib"]["planner"] == "prada"


def test_cli_checks_the_exploration_planner_before_work(tmp_path, capsys):
    base = ["collect", "--sim", "tower", "--sim-opt", "cubes=3", "--traces", "4", "--length", "2", "--quiet",
            "-o", str(tmp_path / "t.json"), "--rounds", "2", "--work", str(tmp_path / "w")]
    for extra, msg in ((["--explore", "glib", "--explore-planner", "nope"], "--explore-planner nope: unknown planner"),
                       (["--explore", "glib", "--explore-planner-opt", "samples=0"], "--explore-planner-opt samples=0"),
                       (["--explore", "glib", "--explore-planner", "symbolic-nn"], "needs symbolic_traces"),
                       (["--explore", "counts", "--explore-planner", "prada"], "only with --explore glib")):
        assert main(base + extra) == 2
        err = capsys.readouterr().err
        assert msg in err and "Traceback" not in err
    assert not (tmp_path / "t.json").exists() and not (tmp_path / "w").exists()


@pytest.mark.slow
def test_cli_glib_gives_the_library_run_with_the_same_options(tmp_path):
    out, work = tmp_path / "t.json", tmp_path / "w"
    argv = ["collect", "--sim", "tower", "--sim-opt", "cubes=3", "--traces", "4", "--length", "4", "--seed", "2",
            "--quiet", "-o", str(out), "--explore", "glib", "--rounds", "2", "--work", str(work),
            "--explore-evals", "400", "--explore-planner-opt", "samples=100"]
    assert main(argv) == 0
    ds = read_traces(out)
    assert ds.meta["explore"]["glib"]["planner_opts"] == [["samples", "100"]]
    assert set(read_traces(work / "round-1.json").meta["glib"]) == {"here", "babbled", "planned", "reached", "fallback"}
    cfg = ExploreConfig(2, 2, 4, evals=400, mode="glib", glib=GlibOptions(planner_opts=(("samples", "100"),)))
    with TowerSim(cubes=3) as sim:
        assert same_traces(ds, explore_traces(sim, cfg, 2, tmp_path / "lib", progress=False))


def test_a_random_share_of_one_never_babbles_and_draws_uniformly():
    model = model_of(pick_put(), {})
    rng = np.random.default_rng(1)
    actions = (A("pick", "a"), A("pick", "b"), A("put", "a"), A("put", "b"))
    obs = Observation(("a", "b"), actions, frozenset(), None, 0, 1)
    picks = [next_action(model, GlibOptions(random_share=1.0), None, obs, rng)[0] for _ in range(400)]
    assert model.stats["babbled"] == 0 and model.stats["random"] == 400
    assert all(70 < picks.count(a) < 130 for a in actions)
