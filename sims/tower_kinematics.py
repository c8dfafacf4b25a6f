"""The Panda's kinematics for the tower cell: converged inverse kinematics, checked by forward
kinematics, and straight Cartesian paths turned into timed joint trajectories.

The solver works on a kinematic copy of the arm in a private pybullet client, so solving never
moves the simulated arm (which only ever moves under its joint motors). pybullet's IK is a damped
least-squares iteration that stops early and, for the Panda's 9 movable joints, silently ignores
limit and rest-pose lists of the wrong length; one call from the current pose left millimetres of
error. Here every solve restarts from the previous solution until forward kinematics agree with
the target, and a solve that does not reach :data:`IK_TOL` is reported, never used quietly.
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

TCP_LINK = 11                      # panda_grasptarget: between the finger pads

ARM_LOWER = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
ARM_UPPER = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
IK_TOL = 5e-4                      # m: a solution must put the TCP this close to the target ...
IK_GOAL = 5e-5                     # ... and the iteration stops once it is this close
ORN_TOL = 1e-5                     # 1 - |<q, q_target>|: about 0.5 deg of hand tilt or turn
IK_ROUNDS = 25                     # restarts from the previous solution at most
MAX_KNOT_STEP = 0.4                # rad: a joint turning more than this between knots is a jump, not a path
HOME_POSE = (0.0, -0.55, 0.0, -2.3, 0.0, 1.75, 0.785)
ARM_INDICES = list(range(7))
ARM_AT_REST = [[0.0]] * 7


class IKError(RuntimeError):
    """No joint angles within the limits put the TCP at the target to :data:`IK_TOL`."""


def down(yaw: float) -> tuple[float, ...]:
    """The hand's orientation pointing straight down, turned by ``yaw`` about the vertical."""
    return pb.getQuaternionFromEuler((np.pi, 0.0, yaw))


class ArmKinematics:
    """A kinematic copy of the Panda: forward kinematics and converged inverse kinematics."""

    def __init__(self) -> None:
        self.client = pb.connect(pb.DIRECT)
        pb.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=self.client)
        self.robot = pb.loadURDF("franka_panda/panda.urdf", (0, 0, 0), useFixedBase=True,
                                 physicsClientId=self.client)
        self.obstacles: list[int] = []

    def place(self, objects: list[tuple[str, float, np.ndarray, np.ndarray]]) -> None:
        """Copies of the objects ``(shape, size, position, orientation)`` to check clearance against
        (the previous copies are removed)."""
        c = self.client
        for uid in self.obstacles:
            pb.removeBody(uid, physicsClientId=c)
        self.obstacles = []
        for shape, size, pos, orn in objects:
            if shape == "cube":
                col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=(size / 2,) * 3, physicsClientId=c)
            elif shape == "can":
                col = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=size / 2, height=size, physicsClientId=c)
            else:
                col = pb.createCollisionShape(pb.GEOM_SPHERE, radius=size / 2, physicsClientId=c)
            self.obstacles.append(pb.createMultiBody(0, col, -1, list(pos), list(orn), physicsClientId=c))

    def clearance(self, q: np.ndarray, reach: float = 0.1) -> float:
        """The least distance between any link of the arm at ``q`` and the placed copies (up to
        ``reach``)."""
        self._set(q)
        gaps = [p[8] for uid in self.obstacles
                for p in pb.getClosestPoints(self.robot, uid, reach, physicsClientId=self.client)]
        return float(min(gaps, default=reach))

    def close(self) -> None:
        if self.client >= 0:
            pb.disconnect(physicsClientId=self.client)
            self.client = -1

    def _set(self, q: np.ndarray) -> None:
        """Put the copy's arm at ``q`` (at rest), in one call (this runs for every IK round)."""
        pb.resetJointStatesMultiDof(self.robot, ARM_INDICES, [[float(x)] for x in q[:7]], ARM_AT_REST,
                                    physicsClientId=self.client)

    def fk(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """TCP position and orientation (quaternion) at joint angles ``q``."""
        self._set(q)
        state = pb.getLinkState(self.robot, TCP_LINK, computeForwardKinematics=1, physicsClientId=self.client)
        return np.array(state[4]), np.array(state[5])

    def solve(self, pos: np.ndarray, yaw: float, seed: np.ndarray) -> tuple[np.ndarray, float]:
        """Joint angles putting the TCP at ``pos``, hand down and turned by ``yaw``, near ``seed``.

        Returns the solution and its forward-kinematics residual (m). Raises :class:`IKError` when
        the iteration does not converge within the joint limits.
        """
        orn = np.array(down(yaw))
        target, target_orn = [float(x) for x in pos], orn.tolist()
        q = np.asarray(seed, dtype=float)
        err = np.inf
        self._set(q)
        for _ in range(IK_ROUNDS):                     # each round starts where fk left the copy: at q
            q = np.array(pb.calculateInverseKinematics(self.robot, TCP_LINK, target, target_orn,
                                                       maxNumIterations=50, residualThreshold=1e-6,
                                                       physicsClientId=self.client)[:7])
            p, o = self.fk(q)
            err = float(np.linalg.norm(p - pos))
            if err < IK_GOAL and 1.0 - abs(float(o @ orn)) < ORN_TOL:
                break
        if err > IK_TOL or 1.0 - abs(float(o @ orn)) > ORN_TOL or np.any(q < ARM_LOWER) or np.any(q > ARM_UPPER):
            raise IKError(f"no IK solution for TCP at {np.round(pos, 4).tolist()}, yaw {yaw:.2f} "
                          f"(residual {err * 1000:.2f} mm)")
        return q, err

    def solve_elbow(self, pos: np.ndarray, yaw: float, elbow: tuple[float, float]) -> np.ndarray:
        """A solution whose arm takes another posture for the same hand pose: the null-space solver
        pulled towards the home pose with the base and upper-arm joints turned by ``elbow``, then
        converged as :meth:`solve` does."""
        rest = np.array(HOME_POSE)
        rest[0] += elbow[0]
        rest[2] += elbow[1]
        lower, upper = [*ARM_LOWER, 0.0, 0.0], [*ARM_UPPER, 0.04, 0.04]
        self._set(rest)
        q = pb.calculateInverseKinematics(self.robot, TCP_LINK, list(map(float, pos)), list(down(yaw)),
                                          lowerLimits=lower, upperLimits=upper,
                                          jointRanges=[u - lo for lo, u in zip(lower, upper)],
                                          restPoses=[*rest, 0.04, 0.04], maxNumIterations=200,
                                          physicsClientId=self.client)
        return self.solve(pos, yaw, np.array(q[:7]))[0]

    def line(self, seed: np.ndarray, start: np.ndarray, end: np.ndarray, yaw0: float, yaw1: float,
             spacing: float, goal: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Joint knots along the straight TCP line ``start -> end`` (yaw turning evenly), at most
        ``spacing`` apart, each solved from the previous; returns knots (K x 7) and the arc length
        of each knot. Between knots a 1 cm apart the joint-space interpolation leaves the line by
        micrometres (the path's curvature in joint space is small at this scale). With ``goal``
        (joint angles solving ``end``), each knot is solved from the joint-space blend of the
        previous knot and ``goal``, so the arm's posture moves evenly into the goal's."""
        length = float(np.linalg.norm(end - start))
        turn = abs(yaw1 - yaw0) * 0.1                  # a turn of 0.1 rad counts as 1 cm of path
        n = max(1, int(np.ceil(max(length, turn) / spacing)))
        fractions = np.linspace(0.0, 1.0, n + 1)
        knots = [np.asarray(seed, dtype=float)]
        for i, f in enumerate(fractions[1:], 1):
            guess = knots[-1] if goal is None else knots[-1] + (goal - knots[-1]) / (n + 1 - i)
            q, _ = self.solve(start + f * (end - start), yaw0 + f * (yaw1 - yaw0), guess)
            if np.abs(q - knots[-1]).max() > MAX_KNOT_STEP:
                raise IKError(f"the arm's posture jumps between knots near {np.round(start + f * (end - start), 4).tolist()}")
            knots.append(q)
        return np.array(knots), fractions * max(length, turn)


@dataclass(frozen=True)
class Speed:
    """A speed profile along a path: top speed (m/s), acceleration (m/s^2), and optionally a lower
    speed ``slow`` over the last ``slow_for`` metres (a guarded approach)."""

    top: float
    accel: float
    slow: float = 0.0
    slow_for: float = 0.0


def profile(length: float, speed: Speed, dt: float) -> np.ndarray:
    """Arc-length positions at each control step of a rest-to-rest move over ``length``: as fast as
    the speed limits and the acceleration allow (the last position is ``length``)."""
    if length <= 1e-9:
        return np.array([0.0])
    a, slow_at = speed.accel, length - speed.slow_for
    floor = 0.02 * speed.top
    s, v, out = 0.0, 0.0, []
    while length - s > 1e-9:
        limit = min(speed.top, np.sqrt(2 * a * (length - s)) + floor)
        if speed.slow_for > 0:
            limit = min(limit, speed.slow if s >= slow_at else np.sqrt(speed.slow ** 2 + 2 * a * (slow_at - s)))
        v = min(v + a * dt, limit)
        s = min(s + v * dt, length)
        out.append(s)
    return np.array(out)
def trajectory(knots: np.ndarray, arc: np.ndarray, speed: Speed, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Joint targets and joint velocities at every control step along the knots."""
    s = profile(float(arc[-1]), speed, dt)
    q = np.column_stack([np.interp(s, arc, knots[:, j]) for j in range(knots.shape[1])])
    qd = np.diff(np.vstack([knots[:1], q]), axis=0) / dt
    return q, qd
