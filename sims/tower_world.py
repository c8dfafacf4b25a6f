"""The tower cell's physical world: a table, a Franka Panda with its hand, cubes and balls.

This module owns pybullet (DIRECT mode, one private client per world) and the arm's controller; it
knows nothing about features, atoms or rewards (``sims/tower.py`` reads those from its poses and
contacts). The arm really moves: every waypoint is turned into joint targets by inverse kinematics
and reached by the joint motors, stepping the physics all the way. Objects are never teleported;
a grasp is stabilised by a fixed constraint once both fingers touch the object, and released by
removing it, so what is let go falls as physics dictates.

Speed comes from few physics steps, not from skipping physics: a 1/120 s step with 4 sub-steps
(the cubes stack stably), fast joint motors, loose convergence tests on coarse waypoints and an
early exit as soon as the world has settled. See ``benchmarks/bench_sim.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import os
import sys

import numpy as np


def _flush_c_stdout() -> None:
    try:
        import ctypes
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):  # pragma: no cover - no C library to flush
        pass


def _import_quietly():
    """Import pybullet without its "build time" banner on stderr, where progress and errors go."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            import pybullet
            import pybullet_data
            _flush_c_stdout()
    finally:
        os.dup2(saved, 2)
        os.close(saved)
    return pybullet, pybullet_data


pb, pybullet_data = _import_quietly()

TIME_STEP = 1.0 / 120.0
SUB_STEPS = 4
SOLVER_ITERATIONS = 20

ARM_JOINTS = tuple(range(7))
FINGER_JOINTS = (9, 10)
LEFT_FINGER, RIGHT_FINGER = 9, 10
HAND_LINK = 8
TCP_LINK = 11                      # panda_grasptarget: between the finger pads
ARM_FORCES = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
ARM_MAX_VELOCITY = 2.5             # rad/s per joint in transit
FINE_VELOCITY = 0.8                # rad/s per joint when descending among objects
FINGER_OPEN = 0.04                 # per finger (pads 7.2 cm apart when open)
FINGER_FORCE = 40.0
HOME_Q = (0.0, -0.55, 0.0, -2.3, 0.0, 1.75, 0.785)
TIP_BELOW_TCP = 0.013             # fingertips reach this far below the TCP
TRANSIT_CLEARANCE = 0.05           # TCP transit height above the highest object (plus what hangs below)
RELEASE_GAP = 0.012                # gap between a released object's bottom and the target's top
PALM_HALF = (0.105, 0.035)         # half extents of the hand across (along the finger axis) and deep
TABLE_HALF = (0.45, 0.6, 0.02)     # table top at z = 0
TABLE_CENTRE = (0.45, 0.0)
FLOOR_Z = -0.62                    # the room's floor, out of the arm's reach
DOWN = pb.getQuaternionFromEuler((np.pi, 0.0, 0.0))

# controller tolerances
JOINT_TOL = 0.03                   # rad: a transit waypoint counts as reached
FINE_TOL = 0.004                   # rad: a grasp or release pose counts as reached ...
REST_SPEED = 0.05                  # rad/s: ... once every joint is this slow
SETTLE_LIN = 0.01                  # m/s: the world is settled below these speeds
SETTLE_ANG = 0.1                   # rad/s


@dataclass(frozen=True)
class Body:
    """One manipulable object: its pybullet id, shape and size (edge or diameter, in metres)."""

    uid: int
    shape: str                     # "cube" or "ball"
    size: float


class TowerWorld:
    """A fresh pybullet world; :meth:`build` makes the same world from the same placement."""

    def __init__(self) -> None:
        self.client = pb.connect(pb.DIRECT)
        self.bodies: list[Body] = []
        self.robot = -1
        self.table = -1
        self.grasp: int | None = None      # constraint id of the stabilised grasp
        self.held: int | None = None       # index into bodies of the object in the grasp
        self.steps = 0                     # physics steps taken since the last build (benchmark)

    # ------------------------------------------------------------------ building

    def build(self, placements: list[tuple[str, float, float, float, float]]) -> None:
        """Reset the simulation and create the table, the arm at home and the objects.

        ``placements`` holds ``(shape, size, x, y, yaw)`` for each object, resting on the table.
        Rebuilding from scratch (not moving bodies back) is what makes episodes bit-for-bit
        repeatable: pybullet keeps solver warm-start caches across resets of single bodies.
        """
        c = self.client
        pb.resetSimulation(physicsClientId=c)
        pb.setPhysicsEngineParameter(fixedTimeStep=TIME_STEP, numSubSteps=SUB_STEPS,
                                     numSolverIterations=SOLVER_ITERATIONS, deterministicOverlappingPairs=1,
                                     physicsClientId=c)
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        pb.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=c)
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=TABLE_HALF, physicsClientId=c)
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=TABLE_HALF, rgbaColor=(0.78, 0.66, 0.5, 1),
                                   physicsClientId=c)
        self.table = pb.createMultiBody(0, col, vis, (*TABLE_CENTRE, -TABLE_HALF[2]), physicsClientId=c)
        pb.changeDynamics(self.table, -1, lateralFriction=0.8, physicsClientId=c)
        floor_half = (3.0, 3.0, 0.01)                                        # catches what falls off
        floor = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=floor_half, physicsClientId=c)
        floor_vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=floor_half, rgbaColor=(0.85, 0.85, 0.82, 1),
                                         physicsClientId=c)
        pb.createMultiBody(0, floor, floor_vis, (0, 0, FLOOR_Z - floor_half[2]), physicsClientId=c)
        self.robot = pb.loadURDF("franka_panda/panda.urdf", (0, 0, 0), useFixedBase=True,
                                 flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=c)
        for j, q in zip(ARM_JOINTS, HOME_Q):
            pb.resetJointState(self.robot, j, q, physicsClientId=c)
        for j in FINGER_JOINTS:
            pb.resetJointState(self.robot, j, FINGER_OPEN, physicsClientId=c)
        self._hold_arm(HOME_Q)
        self._set_fingers(FINGER_OPEN)
        self.bodies = [self._make_object(*p) for p in placements]
        self.grasp = self.held = None
        self.steps = 0
        self.settle()

    def _make_object(self, shape: str, size: float, x: float, y: float, yaw: float) -> Body:
        c = self.client
        half = size / 2
        if shape == "cube":
            col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=(half,) * 3, physicsClientId=c)
            colour = (0.85, 0.25, 0.2, 1) if size < 0.045 else (0.2, 0.35, 0.85, 1)
            vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=(half,) * 3, rgbaColor=colour, physicsClientId=c)
            mass = 800.0 * size ** 3
        else:
            col = pb.createCollisionShape(pb.GEOM_SPHERE, radius=half, physicsClientId=c)
            vis = pb.createVisualShape(pb.GEOM_SPHERE, radius=half, rgbaColor=(0.2, 0.7, 0.3, 1), physicsClientId=c)
            mass = 800.0 * np.pi / 6 * size ** 3
        orn = pb.getQuaternionFromEuler((0, 0, yaw))
        uid = pb.createMultiBody(mass, col, vis, (x, y, half), orn, physicsClientId=c)
        pb.changeDynamics(uid, -1, lateralFriction=0.7, rollingFriction=0.0005 if shape == "ball" else 0.0,
                          spinningFriction=0.001, physicsClientId=c)
        return Body(uid, shape, size)

    def close(self) -> None:
        if self.client >= 0:
            pb.disconnect(physicsClientId=self.client)
            self.client = -1

    def __del__(self) -> None:  # a forgotten close() must not leak physics servers
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown may have torn pybullet down
            pass

    # ------------------------------------------------------------------ reading the world

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Object centres (M x 3) and orientations as quaternions (M x 4), from the simulator."""
        pos, orn = [], []
        for b in self.bodies:
            p, q = pb.getBasePositionAndOrientation(b.uid, physicsClientId=self.client)
            pos.append(p)
            orn.append(q)
        return np.array(pos, dtype=float).reshape(-1, 3), np.array(orn, dtype=float).reshape(-1, 4)

    def contacts(self, a: int, b: int, link_b: int | None = None) -> list:
        """Touching contact points between bodies ``a`` and ``b`` (penetration or gap under 2 mm)."""
        kw = {} if link_b is None else {"linkIndexB": link_b}
        pts = pb.getContactPoints(bodyA=a, bodyB=b, physicsClientId=self.client, **kw)
        return [p for p in pts if p[8] < 0.002]

    def tcp(self) -> np.ndarray:
        return np.array(pb.getLinkState(self.robot, TCP_LINK, physicsClientId=self.client)[4])

    # ------------------------------------------------------------------ stepping and control

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            pb.stepSimulation(physicsClientId=self.client)
        self.steps += n

    def _hold_arm(self, q: tuple[float, ...] | np.ndarray, speed: float = ARM_MAX_VELOCITY) -> None:
        """Joint motor targets ``q``; joint speeds are scaled so that all joints arrive together,
        which keeps short hand motions (a descent, a lift) close to straight lines."""
        dq = np.abs(np.asarray(q) - self.arm_q())
        scale = dq / max(float(dq.max()), 1e-9)
        for j, qj in zip(ARM_JOINTS, q):
            pb.setJointMotorControl2(self.robot, j, pb.POSITION_CONTROL, targetPosition=float(qj),
                                     force=ARM_FORCES[j], positionGain=0.3,
                                     maxVelocity=float(speed * scale[j] + 0.02), physicsClientId=self.client)

    def _set_fingers(self, width: float) -> None:
        for j in FINGER_JOINTS:
            pb.setJointMotorControl2(self.robot, j, pb.POSITION_CONTROL, targetPosition=width,
                                     force=FINGER_FORCE, maxVelocity=0.3, physicsClientId=self.client)

    def arm_q(self) -> np.ndarray:
        states = pb.getJointStates(self.robot, ARM_JOINTS, physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def ik(self, pos: np.ndarray, yaw: float) -> np.ndarray:
        """Joint angles that put the TCP at ``pos`` with the hand pointing down, turned by ``yaw``."""
        orn = pb.getQuaternionFromEuler((np.pi, 0.0, yaw))
        lower = [-2.9, -1.76, -2.9, -3.07, -2.9, -0.02, -2.9]
        upper = [2.9, 1.76, 2.9, -0.07, 2.9, 3.75, 2.9]
        q = pb.calculateInverseKinematics(self.robot, TCP_LINK, list(pos), orn, lowerLimits=lower,
                                          upperLimits=upper, jointRanges=[u - l for l, u in zip(lower, upper)],
                                          restPoses=list(HOME_Q), maxNumIterations=60,
                                          residualThreshold=1e-4, physicsClientId=self.client)
        return np.array(q[:7])

    def move(self, q: np.ndarray, speed: float = ARM_MAX_VELOCITY, tol: float = JOINT_TOL,
             guard: set[int] | None = None, max_steps: int = 90) -> int | None:
        """Drive the arm to joint angles ``q``; return the id of a guarded body touched first, if any.

        With ``guard`` (body ids), the motion stops as soon as the hand or fingers touch one of them:
        a guarded move, as a real arm does when it descends among objects.
        """
        self._hold_arm(q, speed)
        for i in range(max_steps):
            self.step()
            if guard:
                hit = self._hand_touches(guard)
                if hit is not None:
                    self._hold_arm(self.arm_q(), FINE_VELOCITY)
                    return hit
            if i % 3 == 2 and self._reached(q, tol):
                break
        return None

    def _reached(self, q: np.ndarray, tol: float) -> bool:
        """Within ``tol`` of ``q``; a fine pose must also be (almost) at rest, or a release throws."""
        states = pb.getJointStates(self.robot, ARM_JOINTS, physicsClientId=self.client)
        err = max(abs(s[0] - qj) for s, qj in zip(states, q))
        if err >= tol:
            return False
        return tol >= JOINT_TOL or max(abs(s[1]) for s in states) < REST_SPEED

    def _hand_touches(self, guard: set[int]) -> int | None:
        held = None if self.held is None else self.bodies[self.held].uid
        for uid in sorted(guard):
            if uid == held:
                continue
            for link in (HAND_LINK, LEFT_FINGER, RIGHT_FINGER):
                if self.contacts(uid, self.robot, link):
                    return uid
            if held is not None and self.contacts(uid, held):
                return uid
        return None

    def open_fingers(self, max_steps: int = 40) -> None:
        """Open the hand and wait until both fingers are (nearly) fully open."""
        self._set_fingers(FINGER_OPEN)
        for _ in range(max_steps):
            self.step()
            states = pb.getJointStates(self.robot, FINGER_JOINTS, physicsClientId=self.client)
            if min(st[0] for st in states) > FINGER_OPEN - 0.002:
                return

    def _close_on(self, index: int, steps: int = 30) -> None:
        """Close the fingers; stabilise the grasp the moment both touch object ``index``, before
        squeezing can tilt it."""
        self._set_fingers(0.0)
        for i in range(steps):
            self.step()
            if self.held is None and i % 2 == 1 and self.attach(index):
                self.step(4)
                return

    def _arm_rest(self, max_steps: int = 40) -> None:
        """Let the arm come to rest where it stopped (after a guarded move halted it)."""
        for _ in range(max_steps):
            self.step()
            states = pb.getJointStates(self.robot, ARM_JOINTS, physicsClientId=self.client)
            if max(abs(s[1]) for s in states) < REST_SPEED:
                return

    def attach(self, index: int) -> bool:
        """Stabilise the grasp of object ``index`` with a fixed constraint if both fingers touch it."""
        uid = self.bodies[index].uid
        if not (self.contacts(uid, self.robot, LEFT_FINGER) and self.contacts(uid, self.robot, RIGHT_FINGER)):
            return False
        c = self.client
        hp, hq = pb.getLinkState(self.robot, TCP_LINK, physicsClientId=c)[4:6]
        op, oq = pb.getBasePositionAndOrientation(uid, physicsClientId=c)
        inv_p, inv_q = pb.invertTransform(hp, hq)
        rel_p, rel_q = pb.multiplyTransforms(inv_p, inv_q, op, oq)
        self.grasp = pb.createConstraint(self.robot, TCP_LINK, uid, -1, pb.JOINT_FIXED, (0, 0, 0), rel_p, (0, 0, 0),
                                         rel_q, (0, 0, 0, 1), physicsClientId=c)
        pb.changeConstraint(self.grasp, maxForce=200.0, physicsClientId=c)
        self.held = index
        return True

    def release(self) -> None:
        if self.grasp is not None:
            pb.removeConstraint(self.grasp, physicsClientId=self.client)
        self.grasp = self.held = None

    def settled(self) -> bool:
        for b in self.bodies:
            v, w = pb.getBaseVelocity(b.uid, physicsClientId=self.client)
            if max(abs(x) for x in v) > SETTLE_LIN or max(abs(x) for x in w) > SETTLE_ANG:
                return False
        return True

    def settle(self, max_steps: int = 240, check_every: int = 4) -> None:
        """Step until every object is (almost) at rest, at most ``max_steps`` steps."""
        for i in range(0, max_steps, check_every):
            self.step(check_every)
            if self.settled():
                return

    # ------------------------------------------------------------------ primitives

    def tops(self) -> np.ndarray:
        """Height of each object's highest point (cube corners included, whatever its tilt)."""
        pos, orn = self.poses()
        out = np.empty(len(self.bodies))
        for k, b in enumerate(self.bodies):
            half = b.size / 2
            if b.shape == "ball":
                out[k] = pos[k, 2] + half
            else:
                rz = np.array(pb.getMatrixFromQuaternion(orn[k])).reshape(3, 3)[2]
                out[k] = pos[k, 2] + half * np.abs(rz).sum()
        return out

    def _safe_z(self, extra: float) -> float:
        """A transit height for the TCP that clears every object not in the hand."""
        tops = self.tops()
        if self.held is not None:
            tops[self.held] = 0.0
        return float(max(tops.max(), 0.0) + TRANSIT_CLEARANCE + extra)

    def _yaw_of(self, index: int) -> float:
        """The hand yaw for grasping object ``index``: fingers square to a cube's faces, and of the
        two such yaws the one whose wide palm stays further from the neighbours (as a grasp
        planner would choose)."""
        pos, orn = self.poses()
        base = 0.0
        if self.bodies[index].shape == "cube":
            base = pb.getEulerFromQuaternion(orn[index])[2]
            base = float((base + np.pi / 4) % (np.pi / 2) - np.pi / 4)
        others = [k for k in range(len(self.bodies)) if k != index and k != self.held]
        d = pos[others, :2] - pos[index, :2]
        reach = np.array([self.bodies[k].size for k in others]) * 0.71
        best, best_gap = base, -np.inf
        for yaw in (base, base + np.pi / 2 if base < 0 else base - np.pi / 2):
            along = np.abs(d @ np.array([-np.sin(yaw), np.cos(yaw)])) - reach   # fingers open along hand y
            across = np.abs(d @ np.array([np.cos(yaw), np.sin(yaw)])) - reach
            in_swath = across < PALM_HALF[1]
            gap = float(np.min(along[in_swath] - PALM_HALF[0], initial=1.0))
            if gap > best_gap + 1e-9:
                best, best_gap = yaw, gap
        return best

    def _hand_yaw(self) -> float:
        q = pb.getLinkState(self.robot, TCP_LINK, physicsClientId=self.client)[5]
        return float(pb.getEulerFromQuaternion(q)[2])

    def close_hand_around(self, index: int, offset: np.ndarray) -> None:
        """Move above object ``index`` (aim moved by ``offset``), descend, close, lift, go home.

        The descent is guarded: if the hand touches another object (``index`` is covered, or a
        neighbour is in the way) or the target itself from above, the grasp is abandoned and the
        hand does not close. With something already in the hand it cannot close around another
        object: the arm goes above it and back.
        """
        pos, _ = self.poses()
        if self.held is not None:
            if self.held != index:
                yaw = self._hand_yaw()
                self.move(self.ik(np.array([*pos[index, :2], self._safe_z(self._hang())]), yaw))
            self.move(np.array(HOME_Q))
            self.settle()
            return
        yaw = self._yaw_of(index)
        aim = pos[index] + offset
        aim[2] = max(aim[2], TIP_BELOW_TCP + 0.003)
        safe = self._safe_z(TIP_BELOW_TCP)
        self._set_fingers(FINGER_OPEN)
        self.move(self.ik(np.array([aim[0], aim[1], safe]), yaw))
        objects = {b.uid for b in self.bodies}
        hit = self.move(self.ik(aim, yaw), FINE_VELOCITY, FINE_TOL, objects | {self.table}, 120)
        if hit is None or hit == self.table:
            self._close_on(index)
        self.move(self.ik(np.array([aim[0], aim[1], safe]), yaw), FINE_VELOCITY)
        self.move(np.array(HOME_Q))
        self.settle()

    def _hang(self) -> float:
        """How far below the TCP the hand reaches: the fingertips, or the held object's bottom."""
        if self.held is None:
            return TIP_BELOW_TCP
        b = self.bodies[self.held]
        z = pb.getBasePositionAndOrientation(b.uid, physicsClientId=self.client)[0][2]
        return max(TIP_BELOW_TCP, float(self.tcp()[2] - z + b.size / 2))

    def open_hand_over(self, index: int, offset: np.ndarray) -> None:
        """Move what is held over object ``index`` (aim moved by ``offset``), open, go home.

        The held object is brought to a small gap above the top of ``index`` and let go, so it
        drops onto it and may fall off. Over the held object itself the hand opens where it is.
        With an empty hand only the arm moves.
        """
        if self.held == index:
            self.open_fingers()
            self.release()
            self.settle()
            return
        pos, _ = self.poses()
        top = self.tops()[index]
        yaw = self._hand_yaw()
        if self.held is None:
            aim = np.array([pos[index, 0], pos[index, 1], top + TIP_BELOW_TCP + RELEASE_GAP]) + offset
            hang = TIP_BELOW_TCP
        else:
            held_pos = self.poses()[0][self.held]
            shift = self.tcp() - held_pos          # keep the held object's centre over the target
            half = self.bodies[self.held].size / 2
            aim = np.array([pos[index, 0], pos[index, 1], top + half + RELEASE_GAP]) + offset + shift
            hang = self._hang()
        aim[2] = max(aim[2], hang + 0.003)
        safe = max(self._safe_z(hang), aim[2] + 0.02)
        self.move(self.ik(np.array([aim[0], aim[1], safe]), yaw))
        others = {b.uid for k, b in enumerate(self.bodies) if k != self.held}
        if self.move(self.ik(aim, yaw), FINE_VELOCITY, FINE_TOL, others, 120) is not None:
            self._arm_rest()
        self.open_fingers()                    # the grasp constraint still holds it: a clean release
        self.release()
        self.move(self.ik(np.array([aim[0], aim[1], safe]), yaw), FINE_VELOCITY)
        self.move(np.array(HOME_Q))
        self.settle()
