"""How far the local distance's loss values are from the exact loss's, along real searches.

The local distance (``--loss distance=local:K``, docs/symbol-search.md) is an approximation, and
no bound on its error is proven. This script measures one: it runs annealing restarts of the
exact loss on a traces file, scores every candidate they visit with the exact loss and with the
local one (fresh losses, one per distance), and prints the largest differences of the total and
of each term, absolute and per transition, over all candidates. A random sample of symbol sets
(a re-seed's proposals) is scored too: the annealing visits mostly good sets, the random ones
show the error where the search starts.

    python examples/local_distance_bound.py traces.json --evals 2000 --restarts 2 --distance local:1 --out bound.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.anneal import AnnealConfig, advance, random_symbol, start_restart  # noqa: E402
from groundsym.errors import UserError  # noqa: E402
from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.loss import Loss, LossConfig, prepare  # noqa: E402
from groundsym.progress import Progress  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402

TERMS = ("total", "effect", "transition", "reward", "regulariser")


class _Recording(Loss):
    """The exact loss, keeping every candidate it scored."""

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.seen: list[list] = []

    def __call__(self, symbols):
        self.seen.append(list(symbols))
        return super().__call__(symbols)


def visited(data, evals: int, restarts: int, seed: int) -> list[list]:
    """The candidates of ``restarts`` exact annealing restarts of ``evals`` evaluations each."""
    out: list[list] = []
    for r in range(restarts):
        cfg = AnnealConfig(evals=evals, restarts=1)
        loss = _Recording(data, LossConfig())
        advance(start_restart(0, seed + r, loss, cfg), loss, cfg, evals)
        out += loss.seen
    return out


def differences(data, sets: list[list], distance: str) -> dict[str, list[float]]:
    """Per term, local minus exact, for each symbol set."""
    exact, approx = Loss(data), Loss(data, LossConfig(distance=distance))
    out: dict[str, list[float]] = {t: [] for t in TERMS}
    bar = Progress(len(sets), f"scored ({distance} and exact)")
    for k, s in enumerate(sets):
        e, a = exact(s).to_doc(), approx(s).to_doc()
        for t in TERMS:
            out[t].append(a[t] - e[t])
        bar.update(k + 1)
    bar.update(len(sets), force=True)
    return out


def summary(diffs: dict[str, list[float]], n_transitions: int) -> dict[str, dict[str, float]]:
    return {t: {"max_abs": float(np.max(np.abs(v))), "max_abs_per_transition": float(np.max(np.abs(v)) / n_transitions),
                "mean": float(np.mean(v)), "median_abs": float(np.median(np.abs(v)))} for t, v in diffs.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("traces", type=Path)
    ap.add_argument("--evals", type=int, default=2000, help="evaluations per annealing restart")
    ap.add_argument("--restarts", type=int, default=1)
    ap.add_argument("--random", type=int, default=500, help="random symbol sets scored as well")
    ap.add_argument("--distance", default="local:1")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, help="JSON of the figures")
    args = ap.parse_args()
    try:
        LossConfig(distance=args.distance)
        if min(args.evals, args.restarts) < 1 or args.random < 0:
            raise ValueError("--evals and --restarts at least 1, --random at least 0")
        data = prepare(read_traces(args.traces), path=str(args.traces))
    except (ValueError, UserError) as exc:
        print(f"local_distance_bound.py: {exc}", file=sys.stderr)
        return 2
    rng = np.random.default_rng(args.seed)
    cfg = AnnealConfig()
    sets = {"annealing": visited(data, args.evals, args.restarts, args.seed),
            "random": [[random_symbol(rng, 1, "u1", data, cfg), random_symbol(rng, 2, "b1", data, cfg)]
                       for _ in range(args.random)]}
    report = {"traces": str(args.traces), "distance": args.distance, "transitions": data.n_transitions,
              "objects": int(data.features.shape[1])}
    for name, group in sets.items():
        report[name] = {"sets": len(group), **summary(differences(data, group, args.distance), data.n_transitions)}
        tot = report[name]["total"]
        print(f"{name}: {len(group)} symbol sets, local - exact total: max |d| {tot['max_abs']:.2f} nats "
              f"({tot['max_abs_per_transition']:.3f} per transition), median |d| {tot['median_abs']:.2f}, "
              f"mean {tot['mean']:+.2f}; transition max |d| {report[name]['transition']['max_abs']:.2f}, "
              f"reward max |d| {report[name]['reward']['max_abs']:.2f}")
    if args.out:
        atomic_write_json(args.out, report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
