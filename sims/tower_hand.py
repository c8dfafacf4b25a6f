"""The Panda's two-finger hand in the tower cell: the finger motors and the stabilised grasp.

A grasp is stabilised by a fixed constraint once both fingers touch the object, and released by
removing it, so what is let go falls as physics dictates (objects are never teleported). The hand
is apart from the arm's controller (:mod:`sims.tower_control`) because it owns a piece of state
the rest reads: which object is held (:attr:`Hand.held`), which the arm's guards, the approach
planner and the primitives all ask; and because closing and opening are their own small control
loops (close until both fingers touch, open until both are open), not trajectories. It steps the
physics only through :meth:`sims.tower_scene.TowerScene.step`. docs/tower.md describes grasps.
"""

from __future__ import annotations

import numpy as np

from .tower_kinematics import TCP_LINK, pb
from .tower_scene import FINGER_JOINTS, FINGER_OPEN, LEFT_FINGER, RIGHT_FINGER, TowerScene

FINGER_FORCE = 40.0
TIP_BELOW_TCP = 0.013             # fingertips reach this far below the TCP


class Hand:
    """The fingers of the arm in ``scene`` and the grasp constraint that holds an object."""

    def __init__(self, scene: TowerScene) -> None:
        self.scene = scene
        self.grasp: int | None = None      # constraint id of the stabilised grasp
        self.held: int | None = None       # index into bodies of the object in the grasp

    def reset(self) -> None:
        """Forget the grasp: a rebuilt world holds nothing."""
        self.grasp = self.held = None

    def set_fingers(self, width: float | tuple[float, float]) -> None:
        """Finger motor targets: one position for both fingers, or one each."""
        s = self.scene
        widths = (width, width) if np.isscalar(width) else width
        for j, w in zip(FINGER_JOINTS, widths):
            pb.setJointMotorControl2(s.robot, j, pb.POSITION_CONTROL, targetPosition=float(w),
                                     force=FINGER_FORCE, maxVelocity=0.3, physicsClientId=s.client)

    def open_fingers(self, max_steps: int = 40) -> None:
        """Open the hand and wait until both fingers are (nearly) fully open."""
        self.set_fingers(FINGER_OPEN)
        for _ in range(max_steps):
            self.scene.step()
            if min(self.scene.finger_q()) > FINGER_OPEN - 0.002:
                return

    def close_on(self, index: int, steps: int = 40) -> bool:
        """Close the fingers; the moment both touch object ``index``, fix the grasp and hold the
        fingers where they are, so they do not squeeze the held object against the fixed
        constraint (squeezing turned it in the hand; see :meth:`attach` for the contacts)."""
        self.set_fingers(0.0)
        for i in range(steps):
            self.scene.step()
            if i % 2 == 1 and self.attach(index):
                self.set_fingers(self.scene.finger_q())
                self.scene.step(2)
                return True
        self.set_fingers(FINGER_OPEN)
        return False

    def attach(self, index: int) -> bool:
        """Stabilise the grasp of object ``index`` with a fixed constraint if both fingers touch it.

        While the constraint holds, the fingers' contacts with the held object are switched off:
        the constraint is the grasp, and finger contacts on top of it over-determine the object.
        With them, a fast wrist turn (the transit home after a grasp) let the solver pivot the
        cube a few degrees about the finger axis, where the fingers' friction then wedged it off
        the constraint's pose until the fingers opened (in-hand turns up to 5 deg at 7.5 mm noise,
        traced per step; without them, under 0.5 deg). The fingers stay where they closed."""
        s = self.scene
        uid = s.bodies[index].uid
        if not (s.contacts(uid, s.robot, LEFT_FINGER) and s.contacts(uid, s.robot, RIGHT_FINGER)):
            return False
        c = s.client
        hp, hq = pb.getLinkState(s.robot, TCP_LINK, physicsClientId=c)[4:6]
        op, oq = pb.getBasePositionAndOrientation(uid, physicsClientId=c)
        inv_p, inv_q = pb.invertTransform(hp, hq)
        rel_p, rel_q = pb.multiplyTransforms(inv_p, inv_q, op, oq)
        self.grasp = pb.createConstraint(s.robot, TCP_LINK, uid, -1, pb.JOINT_FIXED, (0, 0, 0), rel_p, (0, 0, 0),
                                         rel_q, (0, 0, 0, 1), physicsClientId=c)
        pb.changeConstraint(self.grasp, maxForce=200.0, physicsClientId=c)
        self._finger_contacts(uid, False)
        self.held = index
        return True

    def _finger_contacts(self, uid: int, on: bool) -> None:
        s = self.scene
        for finger in (LEFT_FINGER, RIGHT_FINGER):
            pb.setCollisionFilterPair(s.robot, uid, finger, -1, int(on), physicsClientId=s.client)

    def release(self) -> None:
        """Remove the grasp constraint (the fingers are open by now) and give the fingers their
        contacts with the object back."""
        if self.grasp is not None:
            pb.removeConstraint(self.grasp, physicsClientId=self.scene.client)
        if self.held is not None:
            self._finger_contacts(self.scene.bodies[self.held].uid, True)
        self.grasp = self.held = None

    def hang(self) -> float:
        """How far below the TCP the hand reaches: the fingertips, or the held object's bottom."""
        if self.held is None:
            return TIP_BELOW_TCP
        b = self.scene.bodies[self.held]
        z = pb.getBasePositionAndOrientation(b.uid, physicsClientId=self.scene.client)[0][2]
        return max(TIP_BELOW_TCP, float(self.scene.tcp()[2] - z + b.size / 2))
