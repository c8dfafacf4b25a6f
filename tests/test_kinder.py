"""KinDER's kinematic-2D tasks as groundsym sims (sims/kinder2d.py), checked against KinDER itself:
our relations computed from its state agree with its own ``is_on`` and its own termination, and our
skills solve its tasks in hand-written plans. Skips, saying why, when the kinder extra is absent
(``make kinder``, docs/kinder.md)."""

from __future__ import annotations

import pytest

pytest.importorskip("kinder", reason="KinDER is not installed (make kinder; docs/kinder.md)")

from groundsym.collect import collect_traces  # noqa: E402
from groundsym.logic import Atom  # noqa: E402
from sims.kinder2d import ObstructionSim, StickButtonSim, is_on  # noqa: E402


def _kinder_is_on(sim) -> bool:
    """KinDER's own is_on(target_block, target_surface) on the environment's current state."""
    from kinder.envs.kinematic2d.utils import is_on as kinder_is_on

    inner = sim.env.unwrapped._object_centric_env
    state = inner._current_state
    objs = {o.name: o for o in state}
    return kinder_is_on(state, objs["target_block"], objs["target_surface"], {})


def test_obstruction_plan_solves_o1_o3_and_our_on_is_kinders():
    checked = 0
    for n in (1, 3):
        sim = ObstructionSim(obstructions=n)
        for seed in range(3):
            scene = sim.reset(seed)
            plan = [Atom("putOnTable", (a.args[0],)) for a in sorted(scene.truth) if a.predicate == "blocking"]
            assert plan or n == 3                          # o1's obstruction starts on the surface
            for action in plan + [Atom("putOnTarget", ("target_block", "target_surface"))]:
                scene = sim.step(action)
                assert is_on(sim.state, "target_block", "target_surface") == _kinder_is_on(sim)
                checked += 1
            assert sim.terminated and sim.solved()         # KinDER's termination is its success
            assert Atom("on", ("target_block", "target_surface")) in scene.truth and scene.reward == 1.0
            assert not any(a.predicate == "blocking" for a in scene.truth)
            assert sim.env_steps < 3000
    assert checked >= 8


def test_a_chained_primitive_is_its_two_skills_run_one_after_the_other():
    """putOnTable(X) against pick_block and then place_on_table driven by hand, on the same
    generator stream: the same environment steps and the same end state."""
    import numpy as np

    from sims.kinder2d import pick_block, place_on_table

    sim = ObstructionSim(obstructions=1)
    sim.reset(2)
    sim.step(Atom("putOnTable", ("obstruction0",)))
    chained_steps, chained = sim.env_steps, sim.scene().features

    sim.reset(2)
    rng = np.random.default_rng([2, 1])                  # the stream ObjectCentricSim.reset seeds
    for make in (pick_block, place_on_table):
        script = make(sim.state, ("obstruction0",), rng)
        while (low := script.act(sim.state)) is not None:
            sim._env_step(low)
    assert sim.env_steps == chained_steps > 40
    assert np.array_equal(sim.scene().features, chained)
    assert not any(a.predicate == "blocking" for a in sim.scene().truth)


def test_stickbutton_pressed_is_kinders_termination():
    sim = StickButtonSim(buttons=1)
    for seed in range(3):
        scene = sim.reset(seed)
        on_table = Atom("onTable", ("button0",)) in scene.truth
        plan = [Atom("pick", ("stick",)), Atom("pressWithStick", ("button0",))] if on_table \
            else [Atom("press", ("button0",))]
        for action in plan:
            scene = sim.step(action)
        assert sim.terminated                                  # KinDER's own reward says all are pressed
        assert Atom("pressed", ("button0",)) in scene.truth and scene.reward == 1.0
        if on_table:
            assert Atom("holding", ("stick",)) in scene.truth


def test_collect_is_reproducible_and_counts_env_steps():
    a = collect_traces(StickButtonSim(buttons=3), 2, 3, seed=4, progress=False)
    b = collect_traces(StickButtonSim(buttons=3), 2, 3, seed=4, progress=False)
    assert [t.actions for t in a.traces] == [t.actions for t in b.traces]
    assert all((x.features == y.features).all() for ta, tb in zip(a.traces, b.traces)
               for x, y in zip(ta.scenes, tb.scenes))
    assert a.meta["events"]["primitives"] == 6 and a.meta["events"]["env_steps"] > 0
    assert a.feature_names == ("x", "y", "w", "h", "green", "tip")
    o = ObstructionSim(obstructions=1)
    assert o.feature_names == ("x", "y", "w", "h", "green")     # no tip: docs/kinder.md
    o.close()


def _clear_share(sim) -> float:
    """Share of obstructions whose horizontal extent misses the surface's, from KinDER's raw state
    (rectangles: x, y their lower-left corner, rotated by theta about it)."""
    import math

    inner = sim.env.unwrapped._object_centric_env
    state = inner._current_state
    objs = {o.name: o for o in state}

    def extent(o):
        x, w, t = state.get(o, "x"), state.get(o, "width"), state.get(o, "theta")
        h = state.get(o, "height")
        xs = [x + cx * math.cos(t) - cy * math.sin(t) for cx, cy in ((0, 0), (w, 0), (0, h), (w, h))]
        return min(xs), max(xs)
    s0, s1 = extent(objs["target_surface"])
    obstructions = [o for name, o in objs.items() if o.type.name == "rectangle"]
    clear = [o for o in obstructions if extent(o)[1] <= s0 or extent(o)[0] >= s1]
    return len(clear) / len(obstructions)


def test_graded_o3_reward_is_half_the_clear_share_until_solved():
    """reward=graded (docs/kinder.md): 1 when solved, else half the share of obstructions clear of
    the surface; the hand plan raises it by 1/6 per obstruction put on the table. The default
    stays KinDER's 0/1."""
    graded, kinder = ObstructionSim(obstructions=3, reward="graded"), ObstructionSim(obstructions=3)
    for seed in range(2):
        scene, plain = graded.reset(seed), kinder.reset(seed)
        assert scene.reward == pytest.approx(0.5 * _clear_share(graded)) and plain.reward == 0.0
        plan = [Atom("putOnTable", (a.args[0],)) for a in sorted(scene.truth) if a.predicate == "blocking"]
        rewards = [scene.reward]
        for action in plan + [Atom("putOnTarget", ("target_block", "target_surface"))]:
            scene, plain = graded.step(action), kinder.step(action)
            rewards.append(scene.reward)
            assert scene.reward == (1.0 if graded.solved() else pytest.approx(0.5 * _clear_share(graded)))
            assert plain.reward == (1.0 if kinder.solved() else 0.0)
        assert rewards[-1] == 1.0 and rewards[-2] == pytest.approx(0.5)
        assert all(b == pytest.approx(a + 1 / 6) for a, b in zip(rewards[:-2], rewards[1:-1]))
    graded.close()
    kinder.close()
