"""The paper's Fig. 2(a): validated loss of learned versus random symbols, over training sizes.

For each training size N (transitions taken from the start of the training traces) and seed,
symbols are learned by simulated annealing (1 unary + 1 binary) and their loss is measured on
held-out test traces (400 transitions in the paper). Random symbols (centres drawn from the
training data, random widths, as the annealer's initial candidates) are measured on the same
test data for comparison. Writes `fig2a.md` (table), `fig2a.json` and `fig2a.png`.

Trace files come from `groundsym collect --sim tower` (e.g. 16 traces for training, 40 for test):

    groundsym collect --sim tower --traces 16 --seed 101 -o train.json
    groundsym collect --sim tower --traces 40 --seed 200 -o test.json
    .venv/bin/python examples/fig2a_loss.py --train train.json --test test.json --out results/fig2a
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from groundsym.anneal import AnnealConfig, random_symbol, anneal  # noqa: E402
from groundsym.fileio import atomic_write_bytes, atomic_write_json, atomic_write_text  # noqa: E402
from groundsym.loss import Loss, LossConfig, prepare  # noqa: E402
from groundsym.traces import Dataset, Trace, read_traces  # noqa: E402
from groundsym.workers import default_workers  # noqa: E402


def first_transitions(ds: Dataset, n: int) -> Dataset:
    """The first ``n`` transitions of the traces, in order (the last trace cut short)."""
    traces, left = [], n
    for tr in ds.traces:
        if left <= 0:
            break
        k = min(left, len(tr))
        traces.append(Trace(tr.objects, tr.scenes[: k + 1], tr.actions[:k]))
        left -= k
    return Dataset(traces, ds.feature_names, ds.primitives, ds.meta)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", type=Path, required=True)
    ap.add_argument("--test", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--sizes", type=int, nargs="+", default=[10, 20, 40, 80, 160])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--evals", type=int, default=8000, help="annealing budget per learned symbol set")
    ap.add_argument("--random", type=int, default=20, help="random symbol sets per size and seed")
    ap.add_argument("--workers", type=int, default=None)
    args = ap.parse_args()
    train, test = read_traces(args.train), read_traces(args.test)
    test_loss = Loss(prepare(test, path=str(args.test)))
    cfg = AnnealConfig(evals=args.evals, restarts=4)
    rows = []
    for n in args.sizes:
        ds = first_transitions(train, n)
        data = prepare(ds, path=f"{args.train} (first {n})")
        learned, random = [], []
        for seed in args.seeds:
            res = anneal(data, LossConfig(), cfg, seed, workers=args.workers or default_workers())
            learned.append(test_loss(res.candidate).total)
            rng = np.random.default_rng(seed)
            for _ in range(args.random):
                cand = [random_symbol(rng, 1, "u1", data, cfg), random_symbol(rng, 2, "b1", data, cfg)]
                random.append(test_loss(cand).total)
        q1, med, q3 = (float(x) for x in np.percentile(random, [25, 50, 75]))
        rows.append({"n": n, "learned_mean": float(np.mean(learned)), "learned_std": float(np.std(learned)),
                     "random_mean": float(np.mean(random)), "random_std": float(np.std(random)),
                     "random_median": med, "random_q1": q1, "random_q3": q3,
                     "learned": learned, "random": random})
        print(f"N={n}: learned {np.mean(learned):.1f} +- {np.std(learned):.1f}, "
              f"random median {med:.1f} (quartiles {q1:.1f}, {q3:.1f})", file=sys.stderr)
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(args.out / "fig2a.json", {"train": str(args.train), "test": str(args.test),
                                                "test_transitions": test.n_transitions, "evals": args.evals,
                                                "seeds": args.seeds, "rows": rows})
    table = ["| training transitions | learned symbols: mean +- sd over seeds | random symbols: median "
             "[quartiles] | random: mean |", "|---|---|---|---|"]
    table += [f"| {r['n']} | {r['learned_mean']:.1f} +- {r['learned_std']:.1f} | {r['random_median']:.1f} "
              f"[{r['random_q1']:.1f}, {r['random_q3']:.1f}] | {r['random_mean']:.1f} |" for r in rows]
    text = (f"Loss on {test.n_transitions} held-out transitions ({args.test}), lower is better\n\n"
            + "\n".join(table) + "\n")
    atomic_write_text(args.out / "fig2a.md", text)
    print(text)
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5, 3.6))
    ns = [r["n"] for r in rows]
    ax.errorbar(ns, [r["learned_mean"] for r in rows], [r["learned_std"] for r in rows], marker="o",
                label="learned (mean, sd)")
    med = np.array([r["random_median"] for r in rows])
    iqr = np.array([[m - r["random_q1"], r["random_q3"] - m] for m, r in zip(med, rows)]).T
    ax.errorbar(ns, med, iqr, marker="s", label="random (median, quartiles)")
    ax.set_xscale("log")
    ax.set_xticks(ns, [str(n) for n in ns])
    ax.set_xlabel("training transitions")
    ax.set_ylabel(f"loss on {test.n_transitions} test transitions")
    ax.legend()
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    atomic_write_bytes(args.out / "fig2a.png", buf.getvalue())
    return 0


if __name__ == "__main__":
    sys.exit(main())
