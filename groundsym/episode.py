"""The closed loop: an environment and a planner, step by step, recorded as an episode.

An environment is either a simulation (continuous scenes, abstracted by the model's learned
symbols when there are any) or a symbolic world (a PPDDL problem run by the PPDDL simulator, or
a hand-written rule set). Both give the planner the same :class:`~groundsym.planner.Observation`,
so the same planner runs on robot data and on reference domains. The episode records every
step's abstract state, chosen primitive, the planner's expected value and the reward, and the
discounted episode value ``V = sum_{t=1..T} gamma^(t-1) r_t`` the paper reports (``r_t`` is the
reward of the scene after the t-th primitive).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Protocol, Sequence

import numpy as np

from .logic import Atom, format_state
from .planner import Decision, Goal, Observation
from .threads import decide

EPISODE_SCHEMA = "groundsym.episode/1"


class Environment(Protocol):
    """What the loop needs from a world: start, the current observation, run a primitive."""

    gamma: float

    def reset(self, seed: int, steps: int = 1) -> Observation: ...

    def step(self, action: Atom, t: int, steps_left: int) -> tuple[Observation, float]: ...

    def done(self) -> bool: ...


@dataclass(frozen=True)
class Step:
    """One primitive: what the planner saw and chose, and the reward of the scene it led to."""

    t: int
    state: tuple[str, ...] | None
    action: str
    expected_value: float
    reward: float
    info: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Episode:
    """A whole run of the loop; ``value`` is the discounted sum of the step rewards."""

    planner: str
    seed: int
    gamma: float
    start_reward: float
    steps: tuple[Step, ...]
    final_state: tuple[str, ...] | None
    success: bool | None = None
    dead_end: bool = False      # the planner proved the goal unreachable and stopped the episode

    @property
    def value(self) -> float:
        return float(sum(self.gamma ** t * s.reward for t, s in enumerate(self.steps)))

    def to_doc(self) -> dict[str, Any]:
        return {"schema": EPISODE_SCHEMA, "planner": self.planner, "seed": self.seed, "gamma": self.gamma,
                "value": self.value, "success": self.success, "start_reward": self.start_reward,
                "steps": [{"t": s.t, "state": list(s.state) if s.state is not None else None,
                           "action": s.action, "expected_value": _finite(s.expected_value),
                           "reward": s.reward, "info": s.info} for s in self.steps],
                "final_state": list(self.final_state) if self.final_state is not None else None,
                "dead_end": self.dead_end}


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _state_text(state: frozenset | None) -> tuple[str, ...] | None:
    return None if state is None else tuple(format_state(state))


# ----------------------------------------------------------------------------- environments

class SimEnv:
    """A simulation, its scenes abstracted with ``symbols`` (if given) for symbolic planners."""

    def __init__(self, sim: Any, symbols: Any = None, render_dir: str | Path | None = None):
        self.sim, self.symbols = sim, symbols
        self.gamma = float(sim.gamma)
        self.render_dir = Path(render_dir) if render_dir else None
        self.frame = 0

    def _observe(self, scene: Any, t: int, steps_left: int) -> Observation:
        state = self.symbols.abstract_scene(scene) if self.symbols is not None else None
        if self.render_dir is not None:
            self.render_dir.mkdir(parents=True, exist_ok=True)
            self.sim.render(self.render_dir / f"frame-{self.frame:03d}.png")
            self.frame += 1
        return Observation(tuple(scene.objects), tuple(self.sim.actions()), state, scene, t, steps_left)

    def reset(self, seed: int, steps: int = 1) -> Observation:
        self.frame = 0
        return self._observe(self.sim.reset(seed), 0, steps)

    def step(self, action: Atom, t: int, steps_left: int) -> tuple[Observation, float]:
        scene = self.sim.step(action)
        return self._observe(scene, t, steps_left), float(scene.reward)

    def start_reward(self) -> float:
        return float(self.sim.scene().reward)

    def done(self) -> bool:
        return False


class SymbolicEnv:
    """A symbolic world: a successor sampler over states, an optional goal, a reward per step.

    ``successor(state, action, rng)`` draws ``(next state, reward effects of that outcome)``;
    ``actions(state)`` lists the primitives that may be tried; the reward of a step is
    ``goal.reward`` when the goal holds in the state reached, plus the outcome's reward effects.
    A reached goal ends the episode.
    """

    def __init__(self, objects: Sequence[str], start: frozenset, actions: Callable[[frozenset], Sequence[Atom]],
                 successor: Callable[[frozenset, Atom, np.random.Generator], tuple[frozenset, float]],
                 goal: Goal | None = None, gamma: float = 1.0):
        self.objects, self.start = tuple(objects), frozenset(start)
        self.actions, self.successor, self.goal = actions, successor, goal
        self.gamma = gamma
        self.state = self.start
        self.rng = np.random.default_rng(0)

    def _observe(self, t: int, steps_left: int) -> Observation:
        return Observation(self.objects, tuple(self.actions(self.state)), self.state, None, t, steps_left)

    def reset(self, seed: int, steps: int = 1) -> Observation:
        self.state = self.start
        self.rng = np.random.default_rng(seed)
        return self._observe(0, steps)

    def reward(self, state: frozenset) -> float:
        return float(self.goal.reward) if self.goal is not None and self.goal.holds(state) else 0.0

    def step(self, action: Atom, t: int, steps_left: int) -> tuple[Observation, float]:
        state, extra = self.successor(self.state, action, self.rng)
        self.state = frozenset(state)
        return self._observe(t, steps_left), self.reward(self.state) + float(extra)

    def start_reward(self) -> float:
        return self.reward(self.start)

    def done(self) -> bool:
        return self.goal is not None and self.goal.holds(self.state)

    @property
    def success(self) -> bool | None:
        return None if self.goal is None else self.goal.holds(self.state)


# ----------------------------------------------------------------------------- the loop

def run_episode(env: Any, planner: Any, steps: int, seed: int, name: str = "",
                on_step: Callable[[Step], None] | None = None) -> Episode:
    """Run ``steps`` primitives (fewer if a goal is reached) and record everything.

    The episode also ends when the planner's decision says ``dead_end`` in its info (it proved the
    goal unreachable from here): nothing it could run would help."""
    obs = env.reset(seed, steps)
    start_reward = env.start_reward()
    record: list[Step] = []
    dead_end = False
    for t in range(steps):
        if env.done() or not obs.actions:     # goal reached, or a dead end: nothing can be run
            break
        decision: Decision = decide(planner, obs)     # BLAS on one thread while deciding
        if decision.info.get("dead_end"):
            dead_end = True
            break
        nxt, reward = env.step(decision.action, t + 1, steps - t - 1)
        planner.observe(decision.action, nxt)
        step = Step(t, _state_text(obs.state), str(decision.action), float(decision.expected_value),
                    float(reward), _plain(decision.info))
        record.append(step)
        if on_step is not None:
            on_step(step)
        obs = nxt
    success = getattr(env, "success", None)
    return Episode(name or getattr(planner, "name", "?"), seed, env.gamma, start_reward, tuple(record),
                   _state_text(obs.state), success, dead_end)


def _plain(info: Any) -> dict:
    """Planner info made JSON-safe (numbers, strings, lists)."""
    out = {}
    for k, v in dict(info).items():
        if isinstance(v, (str, int, bool)) or v is None:
            out[k] = v
        elif isinstance(v, float):
            out[k] = v if np.isfinite(v) else None
        elif isinstance(v, (list, tuple)):
            out[k] = [str(x) if not isinstance(x, (int, float, str)) else x for x in v]
        else:
            out[k] = str(v)
    return out


# ----------------------------------------------------------------------------- PPDDL worlds

def goal_of(problem: Any, where: str = "problem") -> Goal | None:
    """A problem's goal as a conjunction of ground literals (what PRADA can score), or None.

    Goals outside that subset (``or``, quantifiers) are refused with one line.
    """
    from .errors import UserError
    from .logic import Literal
    from .ppddl.ast import And, Not

    if problem is None or problem.goal is None:
        return None

    def lits(f: Any) -> list[Literal]:
        if isinstance(f, Atom):
            return [Literal(f, True)]
        if isinstance(f, Not) and isinstance(f.arg, Atom):
            return [Literal(f.arg, False)]
        if isinstance(f, And):
            return [l for x in f.args for l in lits(x)]
        raise UserError(f"{where}: goal: only conjunctions of literals can be planned for, got {f!r}")

    reward = float(problem.goal_reward) if problem.goal_reward is not None else 1.0
    return Goal(tuple(lits(problem.goal)), reward)


def ppddl_world(domain: Any, problem: Any, where: str = "problem") -> tuple[SymbolicEnv, Any]:
    """The PPDDL simulator as an environment, and the :class:`~groundsym.ppddl.simulate.Task`.

    Actions offered are the applicable ground primitives; the reward of a step is the goal reward
    when the goal holds, plus the reward effects of the outcome that happened.
    """
    from .errors import UserError
    from .ppddl.simulate import Task

    if problem is None:
        raise UserError(f"{where}: no problem given (the initial state and goal are needed)")
    task = Task(domain, problem)

    def actions(state: frozenset) -> list[Atom]:
        return task.applicable_primitives(state)

    def successor(state: frozenset, action: Atom, rng: np.random.Generator) -> tuple[frozenset, float]:
        dist = task.distribution(state, action)
        if not dist:
            return state, 0.0
        p = np.array([s.prob for s in dist])
        k = int(rng.choice(len(dist), p=p / p.sum()))
        return dist[k].state, float(dist[k].reward)

    goal = goal_of(problem, where)
    return SymbolicEnv(sorted(task.objects), task.initial_state, actions, successor, goal, gamma=1.0), task


def ppddl_model(domain: Any, problem: Any, task: Any, need_rules: bool = True) -> Any:
    """What a planner may use from a PPDDL domain: its true rules (the NID rule subset), the goal,
    and the domain and problem themselves (for the external planners)."""
    from .errors import UserError
    from .planner import PlanningModel
    from .ppddl.to_rules import domain_to_rules

    try:
        rules = domain_to_rules(domain)
    except UserError as exc:
        if need_rules:
            raise UserError(f"this planner needs the domain as NID rules, but {exc}") from None
        rules = None
    preds = {p.name: p.arity for p in domain.predicates}
    return PlanningModel(task.primitives, predicates=preds, rules=rules, goal=goal_of(problem),
                         domain=domain, problem=problem, ppddl=(domain, problem), gamma=0.95)
