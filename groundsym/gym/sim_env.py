"""A groundsym simulation (the tower cell, the bowling alley, any plug-in) as a Gymnasium environment.

The simulation is found by name through the sim registry (``groundsym.sims`` entry points), so
this module never imports ``sims``; its options are keyword arguments
(``gymnasium.make("groundsym/Tower-v0", cubes=4, noise=0.0)``).

- Observation: a ``Dict`` with one ``Box`` per object (keys ``o1``, ``o2``, ... as the sim names
  them), holding that object's features in the sim's order (tower: x, y, z, size). With
  ``model=`` (a directory from ``groundsym learn``) the learned abstract state is added under
  ``"atoms"`` as a ``MultiBinary`` vector (:mod:`groundsym.gym.abstract`).
- Action: ``Discrete`` over the ground primitives in the sim's order (``env.action_atoms``);
  ``info["action_mask"]`` marks those the sim offers now.
- Reward: the task's. A sim whose episode value is the discounted sum of scene rewards (the
  tower, ``gamma`` 0.8) gives the reward of the scene each primitive led to; a sim scored by its
  final scene (bowling: pins down after the last throw) gives the change in scene reward, the
  first step counting from zero, so the rewards of an episode add up to its score.
- Episode end: ``terminated`` after the task's number of primitives (``steps=`` to change it).
- Seeding: ``reset(seed=s)`` starts the simulation with seed ``s`` itself, the same start state
  and motor noise as ``groundsym collect``/``plan`` with that seed.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from ..errors import UserError
from ..registry import make_sim, sim_names
from ..symbols import SymbolSet
from ..world import Scene
from .abstract import ATOMS_KEY, SymbolObservation
from .options import check_open, episode_seed, frame_size, positive_steps
from .render import sim_frame

class SimGymEnv(gymnasium.Env):
    """``SimGymEnv("tower", cubes=4)``; see the module docstring for spaces, rewards and ends."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 2}

    def __init__(self, sim: str | None = None, render_mode: str | None = None, steps: int | None = None,
                 model: str | Path | SymbolSet | None = None, render_width: int = 640, render_height: int = 480,
                 **options: Any):
        if sim is None:
            raise UserError(f"sim=: name a simulation ({', '.join(sim_names())})")
        if not isinstance(sim, str):
            raise UserError(f"sim={sim!r}: expected the name of a simulation ({', '.join(sim_names())})")
        self.render_mode, self.render_size = render_mode, frame_size(render_mode, render_width, render_height)
        self.sim_name = sim
        self.sim = make_sim(sim, options)
        self._closed = False
        first = self.sim.reset(0)          # the objects and primitives are known once a world exists
        self.objects: tuple[str, ...] = tuple(first.objects)
        self.feature_names: tuple[str, ...] = tuple(self.sim.feature_names)
        self.action_atoms = tuple(self.sim.actions())
        self.steps = positive_steps(steps, sim) if steps is not None else int(self.sim.episode_length)
        self.gamma = float(self.sim.gamma)
        self.final_score = getattr(self.sim, "episode_score", "sum") == "final"
        self.abstraction = SymbolObservation(model, self.objects, self.feature_names) if model is not None else None
        self.observation_space = self._observation_space()
        self.action_space = spaces.Discrete(len(self.action_atoms))
        self._scene: Scene | None = None
        self._t = 0

    def _observation_space(self) -> spaces.Dict:
        box = spaces.Box(-np.inf, np.inf, shape=(len(self.feature_names),), dtype=np.float64)
        table: dict[str, spaces.Space] = {o: box for o in self.objects}
        if self.abstraction is not None:
            if ATOMS_KEY in table:
                raise UserError(f"{self.sim_name}: an object is named {ATOMS_KEY!r}, the key of the abstract state")
            table[ATOMS_KEY] = self.abstraction.index.space()
        return spaces.Dict(table)

    # ------------------------------------------------------------------ the Gymnasium API

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        check_open(self._closed)
        super().reset(seed=seed)
        scene = self.sim.reset(episode_seed(self, seed))
        if tuple(scene.objects) != self.objects:
            raise UserError(f"{self.sim_name}: the objects changed between episodes "
                            f"({', '.join(scene.objects)}); observation spaces need a fixed set")
        self._scene, self._t = scene, 0
        return self._observation(scene), self._info(scene)

    def step(self, action: Any) -> tuple[dict, float, bool, bool, dict]:
        check_open(self._closed)
        if self._scene is None:
            raise RuntimeError("call reset() before step()")
        if self._t >= self.steps:
            raise RuntimeError(f"the episode ended after {self.steps} primitives: call reset()")
        if not self.action_space.contains(action):
            raise ValueError(f"action {action!r}: expected a whole number in 0..{self.action_space.n - 1}")
        before = self._scene.reward if self._t > 0 else 0.0
        scene = self.sim.step(self.action_atoms[int(action)])
        self._scene, self._t = scene, self._t + 1
        reward = float(scene.reward - before) if self.final_score else float(scene.reward)
        return self._observation(scene), reward, self._t >= self.steps, False, self._info(scene)

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            gymnasium.logger.warn("render() without render_mode='rgb_array' draws nothing")
            return None
        check_open(self._closed)
        return sim_frame(self.sim, *self.render_size)

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.sim.close()

    # ------------------------------------------------------------------ helpers

    def current_scene(self) -> Scene:
        """The simulator's scene after the last reset or step (features, reward, ground truth)."""
        if self._scene is None:
            raise RuntimeError("call reset() first")
        return self._scene

    def action_mask(self) -> np.ndarray:
        allowed = set(self.sim.actions())
        return np.array([a in allowed for a in self.action_atoms], dtype=np.int8)

    def _observation(self, scene: Scene) -> dict[str, np.ndarray]:
        feats = np.array(scene.features, dtype=np.float64)
        obs: dict[str, np.ndarray] = {o: feats[i] for i, o in enumerate(self.objects)}
        if self.abstraction is not None:
            obs[ATOMS_KEY] = self.abstraction.vector(scene)
        return obs

    def _info(self, scene: Scene) -> dict[str, Any]:
        return {"action_mask": self.action_mask(), "scene_reward": float(scene.reward), "step": self._t}
