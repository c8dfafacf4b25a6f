"""Loss evaluations per second at the paper's size: 7 objects, 160 transitions, 1 unary + 1 binary
symbol, one core.

Two workloads, each on a fresh :class:`~groundsym.loss.Loss` (empty caches), timed in CPU seconds
of this process (the machine is shared):

* ``annealing``: one simulated-annealing restart from a fixed seed (perturbs, re-seeds, swaps),
  which is what ``learn`` pays per core;
* ``random``: independent random symbol sets (centres from the data, random widths), the worst
  case for caches.

Also prints the time the paper's 1e5 budget would take at the annealing rate.

    .venv/bin/python benchmarks/bench_loss.py [--traces FILE] [--evals 3000]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from groundsym.anneal import AnnealConfig, _random_symbol, advance, start_restart  # noqa: E402
from groundsym.loss import Loss, LossConfig, prepare  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402
from tests.test_loss import kinematic_tower  # noqa: E402


def cpu_rate(fn, n: int) -> float:
    """Evaluations per CPU second of this process (robust to other load on a shared machine)."""
    t0 = time.process_time()
    fn()
    return n / (time.process_time() - t0)


def annealing_rate(data, loss_cfg: LossConfig, cfg: AnnealConfig, evals: int, label: str) -> float:
    """Loss evaluations per CPU second of one annealing restart (caches warm up as in a real run)."""
    loss = Loss(data, loss_cfg)
    state = start_restart(0, 0, loss, cfg)
    a = cpu_rate(lambda: advance(state, loss, cfg, evals), evals)
    print(f"annealing, {label}: one restart, {evals} evaluations on one core: {a:.0f} evals per CPU second "
          f"(1e5 evaluations: {1e5 / a / 60:.1f} CPU minutes; {len(loss._abstraction_cache)} distinct abstractions)")
    return a


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--traces", type=Path, help="continuous traces (default: 16 fixture traces, 7 objects)")
    ap.add_argument("--evals", type=int, default=3000, help="evaluations of the annealing workload")
    ap.add_argument("--compare-previous", action="store_true",
                    help="also the loss and search settings before December 2026, and the ratio")
    args = ap.parse_args()
    ds = read_traces(args.traces) if args.traces else kinematic_tower(16, seed=1)
    data = prepare(ds)
    cfg = AnnealConfig(evals=args.evals * 4, restarts=4)
    print(f"data: {data.n_transitions} transitions, {data.features.shape[1]} objects"
          f"{' from ' + str(args.traces) if args.traces else ' (kinematic fixture world)'}; 1 unary + 1 binary")
    a = annealing_rate(data, LossConfig(), cfg, args.evals, "current loss")
    if args.compare_previous:
        old = annealing_rate(data, LossConfig(predict="successor", width_cap=0.0),
                             dataclasses.replace(cfg, p_ignore=0.0), args.evals,
                             "loss before December 2026 (successor copy, no width cap, no ignored dimensions)")
        print(f"current / previous: {a / old:.2f}")
    rng = np.random.default_rng(0)
    n_random = max(args.evals // 10, 50)
    random = [[_random_symbol(rng, 1, "u1", data, cfg), _random_symbol(rng, 2, "b1", data, cfg)]
              for _ in range(n_random)]
    fresh = Loss(data)
    r = cpu_rate(lambda: [fresh(c) for c in random], n_random)
    print(f"random symbol sets (no reuse): {n_random} evaluations, {r:.0f} evals per CPU second")
    return 0


if __name__ == "__main__":
    sys.exit(main())
