"""The rule learner on little data: held-out gap to the true blocks world at 200 transitions.

The protocol: the reference blocks world (`domains/reference/blocksworld`, problem p01), random
walks of 20 steps with a quarter of the steps trying an inapplicable action (`groundsym simulate
--inapplicable 0.25 --length 20`), training data of 200 transitions from seeds 1-13 (10 traces
each), 2,000 held-out transitions from seed 99 (100 traces). For every learner configuration given
with `--config NAME:KEY=VALUE,...` (fields of `groundsym.rules.learner.LearnOptions`; `default` is
the learner's defaults) it prints each seed's gap (true minus learned mean log-likelihood per
held-out transition, nats), how many seeds are more than 0.1 nats from the truth, and whether the
learned contexts equal the true operators'.

    python examples/rule_small_data.py --config raw:nochange_prior=0 --config default [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import fields
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from groundsym.ppddl.parser import load  # noqa: E402
from groundsym.ppddl.simulate import Task, simulate_traces, transition_model  # noqa: E402
from groundsym.rules.evaluate import score_dataset, score_ruleset  # noqa: E402
from groundsym.rules.learner import LearnOptions, examples_from_dataset, learn_rules  # noqa: E402
from rule_recovery import PPDDLSource, canonical_context, parse_config  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DOMAIN = ROOT / "domains" / "reference" / "blocksworld"


def data(task: Task, seed: int, traces: int):
    return simulate_traces(task, traces, 20, np.random.default_rng(seed), inapplicable=0.25)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", action="append", default=[], help="NAME:KEY=VALUE,... (repeatable)")
    ap.add_argument("--seeds", default="1-13", help="training seeds, e.g. 1-13")
    ap.add_argument("--traces", type=int, default=10, help="training traces of 20 steps (default 10: 200 transitions)")
    ap.add_argument("--test-seed", type=int, default=99)
    ap.add_argument("--problem", default="p01")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    lo, _, hi = args.seeds.partition("-")
    seeds = list(range(int(lo), int(hi or lo) + 1))
    path = DOMAIN / "domain.ppddl"
    domain, problem = load(path, DOMAIN / f"{args.problem}.ppddl")
    task = Task(domain, problem)
    prob, _ = transition_model(path)
    test = data(task, args.test_seed, 100)
    true_ll = score_dataset(prob, test).mean_log_likelihood
    true_ctx = PPDDLSource(DOMAIN).contexts()
    configs = [parse_config(c) for c in (args.config or ["default"])]
    out = {}
    for name, opts in configs:
        rows = []
        for s in seeds:
            train = data(task, s, args.traces)
            rs, _ = learn_rules(examples_from_dataset(train), train.predicates, opts, seed=s, progress=False)
            gap = true_ll - score_ruleset(rs, test).mean_log_likelihood
            same = sorted(canonical_context(r) for r in rs.rules) == true_ctx
            rows.append({"seed": s, "train": train.n_transitions, "gap": gap, "same_contexts": same})
        gaps = np.array([r["gap"] for r in rows])
        print(f"{name:>16s}: gaps " + " ".join(f"{g:.3f}" for g in gaps) +
              f" | > 0.1 nats: {int((gaps > 0.1).sum())}/{len(gaps)}, median {np.median(gaps):.4f}, "
              f"mean {gaps.mean():.4f}, same contexts {sum(r['same_contexts'] for r in rows)}/{len(rows)}", flush=True)
        out[name] = {"options": {f.name: getattr(opts, f.name) for f in fields(LearnOptions)}, "runs": rows}
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "small-data.json").write_text(json.dumps({"true_ll": true_ll, "configs": out}, indent=1,
                                                             default=list) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
