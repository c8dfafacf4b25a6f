"""KinDER's ClutteredRetrieval2D as ``kinder-cluttered`` (sims/kinder_cluttered.py), checked against
KinDER itself: our ``inside`` is its ``is_inside``, our ``holding`` its suctioned objects, a pose our
path planner calls free is free by its collision check, and the primitives do what they say on
seeded episodes (docs/kinder.md, "ClutteredRetrieval2D"). Skips, saying why, without the kinder extra."""

from __future__ import annotations

from math import pi

import numpy as np
import pytest

pytest.importorskip("kinder", reason="KinDER is not installed (make kinder; docs/kinder.md)")

from groundsym.collect import collect_traces  # noqa: E402
from groundsym.errors import UserError  # noqa: E402
from groundsym.logic import Atom  # noqa: E402
from sims.kinder2d_skills import robot_pose  # noqa: E402
from sims.kinder_cluttered import (AWAY, REGION, TARGET, ClutteredSim, approach_and_grasp, blocking,  # noqa: E402
                                   holding, in_robot_frame, inside, obstacles, rect)
from sims.kinder_paths import MARGIN, Clearance, Footprint  # noqa: E402

PUT_IN = Atom("putInRegion", (TARGET, REGION))


def _kinder_state(sim):
    """KinDER's own object-centric state (and its objects by name) behind our sim."""
    state = sim.env.unwrapped._object_centric_env._current_state
    return state, {o.name: o for o in state}


def _put_in_region_solved(seeds: range) -> int:
    sim = ClutteredSim(obstructions=1)
    solved = 0
    for seed in seeds:
        sim.reset(seed)
        sim.step(PUT_IN)
        solved += sim.terminated                     # KinDER's is_inside(target_block, target_region)
        assert sim.terminated == sim.solved() == inside(sim.state, TARGET, REGION)
        assert sim.env_steps < 600
    return solved


def test_put_in_region_solves_unobstructed_o1_starts():
    assert _put_in_region_solved(range(3)) == 3


@pytest.mark.slow
def test_put_in_region_solves_9_of_10_o1_starts_by_kinders_own_termination():
    assert _put_in_region_solved(range(10)) >= 9


def test_inside_is_kinders_is_inside_on_moved_blocks():
    """The target block set at random poses around the region (KinDER's state, edited)."""
    from kinder.envs.kinematic2d.utils import is_inside

    sim = ClutteredSim(obstructions=1)
    sim.reset(3)
    state, objs = _kinder_state(sim)
    r = rect(sim.state, REGION)
    rng = np.random.default_rng(0)
    agree = {True: 0, False: 0}
    for _ in range(300):
        s = state.copy()
        theta = (r.theta + rng.choice([0, pi / 2]) + rng.normal(0, 0.15) + pi) % (2 * pi) - pi
        cx, cy = r.cx + rng.normal(0, 0.03), r.cy + rng.normal(0, 0.03)
        w = s.get(objs[TARGET], "width")                 # KinDER's x, y: the rotated bottom-left corner
        s.set(objs[TARGET], "x", cx - np.cos(theta) * w / 2 + np.sin(theta) * w / 2)
        s.set(objs[TARGET], "y", cy - np.sin(theta) * w / 2 - np.cos(theta) * w / 2)
        s.set(objs[TARGET], "theta", theta)
        ours = inside(sim.SPEC.read_state(sim.env, sim.env.observation_space.vectorize(s)), TARGET, REGION)
        theirs = is_inside(s, objs[TARGET], objs[REGION], {})
        assert ours == theirs
        agree[ours] += 1
    assert min(agree.values()) >= 50                    # both outcomes are exercised


def test_a_pose_called_free_is_free_by_kinders_collision_check():
    """Random robot poses on o10 scenes: each the lattice calls free (the base footprint with
    MARGIN) KinDER's state_2d_has_collision finds free; each with a disc inside an obstacle it
    finds in collision."""
    from kinder.envs.utils import state_2d_has_collision

    sim = ClutteredSim(obstructions=10)
    rng = np.random.default_rng(1)
    called_free = 0
    for seed in range(3):
        sim.reset(seed)
        state, objs = _kinder_state(sim)
        full = state.copy()
        full.data.update(sim.env.unwrapped._object_centric_env.initial_constant_state.data)
        clear = Clearance(obstacles(sim.state))
        for _ in range(150):
            x, y, h = rng.uniform(0.05, 2.45), rng.uniform(0.05, 2.45), rng.uniform(-pi, pi)
            s = full.copy()
            for f, v in (("x", x), ("y", y), ("theta", h)):
                s.set(objs["robot"], f, v)
            hit = state_2d_has_collision(s, {objs["robot"]}, set(s) - {objs["robot"]}, {})
            if clear.free(Footprint.base(), np.array([x]), np.array([y]), h)[0]:
                called_free += 1
                assert not hit, (seed, x, y, h)
            if clear.exact(x, y) < 0.1 - 0.01:           # the base disc reaches into an obstacle or wall
                assert hit, (seed, x, y, h)
    assert called_free >= 100


def test_holding_is_kinders_suction_and_the_held_footprint_covers_the_block():
    from kinder.envs.kinematic2d.utils import get_suctioned_objects

    sim = ClutteredSim(obstructions=1)
    for seed in range(4):
        sim.reset(seed)
        controller = approach_and_grasp(sim.state, TARGET, np.random.default_rng(seed))
        for _ in range(400):
            low = controller.act(sim.state)
            if low is None:
                break
            sim._env_step(low)
        assert holding(sim.state, TARGET)
        sim._env_step(np.zeros(5, np.float32) + np.array([0, 0, 0, 0, 1], np.float32))
        state, objs = _kinder_state(sim)
        sucked = {o.name for o, _ in get_suctioned_objects(state, objs["robot"])}
        assert sucked == {TARGET}
        # every corner of the held block lies in a disc of the footprint that covers it
        fp = Footprint.base().holding(in_robot_frame(sim.state, TARGET))
        corners = rect(sim.state, TARGET).corners()
        discs = fp.placed(*robot_pose(sim.state)[:3])
        assert all((np.hypot(*(discs - c).T) <= fp.radii + 1e-9).any() for c in corners)


def _put_away_blocking(seeds: range, per_seed: int) -> tuple[int, int]:
    """putAway of the blocking obstruction nearest the robot, ``per_seed`` times per start:
    (tried, moved); every moved one ends away from the target block and region, not blocking."""
    sim = ClutteredSim(obstructions=10)
    moved = tried = 0
    for seed in seeds:
        sim.reset(seed)
        for _ in range(per_seed):
            rx, ry = robot_pose(sim.state)[:2]
            blockers = sorted((o for o in sim.state.of_type("rectangle") if blocking(sim.state, o)),
                              key=lambda o: np.hypot(rect(sim.state, o).cx - rx, rect(sim.state, o).cy - ry))
            if not blockers:
                break
            before, steps = rect(sim.state, blockers[0]), sim.env_steps
            sim.step(Atom("putAway", (blockers[0],)))
            after = rect(sim.state, blockers[0])
            tried += 1
            assert sim.env_steps - steps < 600 and sim.events["step_limit"] == 0
            if after != before:
                moved += 1
                t, r = rect(sim.state, TARGET), rect(sim.state, REGION)
                assert np.hypot(after.cx - t.cx, after.cy - t.cy) >= AWAY - MARGIN
                assert np.hypot(after.cx - r.cx, after.cy - r.cy) >= AWAY - MARGIN
                assert not blocking(sim.state, blockers[0])
            assert sim.state.get("robot", "vacuum") == 0.0
    return tried, moved


def test_put_away_takes_a_blocking_obstruction_away():
    assert _put_away_blocking(range(1), 2) == (2, 2)


@pytest.mark.slow
def test_put_away_takes_blocking_obstructions_away_in_bounded_steps():
    tried, moved = _put_away_blocking(range(4), 2)
    assert tried >= 6 and moved >= tried - 2


def test_same_seed_same_trace():
    a = collect_traces(ClutteredSim(obstructions=1), 1, 2, 5, progress=False)
    b = collect_traces(ClutteredSim(obstructions=1), 1, 2, 5, progress=False)
    assert [str(x) for x in a.traces[0].actions] == [str(x) for x in b.traces[0].actions]
    assert all(np.array_equal(s.features, t.features) for s, t in zip(a.traces[0].scenes, b.traces[0].scenes))


def test_unknown_variant_is_one_line():
    with pytest.raises(UserError, match="obstructions=3.*1, 10, 25"):
        ClutteredSim(obstructions=3)


def test_rect_gap_is_shapelys_distance_for_rectangles_apart():
    """``blocking``'s gap between two rectangles against shapely's polygon distance (0 when they overlap)."""
    from shapely import Polygon

    from sims.kinder_paths import Rect

    rng = np.random.default_rng(2)
    checked = 0
    for _ in range(300):
        a, b = (Rect(*rng.uniform(0, 1, 2), rng.uniform(-pi, pi), *rng.uniform(0.05, 0.2, 2)) for _ in range(2))
        pa, pb = Polygon(a.corners()), Polygon(b.corners())
        assert a.gap(b) == pytest.approx(pa.distance(pb), abs=1e-9)
        checked += pa.intersects(pb)
    assert 10 <= checked <= 290                          # overlapping and apart both exercised
