"""Successor generation of the PPDDL simulator against plado's, on random rollouts, in one run.

Both simulators walk the same kind of random rollout: from the initial state, list the applicable
ground actions, pick one uniformly (seeded), generate its successor distribution and sample one;
restart at a dead end or after ``--length`` steps. Rounds alternate between the two so machine
noise hits both; the figure is transitions per second and the ratio. Problems: IPPC 2008
triangle-tireworld p03 and blocksworld p03 (plado reads one ``define`` per file: it gets our
printed domain and problem).

    nice -n 10 .venv/bin/python benchmarks/bench_ppddl_sim.py
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from groundsym.ppddl.parser import load  # noqa: E402
from groundsym.ppddl.simulate import Task  # noqa: E402

PROBLEMS = ["ippc2008/triangle-tireworld/p03.pddl", "ippc2008/blocksworld/p03.pddl"]


def ours(task: Task, steps: int, length: int, rng: np.random.Generator) -> int:
    state, done, t = task.initial_state, 0, 0
    while done < steps:
        acts = task.applicable_actions(state)
        if not acts or t == length:
            state, t = task.initial_state, 0
            continue
        dist = task.outcomes(state, acts[int(rng.integers(len(acts)))])
        state = dist[int(rng.choice(len(dist), p=[d.prob for d in dist]))].state
        done, t = done + 1, t + 1
    return done


class Plado:
    def __init__(self, domain, problem) -> None:
        import plado.parser as pp
        from plado.semantics.applicable_actions_generator import ApplicableActionsGenerator
        from plado.semantics.successor_generator import SuccessorGenerator
        from plado.semantics.task import Task as PTask

        with tempfile.TemporaryDirectory() as tmp:
            d, p = Path(tmp) / "domain.pddl", Path(tmp) / "problem.pddl"
            d.write_text(str(domain))
            p.write_text(str(problem))
            self.t = PTask(*pp.parse_and_normalize(str(d), str(p)))
        self.aag, self.sg = ApplicableActionsGenerator(self.t), SuccessorGenerator(self.t)

    def run(self, steps: int, length: int, rng: np.random.Generator) -> int:
        state, done, t = self.t.initial_state, 0, 0
        while done < steps:
            acts = list(self.aag(state))
            if not acts or t == length:
                state, t = self.t.initial_state, 0
                continue
            dist = self.sg(state, acts[int(rng.integers(len(acts)))])
            probs = np.array([float(p) for _, p in dist])
            state = dist[int(rng.choice(len(dist), p=probs / probs.sum()))][0]
            done, t = done + 1, t + 1
        return done


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000, help="transitions per round")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--length", type=int, default=50, help="rollout length before a restart")
    args = ap.parse_args()
    print(f"{'problem':36s} {'ours tr/s':>10s} {'plado tr/s':>11s} {'ours/plado':>11s}")
    for rel in PROBLEMS:
        domain, problem = load(ROOT / "tests" / "data" / "ippc" / rel)
        task, ref = Task(domain, problem), Plado(domain, problem)
        ours(task, 10, args.length, np.random.default_rng(0))        # grounding, outside the timing
        ref.run(10, args.length, np.random.default_rng(0))
        spent = {"ours": 0.0, "plado": 0.0}
        for r in range(args.rounds):
            t = time.perf_counter()
            ours(task, args.steps, args.length, np.random.default_rng(r))
            spent["ours"] += time.perf_counter() - t
            t = time.perf_counter()
            ref.run(args.steps, args.length, np.random.default_rng(r))
            spent["plado"] += time.perf_counter() - t
        rate = {k: args.steps * args.rounds / v for k, v in spent.items()}
        print(f"{rel:36s} {rate['ours']:10.0f} {rate['plado']:11.0f} {rate['ours'] / rate['plado']:11.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
