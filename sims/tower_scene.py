"""The tower cell's pybullet world: a table, a Franka Panda with its hand, cubes, balls and cans.

This module owns the physics client (DIRECT mode, one private client per world) and everything
that reads the world or steps it: building the room and the objects, poses, contacts, the arm's
joint angles, the objects' highest points, settling. It commands nothing: the joint motors are
:mod:`sims.tower_control`'s and :mod:`sims.tower_hand`'s, the primitives :mod:`sims.tower_skills`'s.
The seam is the one between *what is there* and *what the robot does*: everything above reads
the world through this module and steps it only through :meth:`TowerScene.step` (one place to
count or time the physics, ``benchmarks/bench_sim.py``).

Speed comes from few physics steps, not from skipping physics: a 1/120 s step with 4 sub-steps
(the cubes stack stably), fast joint motors, an early exit as soon as the world has settled, and
objects that sleep once they have rested for 2 s (Bullet's deactivation: a sleeping object is not
integrated, and wakes the moment anything awake touches it or what it rests on). See
``benchmarks/bench_sim.py`` and docs/tower.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .tower_kinematics import HOME_POSE, TCP_LINK, pb, pybullet_data

TIME_STEP = 1.0 / 120.0
SUB_STEPS = 4
SOLVER_ITERATIONS = 20

# the Panda of pybullet_data (franka_panda/panda.urdf): joint and link indices
ARM_JOINTS = tuple(range(7))
FINGER_JOINTS = (9, 10)
LEFT_FINGER, RIGHT_FINGER = 9, 10
HAND_LINK = 8
HAND_PARTS = (HAND_LINK, LEFT_FINGER, RIGHT_FINGER)
FINGER_OPEN = 0.04                 # per finger (pads 7.2 cm apart when open)
HOME_Q = np.array(HOME_POSE)

TABLE_HALF = (0.45, 0.6, 0.02)     # the default table (top at z = 0); sims/tower_layout.py has the others
TABLE_CENTRE = (0.45, 0.0)
FLOOR_Z = -0.62                    # the room's floor, out of the arm's reach
TOUCH_GAP = 0.002                  # m: contact points closer than this touch (penetration or gap)

SETTLE_LIN = 0.01                  # m/s: the world is settled below these speeds
SETTLE_ANG = 0.1                   # rad/s
SETTLE_STEPS = 240                 # 2 s: a primitive reads the scene after this at the latest
SLEEP_MOTION = SETTLE_LIN ** 2     # (m/s)^2: an object with v^2 + w^2 below this for 2 s goes to sleep


@dataclass(frozen=True)
class Body:
    """One manipulable object: its pybullet id, shape and size (edge or diameter, in metres)."""

    uid: int
    shape: str                     # "cube", "ball" or "can" (an upright cylinder as tall as it is wide)
    size: float


class TowerScene:
    """A fresh pybullet client; :meth:`reset` and :meth:`place_objects` make the same world from
    the same placement. The table's top is ``table_half[:2]`` either side of ``table_centre``."""

    def __init__(self, table_half: tuple[float, float, float] = TABLE_HALF,
                 table_centre: tuple[float, float] = TABLE_CENTRE) -> None:
        self.table_half = table_half
        self.table_centre = table_centre
        self.client = pb.connect(pb.DIRECT)
        self.bodies: list[Body] = []
        self.robot = -1
        self.table = -1
        self.steps = 0                     # physics steps taken since the last reset (benchmark)

    # ------------------------------------------------------------------ building

    def reset(self) -> None:
        """Reset the simulation and create the table, the floor and the arm at home, hand open.

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
        half = self.table_half
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=c)
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=(0.78, 0.66, 0.5, 1),
                                   physicsClientId=c)
        self.table = pb.createMultiBody(0, col, vis, (*self.table_centre, -half[2]), physicsClientId=c)
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
        self.bodies = []
        self.steps = 0

    def place_objects(self, placements: list[tuple[str, float, float, float, float]]) -> None:
        """Create the objects, ``(shape, size, x, y, yaw)`` each, resting on the table."""
        self.bodies = [self.make_object(*p) for p in placements]

    def make_object(self, shape: str, size: float, x: float, y: float, yaw: float) -> Body:
        """One object resting on the table at ``(x, y)`` turned by ``yaw``; it may sleep at rest."""
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
        return [p for p in pts if p[8] < TOUCH_GAP]

    def touches(self, uid: int) -> list:
        """Contacts of body ``uid`` with anything (gap under 2 mm): (other body, own link, normal z)."""
        pts = pb.getContactPoints(bodyA=uid, physicsClientId=self.client)
        return [(p[2], p[3], p[7][2]) for p in pts if p[8] < TOUCH_GAP]

    def object_ids(self, *skip: int | None) -> set[int]:
        """The pybullet ids of the objects, but for those at the indices ``skip``."""
        return {b.uid for k, b in enumerate(self.bodies) if k not in skip}

    def tcp(self) -> np.ndarray:
        """Where the hand's tool point (between the finger pads) is."""
        return np.array(pb.getLinkState(self.robot, TCP_LINK, physicsClientId=self.client)[4])

    def hand_yaw(self) -> float:
        """The hand's turn about the vertical."""
        q = pb.getLinkState(self.robot, TCP_LINK, physicsClientId=self.client)[5]
        return float(pb.getEulerFromQuaternion(q)[2])

    def arm_q(self) -> np.ndarray:
        """The arm's seven joint angles."""
        states = pb.getJointStates(self.robot, ARM_JOINTS, physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def finger_q(self) -> tuple[float, float]:
        """The two finger joints' positions (each :data:`FINGER_OPEN` when open)."""
        states = pb.getJointStates(self.robot, FINGER_JOINTS, physicsClientId=self.client)
        return states[0][0], states[1][0]

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

    # ------------------------------------------------------------------ stepping

    def step(self, n: int = 1) -> None:
        """Step the physics ``n`` times: every step of the cell goes through here."""
        for _ in range(n):
            pb.stepSimulation(physicsClientId=self.client)
        self.steps += n

    def settled(self) -> bool:
        """Every object slower than ``SETTLE_LIN`` and ``SETTLE_ANG``."""
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
