"""The tower cell's two motor primitives, ``closeHandAround`` and ``openHandOver``, and the way home.

A primitive plans its path (:mod:`sims.tower_approach`), runs it on the arm's controller with the
guard each leg needs (:mod:`sims.tower_control`), closes or opens the hand (:mod:`sims.tower_hand`),
goes home and waits for the world to settle (:mod:`sims.tower_scene`). This module is where those
meet, and where what the controller met is counted (:attr:`TowerSkills.events`, written to the
traces' ``meta.events``, docs/formats.md). docs/tower.md ("Primitives") describes both.
"""

from __future__ import annotations

from collections import Counter
from typing import Callable

import numpy as np

from .tower_approach import ApproachPlanner, turns
from .tower_control import (FINE_KNOTS, LIFT, TRANSIT, TRANSIT_KNOTS, ArmController, Guard, Leg, grasp_guard,
                            release_guard, transit_guard)
from .tower_hand import TIP_BELOW_TCP, Hand
from .tower_kinematics import ArmKinematics, IKError, Speed, trajectory
from .tower_scene import FINGER_OPEN, HOME_Q, TIME_STEP, TowerScene

RELEASE_GAP = 0.012                # gap between a released object's bottom and the target's top


class TowerSkills:
    """The primitives of the arm in ``scene``; :attr:`events` counts what they met over the
    world's life."""

    def __init__(self, scene: TowerScene, hand: Hand, arm: ArmController, planner: ApproachPlanner,
                 kin: ArmKinematics) -> None:
        self.scene = scene
        self.hand = hand
        self.arm = arm
        self.planner = planner
        self.kin = kin
        self.events: Counter[str] = Counter()   # what the controller met, over the world's life

    def _transit_guard(self, *skip: int | None) -> Guard:
        """The transit guard for the hand as it is now (see :func:`sims.tower_control.transit_guard`)."""
        return transit_guard(self.scene, self.hand.held, *skip)

    # ------------------------------------------------------------------ the primitives

    def close_hand_around(self, index: int, offset: np.ndarray) -> None:
        """Move above object ``index`` (aim moved by ``offset``), descend, close, lift, go home.

        The descent is a straight vertical line, guarded: a hand part touching the target from
        above (a fingertip on top) abandons the grasp; a finger brushing its side does not; an
        arm link touching another object stops the arm (counted). If the fingertips touch the
        table, the hand closes there. With something already in the hand it cannot close around
        another object: the arm goes above it and back.
        """
        self._primitive(lambda: self._grasp(index, offset))

    def open_hand_over(self, index: int, offset: np.ndarray) -> None:
        """Move what is held over object ``index`` (aim moved by ``offset``), open, go home.

        The held object is brought straight down to a small gap above the top of ``index`` and
        let go, so it drops onto it and may fall off; if it touches anything on the way, the hand
        lets go there. Over the held object itself the hand opens where it is. With an empty hand
        only the arm moves.
        """
        self._primitive(lambda: self._place(index, offset))

    def go_home(self) -> None:
        """Up to the transit height, along a straight line to above home, and into the home pose."""
        s, arm = self.scene, self.arm
        here = s.tcp()
        safe = self.planner.safe_z(self.hand.hang())
        hits = []
        if here[2] < safe - 0.005:
            hits.append(arm.go(np.array([here[0], here[1], safe]), s.hand_yaw(), LIFT, TRANSIT_KNOTS,
                               self._transit_guard()))
        home_tcp, _ = self.kin.fk(HOME_Q)
        try:                                   # the posture moves evenly into the home pose's ...
            knots, arc = self.kin.line(s.arm_q(), s.tcp(), home_tcp, s.hand_yaw(), 0.0, TRANSIT_KNOTS, HOME_Q)
        except IKError:                        # ... or, if that jumps, as the solver goes
            knots, arc = self.kin.line(s.arm_q(), s.tcp(), home_tcp, s.hand_yaw(), 0.0, TRANSIT_KNOTS)
        hits.append(arm.run(Leg(knots, arc, TRANSIT), self._transit_guard()))
        self.events["arm_collisions"] += sum(h is not None for h in hits)
        q0 = s.arm_q()
        arc = np.array([0.0, float(np.abs(HOME_Q - q0).max())])
        arm.follow(*trajectory(np.vstack([q0, HOME_Q]), arc, Speed(1.5, 6.0), TIME_STEP))

    # ------------------------------------------------------------------ how they run

    def _primitive(self, run: Callable[[], None]) -> None:
        """Run one primitive; one without an IK solution on its path goes home and is counted."""
        self.events["primitives"] += 1
        try:
            run()
        except IKError:
            self.events["ik_failures"] += 1
        try:
            self._finish()
        except IKError:                                  # pragma: no cover - home is always reachable
            self.events["ik_failures"] += 1

    def _finish(self) -> None:
        """Home, then wait for the world to settle (counted when it does not in time)."""
        self.go_home()
        if not self.scene.settle():
            self.events["unsettled"] += 1

    def _grasp(self, index: int, offset: np.ndarray) -> None:
        s, hand, arm, planner = self.scene, self.hand, self.arm, self.planner
        pos, _ = s.poses()
        if hand.held is not None:
            if hand.held != index:
                self._over(pos[index], s.hand_yaw(), planner.safe_z(hand.hang()))
            return
        aim = pos[index] + offset
        aim[2] = max(aim[2], TIP_BELOW_TCP + 0.003)
        yaw, (transit, descent) = planner.approach([(y, aim) for y in turns(planner.grasp_yaw(index))],
                                                   planner.safe_z(TIP_BELOW_TCP), index)
        hand.set_fingers(FINGER_OPEN)
        if arm.run(transit, self._transit_guard()):
            self.events["arm_collisions"] += 1
            return
        hit = arm.run(descent, grasp_guard(s, index, self.events))
        if hit == "arm":
            self.events["arm_collisions"] += 1
            return
        if hit == "top":
            self.events["top_contacts"] += 1
        elif hand.close_on(index):
            arm.go(np.array([aim[0], aim[1], planner.safe_z(hand.hang())]), yaw, LIFT, FINE_KNOTS,
                   self._transit_guard(index))

    def _over(self, point: np.ndarray, yaw: float, z: float) -> bool:
        """Transit to above ``point`` at height ``z``; True when an arm collision stopped it."""
        if self.arm.go(np.array([point[0], point[1], z]), yaw, TRANSIT, TRANSIT_KNOTS, self._transit_guard()):
            self.events["arm_collisions"] += 1
            return True
        return False

    def _place(self, index: int, offset: np.ndarray) -> None:
        s, hand, arm, planner = self.scene, self.hand, self.arm, self.planner
        if hand.held == index:
            hand.open_fingers()
            hand.release()
            return
        pos, _ = s.poses()
        top = s.tops()[index]
        here = s.hand_yaw()
        shift = np.zeros(3)                        # the TCP's offset from the held object's centre
        if hand.held is None:
            aim = np.array([pos[index, 0], pos[index, 1], top + TIP_BELOW_TCP + RELEASE_GAP]) + offset
            hang = TIP_BELOW_TCP
        else:
            shift = s.tcp() - pos[hand.held]
            aim = np.array([pos[index, 0], pos[index, 1], top + s.bodies[hand.held].size / 2 + RELEASE_GAP]) + offset
            hang = hand.hang()
        candidates = []
        for yaw in turns(here):                    # the TCP's offset from the held object turns with the hand
            c, sn = np.cos(yaw - here), np.sin(yaw - here)
            tcp_aim = aim + np.array([c * shift[0] - sn * shift[1], sn * shift[0] + c * shift[1], shift[2]])
            tcp_aim[2] = max(tcp_aim[2], hang + 0.003)
            candidates.append((yaw, tcp_aim))
        hover_z = max(planner.safe_z(hang), candidates[0][1][2] + 0.02)
        if hand.held is None:
            _, (transit, _) = planner.approach(candidates, hover_z, index)
            if arm.run(transit, self._transit_guard()):
                self.events["arm_collisions"] += 1
            return
        yaw, (transit, descent) = planner.approach(candidates, hover_z, index, hand.held)
        if arm.run(transit, self._transit_guard()):
            self.events["arm_collisions"] += 1
            return
        released = hand.held
        if arm.run(descent, release_guard(s, index, hand.held)) == "arm":
            self.events["arm_collisions"] += 1
        hand.open_fingers()                    # the grasp constraint still holds it: a clean release
        hand.release()
        here = s.tcp()
        arm.go(np.array([here[0], here[1], planner.safe_z(TIP_BELOW_TCP)]), yaw, LIFT, FINE_KNOTS,
               self._transit_guard(index, released))
