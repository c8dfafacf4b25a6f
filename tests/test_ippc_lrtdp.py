"""LRTDP on IPPC triangle-tireworld: the goal reached with probability 1 where FF-Replan gambles.

Independent truth: value iteration over every reachable state of p01 (written here from the
Bellman equation, not from the planner's code), breadth-first distances in the all-outcomes
determinisation (h_max must not exceed them), and the domain's known optimum (probability 1)."""

from __future__ import annotations

from pathlib import Path

import pytest

from groundsym.episode import ppddl_model, ppddl_world, run_episode
from groundsym.logic import Atom
from groundsym.planner import make_planner
from groundsym.ppddl.parser import load

DATA = Path(__file__).parent / "data" / "ippc" / "ippc2008" / "triangle-tireworld"


def _setup(problem: str):
    domain, prob = load(DATA / f"{problem}.pddl")
    env, task = ppddl_world(domain, prob)
    return env, task, ppddl_model(domain, prob, task, need_rules=False)


def reachable_states(task):
    """Every state the task reaches from its initial state (depth first; tests of other modules use it too)."""
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
    planner = make_planner("lrtdp", model, {"share": "0"}, 0)
    states = reachable_states(task)
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
    assert planner.is_solved(s0)
    assert abs(planner.value_of(s0) - value[s0]) < 1e-2
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


# ---------------------------------------------------------------------------- h_add and sharing
BLOCKS = Path(__file__).parent / "data" / "ippc" / "ippc2008" / "blocksworld" / "p01.pddl"


def _reference_h(task, goal_atoms, state, combine):
    """h_max / h_add written from their definition: relaxed ground actions (positive precondition
    atoms, the adds of every outcome), atom costs relaxed until nothing changes."""
    import math
    acts = []
    for a in task.domain.actions:
        for args in task.groundings(a.name):
            ga = task.ground(Atom(a.name, args))
            if ga is not None:
                acts.append((ga.pos, {x for _, adds, _, _ in ga.deltas(task, frozenset()) for x in adds}))
    cost = {x: 0.0 for x in state}
    changed = True
    while changed:
        changed = False
        for pre, adds in acts:
            if all(x in cost for x in pre):
                c = combine([cost[x] for x in pre] or [0.0]) + 1
                for x in adds:
                    if c < cost.get(x, math.inf):
                        cost[x] = c
                        changed = True
    parts = [cost.get(x, math.inf) for x in goal_atoms]
    return combine(parts or [0.0])


def test_hadd_and_hmax_equal_their_definition_on_a_random_walk_of_blocksworld():
    import numpy as np
    from planners.relaxation import Relaxation, relaxed_goal_atoms
    domain, prob = load(BLOCKS)
    env, task = ppddl_world(domain, prob)
    model = ppddl_model(domain, prob, task, need_rules=False)
    goal = relaxed_goal_atoms(model.goal.literals)
    hmax, hadd = Relaxation(task, goal, "hmax"), Relaxation(task, goal, "hadd")
    rng = np.random.default_rng(0)
    s, walk = task.initial_state, []
    for _ in range(30):
        walk.append(s)
        acts = task.applicable_actions(s)
        outs = task.outcomes(s, acts[int(rng.integers(len(acts)))])
        s = outs[int(rng.integers(len(outs)))].state
    got_max, got_add = hmax.batch(walk), hadd.batch(walk)
    for s, m, a in zip(walk, got_max, got_add):
        assert m == _reference_h(task, goal, s, max)
        assert a == _reference_h(task, goal, s, sum)
        assert m <= a
    assert len(set(got_add)) > 3          # the walk is not all one value


def test_lrtdp_with_hadd_stacks_the_2008_blocksworld_p01():
    domain, prob = load(BLOCKS)
    env, task = ppddl_world(domain, prob)
    model = ppddl_model(domain, prob, task, need_rules=False)
    opts = {"heuristic": "hadd", "trials": "20", "seconds": "1000", "share": "0"}
    wins = sum(bool(run_episode(env, make_planner("lrtdp", model, opts, seed), 50, seed).success) for seed in range(2))
    assert wins == 2


def test_search_tables_are_shared_by_problem_and_options_only():
    domain, prob = load(BLOCKS)
    _, task = ppddl_world(domain, prob)
    model = ppddl_model(domain, prob, task, need_rules=False)
    _, _, tyre = _setup("p01")
    a = make_planner("lrtdp", model, {"heuristic": "hadd", "trials": "3"}, 0)
    b = make_planner("lrtdp", model, {"heuristic": "hadd"}, 1)
    c = make_planner("lrtdp", model, {"heuristic": "hmax"}, 0)
    d = make_planner("lrtdp", tyre, {"heuristic": "hadd"}, 0)
    e = make_planner("lrtdp", model, {"heuristic": "hadd", "share": "0"}, 0)
    assert a.search is b.search
    assert len({id(x.search) for x in (a, c, d, e)}) == 4
    a.choose(_observation(task))
    assert b.value_of(task.initial_state) == a.value_of(task.initial_state) > 0
