"""Which transitions the loss counts as "the geometry changed", on what the camera sees and on poses.

The loss's effect term charges 1 for every transition whose geometry changed (some feature of some
object moved by more than ``change_tol`` of that feature's spread) while the learned abstract state
did not. For each traces file (e.g. the same seeds collected with ``features=pose`` and with
``features=pointcloud``: the same actions, the same physics) this prints how many transitions the
loss's own rule (:func:`groundsym.loss.prepare`) counts as changed, how many of them change no
ground-truth atom, and which features trip the rule where the objects' positions (the first three
features) did not move by that much::

    python examples/perception_changes.py POSE/train_1.json PC/train_1.json [--change-tol 0.05 0.2]
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
