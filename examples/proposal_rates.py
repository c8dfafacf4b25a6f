"""How often does the search *propose* a symbol that means a ground-truth relation?

A symbol the loss wants can only be learned if the annealer's re-seeds propose something near it.
This script draws new symbols exactly as a re-seed does (``groundsym.anneal.random_symbol``, with
the search settings given) on a traces file, and counts the share of proposals whose truth on the
file's scenes matches each ground-truth relation of the same arity (F1 at least ``--good``; binary
relations in either argument order, as ``groundsym show --against`` scores them). Diagnosis only:
it reads the simulator's truth, which learning never does.

    python examples/proposal_rates.py results/balls/data/train_5.json --draws 10000
    python examples/proposal_rates.py traces.json --search p_moved=0 --relations on above

Prints one line per arity and relation: matching proposals / draws, and as a rate.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.anneal import AnnealConfig, random_symbol  # noqa: E402
from groundsym.commands.learn import anneal_config  # noqa: E402
from groundsym.errors import UserError  # noqa: E402
from groundsym.grounding import _off_diagonal, scores, truth_arrays  # noqa: E402
from groundsym.loss import LossConfig, prepare  # noqa: E402
from groundsym.symbols import dataset_arrays  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402


def rates(path: Path, draws: int, seed: int, cfg: AnnealConfig, good: float,
          relations: list[str] | None) -> dict[tuple[int, str], int]:
    """(arity, relation) -> how many of ``draws`` proposals of that arity match the relation."""
    ds = read_traces(path)
    data = prepare(ds, LossConfig(), str(path))
    feats, pairs = dataset_arrays(ds)
    true_u, true_b = truth_arrays(ds)
    off = _off_diagonal(feats.shape[1])
    wanted = lambda names: [r for r in sorted(names) if relations is None or r in relations]  # noqa: E731
    rng = np.random.default_rng(seed)
    hits: dict[tuple[int, str], int] = {(1, r): 0 for r in wanted(true_u)}
    hits.update({(2, r): 0 for r in wanted(true_b)})
    for arity in (1, 2):
        names = [r for a, r in hits if a == arity]
        if not names:
            continue
        for _ in range(draws):
            s = random_symbol(rng, arity, "s", data, cfg)
            if arity == 1:
                h = s.holds(feats)
                for r in names:
                    hits[1, r] += scores(h, true_u[r])[2] >= good
            else:
                h = s.holds(pairs) & off
                for r in names:
                    t = true_b[r] & off
                    hits[2, r] += max(scores(h, t)[2], scores(h, t.transpose(0, 2, 1))[2]) >= good
    return hits


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("traces", type=Path, nargs="+")
    ap.add_argument("--draws", type=int, default=10_000, help="proposals per arity and file")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--good", type=float, default=0.8, help="F1 at which a proposal matches a relation")
    ap.add_argument("--relations", nargs="+", help="only these relations (default: all in the traces)")
    ap.add_argument("--search", action="append", default=[], metavar="KEY=VALUE",
                    help="search settings, as for groundsym learn --search")
    args = ap.parse_args()
    try:
        if args.draws < 1:
            raise UserError(f"--draws: must be at least 1, got {args.draws}")
        cfg = anneal_config(argparse.Namespace(search=args.search, unary=1, binary=1, evals=100_000, restarts=4))
        for path in args.traces:
            for (arity, rel), n in rates(path, args.draws, args.seed, cfg, args.good, args.relations).items():
                print(f"{path}: {rel}/{arity}: {n} of {args.draws} proposals (F1 >= {args.good}), "
                      f"{100 * n / args.draws:.2f}%")
    except UserError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
