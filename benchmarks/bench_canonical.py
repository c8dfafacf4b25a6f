"""Canonical forms of symmetric states: CPU time, peak memory and search leaves per state.

The states colour refinement cannot split (the loss meets them with symmetric binary symbols such
as the bowling alley's "same column"): 5 and 6 mutual pairs, a 12-cycle, two 6-cycles, a complete
bipartite 6 + 6, directed cycles, the Petersen graph; then 200 random states of 8-12 objects, and
a batch of 160 real tower states, the loss's everyday work. Enumerating every order of each
colour class, as the canonical forms did before, took 17.6 CPU s and 2.26 GB for the 5 pairs
alone (10! orders).

    .venv/bin/python benchmarks/bench_canonical.py
"""

from __future__ import annotations

import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from groundsym.anneal import AnnealConfig, random_symbol  # noqa: E402
from groundsym.loss import prepare  # noqa: E402
from groundsym.relational.canonical import canonical_form, canonical_forms, search_leaves  # noqa: E402
from groundsym.symbols import binary_truth, unary_truth  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402
from test_canonical import SYMMETRIC, random_state  # noqa: E402


def measure(u: np.ndarray, b: np.ndarray, lock: np.ndarray) -> tuple[float, float, int]:
    """CPU seconds and peak traced MB of one canonical form, and the search's leaves."""
    tracemalloc.start()
    t0 = time.process_time()
    canonical_form(u, b, lock)
    cpu = time.process_time() - t0
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    return cpu, peak, search_leaves(u, b, lock)


def main() -> int:
    print(f"{'state':28s} {'CPU ms':>8s} {'peak MB':>8s} {'leaves':>7s}")
    for name, state in SYMMETRIC.items():
        cpu, peak, leaves = measure(*state)
        print(f"{name:28s} {cpu * 1e3:8.1f} {peak:8.2f} {leaves:7d}")
    rng = np.random.default_rng(9)
    worst = (0.0, 0.0, 0)
    total = 0.0
    for _ in range(200):
        m = int(rng.integers(8, 13))
        s = random_state(rng, m, int(rng.integers(0, 3)), int(rng.integers(1, 3)),
                          float(rng.uniform(0.01, 0.4)), rng.random() < 0.3)
        r = measure(*s)
        total += r[0]
        worst = tuple(max(a, b) for a, b in zip(worst, r))
    print(f"{'200 random, 8-12 objects':28s} {total / 200 * 1e3:8.1f} {worst[1]:8.2f} {worst[2]:7d}"
          f"   (mean CPU; worst: {worst[0] * 1e3:.1f} ms)")
    data = prepare(read_traces(ROOT / "tests" / "data" / "tower_16.json"))
    cfg = AnnealConfig()
    t0 = time.process_time()
    n = 50
    for _ in range(n):
        syms = [random_symbol(rng, 1, "u1", data, cfg), random_symbol(rng, 2, "b1", data, cfg)]
        u = unary_truth(syms[:1], data.features).astype(np.uint8)[data.pre]
        b = binary_truth(syms[1:], data.pairs).astype(np.uint8)[data.pre]
        canonical_forms(u, b, data.lock)
    print(f"{'tower batch, 160 states':28s} {(time.process_time() - t0) / n * 1e3:8.1f}"
          f"   (CPU ms per batch, random 1 + 1 symbols, no cache)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
