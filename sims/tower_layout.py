"""Where the tower cell's objects start, and the table they start on: the cell's workspaces.

The paper's cell (``workspace=table``, the default) has a 0.9 m x 1.2 m table and draws start
positions from a rectangle in front of the arm, centres at least 13 cm apart so that the open hand
fits between them; at most 10 objects fit there. Real scenes hold 10-40 objects, so
``workspace=wide`` gives the arm a wider table (0.9 m x 1.6 m) and draws start positions over
the half-ring the Panda reaches with its hand pointing down: 0.35-0.70 m from the base, within
70 degrees of straight ahead (the default rectangle's far corners are 0.70 m out). The sector
is about 2.8 times the rectangle's area, enough for 20 objects at the same 13 cm spacing
(sampling fails for none of 50 seeds at 22), so the primitives, the controller and the spacing
stay those of the default cell; only the table and the start positions change. The default
workspace draws from the Generator exactly as before this module existed, so the default cell's
traces stay bit-identical (cell version 2). docs/tower.md ("Workspaces") gives the figures.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

REGION_X = (0.35, 0.65)            # the default workspace's start rectangle (reachable, in front of the arm)
REGION_Y = (-0.27, 0.27)
MIN_GAP = 0.13                     # minimal distance between start centres: room for the open hand
PLACEMENT_ROUNDS = 200             # fresh starts of the sequential placement ...
PLACEMENT_TRIES = 400              # ... each drawing this many candidate points at most


@dataclass(frozen=True)
class Workspace:
    """A table (half extents, centre of its top) and the start region on it: the rectangle
    ``box`` (x range, y range) or, when ``sector`` is given, the annular sector
    ``(inner radius, outer radius, half angle in radians)`` around the arm's base."""

    name: str
    table_half: tuple[float, float, float]
    table_centre: tuple[float, float]
    max_objects: int
    box: tuple[tuple[float, float], tuple[float, float]] = (REGION_X, REGION_Y)
    sector: tuple[float, float, float] | None = None

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """One point uniform over the start region (by area)."""
        if self.sector is None:
            return np.array([rng.uniform(*self.box[0]), rng.uniform(*self.box[1])])
        inner, outer, half_angle = self.sector
        radius = np.sqrt(rng.uniform(inner ** 2, outer ** 2))      # uniform by area, not by radius
        angle = rng.uniform(-half_angle, half_angle)
        return np.array([radius * np.cos(angle), radius * np.sin(angle)])

    def contains(self, xy: np.ndarray, slack: float = 0.0) -> np.ndarray:
        """Which of the points ``xy`` (N x 2) lie in the start region, give or take ``slack`` metres."""
        xy = np.atleast_2d(xy)
        if self.sector is None:
            (x0, x1), (y0, y1) = self.box
            return ((xy[:, 0] >= x0 - slack) & (xy[:, 0] <= x1 + slack)
                    & (xy[:, 1] >= y0 - slack) & (xy[:, 1] <= y1 + slack))
        inner, outer, half_angle = self.sector
        r = np.hypot(xy[:, 0], xy[:, 1])
        angle = np.abs(np.arctan2(xy[:, 1], xy[:, 0]))
        return (r >= inner - slack) & (r <= outer + slack) & (angle <= half_angle + slack / inner)

    def sample_positions(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` start positions in the region, pairwise at least ``MIN_GAP`` apart (sequential
        placement, started afresh when it jams)."""
        for _ in range(PLACEMENT_ROUNDS):
            pts: list[np.ndarray] = []
            for _ in range(PLACEMENT_TRIES):
                p = self.draw(rng)
                if all(np.hypot(*(p - q)) >= MIN_GAP for q in pts):
                    pts.append(p)
                    if len(pts) == n:
                        return np.array(pts)
        raise RuntimeError(f"could not place {n} objects {MIN_GAP} m apart")  # not reached for n <= max_objects


WORKSPACES: dict[str, Workspace] = {
    "table": Workspace("table", (0.45, 0.6, 0.02), (0.45, 0.0), 10),
    "wide": Workspace("wide", (0.45, 0.8, 0.02), (0.45, 0.0), 20, sector=(0.35, 0.70, np.radians(70.0))),
}
DEFAULT_WORKSPACE = "table"
