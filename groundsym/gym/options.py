"""The keyword options every groundsym environment shares, checked where they enter.

Gymnasium passes ``gymnasium.make`` keywords straight to the constructor, so these checks are
where user input enters: a bad value is one :class:`~groundsym.errors.UserError` line naming it.
Seeding lives here too: both kinds of environment turn ``reset(seed=...)`` into the integer seed
their simulator takes in the same way.
"""

from __future__ import annotations

import os
from typing import Any

import gymnasium
import numpy as np

from ..errors import UserError

SEED_RANGE = 2 ** 31     # seeds drawn for resets without one


CLOSED = "the environment is closed"


def check_open(closed: bool) -> None:
    """After ``close()`` the simulator is gone: say so, instead of pybullet's ``Not connected to
    physics server`` from deep inside a step."""
    if closed:
        raise RuntimeError(CLOSED)


def path_argument(value: Any, key: str, what: str) -> Any:
    """``value`` if it is a path (text or ``os.PathLike``), else one line naming the keyword; a
    ``None`` or a number used to end in a TypeError from deep inside the file reader."""
    if not isinstance(value, (str, os.PathLike)):
        raise UserError(f"{key}={value!r}: expected the path of {what}")
    return value


def positive_steps(steps: Any, where: str) -> int:
    """The ``steps=`` option as a positive whole number (one clear line otherwise)."""
    if isinstance(steps, bool):                  # True == 1 to int(); no step count
        raise UserError(f"{where}: steps={steps!r}: expected a whole number of at least 1")
    try:
        value = int(steps)
    except (TypeError, ValueError):
        raise UserError(f"{where}: steps={steps!r}: expected a whole number") from None
    if value != steps or value < 1:
        raise UserError(f"{where}: steps={steps!r}: expected a whole number of at least 1")
    return value


def frame_size(render_mode: str | None, width: Any, height: Any) -> tuple[int, int]:
    """The checked ``render_mode`` and frame size options, as ``(width, height)``."""
    if render_mode not in (None, "rgb_array"):
        raise UserError(f"render_mode={render_mode!r}: expected 'rgb_array' or None")
    for key, value in (("render_width", width), ("render_height", height)):
        if not isinstance(value, (int, np.integer)) or not 16 <= value <= 4096:
            raise UserError(f"{key}={value!r}: expected a whole number of pixels between 16 and 4096")
    return int(width), int(height)


def episode_seed(env: gymnasium.Env, seed: int | None) -> int:
    """The seed of an episode: the one given, else one drawn from the environment's generator
    (seeded by the last ``reset(seed=...)``, so a run of unseeded resets repeats too)."""
    return int(seed) if seed is not None else int(env.np_random.integers(SEED_RANGE))
