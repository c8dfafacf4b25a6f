"""How well the depth camera sees: back-projection error and the roundness number over random poses.

For ``--poses`` random poses of each shape (a cube of 4 or 5 cm turned any way, a ball of 4.5 cm,
anywhere over the start region from the table up to 30 cm) in a bare world (only the body), at each
depth noise level (with ``--dropout`` missing pixels when the noise is on):

* back-projection error: each point's distance from the body's true surface (cube: the largest
  local coordinate minus the half edge; ball: distance from the centre minus the radius), noise off;
* the ``sphere_rms`` and ``sphere_curvature`` features of balls and cubes, their ranges, and how
  many poses a threshold midway between the largest ball and the smallest cube residual would
  misclassify.

    python examples/perception_checks.py --poses 100 --noise 0 0.002 0.005 -o OUT.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.pointcloud import FEATURE_NAMES, cloud_features  # noqa: E402
from sims.tower_camera import DepthCamera  # noqa: E402
from sims.tower_kinematics import pb  # noqa: E402


def random_pose(rng: np.random.Generator, size: float) -> tuple[list[float], np.ndarray]:
    pos = [rng.uniform(0.35, 0.65), rng.uniform(-0.27, 0.27), rng.uniform(size / 2, 0.3)]
    q = rng.normal(size=4)
    return pos, q / np.linalg.norm(q)


def surface_error(shape: str, size: float, pos, q, pts: np.ndarray) -> np.ndarray:
    if shape == "ball":
        return np.linalg.norm(pts - pos, axis=1) - size / 2
    rot = np.array(pb.getMatrixFromQuaternion(q)).reshape(3, 3)
    return np.abs((pts - pos) @ rot).max(1) - size / 2


def run(poses: int, noise: float, dropout: float, seed: int) -> dict:
    client = pb.connect(pb.DIRECT)
    rng = np.random.default_rng(seed)
    cam = DepthCamera(noise=noise, dropout=dropout if noise > 0 else 0.0)
    cam.seed(np.random.default_rng(seed + 1))
    feats: dict[str, list] = {"ball": [], "cube": []}
    errors, counts = [], {"ball": [], "cube": []}
    for _ in range(poses):
        for shape in feats:
            size = 0.045 if shape == "ball" else float(rng.choice([0.04, 0.05]))
            pos, q = random_pose(rng, size)
            vis = (pb.createVisualShape(pb.GEOM_SPHERE, radius=size / 2, physicsClientId=client) if shape == "ball"
                   else pb.createVisualShape(pb.GEOM_BOX, halfExtents=[size / 2] * 3, physicsClientId=client))
            uid = pb.createMultiBody(0, -1, vis, pos, q, physicsClientId=client)
            pts = cam.clouds(cam.capture(client), [uid])[0]
            pb.removeBody(uid, physicsClientId=client)
            feats[shape].append(cloud_features(pts))
            counts[shape].append(len(pts))
            if noise == 0:
                errors.append(surface_error(shape, size, np.array(pos), q, pts))
    pb.disconnect(physicsClientId=client)
    rms = {k: np.array(v)[:, FEATURE_NAMES.index("sphere_rms")] for k, v in feats.items()}
    curv = {k: np.array(v)[:, FEATURE_NAMES.index("sphere_curvature")] for k, v in feats.items()}
    cut = (rms["ball"].max() + rms["cube"].min()) / 2
    out = {"noise": noise, "dropout": dropout if noise > 0 else 0.0, "poses": poses,
           "points": {k: [int(min(v)), int(np.median(v)), int(max(v))] for k, v in counts.items()},
           "sphere_rms_mm": {k: [float(v.min() * 1000), float(np.median(v) * 1000), float(v.max() * 1000)]
                             for k, v in rms.items()},
           "sphere_curvature": {k: [float(v.min()), float(np.median(v)), float(v.max())] for k, v in curv.items()},
           "separated": bool(rms["ball"].max() < rms["cube"].min()),
           "misclassified_at_midway_cut": int((rms["ball"] > cut).sum() + (rms["cube"] <= cut).sum())}
    if errors:
        e = np.abs(np.concatenate(errors))
        out["surface_error_mm"] = {"mean": float(e.mean() * 1000), "p95": float(np.percentile(e, 95) * 1000),
                                   "max": float(e.max() * 1000)}
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=100)
    ap.add_argument("--noise", type=float, nargs="+", default=[0.0, 0.002, 0.005])
    ap.add_argument("--dropout", type=float, default=0.1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("-o", "--output", type=Path)
    args = ap.parse_args()
    rows = []
    for noise in args.noise:
        r = run(args.poses, noise, args.dropout, args.seed)
        rows.append(r)
        print(f"depth noise {noise * 1000:g} mm at 1 m, dropout {r['dropout']:g}: points ball/cube (min, median, max) "
              f"{r['points']['ball']} / {r['points']['cube']}; sphere_rms mm ball {np.round(r['sphere_rms_mm']['ball'], 2)} "
              f"cube {np.round(r['sphere_rms_mm']['cube'], 2)}; separated: {r['separated']} "
              f"(misclassified at the midway cut: {r['misclassified_at_midway_cut']} of {2 * args.poses}); "
              f"curvature 1/m ball {np.round(r['sphere_curvature']['ball'], 1)} cube "
              f"{np.round(r['sphere_curvature']['cube'], 1)}"
              + (f"; surface error mm {r['surface_error_mm']}" if "surface_error_mm" in r else ""))
    if args.output:
        atomic_write_json(args.output, {"command": " ".join(sys.argv), "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
