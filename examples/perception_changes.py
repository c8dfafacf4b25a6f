"""Which transitions the loss counts as "the geometry changed", on what the camera sees and on poses.

The loss's effect term charges 1 for every transition whose geometry changed (some feature of some
object moved by more than ``change_tol`` of that feature's spread) while the learned abstract state
did not. For each traces file (e.g. the same seeds collected with ``features=pose`` and with
``features=pointcloud``: the same actions, the same physics) this prints how many transitions the
loss's own rule (:func:`groundsym.loss.prepare`) counts as changed, how many of them change no
ground-truth atom, and which features trip the rule where the objects' positions (the first three
features) did not move by that much::

    python examples/perception_changes.py POSE/train_1.json PC/train_1.json [--change-tol 0.05 0.2]

On point-cloud files it also prints how well ``sphere_rms`` and ``sphere_curvature`` tell balls from
the other objects over all their seen views.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.loss import LossConfig, prepare  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402


def changes(path: Path, tol: float) -> dict:
    """Counts for one traces file at one ``change_tol``."""
    ds = read_traces(path)
    data = prepare(ds, LossConfig(change_tol=tol), str(path))
    truth = [tr.scenes[t].truth != tr.scenes[t + 1].truth for tr in ds.traces for t in range(len(tr.actions))]
    truth = np.array(truth)
    moved = np.abs(data.features[data.post] - data.features[data.pre]) / data.unary_scale > tol   # (T, M, n)
    by_position = moved[:, :, :3].any(axis=(1, 2))
    shape_only = data.changed & ~by_position
    return {"file": str(path), "change_tol": tol, "transitions": len(truth), "changed": int(data.changed.sum()),
            "truth_changed": int(truth.sum()), "changed_without_truth_change": int((data.changed & ~truth).sum()),
            "truth_change_missed": int((truth & ~data.changed).sum()),
            "changed_by_later_features_only": int(shape_only.sum()),
            "tripping_features": {name: int(moved[shape_only][:, :, k].any(axis=1).sum())
                                  for k, name in enumerate(ds.feature_names[3:], 3)}}


def roundness(paths: list[Path]) -> str | None:
    """On point-cloud traces: the range of ``sphere_rms`` and ``sphere_curvature`` over the seen
    views of balls and of the other objects (by the truth), and how many of each lie in the box
    ``sphere_rms`` under 1 mm and ``sphere_curvature`` over 40 1/m."""
    balls, others = [], []
    for path in paths:
        ds = read_traces(path)
        if "sphere_rms" not in ds.feature_names:
            return None
        cols = [ds.feature_names.index("sphere_rms"), ds.feature_names.index("sphere_curvature")]
        for tr in ds.traces:
            for sc in tr.scenes:
                round_ = {a.args[0] for a in sc.truth if a.predicate == "ball"}
                for o, f in zip(sc.objects, sc.features):
                    if o not in sc.unseen:
                        (balls if o in round_ else others).append(np.asarray(f)[cols])
    b, o = np.array(balls), np.array(others)
    box = lambda x: int(((x[:, 0] < 0.001) & (x[:, 1] > 40)).sum())  # noqa: E731
    return (f"{len(b)} ball views: sphere_rms {b[:, 0].min() * 1000:.2f}-{b[:, 0].max() * 1000:.2f} mm, curvature "
            f"{b[:, 1].min():.1f}-{b[:, 1].max():.1f} 1/m, {box(b)} in the box (rms < 1 mm, curvature > 40); "
            f"{len(o)} other views: {box(o)} in the box, {int((o[:, 0] < 0.001).sum())} with rms < 1 mm")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("traces", type=Path, nargs="+")
    ap.add_argument("--change-tol", type=float, nargs="+", default=[LossConfig.change_tol])
    args = ap.parse_args()
    for path in args.traces:
        for tol in args.change_tol:
            r = changes(path, tol)
            trips = ", ".join(f"{k} {v}" for k, v in r["tripping_features"].items() if v)
            print(f"{path} (change_tol {tol}): {r['changed']} of {r['transitions']} transitions changed the geometry, "
                  f"{r['truth_changed']} changed the truth; changed without a truth change {r['changed_without_truth_change']}, "
                  f"truth changed but not the geometry {r['truth_change_missed']}; changed with no position moving "
                  f"{r['changed_by_later_features_only']}" + (f" (tripped by {trips})" if trips else ""))
    line = roundness(args.traces)
    if line:
        print(f"roundness over the point-cloud files: {line}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
