"""The loss with each reward term: evaluations per CPU second of the neighbour reward term, the
linear one, and the linear one with back-off classes, on the same random symbol sets, in one
process, the settings taking turns (``--rounds``), so their ratio shares whatever else the machine
is doing.

Every set is a new abstraction (random centres on the data, widths 0.1-1 spread), so each
evaluation pays the whole miss path: a neighbourhood pass for the prediction term, and for the
reward term either a second pass (neighbour) or the compiled counts and one small ridge solve
(linear; docs/symbols.md, "Keeping a size symbol").

    .venv/bin/python benchmarks/bench_reward_term.py --traces tower7.json --sets 600 --rounds 2
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_loss import benchmark_dataset  # noqa: E402
from groundsym.loss import Loss, LossConfig, LossData, prepare  # noqa: E402
from groundsym.symbols import Symbol  # noqa: E402

SETTINGS = {
    "neighbour": LossConfig(),
    "linear": LossConfig(reward_model="linear", sigma_factor=0.1),
    "linear + back-off": LossConfig(reward_model="linear", static="backoff", sigma_factor=0.1),
}


def random_sets(data: LossData, n_unary: int, n_binary: int, count: int, seed: int) -> list[list[Symbol]]:
    """``count`` random symbol sets: centres on data points, widths 0.1-1 of the spread."""
    rng = np.random.default_rng(seed)
    feats, pairs = data.features, data.pairs
    out = []
    for _ in range(count):
        s = [Symbol(f"u{k + 1}", 1, feats[rng.integers(len(feats)), rng.integers(feats.shape[1])],
                    data.unary_scale * rng.uniform(0.1, 1, feats.shape[-1])) for k in range(n_unary)]
        s += [Symbol(f"b{k + 1}", 2, pairs[rng.integers(len(pairs)), 0, 1],
                     data.pair_scale * rng.uniform(0.1, 1, pairs.shape[-1])) for k in range(n_binary)]
        out.append(s)
    return out


def rates(ds, sets: list[list[Symbol]], rounds: int) -> dict[str, float]:
    """Median evaluations per CPU second of each setting over ``rounds`` turns (fresh losses)."""
    got: dict[str, list[float]] = {k: [] for k in SETTINGS}
    for r in range(rounds):
        order = list(SETTINGS.items()) if r % 2 == 0 else list(reversed(SETTINGS.items()))
        for name, cfg in order:
            loss = Loss(prepare(ds, cfg), cfg)
            loss(sets[0])                         # compile / load the kernels outside the timing
            t = time.process_time()
            for s in sets:
                loss(s)
            got[name].append(len(sets) / max(time.process_time() - t, 1e-9))
    return {k: statistics.median(v) for k, v in got.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--traces", type=Path, help="continuous traces (default: 16 fixture traces, 7 objects)")
    ap.add_argument("--sets", type=int, default=600, help="random symbol sets per setting and round")
    ap.add_argument("--rounds", type=int, default=2, help="turns of the settings (medians are reported)")
    ap.add_argument("--symbols", default="1+1,2+2", help="unary+binary counts, comma-separated")
    args = ap.parse_args()
    ds = benchmark_dataset(args.traces)
    data = prepare(ds)
    print("| symbols | " + " | ".join(SETTINGS) + " | linear / neighbour |")
    print("|---|" + "---|" * (len(SETTINGS) + 1))
    for spec in args.symbols.split(","):
        nu, nb = (int(x) for x in spec.split("+"))
        r = rates(ds, random_sets(data, nu, nb, args.sets, seed=0), args.rounds)
        print(f"| {spec} | " + " | ".join(f"{v:,.0f}" for v in r.values()) + f" | {r['linear'] / r['neighbour']:.2f}x |",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
