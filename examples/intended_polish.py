"""Is it the loss or the search? The intended symbols, fitted and then polished by local search.

A fitted intended symbol (:func:`groundsym.grounding.fit_relation_symbol`: the bounding box of the
relation's examples; the set as ``examples/fig2_loss_check.py`` builds it) is a poor version of
itself: it looks at every feature dimension and pays 20-40 nats of regulariser where a learned
symbol of the same meaning pays a few. This script
starts a search *from* the fitted set, with small perturbations only (no re-seeds, no swaps) and a
low temperature, so the symbols keep their meaning (their F1 against the simulator's truth is
printed) and lose what the bounding box added. Its loss is the yardstick for a learned set on the
same data: when the polished intended set scores below the learned one, the search missed it;
when above, the loss prefers what was learned.

    python examples/intended_polish.py --data OUT/data --seeds 1 2 3 4 5 6 7 8 9 10 \\
        --unary inhand --report OUT/report.json                       # the tower
    python examples/intended_polish.py --data OUT/data --seeds 1 2 3 4 5 6 7 8 9 10 \\
        --unary inhand ball --report OUT/report.json                  # cubes and balls

``--data`` is a directory of ``train_S.json`` files (``examples/grounding_report.py`` writes one);
``--report`` a grounding report whose learned losses are compared. About 20 s per seed.
``--each-restart`` also runs the default search restart by restart (as ``groundsym learn --seed S``
does) and polishes each restart's best the same way: which basins the restarts end in, and what
their symbols mean.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from fig2_loss_check import intended_set  # noqa: E402

from groundsym.anneal import AnnealConfig, RestartState, advance, start_restart  # noqa: E402
from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.grounding import _off_diagonal, match_symbols, scores, truth_arrays  # noqa: E402
from groundsym.loss import Loss, prepare  # noqa: E402
from groundsym.symbols import Symbol, SymbolSet, dataset_arrays  # noqa: E402
from groundsym.traces import Dataset, read_traces  # noqa: E402


def f1_scores(ds: Dataset, symbols: list[Symbol], unary: list[str], rel: str, swapped: bool) -> list[float]:
    """F1 of each symbol against the relation it was fitted to, on the training scenes."""
    feats, pairs = dataset_arrays(ds)
    tu, tb = truth_arrays(ds)
    off = _off_diagonal(feats.shape[1])
    out = [scores(s.holds(feats), tu[r])[2] for s, r in zip(symbols[:-1], unary)]
    truth = tb[rel].transpose(0, 2, 1) if swapped else tb[rel]
    return out + [scores(symbols[-1].holds(pairs) & off, truth & off)[2]]


def polish(loss: Loss, start: list[Symbol], evals: int, seed: int, n_unary: int) -> RestartState:
    """A low-temperature search of small perturbations from ``start`` (a population of 4 copies)."""
    cfg = AnnealConfig(n_unary=n_unary, n_binary=1, evals=evals, restarts=1, population=4, p_reseed=0.0,
                       p_swap=0.0, t_start=0.005, t_end=0.0002, step=0.15, ladder=1.0)
    terms = loss(start)
    rng = np.random.default_rng(seed)
    state = RestartState(0, evals, 4, rng.bit_generator.state, [list(start)] * 4, [terms.total] * 4,
                         list(start), terms)
    return advance(state, loss, cfg, evals)


def restart_by_restart(ds: Dataset, loss: Loss, seed: int, n_unary: int, evals: int) -> list[dict]:
    """Each restart of the default search (``groundsym learn --seed SEED``'s restarts, run one by
    one), its best set polished as the intended one is: where each basin ends and what it means."""
    cfg = AnnealConfig(n_unary=n_unary, n_binary=1)
    out = []
    for index in range(cfg.restarts):
        state = start_restart(index, seed, loss, cfg)
        state = advance(state, loss, cfg, cfg.budget(index))
        polished = polish(loss, state.best, evals, seed, n_unary)
        out.append({"restart": index, "loss": state.best_terms.total, "matches": _words(ds, state.best),
                     "polished": polished.best_terms.to_doc(), "polished_matches": _words(ds, polished.best)})
    return out


def _words(ds: Dataset, symbols: list[Symbol]) -> list[str]:
    """Each symbol's best match on the training scenes (and its negation's, when better)."""
    out = []
    for m in match_symbols(SymbolSet.for_dataset(symbols, ds), ds):
        neg = f" (negation: {m.negation_of} {m.negation_f1:.2f})" if m.negation_of else ""
        out.append(f"{m.symbol} ~ {m.best_match} {m.f1:.2f}{neg}")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="directory of train_S.json files")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--unary", nargs="+", default=["inhand"], help="intended unary relations")
    ap.add_argument("--binary", nargs="+", default=["on", "above"], help="candidate binary relations (the best is kept)")
    ap.add_argument("--evals", type=int, default=20_000, help="evaluations of the polishing search")
    ap.add_argument("--report", type=Path, help="a grounding report.json whose learned losses are compared")
    ap.add_argument("--json", type=Path, help="write the rows here")
    ap.add_argument("--each-restart", action="store_true",
                    help="also run the default search's restarts one by one and polish each one's best "
                         "(about 30 s per restart)")
    args = ap.parse_args()
    learned = {}
    if args.report:
        learned = {r["seed"]: r["loss"] for r in json.loads(args.report.read_text())["runs"]}
    rows = []
    print("| seed | learned | intended, fitted | intended, polished | polished - learned | F1 (training scenes) |")
    print("|---|---|---|---|---|---|")
    for seed in args.seeds:
        ds = read_traces(args.data / f"train_{seed}.json")
        loss = Loss(prepare(ds))
        start, which = intended_set(ds, loss, args.unary, args.binary)
        if start is None:
            raise SystemExit(f"{args.data / f'train_{seed}.json'}: no relation of {args.binary} holds in the data")
        rel, swapped = which
        state = polish(loss, start, args.evals, seed, len(args.unary))
        names = [*args.unary, rel + (" (swapped)" if swapped else "")]
        f1 = f1_scores(ds, state.best, args.unary, rel, swapped)
        row = {"seed": seed, "fitted": loss(start).total, "polished": state.best_terms.total,
               "polished_terms": state.best_terms.to_doc(), "f1": dict(zip(names, f1)),
               "learned": learned.get(seed)}
        if args.each_restart:
            row["restarts"] = restart_by_restart(ds, loss, seed, len(args.unary), args.evals)
        rows.append(row)
        diff = "" if row["learned"] is None else f"{row['polished'] - row['learned']:+.1f}"
        print(f"| {seed} | {'' if row['learned'] is None else format(row['learned'], '.1f')} | {row['fitted']:.1f} "
              f"| {row['polished']:.1f} | {diff} | " + ", ".join(f"{n} {v:.3f}" for n, v in zip(names, f1)) + " |")
        for r in row.get("restarts", []):
            print(f"|   restart {r['restart']} | {r['loss']:.1f} | | {r['polished']['total']:.1f} | | "
                  + "; ".join(r["polished_matches"]) + " |")
    if args.json:
        atomic_write_json(args.json, {"unary": args.unary, "binary": args.binary, "evals": args.evals, "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
