"""Collision-free base paths for KinDER's kinematic-2D robot among rectangles, by a lattice search.

KinDER refuses a step that would collide (the state stays), so a skill that drives straight at its
goal stops at the first object in the way. Obstruction2D's world is a line and its skills could do
that; ClutteredRetrieval2D is a plane with up to 25 obstructions, so the base's path is planned:
Dijkstra on a lattice of base poses (x, y on a 5 cm grid, the heading in 16 steps of pi/8 when the
robot holds an object; LaValle, *Planning Algorithms*, 2006, ch. 5-6). A pose is free when every
disc of the robot's :class:`Footprint` (its base with the arm retracted, and the held object
covered by small discs) keeps :data:`MARGIN` from every obstacle, read from a clearance field (the
distance to the nearest rectangle or wall, sampled every 1.25 cm). The discs cover KinDER's own
bodies and the margin covers the field's sampling and the motion between checked points, so a pose
called free here is free by KinDER's own collision check (tests/test_kinder_cluttered.py compares
the two on random poses).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import atan2, ceil, cos, hypot, pi, sin

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

WORLD = 2.5              # ClutteredRetrieval2D's world is [0, 2.5]^2 (walls outside it)
CELL = 0.05              # lattice spacing of base positions: one environment step
FIELD_RES = 0.0125       # clearance field spacing
HEADINGS = 16            # headings of the lattice when the footprint is not round
ROTATION_CHECKS = 4      # headings checked along each pi/8 turn
MARGIN = 0.03            # >= field sampling (0.009) + farthest point from a checked one (0.018)
EXACT_MARGIN = 0.004     # for segments checked point by point against the exact distances
BASE_DISC = 0.112        # covers the base (radius 0.1) and the retracted gripper (corner at 0.111)
STEP = 0.049             # base motion per environment step (kinder2d_skills.STEP_XY)
COVER_PIECE = 0.06       # a held rectangle is covered by discs over pieces at most this wide


@dataclass(frozen=True)
class Rect:
    """A rectangle by its centre, rotation and size (KinDER stores the rotated bottom-left corner)."""

    cx: float
    cy: float
    theta: float
    w: float
    h: float

    def corners(self) -> np.ndarray:
        c, s = cos(self.theta), sin(self.theta)
        local = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * [self.w / 2, self.h / 2]
        return local @ np.array([[c, s], [-s, c]]) + [self.cx, self.cy]

    def distance(self, px: np.ndarray, py: np.ndarray) -> np.ndarray:
        """Euclidean distance from points to the rectangle (0 inside)."""
        c, s = cos(self.theta), sin(self.theta)
        lx, ly = c * (px - self.cx) + s * (py - self.cy), -s * (px - self.cx) + c * (py - self.cy)
        return np.hypot(np.maximum(np.abs(lx) - self.w / 2, 0), np.maximum(np.abs(ly) - self.h / 2, 0))

    def gap(self, other: "Rect") -> float:
        """Distance between two rectangles: 0 when they overlap (no separating axis among their
        sides' normals), else the least corner-to-rectangle distance (exact for convex shapes apart)."""
        a, b = self.corners(), other.corners()
        for t in (self.theta, self.theta + pi / 2, other.theta, other.theta + pi / 2):
            axis = np.array([cos(t), sin(t)])
            if (a @ axis).max() < (b @ axis).min() or (b @ axis).max() < (a @ axis).min():
                return float(min(other.distance(a[:, 0], a[:, 1]).min(), self.distance(b[:, 0], b[:, 1]).min()))
        return 0.0


@dataclass(frozen=True)
class Footprint:
    """Discs in the robot's frame (x forward along the arm), which together cover the robot."""

    offsets: np.ndarray      # (m, 2)
    radii: np.ndarray        # (m,)

    @staticmethod
    def base() -> "Footprint":
        return Footprint(np.zeros((1, 2)), np.array([BASE_DISC]))

    @property
    def round(self) -> bool:
        return len(self.radii) == 1 and not self.offsets.any()

    def holding(self, held: Rect) -> "Footprint":
        """This footprint plus discs covering ``held`` (given in the robot's frame)."""
        nw, nh = max(1, ceil(held.w / COVER_PIECE)), max(1, ceil(held.h / COVER_PIECE))
        u = (np.arange(nw) + 0.5) / nw * held.w - held.w / 2
        v = (np.arange(nh) + 0.5) / nh * held.h - held.h / 2
        local = np.array([(a, b) for a in u for b in v])
        c, s = cos(held.theta), sin(held.theta)
        pts = local @ np.array([[c, s], [-s, c]]) + [held.cx, held.cy]
        r = hypot(held.w / nw, held.h / nh) / 2
        return Footprint(np.vstack([self.offsets, pts]), np.concatenate([self.radii, np.full(len(pts), r)]))

    def placed(self, x: float, y: float, heading: float) -> np.ndarray:
        c, s = cos(heading), sin(heading)
        return self.offsets @ np.array([[c, s], [-s, c]]) + [x, y]


class Clearance:
    """Distance to the nearest obstacle (rectangles and the world's walls), exact or from a field."""

    def __init__(self, rects: list[Rect]):
        self.rects = rects
        n = round(WORLD / FIELD_RES) + 1
        g = np.arange(n) * FIELD_RES
        self.field = self.exact(*np.meshgrid(g, g, indexing="ij"))

    def exact(self, px: np.ndarray, py: np.ndarray) -> np.ndarray:
        px, py = np.asarray(px, float), np.asarray(py, float)
        d = np.minimum(np.minimum(px, WORLD - px), np.minimum(py, WORLD - py))
        for r in self.rects:
            d = np.minimum(d, r.distance(px, py))
        return d

    def sampled(self, px: np.ndarray, py: np.ndarray) -> np.ndarray:
        """The field at the nearest sample; -1 outside the world."""
        ix, iy = np.rint(px / FIELD_RES).astype(int), np.rint(py / FIELD_RES).astype(int)
        n = self.field.shape[0]
        inside = (ix >= 0) & (ix < n) & (iy >= 0) & (iy < n)
        return np.where(inside, self.field[np.clip(ix, 0, n - 1), np.clip(iy, 0, n - 1)], -1.0)

    def free(self, fp: Footprint, x, y, heading: float) -> np.ndarray:
        """Whether the footprint at base positions (x, y) and ``heading`` keeps MARGIN (field)."""
        ok = np.ones(np.shape(x), bool)
        c, s = cos(heading), sin(heading)
        for (ox, oy), r in zip(fp.offsets, fp.radii):
            ok &= self.sampled(x + c * ox - s * oy, y + s * ox + c * oy) >= r + MARGIN
        return ok

    def segment_free(self, fp: Footprint, a: tuple[float, float], b: tuple[float, float], heading: float,
                     leaving: bool = False) -> bool:
        """The footprint at ``heading`` along the straight segment a-b, checked every 5 mm exactly.
        ``leaving``: a is where the robot stands (KinDER accepted it), perhaps closer than the
        margin to an object it just let go; no disc may come closer than it starts."""
        n = max(2, ceil(hypot(b[0] - a[0], b[1] - a[1]) / 0.005) + 1)
        t = np.linspace(0, 1, n)[:, None]
        centres = (1 - t) * np.asarray(a) + t * np.asarray(b)
        need = fp.radii + EXACT_MARGIN
        for k in range(n):
            pts = fp.placed(centres[k, 0], centres[k, 1], heading)
            gap = self.exact(pts[:, 0], pts[:, 1])
            if k == 0 and leaving:
                need = np.minimum(need, gap)
            if (gap < need).any():
                return False
        return True

    def turn_free(self, fp: Footprint, x: float, y: float, h0: float, h1: float) -> bool:
        """The footprint turning in place from h0 to h1 (the short way), checked every pi/64."""
        d = (h1 - h0 + pi) % (2 * pi) - pi
        for h in h0 + np.linspace(0, d, max(2, ceil(abs(d) / (pi / 64)) + 1)):
            pts = fp.placed(x, y, h)
            if (self.exact(pts[:, 0], pts[:, 1]) < fp.radii + EXACT_MARGIN).any():
                return False
        return True


Pose = tuple[float, float, float]
MOVES = [(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if (di, dj) != (0, 0)]


class Lattice:
    """Base poses (x, y, heading) reachable from a start pose, with the cheapest paths (in steps).

    Headings are ``anchor + k 2pi/K`` (K = 1 for a round footprint: it may turn anywhere)."""

    def __init__(self, clear: Clearance, fp: Footprint, start: Pose, anchor: float):
        self.clear, self.fp, self.anchor = clear, fp, anchor
        self.K = 1 if fp.round else HEADINGS
        self.n = round(WORLD / CELL) + 1
        fine = np.arange(2 * self.n - 1) * CELL / 2
        fx, fy = np.meshgrid(fine, fine, indexing="ij")
        free_fine = np.stack([clear.free(fp, fx, fy, self.heading(k)) for k in range(self.K)])
        self.node_free = free_fine[:, ::2, ::2]
        self.start, start_cost = self._connect(start)
        self.dist = np.full(self.node_free.shape, np.inf)
        self.pred = np.full(self.node_free.size, -9999)
        if self.start is None:
            return
        graph = self._graph(free_fine)
        dist, pred = dijkstra(graph, indices=int(np.ravel_multi_index(self.start, self.node_free.shape)),
                              return_predecessors=True)
        self.dist, self.pred = dist.reshape(self.node_free.shape) + start_cost, pred
        self.start_pose = start

    def heading(self, k: int) -> float:
        return self.anchor + 2 * pi * k / self.K

    def position(self, i: int, j: int) -> tuple[float, float]:
        return i * CELL, j * CELL

    def _k_of(self, heading: float) -> int:
        return int(round(((heading - self.anchor) % (2 * pi)) / (2 * pi / self.K))) % self.K

    def _connect(self, start: Pose) -> tuple[tuple[int, int, int] | None, float]:
        """The cheapest lattice node the start pose reaches in a straight, checked move."""
        return self._link(start, np.where(self.node_free, 0.0, np.inf), leaving=True)

    def _link(self, pose: Pose, base_cost: np.ndarray, leaving: bool) -> tuple[tuple[int, int, int] | None, float]:
        """The node near ``pose`` of least ``base_cost`` plus the straight move between them, the
        move checked at the lattice heading nearest the pose's and the turn between the two
        headings checked at the pose (none for a round footprint: it turns freely)."""
        x, y, h = pose
        k = self._k_of(h)
        hk = self.heading(k) if self.K > 1 else h
        if self.K > 1 and not self.clear.turn_free(self.fp, x, y, hk, h):
            return None, np.inf
        best, cost = None, np.inf
        for i, j in self._near(x, y):
            px, py = self.position(i, j)
            c = base_cost[k, i, j] + hypot(px - x, py - y) / STEP
            if c < cost and self.clear.segment_free(self.fp, (x, y), (px, py), hk, leaving=leaving):
                best, cost = (k, i, j), c
        return best, cost + (2 if self.K > 1 else 0)

    def _graph(self, free_fine: np.ndarray) -> csr_matrix:
        K, n = self.K, self.n
        ids = np.arange(K * n * n).reshape(K, n, n)
        src, dst, w = [], [], []
        for di, dj in MOVES:
            a = (slice(None), slice(max(0, -di), n - max(0, di)), slice(max(0, -dj), n - max(0, dj)))
            b = (slice(None), slice(max(0, di), n - max(0, -di)), slice(max(0, dj), n - max(0, -dj)))
            mid = free_fine[:, 2 * a[1].start + di: 2 * (a[1].stop - 1) + di + 1: 2,
                            2 * a[2].start + dj: 2 * (a[2].stop - 1) + dj + 1: 2]
            ok = self.node_free[a] & self.node_free[b] & mid
            src.append(ids[a][ok])
            dst.append(ids[b][ok])
            w.append(np.full(ok.sum(), CELL * hypot(di, dj) / STEP))
        if K > 1:
            px, py = np.meshgrid(np.arange(n) * CELL, np.arange(n) * CELL, indexing="ij")
            for k in range(K):
                ok = self.node_free[k] & self.node_free[(k + 1) % K]
                for q in range(1, ROTATION_CHECKS):
                    ok &= self.clear.free(self.fp, px, py, self.heading(k + q / ROTATION_CHECKS))
                for a, b in ((k, (k + 1) % K), ((k + 1) % K, k)):
                    src.append(ids[a][ok])
                    dst.append(ids[b][ok])
                    w.append(np.full(ok.sum(), 2.0))     # pi/8 is two steps of at most pi/16
        s, d, ww = np.concatenate(src), np.concatenate(dst), np.concatenate(w)
        return csr_matrix((ww, (s, d)), shape=(K * n * n, K * n * n))

    def reachable(self) -> np.ndarray:
        return np.isfinite(self.dist)

    def path(self, node: tuple[int, int, int]) -> list[Pose]:
        """The lattice poses from the start node to ``node`` (the start pose itself first)."""
        flat = int(np.ravel_multi_index(node, self.node_free.shape))
        chain = []
        while flat >= 0:
            k, i, j = np.unravel_index(flat, self.node_free.shape)
            chain.append((*self.position(int(i), int(j)), self.heading(int(k)) if self.K > 1 else None))
            flat = int(self.pred[flat])
        return [self.start_pose] + chain[::-1]

    def connect_goal(self, goal: Pose) -> tuple[tuple[int, int, int] | None, float]:
        """The reachable node cheapest to ``goal`` (by its path, a straight move at the lattice
        heading nearest the goal's, and a turn to the goal's heading)."""
        return self._link(goal, self.dist, leaving=False)

    def _near(self, x: float, y: float, cells: int = 3) -> list[tuple[int, int]]:
        i0, j0 = int(round(x / CELL)), int(round(y / CELL))
        return [(i, j) for i in range(i0 - cells, i0 + cells + 1) for j in range(j0 - cells, j0 + cells + 1)
                if 0 <= i < self.n and 0 <= j < self.n]

    def route(self, goal: Pose) -> list[Pose] | None:
        """The poses from the start to ``goal`` (None when it cannot be reached)."""
        node, _ = self.connect_goal(goal)
        if node is None:
            return None
        x, y, h = goal
        return self.path(node) + [(x, y, self.heading(node[0]) if self.K > 1 else None), goal]


def waypoints(path: list[Pose]) -> list[Pose]:
    """The path with the middle points of straight runs dropped (a turn is its own waypoint)."""
    out = [path[0]]
    for a, b, c in zip(path, path[1:], path[2:]):
        same_heading = a[2] == b[2] == c[2]
        straight = same_heading and abs(atan2(b[1] - a[1], b[0] - a[0]) - atan2(c[1] - b[1], c[0] - b[0])) < 1e-9
        if not straight:
            out.append(b)
    if len(path) > 1:
        out.append(path[-1])
    return out
