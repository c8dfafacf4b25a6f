"""NID rule learning speed: coverage engine ratio and learning time per dataset (issue 4).

Target: a 160-transition tower dataset learns in seconds (the evaluation learns dozens of models).
Prints, measured in this run so machine noise cancels:

* the speed-up of the vectorised coverage (``ExampleTable.cover``) over the reference
  backtracking (``Rule.covers``, one example at a time) on the same rules and examples;
* learning time for 160 transitions of the PPDDL tower reference domain (25 % inapplicable),
  for the same data with 2 % of atoms flipped at random (noisy symbols make many outcomes), and
  for the 40 real tower-sim transitions in tests/data/tower_small.json over its ground truth.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402
from itertools import permutations  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from examples.rule_recovery import REFERENCE, PPDDLSource  # noqa: E402
from groundsym.logic import Atom  # noqa: E402
from groundsym.rules.coverage import ExampleTable  # noqa: E402
from groundsym.rules.learner import examples_from_dataset, learn_rules  # noqa: E402
from groundsym.rules.model import with_derived  # noqa: E402
from groundsym.symbolic_traces import SymbolicDataset, SymbolicTrace  # noqa: E402


def timed(fn, *a, **k):
    t = time.perf_counter()
    out = fn(*a, **k)
    return out, time.perf_counter() - t


def flip(ds: SymbolicDataset, share: float, rng: np.random.Generator) -> SymbolicDataset:
    traces = []
    for tr in ds.traces:
        atoms = [Atom(p, a) for p, k in ds.predicates.items() for a in permutations(tr.objects, k)]
        states = [frozenset(set(s) ^ {a for a in atoms if rng.random() < share}) for s in tr.states]
        traces.append(SymbolicTrace(tr.objects, states, tr.actions, tr.rewards))
    return SymbolicDataset(traces, ds.predicates, ds.primitives)


def tower_truth() -> SymbolicDataset:
    from groundsym.traces import read_traces

    data = read_traces(ROOT / "tests" / "data" / "tower_small.json")
    preds: dict[str, int] = {}
    traces = []
    for tr in data.traces:
        states = [frozenset(s.truth) for s in tr.scenes]
        for s in states:
            preds.update({a.predicate: a.arity for a in s})
        traces.append(SymbolicTrace(tr.objects, states, list(tr.actions), [float(s.reward) for s in tr.scenes[:-1]]))
    return SymbolicDataset(traces, preds, dict(data.primitives))


def main() -> None:
    src = PPDDLSource(REFERENCE / "tower")
    clean = src.sample(160, np.random.default_rng(0))
    (rs, _), t_clean = timed(learn_rules, examples_from_dataset(clean), clean.predicates, seed=0, progress=False)

    # coverage: every learned rule over every example of its action, both ways
    by_action: dict[str, list] = {}
    for e in examples_from_dataset(clean):
        by_action.setdefault(e.action.predicate, []).append(e)
    t_vec = t_ref = 0.0
    for name, exs in by_action.items():
        table = ExampleTable(exs, clean.predicates, rs.derived)   # contexts may use derived predicates
        states = [with_derived(e.state, rs.derived, e.objects) for e in exs]   # as the table holds them
        for r in rs.rules_for(name):
            cov, t = timed(table.cover, r.action, r.context)
            t_vec += t
            ref, t = timed(lambda: [r.covers(s, e.action, True, e.objects) for s, e in zip(states, exs)])
            t_ref += t
            assert len(cov) == sum(b is not None for b in ref)
    print(f"coverage: vectorised {t_vec * 1e3:.2f} ms vs backtracking {t_ref * 1e3:.2f} ms "
          f"over {len(rs.rules)} rules: {t_ref / t_vec:.1f}x")

    noisy = flip(clean, 0.02, np.random.default_rng(1))
    (rs_noisy, _), t_noisy = timed(learn_rules, examples_from_dataset(noisy), noisy.predicates, seed=0, progress=False)
    real = tower_truth()
    (rs_real, _), t_real = timed(learn_rules, examples_from_dataset(real), real.predicates, seed=0, progress=False)
    print(f"learn, 160 transitions of the PPDDL tower: {t_clean:.2f} s ({len(rs.rules)} rules)")
    print(f"learn, the same with 2 % of atoms flipped: {t_noisy:.2f} s ({len(rs_noisy.rules)} rules); "
          f"{t_noisy / t_clean:.1f}x the clean time")
    print(f"learn, {real.n_transitions} real tower-sim transitions over ground truth: {t_real:.2f} s "
          f"({len(rs_real.rules)} rules)")


if __name__ == "__main__":
    main()
