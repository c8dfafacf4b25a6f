"""LRTDP on IPPC triangle-tireworld: the goal reached with probability 1 where FF-Replan gambles.

Independent truth: value iteration over every reachable state of p01 (written here from the
Bellman equation, not from the planner's code), breadth-first distances in the all-outcomes
determinisation (h_max must not exceed them), and the domain's known optimum (probability 1)."""

from __future__ import annotations

from pathlib import Path

import pytest

from groundsym.episode import ppddl_model, ppddl_world, run_episode
from groundsym.planner import make_planner
from groundsym.ppddl.parser import load

DATA = Path(__file__).parent / "data" / "ippc" / "ippc2008" / "triangle-tireworld"


def _setup(problem: str):
    domain, prob = load(DATA / f"{problem}.pddl")
    env, task = ppddl_world(domain, prob)
    return env, task, ppddl_model(domain, prob, task, need_rules=False)


def _reachable(task):
    seen, todo = {task.initial_state}, [task.initial_state]
    while todo:
        s = todo.pop()
        for a in task.applicable_actions(s):
            for x in task.outcomes(s, a):
                if x.state not in seen:
                    seen.add(x.state)
                    todo.append(x.state)
    return seen


def test_hmax_is_admissible_and_lrtdp_values_match_value_iteration():
    _, task, model = _setup("p01")
    planner = make_planner("lrtdp", model, {}, 0)
    states = _reachable(task)
    goal = model.goal
    dead = planner.dead
    # breadth-first distance to the goal in the all-outcomes determinisation (from each state)
    for s in states:
        frontier, dist, d = {s}, None, 0
        seen = {s}
        while frontier and dist is None:
            if any(goal.holds(x) for x in frontier):
                dist = d
                break
            nxt = {x.state for y in frontier for a in task.applicable_actions(y) for x in task.outcomes(y, a)}
            frontier = nxt - seen
            seen |= nxt
            d += 1
        h = planner.h(s)
        assert (h == float("inf")) == (dist is None)
        assert dist is None or h <= dist
    # value iteration on the same cost model: 1 per step, 0 at the goal, `dead` where stuck
    value = {s: 0.0 for s in states}
    for _ in range(2000):
        delta = 0.0
        for s in states:
            if goal.holds(s):
                continue
            acts = task.applicable_actions(s)
            new = min([dead] + [1 + sum(x.prob * value[x.state] for x in task.outcomes(s, a)) for a in acts])
            delta = max(delta, abs(new - value[s]))
            value[s] = new
        if delta < 1e-9:
            break
    planner.choose(_observation(task))
    s0 = task.initial_state
    assert s0 in planner.solved
    assert abs(planner.value[s0] - value[s0]) < 1e-2
    assert value[s0] < dead / 10          # the optimum never gets stuck (probability 1 of the goal)


def _observation(task):
    from groundsym.planner import Observation
    s0 = task.initial_state
    return Observation(tuple(sorted(task.objects)), tuple(task.applicable_primitives(s0)), s0)


def _successes(problem: str, episodes: int = 20) -> int:
    env, task, model = _setup(problem)
    wins = 0
    for seed in range(episodes):
        ep = run_episode(env, make_planner("lrtdp", model, {}, seed), 100, seed)
        wins += bool(ep.success)
    return wins


def test_lrtdp_reaches_the_goal_on_triangle_tireworld_p01():
    assert _successes("p01") >= 19


@pytest.mark.slow
@pytest.mark.parametrize("problem", ["p02", "p03"])
def test_lrtdp_reaches_the_goal_on_larger_triangle_tireworlds(problem):
    assert _successes(problem) >= 19
