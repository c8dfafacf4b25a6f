"""Gymnasium environments of the sims and of PPDDL problems: the API checker, exact seeding, and
observations, rewards and episode ends against the simulators and hand-worked PPDDL cases."""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from groundsym.gym import PPDDLGymEnv  # importing the package registers the environments
from groundsym.errors import UserError
from groundsym.logic import Atom
from groundsym.registry import make_sim
from sims.bowling import upright_mask

from conftest import ROOT

BW = ROOT / "domains" / "reference" / "blocksworld"
TIRE = ROOT / "tests" / "data" / "ippc" / "ippc2006" / "tireworld"
SMALL = {"render_width": 96, "render_height": 72}


def A(pred: str, *args: str) -> Atom:
    return Atom(pred, args)


def checked(env: gymnasium.Env) -> list[str]:
    """Run Gymnasium's checker; return the warnings other than those about unbounded Boxes
    (positions in metres have no natural bound, as in Gymnasium's own MuJoCo environments)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env)
    return [str(w.message) for w in caught if "infinity" not in str(w.message)]


def rollout(env: gymnasium.Env, seed: int, actions: list[int]) -> tuple[list, list[float], list[tuple[bool, bool]]]:
    obs, info = env.reset(seed=seed)
    observations, rewards, ends = [obs], [], []
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        observations.append(obs)
        rewards.append(r)
        ends.append((term, trunc))
        if term or trunc:
            break
    return observations, rewards, ends


def same(a, b) -> bool:
    return all(gymnasium.utils.env_checker.data_equivalence(x, y, exact=True) for x, y in zip(a, b, strict=True))


# ----------------------------------------------------------------------------- the sims

@pytest.fixture(scope="module")
def tower():
    env = gymnasium.make("groundsym/Tower-v0", cubes=3, big=1, render_mode="rgb_array", **SMALL)
    yield env
    env.close()


@pytest.fixture(scope="module")
def bowling():
    env = gymnasium.make("groundsym/Bowling-v0", pins=4, render_mode="rgb_array", **SMALL)
    yield env
    env.close()


@pytest.mark.parametrize("name", [pytest.param("tower", marks=pytest.mark.slow), "bowling"])
def test_sim_envs_pass_the_gymnasium_checker(name, request):
    """Both are the same class; the tower's check is slow (some 15 pybullet rebuilds of the arm)."""
    env = request.getfixturevalue(name)
    assert checked(env.unwrapped) == []
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (72, 96, 3) and frame.dtype == np.uint8 and frame.std() > 0


def test_tower_spaces_and_observations_are_the_simulators(tower):
    env = tower.unwrapped
    assert env.objects == ("o1", "o2", "o3") and env.feature_names == ("x", "y", "z", "size")
    assert env.action_atoms == tuple(A(p, o) for p in ("closeHandAround", "openHandOver") for o in env.objects)
    assert env.steps == 10 and env.gamma == 0.8
    actions = [0, 4, 1]            # grasp o1, release it over o2, grasp o2
    observations, rewards, ends = rollout(tower, 5, actions)
    sim = make_sim("tower", {"cubes": 3, "big": 1})     # the same sim driven directly
    try:
        scenes = [sim.reset(5)] + [sim.step(env.action_atoms[a]) for a in actions]
    finally:
        sim.close()
    for obs, scene in zip(observations, scenes, strict=True):
        assert set(obs) == {"o1", "o2", "o3"}
        np.testing.assert_array_equal(np.stack([obs[o] for o in env.objects]), scene.features)
    assert rewards == [s.reward for s in scenes[1:]]   # the tower's reward: the scene's own
    assert ends == [(False, False)] * len(actions)


def test_steps_sets_the_episode_length():
    env = gymnasium.make("groundsym/Bowling-v0", pins=1, noise=0.0, steps=3)
    try:
        _, _, ends = rollout(env, 0, [0, 1, 0])
        assert ends == [(False, False), (False, False), (True, False)]
        with pytest.raises(RuntimeError, match="reset"):
            env.step(0)
    finally:
        env.close()


def test_bowling_rewards_add_up_to_the_pins_down(bowling):
    env = bowling.unwrapped
    assert env.steps == 2 and env.final_score
    for seed in range(3):
        observations, rewards, ends = rollout(bowling, seed, [0, 5])
        assert ends == [(False, False), (True, False)]
        final = np.stack([observations[-1][o] for o in env.objects])
        after_first = np.stack([observations[1][o] for o in env.objects])
        # the score of a game is the pins down after both throws (read from the pins' poses)
        assert sum(rewards) == np.count_nonzero(~upright_mask(final))
        assert rewards[0] == np.count_nonzero(~upright_mask(after_first))


@pytest.mark.parametrize("name,actions", [("tower", [1, 3]), ("bowling", [2, 7])])
def test_sim_seeds_reproduce_episodes_exactly(name, actions, request):
    env = request.getfixturevalue(name)
    first = rollout(env, 11, actions)
    other = rollout(env, 12, actions)                    # another episode in between ...
    again = rollout(env, 11, actions)
    assert same(first[0], again[0]) and first[1:] == again[1:]
    assert not same(first[0][:1], other[0][:1])          # ... from another start


def test_unseeded_resets_follow_the_last_seed(bowling):
    bowling.reset(seed=3)
    a = [bowling.reset()[0] for _ in range(2)]
    bowling.reset(seed=3)
    b = [bowling.reset()[0] for _ in range(2)]
    assert same(a, b) and not same(a[:1], a[1:])


def test_sim_options_and_bad_input():
    env = gymnasium.make("groundsym.gym:groundsym/Sim-v0", sim="bowling", spots="1,2", shuffle_ids=False)
    try:
        assert env.unwrapped.objects == ("p1", "p2") and env.action_space.n == 4
    finally:
        env.close()
    with pytest.raises(UserError, match="--sim-opt colour: unknown option for sim 'tower'"):
        gymnasium.make("groundsym/Tower-v0", colour=3)
    with pytest.raises(UserError, match="--sim no-such: unknown simulation"):
        gymnasium.make("groundsym/Sim-v0", sim="no-such")
    with pytest.raises(UserError, match="steps=0: expected a whole number of at least 1"):
        gymnasium.make("groundsym/Bowling-v0", pins=1, steps=0)
    with pytest.raises(UserError, match="sim=: name a simulation"):
        gymnasium.make("groundsym/Sim-v0")
    with pytest.raises(UserError, match="render_width=0: expected a whole number of pixels"):
        gymnasium.make("groundsym/Bowling-v0", pins=1, render_mode="rgb_array", render_width=0)


# ----------------------------------------------------------------------------- PPDDL

@pytest.fixture()
def blocks():
    env = gymnasium.make("groundsym/PPDDL-v0", domain=str(BW / "domain.ppddl"), problem=str(BW / "p01.ppddl"),
                         render_mode="rgb_array", **SMALL)
    yield env
    env.close()


def index_of(env, action: Atom) -> int:
    return env.unwrapped.action_atoms.index(action)


def test_ppddl_env_passes_the_gymnasium_checker(blocks):
    assert checked(blocks.unwrapped) == []
    blocks.reset(seed=0)
    assert blocks.render().shape == (72, 96, 3)


def test_ppddl_observation_is_every_typed_ground_atom_in_sorted_order(blocks):
    env = blocks.unwrapped
    objs = "abcd"
    expect = ([A("clear", o) for o in objs] + [A("handempty")] + [A("holding", o) for o in objs]
              + [A("on", x, y) for x in objs for y in objs] + [A("ontable", o) for o in objs])
    assert env.atoms == tuple(expect) and blocks.observation_space == gymnasium.spaces.MultiBinary(29)
    obs, info = blocks.reset(seed=0)
    start = {A("handempty")} | {A(p, o) for p in ("clear", "ontable") for o in objs}
    assert env.decode(obs) == start
    assert list(obs) == [int(a in start) for a in expect]
    # only the four pick-ups are applicable with every block on the table
    assert {env.action_atoms[k] for k in np.flatnonzero(info["action_mask"])} == {A("pickup", o) for o in objs}
    assert info["action_mask"].dtype == np.int8 and blocks.action_space.n == 4 + 4 + 12 + 12


def test_ppddl_outcome_frequencies_follow_the_domain(blocks):
    """pickup succeeds with probability 4/5 and otherwise changes nothing (the domain file)."""
    pick = index_of(blocks, A("pickup", "a"))
    held = 0
    for seed in range(300):
        obs0, _ = blocks.reset(seed=seed)
        obs, reward, term, trunc, info = blocks.step(pick)
        state = blocks.unwrapped.decode(obs)
        assert reward == 0.0 and not term and not trunc
        if A("holding", "a") in state:
            held += 1
            assert {blocks.unwrapped.action_atoms[k] for k in np.flatnonzero(info["action_mask"])} == \
                {A("putdown", "a")} | {A("stack", "a", o) for o in "bcd"}
        else:
            np.testing.assert_array_equal(obs, obs0)
    assert abs(held / 300 - 0.8) < 0.07          # binomial sd 0.023


def test_ppddl_goal_reward_and_termination(blocks):
    """Drive a stacking plan to the goal (on a b) (on b c); retry whatever failed."""
    env = blocks.unwrapped
    obs, info = blocks.reset(seed=4)
    rewards, goal = [], {A("on", "a", "b"), A("on", "b", "c")}
    for _ in range(60):
        state = env.decode(obs)
        if A("holding", "b") in state:
            act = A("stack", "b", "c")
        elif A("holding", "a") in state:
            act = A("stack", "a", "b") if A("on", "b", "c") in state else A("putdown", "a")
        elif A("on", "b", "c") not in state:
            act = A("unstack", "a", "b") if A("on", "a", "b") in state else (
                A("pickup", "b") if A("ontable", "b") in state and A("clear", "b") in state else
                A("unstack", "b", next(y for y in "acd" if A("on", "b", y) in state)))
        else:
            act = A("pickup", "a") if A("ontable", "a") in state else A("unstack", "a", next(
                y for y in "bcd" if A("on", "a", y) in state))
        obs, reward, term, trunc, info = blocks.step(index_of(blocks, act))
        rewards.append(reward)
        if term:
            break
    assert term and not trunc and goal <= env.decode(obs) and info["goal_reached"]
    assert rewards[-1] == 1.0 and set(rewards[:-1]) <= {0.0}


def test_ppddl_inapplicable_actions_change_nothing_and_the_horizon_truncates():
    env = gymnasium.make("groundsym/PPDDL-v0", domain=str(BW / "domain.ppddl"), problem=str(BW / "p01.ppddl"),
                         steps=3)
    stack = index_of(env, A("stack", "a", "b"))
    obs0, info = env.reset(seed=0)
    assert info["action_mask"][stack] == 0
    _, _, ends = rollout(env, 0, [stack] * 3)
    observations = rollout(env, 0, [stack] * 3)[0]
    assert all(np.array_equal(o, obs0) for o in observations)
    assert ends == [(False, False), (False, False), (False, True)]


def test_ppddl_seeds_reproduce_episodes_exactly():
    env = gymnasium.make("groundsym.gym:groundsym/PPDDL-v0", domain=str(TIRE / "domain.pddl"),
                         problem=str(TIRE / "p02.pddl"))
    assert checked(env.unwrapped) == []

    def masked_walk(seed: int) -> tuple[list, list[float]]:
        rng = np.random.default_rng(seed)
        obs, info = env.reset(seed=seed)
        observations, rewards = [obs], []
        for _ in range(25):
            obs, r, term, trunc, info = env.step(int(rng.choice(np.flatnonzero(info["action_mask"]))))
            observations.append(obs)
            rewards.append(r)
            if term or trunc:
                break
        return observations, rewards

    first, again, other = masked_walk(7), masked_walk(7), masked_walk(8)
    assert same(first[0], again[0]) and first[1] == again[1]
    assert not (len(first[0]) == len(other[0]) and same(first[0], other[0]))


def test_ppddl_bad_input_is_one_line(tmp_path):
    with pytest.raises(UserError, match="no problem given"):
        gymnasium.make("groundsym/PPDDL-v0", domain=str(BW / "domain.ppddl"))
    bad = tmp_path / "broken.pddl"
    bad.write_text("(define (domain d) (:predicates (p ?x)")
    with pytest.raises(UserError, match="broken.pddl"):
        gymnasium.make("groundsym/PPDDL-v0", domain=str(bad), problem=str(BW / "p01.ppddl"))
    with pytest.raises(UserError, match="render_mode='ansi'"):
        PPDDLGymEnv(BW / "domain.ppddl", BW / "p01.ppddl", render_mode="ansi")


def test_a_domain_exported_from_rules_is_played_through_its_primitives():
    """rules.ppddl names its actions closeHandAround_r1, ...; the agent sees the robot's primitives."""
    tower = ROOT / "domains" / "reference" / "tower"
    env = gymnasium.make("groundsym/PPDDL-v0", domain=str(tower / "rules.ppddl"), problem=str(tower / "p01.ppddl"))
    objs = ("o1", "o2", "o3", "o4")
    assert env.unwrapped.action_atoms == tuple(A(p, o) for p in ("closeHandAround", "openHandOver") for o in objs)
    assert checked(env.unwrapped) == []


# ----------------------------------------------------------------------------- arguments of the wrong type

@pytest.mark.parametrize("value", [3.5, True, 3.0, "3.5", None, [3]])
def test_a_whole_number_option_takes_no_float_or_bool(value):
    """``Tower-v0(cubes=3.5)`` built 3 cubes and ``cubes=True`` one."""
    with pytest.raises(UserError, match=r"^--sim-opt cubes=.*: expected a whole number") as info:
        gymnasium.make("groundsym/Tower-v0", cubes=value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("make, message", [
    (lambda: gymnasium.make("groundsym/Bowling-v0", pins=1, model=3),
     "model=3: expected a model directory, a symbols.json file or a SymbolSet"),
    (lambda: gymnasium.make("groundsym/PPDDL-v0", domain=None),
     "domain=None: expected the path of a PPDDL domain file"),
    (lambda: gymnasium.make("groundsym/PPDDL-v0", domain=str(BW / "domain.ppddl"), problem=7),
     "problem=7: expected the path of a PPDDL problem file"),
    (lambda: gymnasium.make("groundsym/Sim-v0", sim=3),
     "sim=3: expected the name of a simulation"),
    (lambda: gymnasium.make("groundsym/Bowling-v0", pins=1, steps=2.5),
     "steps=2.5: expected a whole number"),
])
def test_arguments_of_the_wrong_type_are_one_line_naming_them(make, message):
    """``model=3`` and ``PPDDL-v0(domain=None)`` raised a bare TypeError from deep inside."""
    with pytest.raises(UserError) as info:
        make()
    assert message in str(info.value) and "\n" not in str(info.value), str(info.value)


@pytest.mark.parametrize("make", [
    lambda: gymnasium.make("groundsym/Bowling-v0", pins=1),
    lambda: gymnasium.make("groundsym/PPDDL-v0", domain=str(BW / "domain.ppddl"), problem=str(BW / "p01.ppddl")),
])
def test_a_closed_environment_says_so(make):
    """``step()`` after ``close()`` raised pybullet's ``Not connected to physics server``."""
    env = make()
    env.reset(seed=0)
    env.close()
    env.close()                              # closing twice is allowed, as Gymnasium asks
    for call in (lambda: env.step(0), lambda: env.reset(seed=1)):
        with pytest.raises(RuntimeError, match="^the environment is closed$"):
            call()
