"""Where the hand goes in the tower cell: hand yaws, transit heights and approach paths, planned
before the arm moves.

Planning reads the world (:mod:`sims.tower_scene`) and solves on the kinematic copy of the arm
(:mod:`sims.tower_kinematics`) with copies of the objects; it never steps the physics or commands
a motor. That is the seam to :mod:`sims.tower_skills`, which runs what is planned here and counts
what it meets: a plan is a value (a list of :class:`sims.tower_control.Leg`), so it can be checked
before it is run (the tests do). docs/tower.md ("Paths are planned before the arm moves")
describes the choices.
"""

from __future__ import annotations

import numpy as np

from .tower_control import DESCENT, FINE_KNOTS, TRANSIT, TRANSIT_KNOTS, Leg
from .tower_hand import Hand
from .tower_kinematics import ArmKinematics, IKError, Speed, pb
from .tower_scene import TowerScene

ELBOWS = ((0.6, -0.6), (-0.6, 0.6), (1.0, -1.0), (-1.0, 1.0))   # other arm postures tried for a clear pose
TRANSIT_CLEARANCE = 0.05           # TCP transit height above the highest object (plus what hangs below)
PALM_HALF = (0.105, 0.035)         # half extents of the hand across (along the finger axis) and deep
ARM_CLEARANCE = 0.01               # m: wanted between the arm at a grasp or release pose and other objects
MAX_YAW = 2.0                      # rad: hand yaws the wrist reaches from home with room to spare


def turns(yaw: float) -> list[float]:
    """``yaw`` and the same hand turned by a half and quarter turns, within the wrist's reach."""
    out = [yaw + k * np.pi / 2 for k in (0, 2, -2, 1, -1)]
    return [y for y in out if abs(y) <= MAX_YAW]


class ApproachPlanner:
    """Plans the arm's moves in ``scene`` on the kinematic copy ``kin``; ``hand`` says what is held."""

    def __init__(self, scene: TowerScene, hand: Hand, kin: ArmKinematics) -> None:
        self.scene = scene
        self.hand = hand
        self.kin = kin

    def safe_z(self, extra: float) -> float:
        """A transit height for the TCP that clears every object not in the hand."""
        tops = self.scene.tops()
        if self.hand.held is not None:
            tops[self.hand.held] = 0.0
        return float(max(tops.max(), 0.0) + TRANSIT_CLEARANCE + extra)

    def grasp_yaw(self, index: int) -> float:
        """The hand yaw for grasping object ``index``: fingers square to a cube's faces, and of the
        two such yaws the one whose wide palm stays further from the neighbours (as a grasp
        planner would choose)."""
        bodies = self.scene.bodies
        pos, orn = self.scene.poses()
        base = 0.0
        if bodies[index].shape == "cube":
            base = pb.getEulerFromQuaternion(orn[index])[2]
            base = float((base + np.pi / 4) % (np.pi / 2) - np.pi / 4)
        others = [k for k in range(len(bodies)) if k != index and k != self.hand.held]
        d = pos[others, :2] - pos[index, :2]
        reach = np.array([bodies[k].size for k in others]) * 0.71
        best, best_gap = base, -np.inf
        for yaw in (base, base + np.pi / 2 if base < 0 else base - np.pi / 2):
            along = np.abs(d @ np.array([-np.sin(yaw), np.cos(yaw)])) - reach   # fingers open along hand y
            across = np.abs(d @ np.array([np.cos(yaw), np.sin(yaw)])) - reach
            in_swath = across < PALM_HALF[1]
            gap = float(np.min(along[in_swath] - PALM_HALF[0], initial=1.0))
            if gap > best_gap + 1e-9:
                best, best_gap = yaw, gap
        return float((best + np.pi / 2) % np.pi - np.pi / 2)    # the same grasp, turned least from home

    def approach(self, candidates: list[tuple[float, np.ndarray]], hover_z: float,
                 *skip: int | None) -> tuple[float, list[Leg]]:
        """Plan the transit to above the aim at ``hover_z`` and the vertical descent onto it, for
        the first ``(hand yaw, aim)`` (yaws that grasp or place the same way, in order of
        preference) whose whole path has IK solutions and whose arm keeps ``ARM_CLEARANCE`` from
        every object but ``skip`` all along the descent; else the clearest plannable one; each in
        the posture the solver goes to first, then in the other postures of ``ELBOWS``. Low next
        to a tall tower, the wrist or forearm can otherwise touch its top. Checked on the
        kinematic copy with copies of the objects. Raises :class:`IKError` if nothing works."""
        pos, orn = self.scene.poses()
        self.kin.place([(b.shape, b.size, pos[k], orn[k]) for k, b in enumerate(self.scene.bodies) if k not in skip])
        best: tuple[float, float, list[Leg]] | None = None
        for elbow in (None, *ELBOWS):
            for yaw, aim in candidates:
                hover = np.array([aim[0], aim[1], hover_z])
                try:
                    legs = self._plan_posture(hover, aim, yaw, elbow)
                except IKError:
                    continue
                gap = min(self.kin.clearance(q) for q in legs[-1].knots[::-1])
                if gap >= ARM_CLEARANCE:
                    return yaw, legs
                if best is None or gap > best[0]:
                    best = (gap, yaw, legs)
        if best is None:
            raise IKError(f"no hand yaw reaches {np.round(candidates[0][1], 4).tolist()}")
        return best[1], best[2]

    def _plan_posture(self, hover: np.ndarray, aim: np.ndarray, yaw: float,
                      elbow: tuple[float, float] | None) -> list[Leg]:
        """Transit to ``hover`` and descent to ``aim``: from here as the solver goes (``elbow``
        None), or ending in the arm posture ``elbow`` (see :meth:`ArmKinematics.solve_elbow`)."""
        if elbow is None:
            return self.plan([(hover, TRANSIT, TRANSIT_KNOTS), (aim, DESCENT, FINE_KNOTS)], yaw)
        q_aim = self.kin.solve_elbow(aim, yaw, elbow)
        if self.kin.clearance(q_aim) < ARM_CLEARANCE:
            raise IKError("this posture does not clear the objects either")
        q_hover, _ = self.kin.solve(hover, yaw, q_aim)
        s = self.scene
        transit = self.kin.line(s.arm_q(), s.tcp(), hover, s.hand_yaw(), yaw, TRANSIT_KNOTS, q_hover)
        descent = self.kin.line(transit[0][-1], hover, aim, yaw, yaw, FINE_KNOTS, q_aim)
        return [Leg(*transit, TRANSIT), Leg(*descent, DESCENT)]

    def plan(self, moves: list[tuple[np.ndarray, Speed, float]], yaw: float) -> list[Leg]:
        """Joint knots of consecutive straight TCP moves (end, speed, knot spacing) from here."""
        q, p, y = self.scene.arm_q(), self.scene.tcp(), self.scene.hand_yaw()
        legs = []
        for end, speed, spacing in moves:
            knots, arc = self.kin.line(q, p, end, y, yaw, spacing)
            legs.append(Leg(knots, arc, speed))
            q, p, y = knots[-1], end, yaw
        return legs
