"""The paper's Fig. 2(b), 2(c) and 2(d) as one command: ``python examples/fig2_tower.py``.

* (b), (c): 7 cubes, symbols learned from 40, 80 and 160 transitions, models from 3 and 9 traces
  (the symbols of a run serve both trace counts);
* (d): cubes and balls, 7 objects, 2 unary + 1 binary symbols from 80 and 160 transitions, models
  from 8 traces.

Each setting is an ordinary ``groundsym evaluate`` (printed before it runs, so it can be repeated
by hand), 30 runs by default with the paper's annealing budget of 1e5 loss evaluations; outputs go
to ``--out`` (``cubes/`` and ``balls/``: results.json, results.md, results.png). An interrupted run
resumes where it stopped when started again with the same options. ``--quick`` is a reduced
version (5 runs, 20,000 evaluations) that fits a shared two-core machine in about an hour.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

from groundsym.cli import main as groundsym

METHODS = "random,continuous-nn,symbolic-nn,prada"


def settings(args: argparse.Namespace) -> list[tuple[str, list[str]]]:
    common = ["--methods", METHODS, "--runs", str(args.runs), "--workers", str(args.workers),
              "--seed", str(args.seed), "--evals", str(args.evals)]
    cubes = ["evaluate", "--sim", "tower", "--symbol-data", "40,80,160", "--model-traces", "3,9", *common,
             "-o", str(Path(args.out) / "cubes")]
    balls = ["evaluate", "--sim", "tower", "--sim-opt", "cubes=5", "--sim-opt", "balls=2",
             "--unary", "2", "--binary", "1", "--symbol-data", "80,160", "--model-traces", "8", *common,
             "-o", str(Path(args.out) / "balls")]
    return [("Fig. 2(b)/(c): 7 cubes", cubes), ("Fig. 2(d): cubes and balls", balls)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="results/fig2", help="output folder (default results/fig2)")
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--evals", type=int, default=100_000, help="annealing budget per run (default 1e5)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="5 runs, 20,000 evaluations")
    ap.add_argument("--only", choices=["cubes", "balls"], help="run one of the two settings")
    args = ap.parse_args()
    if args.quick:
        args.runs, args.evals = 5, 20_000
    for title, argv in settings(args):
        if args.only and f"/{args.only}" not in argv[-1].replace("\\", "/"):
            continue
        print(f"\n== {title}\n$ groundsym {' '.join(shlex.quote(a) for a in argv)}", flush=True)
        t0 = time.monotonic()
        status = groundsym(argv)
        if status != 0:
            return status
        print(f"({(time.monotonic() - t0) / 60:.1f} min; table, PNG and JSON in {argv[-1]}/)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
