"""The tower cell: a Franka Panda building towers of cubes (and balls, cans) on a table, as a Sim.

The paper's first scenario (Section VI-B): objects ``o1 .. oM`` (cubes of two sizes, optionally
balls of a third diameter) lie on a table; the robot runs the primitives ``closeHandAround(X)`` and
``openHandOver(X)`` with Gaussian motor noise; it sees each object's centre and size
(``y_i = (x, y, z, size)``) and a reward that measures towers. Physics and the arm's controller live
in :mod:`sims.tower_world`; this module turns the simulator's poses and contacts into scenes,
rewards and (for evaluation only) ground-truth atoms. ``docs/tower.md`` describes the cell.

Reward: ``r`` = mean over cubes (and cans, with ``cans=N``: upright cylinders that stack as cubes
do) of the height of the object's lowest point above the table top, in metres; one in the hand counts 0, so the reward measures towers, not holding. Episode value
``V = sum_{t=1..10} gamma^(t-1) r_t`` with ``gamma = 0.8``, the discount the paper states for its
experiments. :func:`optimal_episode_value` gives the best value in the deterministic world.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from groundsym.errors import UserError
from groundsym.fileio import atomic_write_bytes
from groundsym.logic import Atom
from groundsym.pointcloud import FEATURE_NAMES, MIN_POINTS, PAIR_FEATURE_NAMES, features_from_clouds, mean_differences
from groundsym.options import Option, parse_options
from groundsym.sim import recorded_options
from groundsym.world import Scene

from .camera_picture import write_camera_png
from .tower_camera import DepthCamera, Frame
from .tower_kinematics import pb
from .tower_layout import DEFAULT_WORKSPACE, WORKSPACES, Workspace
from .tower_scene import LEFT_FINGER, RIGHT_FINGER
from .tower_world import TowerWorld

ARM_URDF = "franka_panda/panda.urdf"   # the arm TowerWorld loads (the camera renders it coarser)

GAMMA = 0.8
EPISODE_LENGTH = 10
ON_TABLE_TOL = 0.002               # a lowest point under 2 mm counts as lying on the table (contact slop)
CONTACT_UP = 0.7                   # a contact whose normal has z above this is "resting on"
CAMERA_STREAM = 0x63616d           # second word of the camera's seed: [reset seed, this]

OPTIONS: tuple[Option, ...] = (
    Option("cubes", int, 7, "number of cubes"),
    Option("big", int, None, "how many of the cubes are big (default: 3/7 of them, rounded: 3 of 7)"),
    Option("balls", int, 0, "number of balls"),
    Option("cans", int, 0, "number of cans (upright cylinders, as tall as wide; they count in the reward as cubes do)",
           recorded_at_default=False),
    Option("noise", float, 0.0075, "motor noise: std (m) of the Gaussian added to each axis of a primitive's target "
           "(default chosen from examples/tower_reliability.py, docs/tower.md)"),
    Option("small_size", float, 0.04, "edge of a small cube (m)"),
    Option("big_size", float, 0.05, "edge of a big cube (m)"),
    Option("ball_size", float, 0.045, "diameter of a ball (m)"),
    Option("can_size", float, 0.042, "diameter and height of a can (m)", recorded_at_default=False),
    Option("workspace", str, DEFAULT_WORKSPACE, "where the objects start: table (the paper's cell, at most 10 "
           "objects) or wide (a wider table, start positions over the arm's reachable half-ring, at most 20 objects; "
           "docs/tower.md, Workspaces)", recorded_at_default=False),
    Option("features", str, "pose", "what the learner sees of each object: pose (x, y, z, size from the simulator) "
           "or pointcloud (mean and shape of the object's points seen by the depth camera, docs/perception.md)",
           recorded_at_default=False),
    Option("depth_noise", float, 0.0, "depth camera: std (m) of the depth noise at 1 m depth, growing with "
           "depth squared (features=pointcloud)", recorded_at_default=False),
    Option("depth_dropout", float, 0.0, "depth camera: probability that a pixel returns no depth "
           "(features=pointcloud)", recorded_at_default=False),
)
FEATURE_SPACES = ("pose", "pointcloud")
POSE_FEATURES = ("x", "y", "z", "size")


def resolve_options(given: dict[str, Any]) -> dict[str, Any]:
    """Typed, checked options with defaults filled in (``big`` follows ``cubes`` unless given)."""
    opts = parse_options("--sim-opt", "sim", TowerSim.name, OPTIONS, given)
    if opts["big"] is None:
        opts["big"] = int(round(opts["cubes"] * 3 / 7))
    _check(opts)
    return opts


def _check(opts: dict[str, Any]) -> None:
    """Reject option values the cell cannot build (one line, naming the option)."""
    def bad(key: str, why: str) -> UserError:
        return UserError(f"--sim-opt {key}={opts[key]}: {why}")

    for key in ("cubes", "big", "balls", "cans"):
        if opts[key] < 0:
            raise bad(key, "must be at least 0")
    if opts["cubes"] + opts["balls"] + opts["cans"] < 1:
        raise bad("cubes", "the cell needs at least one object")
    if opts["workspace"] not in WORKSPACES:
        raise bad("workspace", f"unknown workspace (known: {', '.join(WORKSPACES)})")
    room = WORKSPACES[opts["workspace"]].max_objects
    if opts["cubes"] + opts["balls"] + opts["cans"] > room:     # named: the largest count, the likely typo
        more = "" if room == max(w.max_objects for w in WORKSPACES.values()) else ", workspace=wide holds 20"
        raise bad(max(("cubes", "balls", "cans"), key=lambda k: opts[k]),
                  f"at most {room} objects (cubes + balls + cans) fit on the {opts['workspace']} workspace "
                  f"with room for the hand{more}")
    if opts["big"] > opts["cubes"]:
        raise bad("big", f"more big cubes than cubes ({opts['cubes']})")
    if not 0.0 <= opts["noise"] <= 0.05:
        raise bad("noise", "expected a standard deviation between 0 and 0.05 m")
    for key in ("small_size", "big_size", "ball_size", "can_size"):
        if not 0.02 <= opts[key] <= 0.065:
            raise bad(key, "expected a size between 0.02 and 0.065 m (the open hand spans 0.072 m)")
    if len({opts["small_size"], opts["big_size"], opts["ball_size"]}) < 3:
        raise bad("ball_size", "small cubes, big cubes and balls need three distinct sizes")
    if opts["cans"] and opts["can_size"] in (opts["small_size"], opts["big_size"], opts["ball_size"]):
        raise bad("can_size", "cans need a size distinct from the cubes' and the balls'")
    if opts["big_size"] <= opts["small_size"]:
        raise bad("big_size", "must be larger than small_size")
    if opts["features"] not in FEATURE_SPACES:
        raise bad("features", f"unknown feature space (known: {', '.join(FEATURE_SPACES)})")
    if not 0.0 <= opts["depth_noise"] <= 0.05:
        raise bad("depth_noise", "expected a standard deviation between 0 and 0.05 m (at 1 m depth)")
    if not 0.0 <= opts["depth_dropout"] < 1.0:
        raise bad("depth_dropout", "expected a probability in [0, 1)")
    if opts["features"] == "pointcloud" and opts["workspace"] != DEFAULT_WORKSPACE:
        raise bad("workspace", "the depth camera frames the default table only (features=pointcloud)")
    if opts["features"] == "pose":
        for key in ("depth_noise", "depth_dropout"):
            if opts[key]:
                raise bad(key, "the depth camera is used with features=pointcloud only")


class TowerSim:
    """The tower cell; ``TowerSim(cubes=7, noise="0.0075")`` takes option values or strings."""

    name: ClassVar[str] = "tower"
    OPTIONS: ClassVar[tuple[Option, ...]] = OPTIONS
    # 2: converged IK, straight Cartesian moves, rigid grasps, guards on every arm link (issue 13)
    CELL_VERSION: ClassVar[int] = 2
    feature_names = POSE_FEATURES                 # an instance's own: see features_for
    primitives = {"closeHandAround": 1, "openHandOver": 1}
    truth_predicates = {"inhand": 1, "on": 2, "above": 2, "ontable": 1, "clear": 1, "ball": 1, "big": 1,
                        "small": 1, "bigger": 2}
    episode_length = EPISODE_LENGTH
    gamma = GAMMA

    def __init__(self, **options: Any) -> None:
        opts = resolve_options(options)
        self.options = recorded_options(OPTIONS, opts)       # what traces record (see Option.recorded_at_default)
        self.resolved = opts                                 # every option, defaults filled in
        self.objects = tuple(f"o{i + 1}" for i in range(opts["cubes"] + opts["balls"] + opts["cans"]))
        self.workspace: Workspace = WORKSPACES[opts["workspace"]]
        self.world = TowerWorld(self.workspace.table_half, self.workspace.table_centre)
        self.rng = np.random.default_rng(0)
        self.kinds: list[tuple[str, float]] = []
        self.feature_names = self.features_for(opts)
        self.pair_feature_names = PAIR_FEATURE_NAMES if opts["features"] == "pointcloud" else None
        self.camera = DepthCamera(opts["depth_noise"], opts["depth_dropout"]) if opts["features"] == "pointcloud" \
            else None
        self.seen_features: np.ndarray | None = None   # each object's features when last seen
        self.frame: Frame | None = None                # the camera's last capture

    @classmethod
    def features_for(cls, options: dict[str, Any]) -> tuple[str, ...]:
        """The feature names of a cell made with ``options`` (known before the physics starts)."""
        return FEATURE_NAMES if resolve_options(options)["features"] == "pointcloud" else POSE_FEATURES

    # ------------------------------------------------------------------ episodes

    def reset(self, seed: int) -> Scene:
        """A fresh world: objects shuffled over ids, on the table at random places, all from ``seed``.

        One Generator serves the whole episode (start state, then motor noise), so the same seed
        and options give the same trace bit for bit.
        """
        self.rng = np.random.default_rng(seed)
        if self.camera is not None:                  # its own stream: depth noise never shifts motor noise
            self.camera.seed(np.random.default_rng([seed, CAMERA_STREAM]))
        self.seen_features = None
        o = self.resolved
        kinds = ([("cube", o["big_size"])] * o["big"] + [("cube", o["small_size"])] * (o["cubes"] - o["big"])
                 + [("ball", o["ball_size"])] * o["balls"] + [("can", o["can_size"])] * o["cans"])
        self.kinds = [kinds[i] for i in self.rng.permutation(len(kinds))]
        xy = self.workspace.sample_positions(self.rng, len(self.kinds))
        yaws = self.rng.uniform(-np.pi / 4, np.pi / 4, len(self.kinds))
        self.world.build([(shape, size, x, y, yaw) for (shape, size), (x, y), yaw in zip(self.kinds, xy, yaws)])
        if self.camera is not None:                  # it renders a copy whose arm has coarser looks
            self.camera.watch(self.world.client, self.world.robot, ARM_URDF)
        return self.scene()

    def actions(self) -> list[Atom]:
        return [Atom(p, (obj,)) for p in self.primitives for obj in self.objects]

    def step(self, action: Atom) -> Scene:
        """Run one primitive (with motor noise drawn from the episode's Generator) until settled."""
        if not self.kinds:
            raise RuntimeError("call reset(seed) before step()")
        if action.predicate not in self.primitives or action.arity != 1 or action.args[0] not in self.objects:
            raise ValueError(f"{action}: not a primitive of the tower cell (objects {', '.join(self.objects)})")
        offset = self.rng.normal(0.0, 1.0, 3) * self.options["noise"]
        index = self.objects.index(action.args[0])
        if action.predicate == "closeHandAround":
            self.world.close_hand_around(index, offset)
        else:
            self.world.open_hand_over(index, offset)
        return self.scene()

    @property
    def events(self) -> dict[str, int]:
        """What the arm's controller met so far (primitives, arm collisions, fingertips on top,
        side contacts, IK failures, scenes read before they settled); ``collect`` records them."""
        return dict(self.world.events)

    # ------------------------------------------------------------------ observation

    def scene(self) -> Scene:
        """What the learner sees (poses, or the camera's point clouds), the reward and the truth
        (both from the simulator, whatever the features)."""
        pos, orn = self.world.poses()
        sizes = np.array([size for _, size in self.kinds])
        held = self._inhand()
        lowest = lowest_points(pos, orn, sizes, [shape for shape, _ in self.kinds])
        reward, truth = self._reward(lowest, held), self._truth(pos, held)
        if self.camera is None:
            return Scene(self.objects, np.column_stack([pos, sizes]), reward, truth)
        features, seen = self.perceive()
        unseen = tuple(o for o, s in zip(self.objects, seen) if not s)
        return Scene(self.objects, features, reward, truth, mean_differences(features), unseen)

    def perceive(self) -> tuple[np.ndarray, np.ndarray]:
        """Point-cloud features of every object from one camera frame, and which were seen; an
        object with too few points keeps the features it had when last seen."""
        self.frame = self.camera.capture(self.world.client)
        clouds = self.camera.clouds(self.frame, [b.uid for b in self.world.bodies])
        self.seen_features, seen = features_from_clouds(clouds, self.seen_features)
        return self.seen_features.copy(), seen

    def _reward(self, lowest: np.ndarray, held: set[int]) -> float:
        blocks = [i for i, (shape, _) in enumerate(self.kinds) if shape != "ball"]     # cubes and cans
        if not blocks:
            return 0.0
        h = np.where(lowest < ON_TABLE_TOL, 0.0, lowest)
        return float(np.mean([0.0 if i in held else h[i] for i in blocks]))

    def _inhand(self) -> set[int]:
        """Objects in the grasp: the stabilised one, or any squeezed between both fingers off the table."""
        w = self.world
        held = set() if w.held is None else {w.held}
        for i, b in enumerate(w.bodies):
            if (w.contacts(b.uid, w.robot, LEFT_FINGER) and w.contacts(b.uid, w.robot, RIGHT_FINGER)
                    and not w.contacts(b.uid, w.table)):
                held.add(i)
        return held

    def _truth(self, pos: np.ndarray, held: set[int]) -> frozenset[Atom]:
        """Ground-truth atoms from the simulator's contacts and poses (evaluation only). Sizes are
        named three ways (what a vocabulary that sees cube size could learn and be graded against): ``big(X)``
        and ``small(X)`` for the cell's two cube sizes, and ``bigger(X,Y)``, X's size (cube edge,
        ball or can diameter) larger than Y's."""
        w, ids = self.world, self.objects
        atoms: set[Atom] = set()
        on = np.zeros((len(ids), len(ids)), dtype=bool)
        for i, b in enumerate(w.bodies):
            shape, size = self.kinds[i]
            if shape == "ball":
                atoms.add(Atom("ball", (ids[i],)))
            elif size == self.options["big_size"]:
                atoms.add(Atom("big", (ids[i],)))
            elif shape == "cube" and size == self.options["small_size"]:
                atoms.add(Atom("small", (ids[i],)))
            atoms.update(Atom("bigger", (ids[i], ids[j])) for j, (_, other) in enumerate(self.kinds) if size > other)
            if i in held:
                atoms.add(Atom("inhand", (ids[i],)))
                continue
            if any(c[7][2] > CONTACT_UP for c in w.contacts(b.uid, w.table)):
                atoms.add(Atom("ontable", (ids[i],)))
            for j, other in enumerate(w.bodies):
                if j != i and pos[i, 2] > pos[j, 2] and any(c[7][2] > CONTACT_UP for c in w.contacts(b.uid, other.uid)):
                    on[i, j] = True
        above = transitive_closure(on)
        for i in range(len(ids)):
            if not on[:, i].any():
                atoms.add(Atom("clear", (ids[i],)))
            for j in range(len(ids)):
                if on[i, j]:
                    atoms.add(Atom("on", (ids[i], ids[j])))
                if above[i, j]:
                    atoms.add(Atom("above", (ids[i], ids[j])))
        return frozenset(atoms)

    # ------------------------------------------------------------------ pictures and cleanup

    def render(self, path: str | Path, width: int = 640, height: int = 480) -> None:
        """Write a PNG of the cell (pybullet's software renderer), objects labelled with their ids;
        with ``features=pointcloud``, beside it what the depth camera saw (sims/camera_picture.py)."""
        view, labels = self.picture(width, height), self._labels(width, height)
        if self.camera is None or self.frame is None:
            write_png(path, view, labels)
            return
        clouds = self.camera.clouds(self.frame, [b.uid for b in self.world.bodies])
        unseen = tuple(o for o, c in zip(self.objects, clouds) if len(c) < MIN_POINTS)
        write_camera_png(path, view, labels, self.frame, clouds, self.objects, unseen)

    def picture(self, width: int, height: int) -> np.ndarray:
        c = self.world.client
        view = pb.computeViewMatrix((1.45, 0.8, 0.95), (0.32, 0.0, 0.2), (0, 0, 1), physicsClientId=c)
        proj = pb.computeProjectionMatrixFOV(45, width / height, 0.05, 5.0, physicsClientId=c)
        self._camera = (np.array(view).reshape(4, 4).T, np.array(proj).reshape(4, 4).T)
        img = pb.getCameraImage(width, height, view, proj, renderer=pb.ER_TINY_RENDERER,
                                lightDirection=(1.0, -0.6, 2.0), shadow=1, physicsClientId=c)[2]
        return np.asarray(img, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]

    def _labels(self, width: int, height: int) -> list[tuple[float, float, str]]:
        """Pixel positions just right of each object (half its projected size plus a margin)."""
        view, proj = self._camera
        pos, _ = self.world.poses()

        def pixel(point: np.ndarray) -> np.ndarray:
            clip = proj @ view @ np.array([*point, 1.0])
            return np.array([(clip[0] / clip[3] + 1) / 2 * width, (1 - clip[1] / clip[3]) / 2 * height])

        out = []
        for k, p in enumerate(pos):
            centre = pixel(p)
            half = np.linalg.norm(pixel(p + np.array([0.0, 0.0, self.kinds[k][1] / 2])) - centre)
            out.append((centre[0] + half + 3, centre[1], self.objects[k]))
        return out

    def close(self) -> None:
        self.world.close()
        if self.camera is not None:
            self.camera.close()

    def __enter__(self) -> "TowerSim":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# ---------------------------------------------------------------------- helpers

def lowest_points(pos: np.ndarray, orn: np.ndarray, sizes: np.ndarray, shapes: list[str]) -> np.ndarray:
    """Height of each object's lowest point: a cube's lowest corner, a can's lowest rim point, whatever
    their tilt (a can is as tall as it is wide)."""
    out = pos[:, 2] - sizes / 2
    for k, q in enumerate(orn):
        if shapes[k] != "ball":
            rz = np.array(pb.getMatrixFromQuaternion(q)).reshape(3, 3)[2]
            reach = np.abs(rz).sum() if shapes[k] == "cube" else abs(rz[2]) + np.sqrt(max(0.0, 1 - rz[2] ** 2))
            out[k] = pos[k, 2] - sizes[k] / 2 * reach
    return out


def transitive_closure(rel: np.ndarray) -> np.ndarray:
    """``above`` from ``on``: X is above Y if a chain of on-relations leads from X down to Y."""
    closure = rel.copy()
    for k in range(len(rel)):
        closure |= closure[:, [k]] & closure[[k], :]
    return closure


def write_png(path: str | Path, rgb: np.ndarray, labels: list[tuple[float, float, str]] = ()) -> None:
    """Save an RGB image as PNG atomically, with text labels at pixel positions."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    h, w = rgb.shape[:2]
    fig = Figure(figsize=(w / 100, h / 100), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.imshow(rgb)
    ax.set_axis_off()
    for x, y, text in labels:
        ax.text(x, y, text, ha="left", va="center", fontsize=8, color="black",
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.7})
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    atomic_write_bytes(path, buf.getvalue())


def optimal_episode_value(options: dict[str, Any] | None = None) -> float:
    """The best episode value of the deterministic cell (see :mod:`sims.tower_optimum`)."""
    from .tower_optimum import best_plan

    return best_plan(resolve_options(options or {}), GAMMA, EPISODE_LENGTH).value
