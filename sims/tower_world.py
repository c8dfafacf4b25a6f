"""The tower cell's physical world: a table, a Franka Panda with its hand, cubes and balls.

This module owns pybullet (DIRECT mode, one private client per world) and the arm's controller; it
knows nothing about features, atoms or rewards (``sims/tower.py`` reads those from its poses and
contacts). The arm really moves: every waypoint is turned into joint targets by inverse kinematics
and reached by the joint motors, stepping the physics all the way. Objects are never teleported;
a grasp is stabilised by a fixed constraint once both fingers touch the object, and released by
removing it, so what is let go falls as physics dictates.

Speed comes from few physics steps, not from skipping physics: a 1/120 s step with 4 sub-steps
(the cubes stack stably), fast joint motors, an early exit as soon as the world has settled, and
objects that sleep once they have rested for 2 s (Bullet's deactivation: a sleeping object is not
integrated, and wakes the moment anything awake touches it or what it rests on). See
``benchmarks/bench_sim.py``.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .tower_kinematics import HOME_POSE, TCP_LINK, ArmKinematics, IKError, Speed, pb, pybullet_data, trajectory

TIME_STEP = 1.0 / 120.0
SUB_STEPS = 4
SOLVER_ITERATIONS = 20

ARM_JOINTS = tuple(range(7))
FINGER_JOINTS = (9, 10)
LEFT_FINGER, RIGHT_FINGER = 9, 10
HAND_LINK = 8
HAND_PARTS = (HAND_LINK, LEFT_FINGER, RIGHT_FINGER)
ARM_FORCES = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
POSITION_GAIN = 0.2                # joint motors: position and velocity gains of the tracking law
VELOCITY_GAIN = 1.0
POSITION_GAINS, VELOCITY_GAINS = (POSITION_GAIN,) * 7, (VELOCITY_GAIN,) * 7
FINGER_OPEN = 0.04                 # per finger (pads 7.2 cm apart when open)
FINGER_FORCE = 40.0
HOME_Q = np.array(HOME_POSE)
ELBOWS = ((0.6, -0.6), (-0.6, 0.6), (1.0, -1.0), (-1.0, 1.0))   # other arm postures tried for a clear pose
TIP_BELOW_TCP = 0.013             # fingertips reach this far below the TCP
TRANSIT_CLEARANCE = 0.05           # TCP transit height above the highest object (plus what hangs below)
RELEASE_GAP = 0.012                # gap between a released object's bottom and the target's top
PALM_HALF = (0.105, 0.035)         # half extents of the hand across (along the finger axis) and deep
TABLE_HALF = (0.45, 0.6, 0.02)     # table top at z = 0
TABLE_CENTRE = (0.45, 0.0)
FLOOR_Z = -0.62                    # the room's floor, out of the arm's reach
CONTACT_UP = 0.7                   # a contact normal with |z| above this is a touch from above
ARM_CLEARANCE = 0.01               # m: wanted between the arm at a grasp or release pose and other objects
MAX_YAW = 2.0                      # rad: hand yaws the wrist reaches from home with room to spare

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
SETTLE_LIN = 0.01                  # m/s: the world is settled below these speeds
SETTLE_ANG = 0.1                   # rad/s
SETTLE_STEPS = 240                 # 2 s: a primitive reads the scene after this at the latest
SLEEP_MOTION = SETTLE_LIN ** 2     # (m/s)^2: an object with v^2 + w^2 below this for 2 s goes to sleep

Guard = Callable[[], "str | None"]


@dataclass(frozen=True)
class Leg:
    """One planned straight TCP move: joint knots, their arc lengths, the speed profile."""

    knots: np.ndarray
    arc: np.ndarray
    speed: Speed


@dataclass(frozen=True)
class Body:
    """One manipulable object: its pybullet id, shape and size (edge or diameter, in metres)."""

    uid: int
    shape: str                     # "cube", "ball" or "can" (an upright cylinder as tall as it is wide)
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
        self.kin = ArmKinematics()
        self.events: Counter[str] = Counter()   # what the controller met, over the world's life
        self.clearance: float | None = None     # when not None: the least transit clearance seen (m)

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
                                 flags=pb.URDF_USE_INERTIA_FROM_FILE | pb.URDF_ENABLE_CACHED_GRAPHICS_SHAPES,
                                 physicsClientId=c)
        for j, q in zip(ARM_JOINTS, HOME_Q):
            pb.resetJointState(self.robot, j, q, physicsClientId=c)
        for j in FINGER_JOINTS:
            pb.resetJointState(self.robot, j, FINGER_OPEN, physicsClientId=c)
        self._command(HOME_Q, np.zeros(7))
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
        elif shape == "can":                                         # upright cylinder, height = diameter
            col = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=half, height=size, physicsClientId=c)
            vis = pb.createVisualShape(pb.GEOM_CYLINDER, radius=half, length=size, rgbaColor=(0.9, 0.75, 0.15, 1),
                                       physicsClientId=c)
            mass = 800.0 * np.pi / 4 * size ** 3
        else:
            col = pb.createCollisionShape(pb.GEOM_SPHERE, radius=half, physicsClientId=c)
            vis = pb.createVisualShape(pb.GEOM_SPHERE, radius=half, rgbaColor=(0.2, 0.7, 0.3, 1), physicsClientId=c)
            mass = 800.0 * np.pi / 6 * size ** 3
        orn = pb.getQuaternionFromEuler((0, 0, yaw))
        uid = pb.createMultiBody(mass, col, vis, (x, y, half), orn, physicsClientId=c)
        pb.changeDynamics(uid, -1, lateralFriction=0.7, rollingFriction=0.0005 if shape == "ball" else 0.0,
                          spinningFriction=0.001, activationState=pb.ACTIVATION_STATE_ENABLE_SLEEPING,
                          sleepThreshold=SLEEP_MOTION, physicsClientId=c)
        return Body(uid, shape, size)

    def close(self) -> None:
        if self.client >= 0:
            pb.disconnect(physicsClientId=self.client)
            self.client = -1
        self.kin.close()

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

    def arm_q(self) -> np.ndarray:
        states = pb.getJointStates(self.robot, ARM_JOINTS, physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def _arrived(self, target: np.ndarray) -> bool:
        """Every arm joint within ``ARRIVE_TOL`` of ``target`` and slower than ``REST_SPEED``."""
        states = pb.getJointStates(self.robot, ARM_JOINTS, physicsClientId=self.client)
        return (max(abs(s[0] - t) for s, t in zip(states, target)) < ARRIVE_TOL
                and max(abs(s[1]) for s in states) < REST_SPEED)

    def _command(self, q: np.ndarray, qd: np.ndarray) -> None:
        """Joint motor targets: position ``q`` with feed-forward velocity ``qd`` (tracking a path)."""
        pb.setJointMotorControlArray(self.robot, ARM_JOINTS, pb.POSITION_CONTROL, targetPositions=q.tolist(),
                                     targetVelocities=qd.tolist(), forces=ARM_FORCES, positionGains=POSITION_GAINS,
                                     velocityGains=VELOCITY_GAINS, physicsClientId=self.client)

    def _set_fingers(self, width: float | tuple[float, float]) -> None:
        widths = (width, width) if np.isscalar(width) else width
        for j, w in zip(FINGER_JOINTS, widths):
            pb.setJointMotorControl2(self.robot, j, pb.POSITION_CONTROL, targetPosition=float(w),
                                     force=FINGER_FORCE, maxVelocity=0.3, physicsClientId=self.client)

    def _finger_q(self) -> tuple[float, float]:
        states = pb.getJointStates(self.robot, FINGER_JOINTS, physicsClientId=self.client)
        return states[0][0], states[1][0]

    # ------------------------------------------------------------------ moving the hand

    def follow(self, q: np.ndarray, qd: np.ndarray, guard: Guard | None = None, watch: bool = False) -> str | None:
        """Track the joint trajectory ``q`` (velocities ``qd``) step by step, then wait to arrive.

        With a ``guard``, the motion stops the first step the guard names a reason (the arm holds
        where it is) and the reason is returned. With ``watch`` (a transit) and :attr:`clearance`
        set, the least distance to the objects is recorded.
        """
        watch = watch and self.clearance is not None
        for k in range(len(q)):
            self._command(q[k], qd[k])
            self.step()
            if watch:
                self._watch_clearance()
            hit = guard() if guard else None
            if hit:
                self._command(self.arm_q(), np.zeros(7))
                return hit
        self._command(q[-1], np.zeros(7))
        for _ in range(ARRIVE_STEPS):
            if self._arrived(q[-1]):
                break
            self.step()
            hit = guard() if guard else None
            if hit:
                self._command(self.arm_q(), np.zeros(7))
                return hit
        return None

    def go(self, end: np.ndarray, yaw: float, speed: Speed, spacing: float,
           guard: Guard | None = None) -> str | None:
        """Move the TCP along a straight line from where it is to ``end`` (hand down, yaw turning
        evenly to ``yaw``). Raises :class:`IKError` when a point of the line has no solution."""
        knots, arc = self.kin.line(self.arm_q(), self.tcp(), np.asarray(end, dtype=float), self._hand_yaw(),
                                   yaw, spacing)
        return self.follow(*trajectory(knots, arc, speed, TIME_STEP), guard, watch=speed is TRANSIT)

    def go_home(self) -> None:
        """Up to the transit height, along a straight line to above home, and into the home pose."""
        here = self.tcp()
        safe = self._safe_z(self._hang())
        hits = []
        if here[2] < safe - 0.005:
            hits.append(self.go(np.array([here[0], here[1], safe]), self._hand_yaw(), LIFT, TRANSIT_KNOTS,
                                self._guard_transit()))
        home_tcp, _ = self.kin.fk(HOME_Q)
        try:                                   # the posture moves evenly into the home pose's ...
            knots, arc = self.kin.line(self.arm_q(), self.tcp(), home_tcp, self._hand_yaw(), 0.0, TRANSIT_KNOTS, HOME_Q)
        except IKError:                        # ... or, if that jumps, as the solver goes
            knots, arc = self.kin.line(self.arm_q(), self.tcp(), home_tcp, self._hand_yaw(), 0.0, TRANSIT_KNOTS)
        hits.append(self._run(Leg(knots, arc, TRANSIT), self._guard_transit()))
        self.events["arm_collisions"] += sum(h is not None for h in hits)
        q0 = self.arm_q()
        arc = np.array([0.0, float(np.abs(HOME_Q - q0).max())])
        self.follow(*trajectory(np.vstack([q0, HOME_Q]), arc, Speed(1.5, 6.0), TIME_STEP))

    # ------------------------------------------------------------------ guards

    def _touches(self, uid: int) -> list:
        """Contacts of body ``uid`` with anything (gap under 2 mm): (other body, own link, normal z)."""
        pts = pb.getContactPoints(bodyA=uid, physicsClientId=self.client)
        return [(p[2], p[3], p[7][2]) for p in pts if p[8] < 0.002]

    def _object_ids(self, *skip: int | None) -> set[int]:
        return {b.uid for k, b in enumerate(self.bodies) if k not in skip}

    def _guard_transit(self, *skip: int | None) -> Guard:
        """Any arm link, or the held object, touching an object (other than ``skip``, or one it
        touches already: a move may leave what it rests on) stops the arm."""
        held = None if self.held is None else self.bodies[self.held].uid
        touching = {b for uid in (self.robot, held) if uid is not None for b, _, _ in self._touches(uid)}
        others = self._object_ids(self.held, *skip) - touching

        def transit() -> str | None:
            hit = any(b in others for b, _, _ in self._touches(self.robot))
            if not hit and held is not None:
                hit = any(b in others for b, _, _ in self._touches(held))
            return "arm" if hit else None

        return transit

    def _guard_grasp(self, index: int) -> Guard:
        """The descent onto object ``index``: a hand part touching it from above stops the hand
        (a fingertip on top); a touch on its side is part of a grasp; the fingers on the table
        stop the hand there; any arm link touching another object stops the arm."""
        target = self.bodies[index].uid
        others = self._object_ids(index)
        sided = [False]

        def grasp() -> str | None:
            for body, link, nz in self._touches(self.robot):
                if body in others:
                    return "arm"
                if body == target:
                    if link in HAND_PARTS and abs(nz) > CONTACT_UP:
                        return "top"
                    if not sided[0]:
                        sided[0] = True
                        self.events["side_contacts"] += 1
                if body == self.table:
                    return "table"
            return None

        return grasp

    def _guard_release(self, index: int) -> Guard:
        """The descent with the held object over ``index``: the held object (or the hand) touching
        anything lets it go there; any arm link touching an object other than ``index`` stops."""
        held = self.bodies[self.held].uid
        target = self.bodies[index].uid
        others = self._object_ids(index, self.held)

        def release() -> str | None:
            for body, _, _ in self._touches(self.robot):
                if body in others:
                    return "arm"
                if body in (target, self.table):
                    return "placed"
            if any(body != self.robot for body, _, _ in self._touches(held)):
                return "placed"
            return None

        return release

    def _watch_clearance(self) -> None:
        """Record the least distance between the arm (or held object) and any object not held."""
        held = None if self.held is None else self.bodies[self.held].uid
        for b in self.bodies:
            if b.uid == held:
                continue
            for body in (self.robot, held):
                if body is None:
                    continue
                pts = pb.getClosestPoints(body, b.uid, 0.05, physicsClientId=self.client)
                if pts:
                    self.clearance = min(self.clearance, min(p[8] for p in pts))

    # ------------------------------------------------------------------ the hand

    def open_fingers(self, max_steps: int = 40) -> None:
        """Open the hand and wait until both fingers are (nearly) fully open."""
        self._set_fingers(FINGER_OPEN)
        for _ in range(max_steps):
            self.step()
            if min(self._finger_q()) > FINGER_OPEN - 0.002:
                return

    def _close_on(self, index: int, steps: int = 40) -> bool:
        """Close the fingers; the moment both touch object ``index``, fix the grasp and hold the
        fingers where they are, so they do not squeeze the held object against the fixed
        constraint (squeezing turned it in the hand; see :meth:`attach` for the contacts)."""
        self._set_fingers(0.0)
        for i in range(steps):
            self.step()
            if i % 2 == 1 and self.attach(index):
                self._set_fingers(self._finger_q())
                self.step(2)
                return True
        self._set_fingers(FINGER_OPEN)
        return False

    def attach(self, index: int) -> bool:
        """Stabilise the grasp of object ``index`` with a fixed constraint if both fingers touch it.

        While the constraint holds, the fingers' contacts with the held object are switched off:
        the constraint is the grasp, and finger contacts on top of it over-determine the object.
        With them, a fast wrist turn (the transit home after a grasp) let the solver pivot the
        cube a few degrees about the finger axis, where the fingers' friction then wedged it off
        the constraint's pose until the fingers opened (in-hand turns up to 5 deg at 7.5 mm noise,
        traced per step; without them, under 0.5 deg). The fingers stay where they closed."""
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
        self._finger_contacts(uid, False)
        self.held = index
        return True

    def _finger_contacts(self, uid: int, on: bool) -> None:
        for finger in (LEFT_FINGER, RIGHT_FINGER):
            pb.setCollisionFilterPair(self.robot, uid, finger, -1, int(on), physicsClientId=self.client)

    def release(self) -> None:
        """Remove the grasp constraint (the fingers are open by now) and give the fingers their
        contacts with the object back."""
        if self.grasp is not None:
            pb.removeConstraint(self.grasp, physicsClientId=self.client)
        if self.held is not None:
            self._finger_contacts(self.bodies[self.held].uid, True)
        self.grasp = self.held = None

    def settled(self) -> bool:
        for b in self.bodies:
            v, w = pb.getBaseVelocity(b.uid, physicsClientId=self.client)
            if max(abs(x) for x in v) > SETTLE_LIN or max(abs(x) for x in w) > SETTLE_ANG:
                return False
        return True

    def settle(self, max_steps: int = SETTLE_STEPS, check_every: int = 4) -> bool:
        """Step until every object is (almost) at rest, at most ``max_steps`` steps; say whether
        it came to rest."""
        for i in range(0, max_steps, check_every):
            self.step(check_every)
            if self.settled():
                return True
        return False

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
        return float((best + np.pi / 2) % np.pi - np.pi / 2)    # the same grasp, turned least from home

    def _approach(self, candidates: list[tuple[float, np.ndarray]], hover_z: float,
                  *skip: int | None) -> tuple[float, list[Leg]]:
        """Plan the transit to above the aim at ``hover_z`` and the vertical descent onto it, for
        the first ``(hand yaw, aim)`` (yaws that grasp or place the same way, in order of
        preference) whose whole path has IK solutions and whose arm keeps ``ARM_CLEARANCE`` from
        every object but ``skip`` all along the descent; else the clearest plannable one; each in
        the posture the solver goes to first, then in the other postures of ``ELBOWS``. Low next
        to a tall tower, the wrist or forearm can otherwise touch its top. Checked on the
        kinematic copy with copies of the objects. Raises :class:`IKError` if nothing works."""
        pos, orn = self.poses()
        self.kin.place([(b.shape, b.size, pos[k], orn[k]) for k, b in enumerate(self.bodies) if k not in skip])
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
            return self._plan([(hover, TRANSIT, TRANSIT_KNOTS), (aim, DESCENT, FINE_KNOTS)], yaw)
        q_aim = self.kin.solve_elbow(aim, yaw, elbow)
        if self.kin.clearance(q_aim) < ARM_CLEARANCE:
            raise IKError("this posture does not clear the objects either")
        q_hover, _ = self.kin.solve(hover, yaw, q_aim)
        transit = self.kin.line(self.arm_q(), self.tcp(), hover, self._hand_yaw(), yaw, TRANSIT_KNOTS, q_hover)
        descent = self.kin.line(transit[0][-1], hover, aim, yaw, yaw, FINE_KNOTS, q_aim)
        return [Leg(*transit, TRANSIT), Leg(*descent, DESCENT)]

    def _plan(self, moves: list[tuple[np.ndarray, Speed, float]], yaw: float) -> list[Leg]:
        """Joint knots of consecutive straight TCP moves (end, speed, knot spacing) from here."""
        q, p, y = self.arm_q(), self.tcp(), self._hand_yaw()
        legs = []
        for end, speed, spacing in moves:
            knots, arc = self.kin.line(q, p, end, y, yaw, spacing)
            legs.append(Leg(knots, arc, speed))
            q, p, y = knots[-1], end, yaw
        return legs

    def _run(self, leg: Leg, guard: Guard) -> str | None:
        return self.follow(*trajectory(leg.knots, leg.arc, leg.speed, TIME_STEP), guard, watch=leg.speed is TRANSIT)

    @staticmethod
    def _turns(yaw: float) -> list[float]:
        """``yaw`` and the same hand turned by a half and quarter turns, within the wrist's reach."""
        out = [yaw + k * np.pi / 2 for k in (0, 2, -2, 1, -1)]
        return [y for y in out if abs(y) <= MAX_YAW]

    def _hand_yaw(self) -> float:
        q = pb.getLinkState(self.robot, TCP_LINK, physicsClientId=self.client)[5]
        return float(pb.getEulerFromQuaternion(q)[2])

    def _hang(self) -> float:
        """How far below the TCP the hand reaches: the fingertips, or the held object's bottom."""
        if self.held is None:
            return TIP_BELOW_TCP
        b = self.bodies[self.held]
        z = pb.getBasePositionAndOrientation(b.uid, physicsClientId=self.client)[0][2]
        return max(TIP_BELOW_TCP, float(self.tcp()[2] - z + b.size / 2))

    def _finish(self) -> None:
        """Home, then wait for the world to settle (counted when it does not in time)."""
        self.go_home()
        if not self.settle():
            self.events["unsettled"] += 1

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

    def close_hand_around(self, index: int, offset: np.ndarray) -> None:
        """Move above object ``index`` (aim moved by ``offset``), descend, close, lift, go home.

        The descent is a straight vertical line, guarded: a hand part touching the target from
        above (a fingertip on top) abandons the grasp; a finger brushing its side does not; an
        arm link touching another object stops the arm (counted). If the fingertips touch the
        table, the hand closes there. With something already in the hand it cannot close around
        another object: the arm goes above it and back.
        """
        self._primitive(lambda: self._grasp(index, offset))

    def _grasp(self, index: int, offset: np.ndarray) -> None:
        pos, _ = self.poses()
        if self.held is not None:
            if self.held != index:
                self._over(pos[index], self._hand_yaw(), self._safe_z(self._hang()))
            return
        aim = pos[index] + offset
        aim[2] = max(aim[2], TIP_BELOW_TCP + 0.003)
        yaw, (transit, descent) = self._approach([(y, aim) for y in self._turns(self._yaw_of(index))],
                                                 self._safe_z(TIP_BELOW_TCP), index)
        self._set_fingers(FINGER_OPEN)
        if self._run(transit, self._guard_transit()):
            self.events["arm_collisions"] += 1
            return
        hit = self._run(descent, self._guard_grasp(index))
        if hit == "arm":
            self.events["arm_collisions"] += 1
            return
        if hit == "top":
            self.events["top_contacts"] += 1
        elif self._close_on(index):
            self.go(np.array([aim[0], aim[1], self._safe_z(self._hang())]), yaw, LIFT, FINE_KNOTS,
                    self._guard_transit(index))

    def _over(self, point: np.ndarray, yaw: float, z: float) -> bool:
        """Transit to above ``point`` at height ``z``; True when an arm collision stopped it."""
        if self.go(np.array([point[0], point[1], z]), yaw, TRANSIT, TRANSIT_KNOTS, self._guard_transit()):
            self.events["arm_collisions"] += 1
            return True
        return False

    def open_hand_over(self, index: int, offset: np.ndarray) -> None:
        """Move what is held over object ``index`` (aim moved by ``offset``), open, go home.

        The held object is brought straight down to a small gap above the top of ``index`` and
        let go, so it drops onto it and may fall off; if it touches anything on the way, the hand
        lets go there. Over the held object itself the hand opens where it is. With an empty hand
        only the arm moves.
        """
        self._primitive(lambda: self._place(index, offset))

    def _place(self, index: int, offset: np.ndarray) -> None:
        if self.held == index:
            self.open_fingers()
            self.release()
            return
        pos, _ = self.poses()
        top = self.tops()[index]
        here = self._hand_yaw()
        shift = np.zeros(3)                        # the TCP's offset from the held object's centre
        if self.held is None:
            aim = np.array([pos[index, 0], pos[index, 1], top + TIP_BELOW_TCP + RELEASE_GAP]) + offset
            hang = TIP_BELOW_TCP
        else:
            shift = self.tcp() - pos[self.held]
            aim = np.array([pos[index, 0], pos[index, 1], top + self.bodies[self.held].size / 2 + RELEASE_GAP]) + offset
            hang = self._hang()
        candidates = []
        for yaw in self._turns(here):              # the TCP's offset from the held object turns with the hand
            c, s = np.cos(yaw - here), np.sin(yaw - here)
            tcp_aim = aim + np.array([c * shift[0] - s * shift[1], s * shift[0] + c * shift[1], shift[2]])
            tcp_aim[2] = max(tcp_aim[2], hang + 0.003)
            candidates.append((yaw, tcp_aim))
        hover_z = max(self._safe_z(hang), candidates[0][1][2] + 0.02)
        if self.held is None:
            _, (transit, _) = self._approach(candidates, hover_z, index)
            if self._run(transit, self._guard_transit()):
                self.events["arm_collisions"] += 1
            return
        yaw, (transit, descent) = self._approach(candidates, hover_z, index, self.held)
        if self._run(transit, self._guard_transit()):
            self.events["arm_collisions"] += 1
            return
        released = self.held
        if self._run(descent, self._guard_release(index)) == "arm":
            self.events["arm_collisions"] += 1
        self.open_fingers()                    # the grasp constraint still holds it: a clean release
        self.release()
        here = self.tcp()
        self.go(np.array([here[0], here[1], self._safe_z(TIP_BELOW_TCP)]), yaw, LIFT, FINE_KNOTS,
                self._guard_transit(index, released))
