"""Why PRADA falls short of the optimum in the tower cell: model data, planner, or motor noise?

PRADA plans on the simulator's ground-truth `inhand` and `on` (no symbol learning involved) with
NID rules and a reward model learned from random traces. The traces come from a *pool*: chunks of 3
random traces (`groundsym collect --traces 3 --seed S`, one file per seed, collected here when
missing, so an interrupted pool resumes). Models are learned on disjoint consecutive groups of
`--traces` traces of the pool (a pool of 90 traces gives 10 models of 9, 3 of 30, 1 of 90), and
each model plays `--starts` start states. Every episode is appended to `episodes.jsonl` in `--out`
as soon as it ends, so the run resumes too.

Each episode is read for what went wrong, step by step, against the simulator's truth:

* grasps tried and failed (`closeHandAround(X)` without `inhand(X)` after it), and releases that did
  not leave the held cube on another one;
* "undo" grasps: a grasp of a cube that stands on another one (it takes a tower apart), and
  grasps of a covered cube (another one stands on it: the hand cannot reach it), and releases
  over a covered cube (the held one lands on whatever stands on it, or falls);
* repeats: the same primitive again after it changed nothing;
* the rules' probability of what happened (mean log-likelihood of the observed successor) and the
  share of steps the model had no rule for (the default rule covered them).

    python examples/tower_prada_diagnosis.py --pool results/pool --pool-seeds 0-29 --traces 9 \\
        --starts 3 --out results/diag9 [--planner-opt horizon=6] [--sim-opt noise=0]

Tune options on a pool and start seeds that are not reported (e.g. `--pool-seeds 1000-1005
--start-seed 5000`).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from groundsym.collect import collect_traces  # noqa: E402
from groundsym.episode import SimEnv, run_episode  # noqa: E402
from groundsym.evaluation.truth import TruthSymbols  # noqa: E402
from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.logic import Atom, parse_atom  # noqa: E402
from groundsym.reward import fit_reward  # noqa: E402
from groundsym.rules.learner import LearnOptions, examples_from_dataset, learn_rules  # noqa: E402
from groundsym.planner import PlanningModel, make_planner  # noqa: E402
from groundsym.registry import make_sim  # noqa: E402
from groundsym.options import split_key_values  # noqa: E402
from groundsym.traces import Dataset, read_traces, write_traces  # noqa: E402
from rule_recovery import parse_config  # noqa: E402
from sims.tower import optimal_episode_value  # noqa: E402

CHUNK = 3          # traces per pool file


def seed_range(text: str) -> list[int]:
    """``0-29`` or ``0,3,5`` -> the seeds."""
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def pool_traces(sim, pool: Path, seeds: list[int]) -> list:
    """The pool's traces in seed order, collecting missing chunks first (resumable)."""
    pool.mkdir(parents=True, exist_ok=True)
    traces, info = [], None
    for s in seeds:
        path = pool / f"c{s}.json"
        if not path.exists():
            print(f"collecting pool chunk {s} ({CHUNK} traces)", file=sys.stderr, flush=True)
            write_traces(path, collect_traces(sim, CHUNK, sim.episode_length, s, progress=False))
        ds = read_traces(path)
        traces.extend(ds.traces)
        info = ds
    return traces, info


def step_reading(ep, rules, objects: tuple[str, ...]) -> dict:
    """What went wrong in one episode (module docstring), read off its recorded steps."""
    grasps = failed_grasps = releases = failed_releases = undo = covered = covered_rel = repeats = uncovered = 0
    loglik, prev = [], None
    states = [frozenset(parse_atom(a) for a in s.state or ()) for s in ep.steps]
    states.append(frozenset(parse_atom(a) for a in ep.final_state or ()))
    for t, s in enumerate(ep.steps):
        act, before, after = parse_atom(s.action), states[t], states[t + 1]
        x = act.args[0]
        if act.predicate == "closeHandAround":
            grasps += 1
            failed_grasps += Atom("inhand", (x,)) not in after
            undo += any(a.predicate == "on" and a.args[0] == x for a in before)
            covered += any(a.predicate == "on" and a.args[1] == x for a in before)
        else:
            held = [a.args[0] for a in before if a.predicate == "inhand"]
            if held:
                releases += 1
                failed_releases += not any(a.predicate == "on" and a.args[0] == held[0] for a in after)
                covered_rel += any(a.predicate == "on" and a.args[1] == x for a in before)
        repeats += prev is not None and prev == (act, before) and before == after
        prev = (act, after)
        rule, _ = rules.covering(before, act, objects)
        uncovered += rule is None
        loglik.append(np.log(max(rules.likelihood(before, act, after, objects), 1e-300)))
    return {"grasps": grasps, "failed_grasps": failed_grasps, "releases": releases,
            "failed_releases": failed_releases, "undo_grasps": undo, "covered_grasps": covered, "covered_releases": covered_rel, "repeats": repeats,
            "default_rule_steps": uncovered, "mean_loglik": float(np.mean(loglik)) if loglik else 0.0,
            "actions": [s.action for s in ep.steps], "rewards": [s.reward for s in ep.steps],
            "states": [sorted(map(str, st)) for st in states]}


def config_key(args: argparse.Namespace) -> str:
    """Episodes of the same configuration resume; any other configuration starts its own rows."""
    cfg = {k: getattr(args, k) for k in ("pool_seeds", "traces", "starts", "start_seed", "planner_opt", "sim_opt")}
    cfg["reward_chain"] = None if args.reward_chain == 3 else args.reward_chain     # keys of the first runs
    if args.learn_opt:
        cfg["learn_opt"] = args.learn_opt
    if args.untied:
        cfg["untied"] = True
    return hashlib.sha256(json.dumps(cfg, sort_keys=True).encode()).hexdigest()[:16]


def learn(sym: TruthSymbols, traces: list, info: Dataset, k: int, options: LearnOptions, chain: int,
          tie: bool = True) -> tuple:
    """Rules and reward of model ``k``, as ``groundsym learn`` fits them (seed ``k``)."""
    ds = Dataset(traces, info.feature_names, dict(info.primitives), dict(info.meta))
    sds = sym.to_symbolic_dataset(ds)
    rules, _ = learn_rules(examples_from_dataset(sds), sds.predicates, options, seed=k, progress=False)
    return ds, sds, rules, fit_reward(sds, seed=k, chain=chain, tie_chains=tie)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pool", type=Path, required=True, help="folder of trace chunks (collected when missing)")
    ap.add_argument("--pool-seeds", default="0-29", help="chunk seeds, e.g. 0-29 (3 traces each)")
    ap.add_argument("--traces", type=int, default=9, help="traces per model (disjoint groups of the pool)")
    ap.add_argument("--models", type=int, default=None, help="at most this many models")
    ap.add_argument("--starts", type=int, default=3, help="start states per model")
    ap.add_argument("--start-seed", type=int, default=500, help="start state of model m, start k: this + m*starts + k")
    ap.add_argument("--planner-opt", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--reward-chain", type=int, default=3, help="longest on-chain feature of the reward (default 3)")
    ap.add_argument("--learn-opt", default="", help="rule learner options KEY=VALUE,... (LearnOptions fields)")
    ap.add_argument("--untied", action="store_true", help="reward without the tied path column "
                    "(fit_reward tie_chains=False, the reward model before it)")
    ap.add_argument("--sim-opt", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    opts = split_key_values(args.sim_opt, "--sim-opt")
    popts = split_key_values(args.planner_opt, "--planner-opt")
    sim = make_sim("tower", opts)
    best = optimal_episode_value({k: v for k, v in opts.items() if k != "noise"})
    sym = TruthSymbols(("inhand", "on"), dict(sim.truth_predicates))
    traces, info = pool_traces(sim, args.pool, seed_range(args.pool_seeds))
    n_models = len(traces) // args.traces if args.models is None else min(args.models, len(traces) // args.traces)
    key = config_key(args)
    args.out.mkdir(parents=True, exist_ok=True)
    log = args.out / "episodes.jsonl"
    done = {(r["model"], r["start"]) for r in map(json.loads, log.read_text().splitlines())
            if r["config"] == key} if log.exists() else set()
    _, learn_opts = parse_config(f"cli:{args.learn_opt}")
    for m in range(n_models):
        if all((m, k) in done for k in range(args.starts)):
            continue
        group = traces[m * args.traces:(m + 1) * args.traces]
        ds, sds, rules, reward = learn(sym, group, info, m, learn_opts, args.reward_chain, not args.untied)
        model = PlanningModel(dict(sim.primitives), predicates=dict(sym.predicates), symbols=sym,
                              rules=rules, reward=reward, traces=ds, symbolic_traces=sds, gamma=float(sim.gamma))
        for k in range(args.starts):
            if (m, k) in done:
                continue
            start = args.start_seed + m * args.starts + k
            planner = make_planner("prada", model, popts, 1000 + start)
            ep = run_episode(SimEnv(sim, sym), planner, sim.episode_length, start, "prada")
            row = {"config": key, "model": m, "start": k, "start_seed": start, "value": ep.value,
                   "share": ep.value / best, "rules": len(rules.rules), **step_reading(ep, rules, tuple(sim.objects))}
            with log.open("a") as f:
                f.write(json.dumps(row) + "\n")
            print(f"model {m + 1}/{n_models} start {k + 1}: {row['share']:.1%} of V*; grasps failed "
                  f"{row['failed_grasps']}/{row['grasps']}, releases failed {row['failed_releases']}/"
                  f"{row['releases']}, undo {row['undo_grasps']}, repeats {row['repeats']}",
                  file=sys.stderr, flush=True)
    rows = [r for r in map(json.loads, log.read_text().splitlines()) if r["config"] == key]
    return summarise(rows, args, best)


def summarise(rows: list[dict], args: argparse.Namespace, best: float) -> int:
    share = np.array([r["share"] for r in rows])
    se = float(share.std(ddof=1) / np.sqrt(len(share))) if len(share) > 1 else None
    tot = {k: int(sum(r.get(k, 0) for r in rows)) for k in ("grasps", "failed_grasps", "releases", "failed_releases",
                                                    "undo_grasps", "covered_grasps", "covered_releases", "repeats",
                                                    "default_rule_steps")}
    print(f"PRADA, true inhand/on, rules from {args.traces} traces, {len(rows)} episodes "
          f"({len({r['model'] for r in rows})} models): {share.mean():.1%} +- {se or 0:.1%} of V*; per episode: "
          + ", ".join(f"{k} {v / max(len(rows), 1):.2f}" for k, v in tot.items()))
    atomic_write_json(args.out / "summary.json", {
        "traces": args.traces, "pool_seeds": args.pool_seeds, "starts": args.starts,
        "planner_opt": args.planner_opt, "sim_opt": args.sim_opt, "reward_chain": args.reward_chain,
        "learn_opt": args.learn_opt, "untied": args.untied,
        "episodes": len(rows), "mean_share": float(share.mean()), "stderr": se, "optimum": best,
        "totals": tot, "mean_loglik": float(np.mean([r["mean_loglik"] for r in rows]))})
    return 0


if __name__ == "__main__":
    sys.exit(main())
