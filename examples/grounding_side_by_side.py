"""Two grounding reports side by side: per seed, the best F1 any learned symbol reaches on each relation.

Reads folders written by ``examples/grounding_report.py`` (``DIR/model_S`` learned on
``DIR/data/train_S.json``, held-out ``DIR/data/test.json``), e.g. one on point-cloud features and
one on pose features with the same seeds. For every model and relation (``inhand``, ``ball``: a
unary symbol or its complement; ``on``/``above``: a binary symbol in either argument order) it
prints the best F1 over the model's symbols on the held-out scenes, and how many seeds reach
``--good``::

    python examples/grounding_side_by_side.py pointcloud=OUT/pc pose=OUT/pose --seeds 1 2 3 4 5 -o OUT.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.grounding import scores, truth_arrays  # noqa: E402
from groundsym.symbols import dataset_arrays, load_symbols  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402

UNARY = ("inhand", "ball")
BINARY = ("on", "above")


def best_f1(model: Path, test) -> dict[str, float]:
    """Best F1 per relation over the model's symbols (unary: or complement; binary: either order)."""
    symbols = load_symbols(model / "symbols.json", test.feature_names)
    feats, pairs = dataset_arrays(test)
    u, b = symbols.truth_arrays(feats, pairs)
    true_u, true_b = truth_arrays(test)
    off = ~np.eye(feats.shape[1], dtype=bool)[None]
    out = {}
    for rel in UNARY:
        out[rel] = max([scores(p, true_u[rel])[2] for k in range(u.shape[-1]) for p in (u[..., k], ~u[..., k])],
                       default=0.0)
    for rel in BINARY:
        t = true_b[rel] & off
        out[rel] = max([scores(b[..., k] & off, tt)[2] for k in range(b.shape[-1])
                        for tt in (t, t.transpose(0, 2, 1))], default=0.0)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("reports", nargs="+", help="LABEL=DIR of a grounding report")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--good", type=float, default=0.9)
    ap.add_argument("-o", "--output", type=Path)
    args = ap.parse_args()
    table: dict[str, dict[int, dict[str, float]]] = {}
    for item in args.reports:
        label, _, folder = item.partition("=")
        test = read_traces(Path(folder) / "data" / "test.json")
        table[label] = {s: best_f1(Path(folder) / f"model_{s}", test) for s in args.seeds}
    rels = [*UNARY, "on|above"]
    head = "| seed | " + " | ".join(f"{lab}: {r}" for lab in table for r in rels) + " |"
    print(head)
    print("|" + "---|" * (1 + len(table) * len(rels)))
    for s in args.seeds:
        cells = []
        for lab in table:
            f = table[lab][s]
            cells += [f"{f['inhand']:.3f}", f"{f['ball']:.3f}", f"{max(f['on'], f['above']):.3f}"]
        print(f"| {s} | " + " | ".join(cells) + " |")
    for lab in table:
        counts = {r: sum(max(table[lab][s][x] for x in r.split("|")) >= args.good for s in args.seeds) for r in rels}
        print(f"{lab}: F1 >= {args.good} in " + ", ".join(f"{r} {n} of {len(args.seeds)}" for r, n in counts.items()))
    if args.output:
        atomic_write_json(args.output, {"command": " ".join(sys.argv), "good": args.good,
                                        "best_f1": {lab: {str(s): v for s, v in t.items()} for lab, t in table.items()}})
    return 0


if __name__ == "__main__":
    sys.exit(main())
