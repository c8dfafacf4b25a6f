"""Fast exact relational distance against the naive enumeration of all permutations.

Per pair at M = 7 and M = 10 objects, and over a whole leave-one-out nearest-neighbour pass of 160
state-action pairs at M = 7 (the loss's transition predictor). States are abstractions of random
traces of a kinematic stacking world through the intended symbols (``inhand``, ``on``), or of a
traces file given with ``--traces``. The naive pass enumerates every permutation of every
candidate once (vectorised numpy, as the paper's kernel) and compares each query against all.
Prints identical-minimum checks and speed ratios measured in this one run (CPU seconds of this
process, so other load on a shared machine does not distort them).

    .venv/bin/python benchmarks/bench_distance.py [--traces FILE] [--pairs 40]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from groundsym.backends import new_backend  # noqa: E402
from groundsym.loss import prepare  # noqa: E402
from groundsym.relational import Encoded, exact_state_distance, naive_state_distance  # noqa: E402
from groundsym.symbols import binary_truth, unary_truth  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402
from tests.test_loss import intended_symbols, kinematic_tower  # noqa: E402


def items(ds):
    """Encoded state-action pairs (s_t, a_t) of every transition, and the LossData."""
    data = prepare(ds)
    syms = intended_symbols()
    u = unary_truth(syms[:1], data.features).astype(np.uint8)
    b = binary_truth(syms[1:], data.pairs).astype(np.uint8)
    enc = [Encoded(u[data.pre[t]], b[data.pre[t]], np.zeros(0, np.uint8), data.lock[t], int(data.label[t]))
           for t in range(data.n_transitions)]
    return enc, data, u, b


def per_pair(enc, n_pairs, rng):
    pairs = []
    while len(pairs) < n_pairs:  # comparable pairs only (same primitive): others are inf at once
        i, j = rng.choice(len(enc), 2, replace=False)
        if enc[i].label == enc[j].label:
            pairs.append((i, j))
    t0 = time.process_time()
    fast = [exact_state_distance(enc[i], enc[j])[0] for i, j in pairs]
    t1 = time.process_time()
    naive = [naive_state_distance(enc[i], enc[j])[0] for i, j in pairs]
    t2 = time.process_time()
    return fast == naive, (t1 - t0) / n_pairs, (t2 - t1) / n_pairs


def naive_pass(enc):
    """Leave-one-out minimum for every query by full enumeration (all perms of each candidate once)."""
    m = enc[0].n_objects
    perms = np.array(list(itertools.permutations(range(m))), dtype=np.int64)
    flat = []
    for e in enc:
        pu = e.unary[perms].reshape(len(perms), -1)
        pb = e.binary[perms[:, :, None], perms[:, None, :]].reshape(len(perms), -1)
        flat.append((np.concatenate([pu, pb], 1), e.lock[perms], e.label))
    out = []
    for i, q in enumerate(enc):
        qrow = np.concatenate([q.unary.ravel(), q.binary.ravel()])
        best = np.inf
        for j, (rows, locks, label) in enumerate(flat):
            if j == i or label != q.label:
                continue
            ok = (locks == q.lock).all(1)
            if ok.any():
                best = min(best, float((rows[ok] != qrow).sum(1).min()))
        out.append(best)
    return np.array(out)


def fast_pass(data, u, b):
    backend = new_backend()  # fresh memos
    pre_u, pre_b = u[data.pre], b[data.pre]
    nb = backend.neighbours(pre_u, pre_b, data.lock, data.label)
    dist = np.zeros(data.n_transitions)
    for k, group in enumerate(nb.members):
        if len(group) == 1:
            dist[group[0]] = nb.hits[k][0]
    return dist, nb


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--traces", type=Path, help="continuous traces (default: 16 fixture traces, 7 objects)")
    ap.add_argument("--pairs", type=int, default=40, help="sampled pairs per size at M = 7 (a few at M = 10)")
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    ds7 = read_traces(args.traces) if args.traces else kinematic_tower(16, seed=1)
    enc7, data, u, b = items(ds7)
    enc10, *_ = items(kinematic_tower(4, seed=2, n_cubes=10))
    print(f"data: {len(enc7)} state-action pairs, {enc7[0].n_objects} objects"
          f"{' from ' + str(args.traces) if args.traces else ' (kinematic fixture world)'}")
    for name, enc, n in (("M=7", enc7, args.pairs), ("M=10", enc10, 3)):
        same, tf, tn = per_pair(enc, n, rng)
        print(f"per pair {name}: {n} pairs, identical minima: {same}; fast {tf * 1e3:.3f} ms, "
              f"naive {tn * 1e3:.1f} ms, ratio {tn / tf:.0f}x")
    # the first pass also builds the per-size permutation tables (once per process); later passes,
    # each on a fresh backend (empty memos), show the cost of one pass itself
    times = []
    for _ in range(4):
        t0 = time.process_time()
        fast, nb = fast_pass(data, u, b)
        times.append(time.process_time() - t0)
    t1 = time.process_time()
    naive = naive_pass(enc7)
    tn = time.process_time() - t1
    singles = sum(len(g) == 1 for g in nb.members)
    tf = float(np.median(times[1:]))
    print(f"leave-one-out NN pass over {len(enc7)} pairs (M=7): identical minima: {bool(np.array_equal(fast, naive))}; "
          f"fast {tf:.4f} s (first pass, with the permutation tables: {times[0]:.3f} s), naive {tn:.2f} s, "
          f"ratio {tn / tf:.0f}x (first pass {tn / times[0]:.0f}x) "
          f"({len(nb.members)} classes of isomorphic pairs, {singles} needed a search)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
