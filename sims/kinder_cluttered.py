"""KinDER's ClutteredRetrieval2D as a groundsym simulation (``--sim kinder-cluttered``).

A top-down world of 2.5 x 2.5 m: KinDER's CRV robot (a round base, a telescoping arm, a vacuum at
its tip), a 0.14 m square target block that must end fully inside a 0.21 m square target region
(both rotated arbitrarily), and ``obstructions`` = 1, 10 or 25 rectangles (5-20 cm a side) sampled
around the target block (KinDER's variants o1, o10, o25). Primitives, written here as closed-loop
controllers over the environment's actions (docs/kinder.md, "ClutteredRetrieval2D"):

- ``putAway(X)``: drive to a face of obstruction X along a planned collision-free path
  (:mod:`sims.kinder_paths`), reach, suck, carry X to a free spot at least :data:`AWAY` from the
  target block and the target region and off the line between them, and release it;
- ``putInRegion(T, R)``: the same grasp of the target block T, then carry it, turned so its
  square lines up with the region's, until its centre is over the region's centre, and release.

Continuous parameters (which face, where along it, how far the base stands, which of the free
spots) come from the episode's seeded generator. Both primitives end with the vacuum off, so
nothing is held between primitives and ``holding`` is not a relation of the task here.
"""

from __future__ import annotations

from math import atan2, cos, hypot, pi, sin
from typing import Any, Iterable, Mapping

import numpy as np

from groundsym.errors import UserError
from groundsym.logic import Atom
from groundsym.options import Option, one_of

from .kinder2d import make_kinder_env, read_kinder_state
from .kinder2d_skills import ROBOT, Script, arm_to, drive_to, rect_centre, robot_pose, set_vacuum, turn_to
from .kinder_paths import Clearance, Footprint, Lattice, Pose, Rect, waypoints
from .object_centric import Chained, Controller, ObjectState, Primitive, WorldSpec, sim_class

FEATURES = ("x", "y", "theta", "w", "h", "green")
VARIANTS = (1, 10, 25)
TARGET, REGION = "target_block", "target_region"
ARM_MIN = 0.1                  # the arm fully retracted (KinDER: the base radius)
SUCTION_AHEAD = 0.015          # suction zone centre beyond the arm joint (gripper width + half the zone)
STANDOFF = (0.16, 0.185)       # base centre to the grasped face, drawn per grasp
FACE_EDGE = 0.035              # the grasp point keeps this far from a face's ends (half the gripper)
ARM_SWEEP_DISC = 0.0355        # covers the gripper (0.07 x 0.01) wherever it is along the arm
AWAY = 0.5                     # putAway: the held object's centre at least this far from T and R ...
OFF_LINE = 0.35                # ... and from the segment between them
BLOCKING = 0.25                # blocking(X): X within this of the target block or the region
BACK_OFF = 0.05                # after letting go, the base backs off this far (the object stood at its edge)
HOLD_GAP = 0.006               # an object this close to the suction zone's centre, vacuum on, is held
PUT_IN = Atom("putInRegion", (TARGET, REGION))


# ----------------------------------------------------------------------------- geometry of the state

def rect(state: ObjectState, obj: str) -> Rect:
    cx, cy = rect_centre(state, obj)
    return Rect(cx, cy, state.get(obj, "theta"), state.get(obj, "width"), state.get(obj, "height"))


def obstacles(state: ObjectState, without: Iterable[str] = ()) -> list[Rect]:
    """Everything the robot and a held object collide with: the obstructions and the target block
    (the region collides with nothing: KinDER's z-order NONE); walls are the world's edge."""
    skip = set(without)
    return [rect(state, o) for o in state.of_type("rectangle") + state.of_type(TARGET) if o not in skip]


def suction_point(state: ObjectState) -> tuple[float, float]:
    x, y, theta, arm = robot_pose(state)
    return x + cos(theta) * (arm + SUCTION_AHEAD), y + sin(theta) * (arm + SUCTION_AHEAD)


def holding(state: ObjectState, obj: str) -> bool:
    sx, sy = suction_point(state)
    return state.get(ROBOT, "vacuum") > 0.5 and float(rect(state, obj).distance(sx, sy)) < HOLD_GAP


def in_robot_frame(state: ObjectState, obj: str) -> Rect:
    x, y, theta, _ = robot_pose(state)
    r = rect(state, obj)
    c, s = cos(theta), sin(theta)
    return Rect(c * (r.cx - x) + s * (r.cy - y), -s * (r.cx - x) + c * (r.cy - y), r.theta - theta, r.w, r.h)


def inside(state: ObjectState, inner: str, outer: str) -> bool:
    """KinDER's ``is_inside`` written anew: every corner of ``inner`` lies in ``outer``."""
    o = rect(state, outer)
    c, s = cos(o.theta), sin(o.theta)
    for x, y in rect(state, inner).corners():
        lx, ly = c * (x - o.cx) + s * (y - o.cy), -s * (x - o.cx) + c * (y - o.cy)
        if abs(lx) > o.w / 2 or abs(ly) > o.h / 2:
            return False
    return True


def blocking(state: ObjectState, obj: str) -> bool:
    """An obstruction within :data:`BLOCKING` (25 cm) of the target block or of the region, not
    held: the room a grasp of the block needs in front of a face (the base stands 16-18.5 cm off
    it, radius 11 cm), and the room the carried block needs at the region."""
    r = rect(state, obj)
    return not holding(state, obj) and min(r.gap(rect(state, TARGET)), r.gap(rect(state, REGION))) < BLOCKING


def cluttered_truth(state: ObjectState) -> Iterable[Atom]:
    yield Atom("targetBlock", (TARGET,))
    for obj in state.of_type("rectangle") + [TARGET]:
        if inside(state, obj, REGION):
            yield Atom("inside", (obj, REGION))
        if obj != TARGET and blocking(state, obj):
            yield Atom("blocking", (obj,))


def object_features(state: ObjectState, obj: str) -> list[float]:
    """Centre, orientation modulo a quarter turn (a rectangle's turned by pi looks the same, and
    the squares by pi/2), size and the colour's green channel (0 target block, 0.1 obstruction,
    0.2 region). Nothing that records history (docs/kinder.md, "Why Obstruction2D has no tip")."""
    r = rect(state, obj)
    return [r.cx, r.cy, r.theta % (pi / 2), r.w, r.h, state.get(obj, "color_g")]


# ----------------------------------------------------------------------------- skills

def follow(path: list[Pose], vacuum: float) -> list:
    """Phases that drive a lattice path: turns in place, straight drives between waypoints."""
    phases = []
    for x, y, h in waypoints(path)[1:]:
        if h is not None:
            phases.append(turn_to(h))
        phases.append(drive_to(x, y))
    return phases


def grasp_poses(state: ObjectState, obj: str, rng: np.random.Generator) -> list[tuple[Pose, float]]:
    """Per face of ``obj``: a base pose facing it (a random point along the face, a random
    standoff) and the arm length that puts the suction zone on the face."""
    r = rect(state, obj)
    out = []
    for m in rng.permutation(4):
        normal = r.theta + m * pi / 2
        half_depth, half_len = (r.w / 2, r.h / 2) if m % 2 == 0 else (r.h / 2, r.w / 2)
        along = rng.uniform(-1, 1) * max(half_len - FACE_EDGE, 0.0)
        standoff = rng.uniform(*STANDOFF)
        nx, ny, tx, ty = cos(normal), sin(normal), -sin(normal), cos(normal)
        x = r.cx + nx * (half_depth + standoff) + tx * along
        y = r.cy + ny * (half_depth + standoff) + ty * along
        out.append(((x, y, atan2(-ny, -nx)), standoff - SUCTION_AHEAD + 0.003))
    return out


def reach_free(clear_others: Clearance, pose: Pose, arm: float) -> bool:
    """The gripper sweeping out to ``arm`` and its suction zone touch nothing but the object."""
    x, y, h = pose
    for a in np.arange(ARM_MIN, arm + SUCTION_AHEAD + 1e-9, 0.01):
        if clear_others.exact(x + cos(h) * a, y + sin(h) * a) < ARM_SWEEP_DISC + 0.004:
            return False
    return True


def approach_and_grasp(state: ObjectState, obj: str, rng: np.random.Generator) -> Controller:
    """Drive (arm retracted) to the cheapest reachable grasp pose of ``obj``, face it, reach, suck,
    retract; nothing when no face can be reached."""
    clear = Clearance(obstacles(state))
    clear_others = Clearance(obstacles(state, without=[obj]))
    lattice = Lattice(clear, Footprint.base(), robot_pose(state)[:3], 0.0)
    best = None
    for pose, arm in grasp_poses(state, obj, rng):
        node, cost = lattice.connect_goal(pose)
        if node is not None and (best is None or cost < best[0]) and reach_free(clear_others, pose, arm):
            best = (cost, node, pose, arm)
    if best is None:
        return Script([])
    _, _, pose, arm = best
    return Script(follow(lattice.route(pose), 0.0) + [arm_to(arm), set_vacuum(True), arm_to(ARM_MIN)])


def carry_lattice(state: ObjectState, obj: str, anchor: float) -> tuple[Lattice, Footprint]:
    fp = Footprint.base().holding(in_robot_frame(state, obj))
    return Lattice(Clearance(obstacles(state, without=[obj])), fp, robot_pose(state)[:3], anchor), fp


def let_go(state: ObjectState) -> list:
    """Vacuum off, then back off: the released object stands right at the base's edge (the arm is
    retracted), where the next path's start would have no margin."""
    return let_go_at(robot_pose(state)[:3])


def let_go_at(pose: Pose) -> list:
    x, y, theta = pose
    return [set_vacuum(False), drive_to(x - cos(theta) * BACK_OFF, y - sin(theta) * BACK_OFF)]


def release_here(state: ObjectState) -> Script:
    return Script(let_go(state), vacuum=1.0)


def carry_away(state: ObjectState, obj: str, rng: np.random.Generator) -> Controller:
    """Carry the held ``obj`` to a reachable free spot away from T, R and the line between them
    (a random one of the nearest quarter), and let go; if none, let go where it is."""
    if not holding(state, obj):
        return Script([set_vacuum(False)], vacuum=state.get(ROBOT, "vacuum"))
    lattice, fp = carry_lattice(state, obj, robot_pose(state)[2])
    held = in_robot_frame(state, obj)
    t, r = rect(state, TARGET), rect(state, REGION)
    k, i, j = np.nonzero(lattice.reachable())
    h = np.array([lattice.heading(int(q)) for q in k])
    ox = i * 0.05 + np.cos(h) * held.cx - np.sin(h) * held.cy
    oy = j * 0.05 + np.sin(h) * held.cx + np.cos(h) * held.cy
    ok = ((np.hypot(ox - t.cx, oy - t.cy) >= AWAY) & (np.hypot(ox - r.cx, oy - r.cy) >= AWAY)
          & (segment_distance(ox, oy, (t.cx, t.cy), (r.cx, r.cy)) >= OFF_LINE))
    if not ok.any():
        return release_here(state)
    cost = lattice.dist[k[ok], i[ok], j[ok]]
    order = np.argsort(cost, kind="stable")[: max(1, ok.sum() // 4)]
    pick = int(order[rng.integers(len(order))])
    node = (int(k[ok][pick]), int(i[ok][pick]), int(j[ok][pick]))
    path = lattice.path(node)
    return Script(follow(path, 1.0) + let_go_at(path[-1]), vacuum=1.0)


def segment_distance(px: np.ndarray, py: np.ndarray, a: tuple[float, float], b: tuple[float, float]) -> np.ndarray:
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    t = np.clip(((px - ax) * dx + (py - ay) * dy) / max(dx * dx + dy * dy, 1e-12), 0, 1)
    return np.hypot(px - ax - t * dx, py - ay - t * dy)


def carry_into(state: ObjectState, obj: str, region: str) -> Controller:
    """Carry the held ``obj`` so that its centre is over the region's centre, turned so its sides
    line up with the region's (any of the four quarter turns that can be reached), and let go."""
    if not holding(state, obj):
        return Script([set_vacuum(False)], vacuum=state.get(ROBOT, "vacuum"))
    held, r = in_robot_frame(state, obj), rect(state, region)
    lattice, _ = carry_lattice(state, obj, robot_pose(state)[2])
    best = None
    for m in range(4):
        h = r.theta - held.theta + m * pi / 2
        goal = (r.cx - cos(h) * held.cx + sin(h) * held.cy, r.cy - sin(h) * held.cx - cos(h) * held.cy, h)
        node, cost = lattice.connect_goal(goal)
        if node is not None and (best is None or cost < best[0]):
            best = (cost, goal)
    if best is None:
        return release_here(state)
    path = lattice.route(best[1])
    return Script(follow(path, 1.0) + let_go_at(path[-1]), vacuum=1.0)


def _retracted(state: ObjectState) -> Script:
    return Script([set_vacuum(False), arm_to(ARM_MIN)], vacuum=state.get(ROBOT, "vacuum"))


def put_away(state: ObjectState, args: tuple[str, ...], rng: np.random.Generator) -> Controller:
    obj = args[0]
    return Chained(_retracted(state), lambda s: Chained(approach_and_grasp(s, obj, rng),
                                                        lambda s2: carry_away(s2, obj, rng)))


def put_in_region(state: ObjectState, args: tuple[str, ...], rng: np.random.Generator) -> Controller:
    obj, region = args
    return Chained(_retracted(state), lambda s: Chained(approach_and_grasp(s, obj, rng),
                                                        lambda s2: carry_into(s2, obj, region)))


# ----------------------------------------------------------------------------- the world

def _variant(options: Mapping[str, Any]) -> int:
    n = options["obstructions"]
    if n not in VARIANTS:
        raise UserError(f"--sim-opt obstructions={n}: KinDER's ClutteredRetrieval2D has the variants "
                        f"{', '.join(map(str, VARIANTS))}")
    return n


def solved(state: ObjectState, terminated: bool = False) -> bool:
    return inside(state, TARGET, REGION)


def graded_reward(state: ObjectState) -> float:
    """``reward=graded``: 1 when the target block is inside the region (KinDER's success), else
    half the share of obstructions not blocking (computed from the task's state, as the issue
    allows, and said in docs/kinder.md)."""
    if solved(state):
        return 1.0
    obstructions = state.of_type("rectangle")
    return 0.5 * (1 - sum(blocking(state, o) for o in obstructions) / len(obstructions)) if obstructions else 0.0


CLUTTERED = WorldSpec(
    name="kinder-cluttered",
    make_env=lambda o: make_kinder_env(f"kinder/ClutteredRetrieval2D-o{_variant(o)}-v0"),
    read_state=read_kinder_state, feature_names=FEATURES,
    type_features={"rectangle": object_features, TARGET: object_features, REGION: object_features},
    primitives=(Primitive("putAway", ("rectangle",), put_away, max_steps=600),
                Primitive("putInRegion", (TARGET, REGION), put_in_region, max_steps=600)),
    reward=lambda s, env_reward, terminated: 1.0 if solved(s) else 0.0,
    graded_reward=graded_reward,
    truth=cluttered_truth, truth_predicates={"inside": 2, "blocking": 1, "targetBlock": 1},
    success=solved, episode_length=10, gamma=0.95,
    options=(Option("obstructions", int, 10, "number of obstructions: KinDER's variants 1, 10, 25 (o1, o10, o25)"),
             Option("reward", one_of("kinder", "graded"), "kinder", "kinder: 1 when the target block is inside "
                    "the region, else 0; graded: else half the share of obstructions not blocking")),
)


ClutteredSim = sim_class(CLUTTERED, "ClutteredSim")


# ----------------------------------------------------------------------------- a scripted policy

def scripted_episode(sim: ClutteredSim, seed: int, budget: int = 3000) -> dict:
    """The ceiling of these skills on one episode: put away the blocking obstructions (nearest to
    the robot first), then ``putInRegion``; after a failed ``putInRegion``, put away the
    obstruction nearest the target block. An obstruction a putAway did not move is not tried
    again until something else has moved. Success is KinDER's: solved within ``budget`` steps."""
    sim.reset(seed)
    stuck: set[str] = set()
    actions: list[str] = []
    while not sim.solved() and sim.env_steps < budget:
        state = sim.state
        rx, ry = state.get(ROBOT, "x"), state.get(ROBOT, "y")
        free = [o for o in state.of_type("rectangle") if o not in stuck]
        blockers = [o for o in free if blocking(state, o)]
        if blockers:
            obj = min(blockers, key=lambda o: hypot(rect(state, o).cx - rx, rect(state, o).cy - ry))
            action = Atom("putAway", (obj,))
        elif not actions or actions[-1] != str(PUT_IN):
            action = PUT_IN
        elif free:
            t = rect(state, TARGET)
            action = Atom("putAway", (min(free, key=lambda o: rect(state, o).gap(t)),))
        else:
            break
        before = rect(state, action.args[0])
        sim.step(action)
        actions.append(str(action))
        moved = rect(sim.state, action.args[0]) != before
        if action.predicate == "putAway":
            stuck = set() if moved else stuck | {action.args[0]}
    return {"seed": seed, "success": bool(sim.solved() and sim.env_steps <= budget),
            "env_steps": int(sim.env_steps), "actions": actions}
