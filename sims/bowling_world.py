"""The bowling alley's physics: a lane, a pin deck, pins and a ball in one pybullet DIRECT client.

The alley is a 0.656 scale model of a regulation ten-pin alley, the scale at which the rack's
equilateral triangle has the paper's side of 60 cm (regulation: 36 in = 91.44 cm). Every length
(pin profile, ball, lane width) is scaled by the same factor and every mass by its cube, so the
pins topple, slide and knock each other over the way full-size pins do, only smaller.

Frame: the lane axis is +y (the ball rolls towards +y), x is lateral (+x is the bowler's right),
z is up; the head pin stands at the origin and the deck surface is z = 0. This module knows
nothing about symbols or rewards; :mod:`sims.bowling` builds the task on top of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import pi, sqrt
from pathlib import Path

import numpy as np
import pybullet as pb

SCALE = 0.60 / 0.9144           # the paper's 60 cm rack over the regulation 36 in rack
PIN_SPACING = 0.20              # centre to centre along a side: 60 cm / 3 gaps
ROW_DEPTH = PIN_SPACING * sqrt(3) / 2
PIN_MASS = 1.53 * SCALE ** 3    # regulation 3 lb 6 oz pin
BALL_MASS = 6.35 * SCALE ** 3   # a 14 lb ball
BALL_RADIUS = 0.1085 * SCALE    # regulation 8.5 in diameter
LANE_HALF_WIDTH = 0.527 * SCALE  # regulation 41.5 in wide
GUTTER_WIDTH = 0.235 * SCALE    # regulation 9.25 in: the ball (14.2 cm here) fits in it
DECK_END = 3 * ROW_DEPTH + 0.25  # the pit starts 25 cm behind the last row
LANE_START = -2.0               # where the modelled lane begins (the ball starts 1.5 m before pin 1)
BALL_START_Y = -1.5
FLOOR_Z = -0.06                 # gutters and pit lie below the deck
CAMERA_EYE, CAMERA_TARGET, CAMERA_FOV = (0.0, -1.0, 1.0), (0.0, 0.42, 0.0), 40

# Friction and restitution are combined by Bullet as products of the two bodies' values.
LANE_FRICTION, PIN_FRICTION, BALL_FRICTION = 0.6, 0.5, 0.3
PIN_RESTITUTION, BALL_RESTITUTION, LANE_RESTITUTION = 0.7, 0.6, 0.4


@dataclass(frozen=True)
class PinPart:
    """One convex piece of the pin's compound shape, centred ``z`` above the pin's foot."""

    shape: int           # pb.GEOM_CYLINDER, pb.GEOM_CAPSULE or pb.GEOM_SPHERE
    radius: float
    length: float        # cylinder part of a cylinder or capsule; 0 for a sphere
    z: float

    @property
    def volume(self) -> float:
        cyl = pi * self.radius ** 2 * self.length
        if self.shape == pb.GEOM_CYLINDER:
            return cyl
        return cyl + 4 / 3 * pi * self.radius ** 3


def _pin_profile() -> tuple[PinPart, ...]:
    """A regulation pin (38.1 cm tall, 12.1 cm belly, 5.2 cm base, 4.6 cm neck) at scale.

    Foot, belly, neck and head: four convex pieces follow the silhouette well enough that the pin
    stands on its narrow base, tips over past about 10 degrees and rolls on its belly when down.
    """
    s = SCALE
    return (
        PinPart(pb.GEOM_CYLINDER, 0.0258 * s, 0.046 * s, 0.023 * s),   # foot
        PinPart(pb.GEOM_CAPSULE, 0.0605 * s, 0.030 * s, 0.114 * s),    # belly, widest 11.4 cm up
        PinPart(pb.GEOM_CYLINDER, 0.0230 * s, 0.122 * s, 0.252 * s),   # neck
        PinPart(pb.GEOM_SPHERE, 0.0320 * s, 0.0, 0.349 * s),           # head, top at 38.1 cm
    )


PIN_PARTS = _pin_profile()
PIN_HEIGHT = PIN_PARTS[-1].z + PIN_PARTS[-1].radius
PIN_COM_Z = sum(p.volume * p.z for p in PIN_PARTS) / sum(p.volume for p in PIN_PARTS)


def rack_positions() -> np.ndarray:
    """The 10 pin spots (10 x 2, metres), numbered as in bowling: 1 is the head pin, 7-10 the back row.

    Rows r = 0..3 lie ``r * ROW_DEPTH`` down the lane; spot i of row r sits at
    ``x = (i - r/2) * PIN_SPACING``, numbered from the bowler's left.
    """
    spots = [((i - r / 2) * PIN_SPACING, r * ROW_DEPTH) for r in range(4) for i in range(r + 1)]
    return np.array(spots, dtype=float)


@dataclass(frozen=True)
class PinPoses:
    """Where the pins are: centres of mass (M x 3) and their long (z) axes in the world (M x 3)."""

    positions: np.ndarray
    axes: np.ndarray


class Alley:
    """One pybullet DIRECT client holding the alley; :meth:`build` resets it to a fresh rack.

    The world is rebuilt from scratch for every episode (``resetSimulation``), so an episode's
    physics depends only on its own calls, never on earlier episodes: that is what makes a seed
    reproduce a trace bit for bit.
    """

    def __init__(self, timestep: float = 1 / 240, solver_iterations: int = 10):
        self.timestep = timestep
        self.solver_iterations = solver_iterations
        self.client = pb.connect(pb.DIRECT)
        self.pins: list[int] = []
        self.ball: int | None = None
        self.steps_run = 0          # physics steps since the client was created (for benchmarks)
        self.early_exit = True      # stop a throw once everything rests (benchmarks turn it off)

    # -- building -------------------------------------------------------------------------------
    def build(self, spots: np.ndarray) -> None:
        """A fresh world with one standing pin on each spot (K x 2 array of x, y); no ball yet."""
        c = self.client
        pb.resetSimulation(physicsClientId=c)
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        pb.setPhysicsEngineParameter(fixedTimeStep=self.timestep, numSolverIterations=self.solver_iterations,
                                     deterministicOverlappingPairs=1, physicsClientId=c)
        self._build_alley()
        col, vis = self._pin_shapes()
        self.pins = [pb.createMultiBody(PIN_MASS, col, vis, basePosition=(x, y, PIN_COM_Z + 1e-4),
                                        physicsClientId=c) for x, y in spots]
        for body in self.pins:
            pb.changeDynamics(body, -1, lateralFriction=PIN_FRICTION, restitution=PIN_RESTITUTION,
                              rollingFriction=0.002, spinningFriction=0.002, linearDamping=0.0,
                              angularDamping=0.0, physicsClientId=c)
        self.ball = None

    def _static_box(self, half: tuple[float, float, float], centre: tuple[float, float, float],
                    rgba: tuple[float, float, float, float], friction: float, restitution: float) -> int:
        c = self.client
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=c)
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=rgba, physicsClientId=c)
        body = pb.createMultiBody(0, col, vis, basePosition=centre, physicsClientId=c)
        pb.changeDynamics(body, -1, lateralFriction=friction, restitution=restitution, physicsClientId=c)
        return body

    def _build_alley(self) -> None:
        """Lane and deck (one slab), gutters and pit below it, side kickbacks and the pit cushion."""
        length = DECK_END - LANE_START
        wood = (0.80, 0.62, 0.40, 1)
        self._static_box((LANE_HALF_WIDTH, length / 2, 0.05), (0, (DECK_END + LANE_START) / 2, -0.05),
                         wood, LANE_FRICTION, LANE_RESTITUTION)
        far = DECK_END + 0.6
        self._static_box((1.0, (far - LANE_START) / 2, 0.05), (0, (far + LANE_START) / 2, FLOOR_Z - 0.05),
                         (0.15, 0.15, 0.15, 1), LANE_FRICTION, 0.2)
        wall = (0.25, 0.25, 0.3, 1)
        side_len = (far + 0.5) / 2
        for sign in (-1, 1):
            self._static_box((0.02, side_len, 0.15), (sign * (LANE_HALF_WIDTH + GUTTER_WIDTH + 0.02),
                                                      far - side_len, 0.09),
                             wall, 0.5, 0.3)
        self._static_box((LANE_HALF_WIDTH + GUTTER_WIDTH + 0.04, 0.02, 0.15), (0, far, 0.09), wall, 0.8, 0.1)

    def _pin_shapes(self) -> tuple[int, int]:
        """Compound collision and visual shapes of one pin, framed at its centre of mass."""
        c = self.client
        kinds = [p.shape for p in PIN_PARTS]
        radii = [p.radius for p in PIN_PARTS]
        lengths = [p.length for p in PIN_PARTS]
        frames = [(0.0, 0.0, p.z - PIN_COM_Z) for p in PIN_PARTS]
        col = pb.createCollisionShapeArray(kinds, radii=radii, lengths=lengths, collisionFramePositions=frames,
                                           physicsClientId=c)
        white, red = (0.95, 0.95, 0.92, 1), (0.8, 0.1, 0.1, 1)
        vis = pb.createVisualShapeArray(kinds, radii=radii, lengths=lengths, visualFramePositions=frames,
                                        rgbaColors=[white, white, red, white], physicsClientId=c)
        return col, vis

    # -- observing ------------------------------------------------------------------------------
    def poses(self) -> PinPoses:
        c = self.client
        pos, axes = [], []
        for body in self.pins:
            p, q = pb.getBasePositionAndOrientation(body, physicsClientId=c)
            m = pb.getMatrixFromQuaternion(q)
            pos.append(p)
            axes.append((m[2], m[5], m[8]))
        return PinPoses(np.array(pos, dtype=float), np.array(axes, dtype=float))

    def _moving(self, lin_tol: float, ang_tol: float) -> bool:
        c = self.client
        bodies = self.pins + ([self.ball] if self.ball is not None else [])
        for body in bodies:
            v, w = pb.getBaseVelocity(body, physicsClientId=c)
            if v[0] * v[0] + v[1] * v[1] + v[2] * v[2] > lin_tol * lin_tol:
                return True
            if w[0] * w[0] + w[1] * w[1] + w[2] * w[2] > ang_tol * ang_tol:
                return True
        return False

    # -- acting ---------------------------------------------------------------------------------
    def run(self, max_time: float, check_every: int = 6, lin_tol: float = 0.01, ang_tol: float = 0.1,
            calm_checks: int = 3) -> float:
        """Step until nothing moves (``calm_checks`` checks in a row) or ``max_time`` passes.

        The ball is taken out once it has rolled past the deck into the pit, so a ball rolling
        around the pit does not keep the episode alive. Returns the simulated time.
        """
        c = self.client
        steps_max = int(round(max_time / self.timestep))
        calm = 0
        for k in range(1, steps_max + 1):
            pb.stepSimulation(physicsClientId=c)
            if k % check_every:
                continue
            self._drop_ball_in_pit()
            calm = 0 if self._moving(lin_tol, ang_tol) else calm + 1
            if calm >= calm_checks and self.early_exit:
                break
        self.steps_run += k
        return k * self.timestep

    def _drop_ball_in_pit(self) -> None:
        if self.ball is None:
            return
        (x, y, z), _ = pb.getBasePositionAndOrientation(self.ball, physicsClientId=self.client)
        if y > DECK_END + BALL_RADIUS or z < -BALL_RADIUS:
            pb.removeBody(self.ball, physicsClientId=self.client)
            self.ball = None

    def launch(self, x: float, speed: float) -> None:
        """Place the ball on the lane at lateral ``x`` and roll it down the lane (+y) at ``speed``."""
        c = self.client
        if self.ball is not None:
            pb.removeBody(self.ball, physicsClientId=c)
        col = pb.createCollisionShape(pb.GEOM_SPHERE, radius=BALL_RADIUS, physicsClientId=c)
        vis = pb.createVisualShape(pb.GEOM_SPHERE, radius=BALL_RADIUS, rgbaColor=(0.1, 0.2, 0.7, 1),
                                   physicsClientId=c)
        self.ball = pb.createMultiBody(BALL_MASS, col, vis, basePosition=(x, BALL_START_Y, BALL_RADIUS),
                                       physicsClientId=c)
        # pybullet damps every body by default (linear 0.04, angular 0.04 per second): a ball launched
        # rolling at 6 m/s reached the head pin at 5.19 m/s, skidding; no air drag acts at this scale
        pb.changeDynamics(self.ball, -1, lateralFriction=BALL_FRICTION, restitution=BALL_RESTITUTION,
                          rollingFriction=0.0005, linearDamping=0.0, angularDamping=0.0, physicsClientId=c)
        # rolling without slipping: the contact point is at rest, so omega_x = -v / r
        pb.resetBaseVelocity(self.ball, (0, speed, 0), (-speed / BALL_RADIUS, 0, 0), physicsClientId=c)

    # -- looking --------------------------------------------------------------------------------
    def _camera(self, width: int, height: int) -> tuple[list[float], list[float]]:
        """View and projection matrices: from above and behind the bowler's end, looking down the lane."""
        c = self.client
        view = pb.computeViewMatrix(cameraEyePosition=CAMERA_EYE, cameraTargetPosition=CAMERA_TARGET,
                                    cameraUpVector=(0, 0, 1), physicsClientId=c)
        proj = pb.computeProjectionMatrixFOV(fov=CAMERA_FOV, aspect=width / height, nearVal=0.05, farVal=6.0,
                                             physicsClientId=c)
        return view, proj

    def image(self, width: int, height: int) -> np.ndarray:
        """An RGB image (height x width x 3, uint8) of the alley (pybullet's software renderer)."""
        view, proj = self._camera(width, height)
        _, _, rgba, _, _ = pb.getCameraImage(width, height, view, proj, renderer=pb.ER_TINY_RENDERER,
                                             physicsClientId=self.client)
        return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]

    def pixels(self, points: np.ndarray, width: int, height: int) -> np.ndarray:
        """Where world points (K x 3) appear in :meth:`image` (K x 2 pixel columns and rows)."""
        view, proj = self._camera(width, height)
        # pybullet's matrices are column-major (OpenGL): reshape to 4 x 4 and transpose
        m = np.array(proj).reshape(4, 4).T @ np.array(view).reshape(4, 4).T
        clip = np.hstack([points, np.ones((len(points), 1))]) @ m.T
        ndc = clip[:, :2] / clip[:, 3:4]
        return np.column_stack([(ndc[:, 0] + 1) / 2 * width, (1 - ndc[:, 1]) / 2 * height])

    def close(self) -> None:
        if self.client is not None and self.client >= 0:
            pb.disconnect(physicsClientId=self.client)
        self.client = -1


def save_png(path: str | Path, rgb: np.ndarray, labels: list[tuple[float, float, str]] = ()) -> None:
    """Write an RGB image as PNG atomically, with text labels at (column, row) pixels.

    matplotlib's Agg canvas draws the labels, so the file has exactly the image's pixel size.
    """
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from groundsym.fileio import atomic_write_bytes

    height, width = rgb.shape[:2]
    dpi = 100
    fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.imshow(rgb, interpolation="nearest")
    ax.set_axis_off()
    size = max(6.0, height / 45)
    for col, row, text in labels:
        if 0 <= col < width and 0 <= row < height:
            ax.text(col, row, text, fontsize=size, ha="center", va="bottom", color="black",
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.75})
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    atomic_write_bytes(path, buf.getvalue())
