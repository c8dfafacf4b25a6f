"""Does the loss prefer the learned symbols to ``ball`` because shape features jitter? (Diagnosis only:
the intended symbols are fitted to the simulator's truth, which learning never sees.)

For every seed S of a ``examples/grounding_report.py`` folder (``OUT/model_S``, trained on
``DATA/train_S.json``) and every ``change_tol`` given, the loss of the learned symbols, of the
intended set (``inhand``, ``ball`` and the better of ``on``/``above`` fitted to the truth as RBFs,
``examples/fig2_loss_check.py``) and of the intended set without ``ball``. ``change_tol`` decides
which transitions the effect term counts as geometry changes (examples/perception_changes.py): on
point clouds the shape numbers of objects that did not move trip it at the default, so a symbol
that flickers with them earns what a static ``ball`` cannot::

    python examples/perception_loss_check.py --out OUT --data DATA --seeds 1 2 3 4 5 --change-tol 0.05 0.2
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from fig2_loss_check import intended_losses  # noqa: E402
from groundsym.errors import UserError  # noqa: E402
from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.loss import Loss, LossConfig, prepare  # noqa: E402
from groundsym.symbols import load_symbols  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="a grounding_report.py folder (model_S inside)")
    ap.add_argument("--data", type=Path, required=True, help="its trace folder (train_S.json)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--change-tol", type=float, nargs="+", default=[LossConfig.change_tol, 0.2])
    ap.add_argument("-o", "--output", type=Path, help="JSON of the rows (default: OUT/perception-loss-check.json)")
    args = ap.parse_args()
    rows = []
    try:
        for seed in args.seeds:
            path = args.data / f"train_{seed}.json"
            ds = read_traces(path)
            model = args.out / f"model_{seed}"
            if not (model / "symbols.json").exists():
                continue
            learned = list(load_symbols(model / "symbols.json", ds.feature_names).symbols)
            for tol in args.change_tol:
                loss = Loss(prepare(ds, LossConfig(change_tol=tol), str(path)), LossConfig(change_tol=tol))
                row = {"seed": seed, "change_tol": tol, "learned": loss(learned).total,
                       **intended_losses(ds, loss, ["inhand", "ball"], ["on", "above"], 1, without="ball")}
                row["without_ball"] = row.pop("without")
                rows.append(row)
                print(json.dumps(row), file=sys.stderr, flush=True)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    atomic_write_json(args.output or args.out / "perception-loss-check.json", {"seeds": args.seeds, "rows": rows})
    print("| seed | change_tol | learned | intended | without ball | ball worth (nats) | intended beats learned |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['seed']} | {r['change_tol']} | {r['learned']:.1f} | {r['intended']:.1f} | {r['without_ball']:.1f} "
              f"| {r['without_ball'] - r['intended']:.1f} | {'yes' if r['intended'] < r['learned'] else 'no'} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
