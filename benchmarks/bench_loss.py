"""Loss evaluations per second at the paper's size: 7 objects, 160 transitions, 1 unary + 1 binary
symbol, one core.

Two workloads, each on a fresh :class:`~groundsym.loss.Loss` (empty caches):

* ``annealing``: the exact sequence of candidates a simulated-annealing restart evaluates (recorded
  from a short run with a fixed seed; perturbs, re-seeds and swaps), which is what ``learn`` pays;
* ``random``: independent random symbol sets (centres from the data, random widths), the worst
  case for caches.

Also prints the time the paper's 1e5 budget would take at the annealing rate.

    .venv/bin/python benchmarks/bench_loss.py [--traces FILE] [--evals 3000]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from groundsym.anneal import AnnealConfig, _random_symbol, advance, start_restart  # noqa: E402
from groundsym.loss import Loss, prepare  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402
from tests.test_loss import kinematic_tower  # noqa: E402


class Recorder(Loss):
    """A loss that remembers every candidate it was asked about."""

    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        self.seen = []

    def __call__(self, symbols):
        self.seen.append(list(symbols))
        return super().__call__(symbols)


def rate(data, candidates) -> float:
    loss = Loss(data)
    t0 = time.perf_counter()
    for c in candidates:
        loss(c)
    return len(candidates) / (time.perf_counter() - t0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--traces", type=Path, help="continuous traces (default: 16 fixture traces, 7 objects)")
    ap.add_argument("--evals", type=int, default=3000, help="evaluations per workload")
    args = ap.parse_args()
    ds = read_traces(args.traces) if args.traces else kinematic_tower(16, seed=1)
    data = prepare(ds)
    cfg = AnnealConfig(evals=args.evals * 4, restarts=4)
    rec = Recorder(data)
    state = start_restart(0, 0, rec, cfg)
    advance(state, rec, cfg, args.evals)
    annealing = rec.seen[: args.evals]
    rng = np.random.default_rng(0)
    random = [[_random_symbol(rng, 1, "u1", data, cfg), _random_symbol(rng, 2, "b1", data, cfg)]
              for _ in range(max(args.evals // 5, 50))]
    print(f"data: {data.n_transitions} transitions, {data.features.shape[1]} objects"
          f"{' from ' + str(args.traces) if args.traces else ' (kinematic fixture world)'}; 1 unary + 1 binary")
    a = rate(data, annealing)
    r = rate(data, random)
    print(f"annealing workload: {len(annealing)} evaluations, {a:.0f} evals/s "
          f"(1e5 evaluations: {1e5 / a / 60:.1f} min on one core)")
    print(f"random symbol sets: {len(random)} evaluations, {r:.0f} evals/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
