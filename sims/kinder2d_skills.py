"""Closed-loop skills for KinDER's kinematic-2D robot, written here over the environment's own actions.

KinDER's robot (Kurenkov et al.'s CRV robot of the kinematic-2D environments) is a circular base
with a telescoping arm and a vacuum at its tip; an action is a bounded change ``(dx, dy, dtheta,
darm)`` plus an absolute vacuum setting, and a step that would collide is refused (the state stays).
Each skill here is a short script of phases (turn, drive, reach, switch the vacuum), each phase
driven by the current state, so a refused step is seen and the skill gives up instead of pushing
forever (:class:`Script`). KinDER's own parameterised skills are not published on PyPI; these are
ours, with the same role as the skills of bilevel planning (Silver et al., CoRL 2022).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import atan2, cos, pi, sin
from typing import Callable

import numpy as np

from .object_centric import ObjectState

ROBOT = "robot"
STEP_XY = 0.049          # below the action bound 0.05 (float32 rounding must not leave the box)
STEP_THETA = pi / 16 - 1e-4
STEP_ARM = 0.099
STUCK_STEPS = 6          # a phase whose commanded motion is refused this many times in a row gives up
# (each refusal halves the next step, so a base can still creep up to a wall or an object)
TIP_REACH = 0.0125       # suction zone centre beyond the arm joint: gripper width + half the zone (KinDER)

Phase = Callable[[ObjectState], "np.ndarray | None"]


def wrap(angle: float) -> float:
    return (angle + pi) % (2 * pi) - pi


def robot_pose(state: ObjectState) -> tuple[float, float, float, float]:
    return (state.get(ROBOT, "x"), state.get(ROBOT, "y"), state.get(ROBOT, "theta"), state.get(ROBOT, "arm_joint"))


def tool_tip(state: ObjectState) -> tuple[float, float]:
    """The point the vacuum acts on: the middle of the suction zone in front of the gripper."""
    x, y, theta, arm = robot_pose(state)
    reach = arm + TIP_REACH
    return x + cos(theta) * reach, y + sin(theta) * reach


@dataclass
class Script:
    """Phases run in order; a phase returns the next action or None when it is complete. A phase
    whose steps the environment keeps refusing (a collision) ends where it got to. The vacuum keeps
    the last value set, so a held object stays held while the base moves."""

    phases: list[Callable[["Script", ObjectState], np.ndarray | None]]
    vacuum: float = 0.0
    index: int = 0
    stuck: int = 0
    last: tuple[float, ...] | None = None
    refused: int = 0      # phases that ended short of their target (a step was refused)

    def act(self, state: ObjectState) -> np.ndarray | None:
        pose = robot_pose(state)
        if self.last is not None and np.allclose(pose, self.last, atol=1e-9):
            self.stuck += 1
            if self.stuck >= STUCK_STEPS:    # as close as it gets: the phase ends, the script goes on
                self.refused += 1
                self.index, self.stuck, self.last = self.index + 1, 0, None
        else:
            self.stuck = 0
        while self.index < len(self.phases):
            action = self.phases[self.index](self, state)
            if action is not None:
                self.last = pose if action[:4].any() else None
                action[:4] *= 0.5 ** self.stuck
                return action
            self.index, self.stuck, self.last = self.index + 1, 0, None
        return None

    def action(self, dx: float = 0.0, dy: float = 0.0, dtheta: float = 0.0, darm: float = 0.0) -> np.ndarray:
        return np.array([dx, dy, dtheta, darm, self.vacuum], dtype=np.float32)


def turn_to(theta: float):
    def phase(s: Script, state: ObjectState) -> np.ndarray | None:
        d = wrap(theta - state.get(ROBOT, "theta"))
        return None if abs(d) < 1e-6 else s.action(dtheta=float(np.clip(d, -STEP_THETA, STEP_THETA)))
    return phase


def drive_to(x: float | Callable[[ObjectState], float] | None, y: float | Callable[[ObjectState], float] | None,
             tol: float = 1e-4):
    """Drive the base straight to (x, y); None keeps that coordinate; a callable is read each step."""
    def phase(s: Script, state: ObjectState) -> np.ndarray | None:
        rx, ry = state.get(ROBOT, "x"), state.get(ROBOT, "y")
        tx = rx if x is None else (x(state) if callable(x) else x)
        ty = ry if y is None else (y(state) if callable(y) else y)
        dx, dy = tx - rx, ty - ry
        dist = float(np.hypot(dx, dy))
        if dist < tol:
            return None
        scale = min(1.0, STEP_XY / dist)
        return s.action(dx=dx * scale, dy=dy * scale)
    return phase


def arm_to(length: float):
    def phase(s: Script, state: ObjectState) -> np.ndarray | None:
        d = length - state.get(ROBOT, "arm_joint")
        return None if abs(d) < 1e-6 else s.action(darm=float(np.clip(d, -STEP_ARM, STEP_ARM)))
    return phase


def set_vacuum(on: bool):
    """One step that switches the vacuum (the environment reads it as an absolute setting)."""
    def phase(s: Script, state: ObjectState) -> np.ndarray | None:
        want = 1.0 if on else 0.0
        if state.get(ROBOT, "vacuum") == want:
            return None
        s.vacuum = want
        return s.action()
    return phase


def until(done: Callable[[ObjectState], bool], inner):
    """Run ``inner`` until ``done`` holds (e.g. drive toward a button until it is pressed)."""
    def phase(s: Script, state: ObjectState) -> np.ndarray | None:
        return None if done(state) else inner(s, state)
    return phase


def heading(x0: float, y0: float, x1: float, y1: float) -> float:
    return atan2(y1 - y0, x1 - x0)


def rect_centre(state: ObjectState, obj: str) -> tuple[float, float]:
    """Centre of a KinDER rectangle (its x, y are the bottom-left corner, rotated by theta about it)."""
    x, y, t = state.get(obj, "x"), state.get(obj, "y"), state.get(obj, "theta")
    w, h = state.get(obj, "width"), state.get(obj, "height")
    return x + cos(t) * w / 2 - sin(t) * h / 2, y + sin(t) * w / 2 + cos(t) * h / 2
