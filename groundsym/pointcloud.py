"""Object features from a point cloud: the cloud's mean and seven numbers describing its shape.

The paper describes objects seen by a depth camera by the mean of each object's point cloud and
its "first 7 PCA components" (y in R^10) without saying which seven numbers those are. A camera sees
one side of an object only, and a full cube and a full ball both have an isotropic covariance, so
the spread alone cannot tell them apart; their *visible* surfaces differ: two or three flat faces
meeting at edges, or one smoothly curved cap. The seven numbers chosen here (``docs/perception.md``):

* ``pca_sd1 >= pca_sd2 >= pca_sd3`` (m): the square roots of the covariance's eigenvalues, the
  cloud's spread along its principal axes (its size and flatness);
* ``pca_axis1_z`` and ``pca_axis3_z``: the absolute vertical component of the first and the third
  principal axis (an upright elongated cloud has ``pca_axis1_z`` near 1; a cloud that is mostly a
  horizontal face has ``pca_axis3_z`` near 1);
* ``sphere_rms`` (m): the root-mean-square distance of the points from the sphere that fits them
  best (algebraic least squares), near the sensor noise on a ball's cap and millimetres on a
  cube's faces and edges: what tells a curved surface from flat faces in a single view;
* ``sphere_curvature`` (1/m): one over that sphere's radius, clipped at :data:`MAX_CURVATURE`
  (``2 / diameter`` on a ball; on flat faces the fit is a poor sphere of about the cloud's size).

Pair features are the differences of the means only (``dmean_x, dmean_y, dmean_z``): where one
object is relative to another, which the shape numbers do not say.
"""

from __future__ import annotations

import numpy as np

FEATURE_NAMES: tuple[str, ...] = ("mean_x", "mean_y", "mean_z", "pca_sd1", "pca_sd2", "pca_sd3", "pca_axis1_z",
                                  "pca_axis3_z", "sphere_rms", "sphere_curvature")
PAIR_FEATURE_NAMES: tuple[str, ...] = ("dmean_x", "dmean_y", "dmean_z")
MIN_POINTS = 30                    # fewer visible points than this: the object counts as unseen
MAX_CURVATURE = 200.0              # 1/m: a sphere of 5 mm radius, far tighter than any object


def cloud_features(points: np.ndarray) -> np.ndarray:
    """The 10 features of one object's visible points (N x 3, N >= 4, world frame, metres)."""
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < 4:
        raise ValueError(f"expected at least 4 points as an N x 3 array, got shape {pts.shape}")
    mean = pts.mean(0)
    centred = pts - mean
    evals, evecs = np.linalg.eigh(centred.T @ centred / len(pts))      # ascending
    sd = np.sqrt(np.clip(evals[::-1], 0.0, None))
    rms, curvature = sphere_fit(centred)
    return np.array([*mean, *sd, abs(evecs[2, 2]), abs(evecs[2, 0]), rms, curvature])


def sphere_fit(centred: np.ndarray) -> tuple[float, float]:
    """RMS distance of the points from their best-fitting sphere, and its curvature (1/radius).

    The algebraic fit solves ``|p|^2 = 2 c.p + k`` by least squares (linear in the centre ``c`` and
    ``k = r^2 - |c|^2``); the points are centred and scaled to unit spread first so that it is well
    conditioned. On an exactly flat patch it fits the circle about the patch's centre in its plane
    (the residual is then millimetres); on a nearly flat one it may fit a sphere of enormous radius
    instead (residual near 0, but curvature near 0, far from any ball's). The curvature is clipped
    at ``MAX_CURVATURE``.
    """
    scale = float(np.sqrt((centred ** 2).sum(1).mean())) or 1.0
    p = centred / scale
    a = np.column_stack([2 * p, np.ones(len(p))])
    sol, *_ = np.linalg.lstsq(a, (p ** 2).sum(1), rcond=None)
    centre, k = sol[:3], sol[3]
    r2 = k + centre @ centre
    if r2 <= 0:                                  # degenerate (collinear points): no sphere
        return float(np.sqrt((p ** 2).sum(1).mean()) * scale), 0.0
    r = float(np.sqrt(r2))
    dist = np.linalg.norm(p - centre, axis=1) - r
    return float(np.sqrt((dist ** 2).mean()) * scale), float(min(1.0 / (r * scale), MAX_CURVATURE))


def mean_differences(features: np.ndarray) -> np.ndarray:
    """Pair features ``mean_i - mean_j`` (M x M x 3) of an M x 10 feature matrix."""
    means = np.asarray(features, dtype=float)[:, :3]
    return means[:, None, :] - means[None, :, :]


def features_from_clouds(clouds: list[np.ndarray], last: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Features of each object's visible points (M x 10) and which objects were seen (M bools).

    An object with fewer than :data:`MIN_POINTS` points is not seen: it keeps its row of ``last``
    (its features when it was last seen); one never seen yet has all features 0. Nothing is ever
    filled in from anything but the points.
    """
    out = np.zeros((len(clouds), len(FEATURE_NAMES))) if last is None else np.array(last, dtype=float)
    seen = np.array([len(c) >= MIN_POINTS for c in clouds], dtype=bool)
    for k in np.flatnonzero(seen):
        out[k] = cloud_features(clouds[k])
    return out, seen
