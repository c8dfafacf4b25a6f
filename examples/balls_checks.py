"""Does the loss ask for ``ball``? Checks on a cubes-and-balls grounding report (diagnosis only:
the intended symbols are fitted to the simulator's truth, which learning never sees).

For every seed S of a folder written by ``examples/grounding_report.py --sim-opt "cubes=5 balls=2"
--unary 2`` (``OUT/model_S``, trained on ``DATA/train_S.json``):

* ``learned``: the loss of the learned symbols;
* ``intended``, ``without_ball``: the loss of ``inhand`` + ``ball`` + the better of ``on`` /
  ``above`` (either argument order) written as RBFs, and the same with ``ball`` switched off
  (``examples/fig2_loss_check.py``'s fit);
* with ``--fixed-ball-evals E``: the best loss a search of 1 unary + 1 binary symbol reaches with the
  fitted ``ball`` held fixed as the second unary symbol (4 restarts, E evaluations in all), i.e.
  how good the best set *with* ``ball`` is that the search can find;
* with ``--looks subset --looks-evals E``: learning again with another way of choosing the
  dimensions new symbols ignore (``AnnealConfig.looks``), and what the symbols match on
  ``DATA/test.json``.

    python examples/balls_checks.py --out OUT --data DATA --seeds 1 2 3 4 5 [--fixed-ball-evals 20000]
        [--looks subset --looks-evals 100000]

Writes ``OUT/balls-checks.json`` and prints a table.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from fig2_loss_check import intended_losses  # noqa: E402
from groundsym.anneal import LOOKS, AnnealConfig, advance, anneal, start_restart  # noqa: E402
from groundsym.errors import UserError  # noqa: E402
from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.grounding import fit_relation_symbol, match_symbols  # noqa: E402
from groundsym.loss import Loss, LossConfig, LossData, LossTerms, prepare  # noqa: E402
from groundsym.symbols import Symbol, SymbolSet  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402


class LossWithFixed(Loss):
    """The loss of a candidate set together with fixed symbols (placed after its unary ones)."""

    def __init__(self, data: LossData, fixed: list[Symbol], config: LossConfig = LossConfig()):
        super().__init__(data, config)
        self.fixed = fixed

    def __call__(self, symbols) -> LossTerms:
        unary = [s for s in symbols if s.arity == 1]
        binary = [s for s in symbols if s.arity == 2]
        return super().__call__([*unary, *self.fixed, *binary])


def fixed_search(data: LossData, fixed: list[Symbol], evals: int, seed: int) -> float:
    """Best loss of 1 + 1 searched symbols with ``fixed`` added, over 4 restarts (one process)."""
    cfg = AnnealConfig(n_unary=1, n_binary=1, evals=evals, restarts=4)
    loss = LossWithFixed(data, fixed)
    best = float("inf")
    for r in range(cfg.restarts):
        state = start_restart(r, seed, loss, cfg)
        while not state.finished:
            state = advance(state, loss, cfg, cfg.chunk)
        best = min(best, state.best_terms.total)
    return best


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="a grounding_report.py folder (model_S inside)")
    ap.add_argument("--data", type=Path, required=True, help="its trace folder (train_S.json, test.json)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--fixed-ball-evals", type=int, default=0)
    ap.add_argument("--looks", choices=LOOKS, default=None)
    ap.add_argument("--looks-evals", type=int, default=100_000)
    args = ap.parse_args()
    try:
        test = read_traces(args.data / "test.json") if args.looks else None
        rows = []
        for seed in args.seeds:
            ds = read_traces(args.data / f"train_{seed}.json")
            data = prepare(ds)
            learned = json.loads((args.out / f"model_{seed}" / "symbols.json").read_text())["loss"]["total"]
            row = {"seed": seed, "learned": learned,
                   **intended_losses(ds, Loss(data), ["inhand", "ball"], ["on", "above"], 1, without="ball")}
            row["without_ball"] = row.pop("without")
            if args.fixed_ball_evals:
                ball = fit_relation_symbol("u2", "ball", ds)
                if ball is None:
                    raise UserError(f"{args.data / f'train_{seed}.json'}: no ball in the traces")
                row["fixed_ball"] = fixed_search(data, [ball], args.fixed_ball_evals, seed)
            if args.looks:
                cfg = AnnealConfig(n_unary=2, n_binary=1, evals=args.looks_evals, restarts=4, looks=args.looks)
                res = anneal(data, LossConfig(), cfg, seed, workers=1)
                row[f"looks_{args.looks}"] = {
                    "loss": res.terms.total,
                    "matches": [dataclasses.asdict(m) for m in match_symbols(SymbolSet(tuple(res.symbols), ds.feature_names), test)]}
            rows.append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    except UserError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    atomic_write_json(args.out / "balls-checks.json", {"seeds": args.seeds, "rows": rows})
    print("| seed | learned | intended | without ball | search with ball fixed |")
    print("|---|---|---|---|---|")
    for r in rows:
        fixed = f"{r['fixed_ball']:.1f}" if "fixed_ball" in r else ""
        print(f"| {r['seed']} | {r['learned']:.1f} | {r['intended']:.1f} | {r['without_ball']:.1f} | {fixed} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
