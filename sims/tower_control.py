"""The arm's joint control in the tower cell: tracking joint trajectories, guarded, and the guards.

The arm really moves: every waypoint is turned into joint targets by inverse kinematics
(:mod:`sims.tower_kinematics`) and reached by the joint motors, stepping the physics all the way.
:class:`ArmController` knows how to move (follow a trajectory, a straight TCP line, a planned
:class:`Leg`) but not where to go: that is the approach planner's (:mod:`sims.tower_approach`)
and the primitives' (:mod:`sims.tower_skills`). The guards live here with the motion they stop:
a guard is a check run after every physics step of a move, built from the scene's contacts when
the move starts. docs/tower.md describes the controller and what each guard stops.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .tower_hand import Hand
from .tower_kinematics import ArmKinematics, Speed, pb, trajectory
from .tower_scene import ARM_JOINTS, HAND_PARTS, TIME_STEP, TowerScene

ARM_FORCES = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
POSITION_GAIN = 0.2                # joint motors: position and velocity gains of the tracking law
VELOCITY_GAIN = 1.0
POSITION_GAINS, VELOCITY_GAINS = (POSITION_GAIN,) * 7, (VELOCITY_GAIN,) * 7
CONTACT_UP = 0.7                   # a contact normal with |z| above this is a touch from above

# Cartesian speed profiles (top speed m/s, acceleration m/s^2) and IK knot spacing (m)
TRANSIT = Speed(1.5, 8.0)
LIFT = Speed(0.6, 4.0)
DESCENT = Speed(0.6, 4.0, slow=0.15, slow_for=0.04)      # the last 4 cm slow and guarded
TRANSIT_KNOTS = 0.05
FINE_KNOTS = 0.01

# controller tolerances
ARRIVE_TOL = 0.002                 # rad: a move ends once every joint is this close to its target ...
REST_SPEED = 0.05                  # rad/s: ... and this slow
ARRIVE_STEPS = 60                  # at most this many steps to arrive after the trajectory ends

Guard = Callable[[], "str | None"]


@dataclass(frozen=True)
class Leg:
    """One planned straight TCP move: joint knots, their arc lengths, the speed profile."""

    knots: np.ndarray
    arc: np.ndarray
    speed: Speed


class ArmController:
    """The arm's joint motors in ``scene``, tracking trajectories solved on ``kin``."""

    def __init__(self, scene: TowerScene, hand: Hand, kin: ArmKinematics) -> None:
        self.scene = scene
        self.hand = hand
        self.kin = kin
        self.clearance: float | None = None     # when not None: the least transit clearance seen (m)

    def command(self, q: np.ndarray, qd: np.ndarray) -> None:
        """Joint motor targets: position ``q`` with feed-forward velocity ``qd`` (tracking a path)."""
        s = self.scene
        pb.setJointMotorControlArray(s.robot, ARM_JOINTS, pb.POSITION_CONTROL, targetPositions=q.tolist(),
                                     targetVelocities=qd.tolist(), forces=ARM_FORCES, positionGains=POSITION_GAINS,
                                     velocityGains=VELOCITY_GAINS, physicsClientId=s.client)

    def _arrived(self, target: np.ndarray) -> bool:
        """Every arm joint within ``ARRIVE_TOL`` of ``target`` and slower than ``REST_SPEED``."""
        states = pb.getJointStates(self.scene.robot, ARM_JOINTS, physicsClientId=self.scene.client)
        return (max(abs(s[0] - t) for s, t in zip(states, target)) < ARRIVE_TOL
                and max(abs(s[1]) for s in states) < REST_SPEED)

    def follow(self, q: np.ndarray, qd: np.ndarray, guard: Guard | None = None, watch: bool = False) -> str | None:
        """Track the joint trajectory ``q`` (velocities ``qd``) step by step, then wait to arrive.

        With a ``guard``, the motion stops the first step the guard names a reason (the arm holds
        where it is) and the reason is returned. With ``watch`` (a transit) and :attr:`clearance`
        set, the least distance to the objects is recorded.
        """
        watch = watch and self.clearance is not None
        for k in range(len(q)):
            self.command(q[k], qd[k])
            self.scene.step()
            if watch:
                self._watch_clearance()
            hit = guard() if guard else None
            if hit:
                self.command(self.scene.arm_q(), np.zeros(7))
                return hit
        self.command(q[-1], np.zeros(7))
        for _ in range(ARRIVE_STEPS):
            if self._arrived(q[-1]):
                break
            self.scene.step()
            hit = guard() if guard else None
            if hit:
                self.command(self.scene.arm_q(), np.zeros(7))
                return hit
        return None

    def go(self, end: np.ndarray, yaw: float, speed: Speed, spacing: float,
           guard: Guard | None = None) -> str | None:
        """Move the TCP along a straight line from where it is to ``end`` (hand down, yaw turning
        evenly to ``yaw``). Raises :class:`IKError` when a point of the line has no solution."""
        s = self.scene
        knots, arc = self.kin.line(s.arm_q(), s.tcp(), np.asarray(end, dtype=float), s.hand_yaw(), yaw, spacing)
        return self.follow(*trajectory(knots, arc, speed, TIME_STEP), guard, watch=speed is TRANSIT)

    def run(self, leg: Leg, guard: Guard) -> str | None:
        """Move along a planned leg (see :meth:`follow`)."""
        return self.follow(*trajectory(leg.knots, leg.arc, leg.speed, TIME_STEP), guard, watch=leg.speed is TRANSIT)

    def _watch_clearance(self) -> None:
        """Record the least distance between the arm (or held object) and any object not held."""
        s = self.scene
        held = None if self.hand.held is None else s.bodies[self.hand.held].uid
        for b in s.bodies:
            if b.uid == held:
                continue
            for body in (s.robot, held):
                if body is None:
                    continue
                pts = pb.getClosestPoints(body, b.uid, 0.05, physicsClientId=s.client)
                if pts:
                    self.clearance = min(self.clearance, min(p[8] for p in pts))


# ---------------------------------------------------------------------- guards

def transit_guard(scene: TowerScene, held: int | None, *skip: int | None) -> Guard:
    """Any arm link, or the held object (index ``held``), touching an object (other than ``skip``,
    or one it touches already: a move may leave what it rests on) stops the arm."""
    held_uid = None if held is None else scene.bodies[held].uid
    touching = {b for uid in (scene.robot, held_uid) if uid is not None for b, _, _ in scene.touches(uid)}
    others = scene.object_ids(held, *skip) - touching

    def transit() -> str | None:
        hit = any(b in others for b, _, _ in scene.touches(scene.robot))
        if not hit and held_uid is not None:
            hit = any(b in others for b, _, _ in scene.touches(held_uid))
        return "arm" if hit else None

    return transit


def grasp_guard(scene: TowerScene, index: int, events: Counter[str]) -> Guard:
    """The descent onto object ``index``: a hand part touching it from above stops the hand
    (a fingertip on top); a touch on its side is part of a grasp (counted in ``events``); the
    fingers on the table stop the hand there; any arm link touching another object stops the arm."""
    target = scene.bodies[index].uid
    others = scene.object_ids(index)
    sided = [False]

    def grasp() -> str | None:
        for body, link, nz in scene.touches(scene.robot):
            if body in others:
                return "arm"
            if body == target:
                if link in HAND_PARTS and abs(nz) > CONTACT_UP:
                    return "top"
                if not sided[0]:
                    sided[0] = True
                    events["side_contacts"] += 1
            if body == scene.table:
                return "table"
        return None

    return grasp


def release_guard(scene: TowerScene, index: int, held: int) -> Guard:
    """The descent with the held object (index ``held``) over ``index``: the held object (or the
    hand) touching anything lets it go there; any arm link touching an object other than ``index``
    stops."""
    held_uid = scene.bodies[held].uid
    target = scene.bodies[index].uid
    others = scene.object_ids(index, held)

    def release() -> str | None:
        for body, _, _ in scene.touches(scene.robot):
            if body in others:
                return "arm"
            if body in (target, scene.table):
                return "placed"
        if any(body != scene.robot for body, _, _ in scene.touches(held_uid)):
            return "placed"
        return None

    return release
