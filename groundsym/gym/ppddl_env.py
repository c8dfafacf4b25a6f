"""Any PPDDL domain and problem as a Gymnasium environment, run by groundsym's PPDDL simulator.

``gymnasium.make("groundsym/PPDDL-v0", domain="domain.pddl", problem="p01.pddl")``. The dynamics
are those of ``groundsym plan --domain ... --problem ...`` (:func:`groundsym.episode.ppddl_world`):

- Observation: the true atoms of the state as a ``MultiBinary`` vector over every ground atom of
  the domain's predicates on the problem's objects and constants (arguments of the declared types),
  sorted by predicate then arguments; ``env.atoms`` lists them, ``env.decode(obs)`` reads a vector.
- Action: ``Discrete`` over the ground primitives (``env.action_atoms``, sorted; a domain exported
  from NID rules is played through its primitives). ``info["action_mask"]`` marks the applicable
  ones; an inapplicable primitive is tried and changes nothing, as a robot's would.
- Reward: the problem's goal reward when the goal holds in the state reached, plus the
  ``(increase (reward) n)`` effects of the outcome that happened.
- Episode end: ``terminated`` when the goal holds or nothing is applicable any more (a dead end);
  ``truncated`` after ``steps`` primitives (default 30, as ``groundsym plan``), since the problem
  itself sets no horizon.
- Seeding: ``reset(seed=s)`` draws the outcomes from seed ``s``, as ``groundsym plan --seed``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from ..episode import ppddl_world
from ..errors import UserError
from ..logic import format_state
from ..ppddl.parser import load
from ..ppddl.simulate import Task
from .atoms import AtomIndex, typed_atoms
from .render import text_frame
from .options import check_open, episode_seed, frame_size, path_argument, positive_steps

DEFAULT_STEPS = 30


def ground_atoms(task: Task) -> list:
    """Every ground atom of the task's predicates whose arguments have the declared types."""
    return typed_atoms((p.name, [task.objects_of(a.type) for a in p.params]) for p in task.domain.predicates)


class PPDDLGymEnv(gymnasium.Env):
    """A PPDDL problem as an environment; see the module docstring."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 2}

    def __init__(self, domain: str | Path, problem: str | Path | None = None, steps: int = DEFAULT_STEPS,
                 render_mode: str | None = None, render_width: int = 640, render_height: int = 480, **unknown: Any):
        if unknown:                 # one line as the sims' unknown options get, not Python's bare TypeError
            key = sorted(unknown)[0]
            raise UserError(f"{key}={unknown[key]!r}: unknown keyword for a PPDDL environment (known: domain, "
                            "problem, steps, render_mode, render_width, render_height)")
        self.render_mode, self.render_size = render_mode, frame_size(render_mode, render_width, render_height)
        path_argument(domain, "domain", "a PPDDL domain file")
        if problem is not None:
            path_argument(problem, "problem", "a PPDDL problem file")
        where = str(problem or domain)
        dom, prob = load(domain, problem)
        self.world, self.task = ppddl_world(dom, prob, where)
        self.name = prob.name
        self.steps = positive_steps(steps, where)
        self.index = AtomIndex([*ground_atoms(self.task), *self.task.initial_state], where)
        self.action_atoms = tuple(self.task.primitive_actions())
        if not self.action_atoms:
            raise UserError(f"{where}: the domain has no ground primitive on these objects")
        self.observation_space = self.index.space()
        self.action_space = spaces.Discrete(len(self.action_atoms))
        self._t: int | None = None
        self._applicable: tuple[frozenset, frozenset] | None = None
        self._last = ""
        self._closed = False

    @property
    def atoms(self) -> tuple:
        return self.index.atoms

    def decode(self, observation: np.ndarray) -> frozenset:
        return self.index.state(observation)

    # ------------------------------------------------------------------ the Gymnasium API

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        check_open(self._closed)
        super().reset(seed=seed)
        self.world.reset(episode_seed(self, seed), self.steps)
        self._t, self._last = 0, ""
        return self.index.vector(self.world.state), self._info()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        check_open(self._closed)
        if self._t is None:
            raise RuntimeError("call reset() before step()")
        if self._t >= self.steps or self._ended():
            raise RuntimeError("the episode has ended: call reset()")
        if not self.action_space.contains(action):
            raise ValueError(f"action {action!r}: expected a whole number in 0..{self.action_space.n - 1}")
        self._t += 1
        atom = self.action_atoms[int(action)]
        _, reward = self.world.step(atom, self._t, self.steps - self._t)
        self._last = str(atom)
        terminated = self._ended()
        truncated = not terminated and self._t >= self.steps
        return self.index.vector(self.world.state), float(reward), terminated, truncated, self._info()

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            gymnasium.logger.warn("render() without render_mode='rgb_array' draws nothing")
            return None
        status = "goal reached" if self.world.done() else f"step {self._t or 0} of {self.steps}"
        after = f", after {self._last}" if self._last else ""
        return text_frame(f"{self.name}: {status}{after}", format_state(self.world.state), *self.render_size)

    def close(self) -> None:
        """Nothing to release (the simulator is pure Python), but a closed environment says so
        when it is used again, as the simulation environments do."""
        self._closed = True

    # ------------------------------------------------------------------ helpers

    def applicable(self) -> frozenset:
        """The primitives applicable in the current state (computed once per state)."""
        state = self.world.state
        if self._applicable is None or self._applicable[0] is not state:
            self._applicable = (state, frozenset(self.world.actions(state)))
        return self._applicable[1]

    def action_mask(self) -> np.ndarray:
        allowed = self.applicable()
        return np.array([a in allowed for a in self.action_atoms], dtype=np.int8)

    def _ended(self) -> bool:
        """The goal holds, or no primitive is applicable: nothing the agent does matters any more."""
        return self.world.done() or not self.applicable()

    def _info(self) -> dict[str, Any]:
        return {"action_mask": self.action_mask(), "step": self._t,
                "goal_reached": bool(self.world.done())}
