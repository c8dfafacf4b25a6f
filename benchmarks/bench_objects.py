"""PRADA and the NID rule learner against the number of objects, 7 to 40, on one core.

Real scenes hold 10-40 objects; the tower cell's default holds 7 and ``workspace=wide`` 20
(docs/tower.md). This benchmark prints, per object count M, CPU seconds (``time.process_time``,
so the loaded machine's other processes do not count):

* **PRADA**: grounding the model on M objects once, and one decision at horizon 4 with 500
  samples (median of ``--repeats``), with the shares of factored-frontier inference, sampling
  and the reward in a decision. The model is the one ``bench_prada.py`` plans with (9 random
  traces of the 7-cube tower cell abstracted with its true ``inhand`` and ``on``, rules and
  reward learned as ``groundsym learn`` does); NID rules are relational, so the same model plans
  over any M. The state is the cell's start: every object on the table (no atom true).
* **The rule learner**: learning NID rules from 160 transitions of the PPDDL tower reference
  domain (``domains/reference/tower``, the cell's dynamics by hand) on M cubes, all on the table
  at the start, random walks of 20 steps with 25 % inapplicable primitives (as ``bench_rules.py``
  samples it), and which functions take most of the time at the largest M (cProfile, own time).

It writes the curve to ``--out`` (JSON and a PNG). docs/tower.md ("Larger problems") reports it.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import cProfile  # noqa: E402
import pstats  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, Callable  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import planners.prada.core as prada_core  # noqa: E402
from bench_prada import Timer, build_model  # noqa: E402
from groundsym.fileio import atomic_write_bytes, atomic_write_json  # noqa: E402
from groundsym.planner import Observation, PlanningModel  # noqa: E402
from planners.prada import PradaPlanner  # noqa: E402
from planners.prada.frontier import TRANSITION_MODES  # noqa: E402

TOWER_DOMAIN = ROOT / "domains" / "reference" / "tower" / "domain.ppddl"
TRACE_LENGTH = 20


def cpu(fn: Callable[[], Any]) -> tuple[Any, float]:
    t = time.process_time()
    out = fn()
    return out, time.process_time() - t


def prada_row(pm: PlanningModel, m: int, repeats: int) -> dict[str, Any]:
    """Grounding and decision CPU times on ``m`` objects, all on the table."""
    objects = tuple(f"o{i + 1}" for i in range(m))
    state: frozenset = frozenset()
    obs = Observation(objects, (), state)
    planner = PradaPlanner(pm, {"horizon": "4", "samples": "500"}, seed=0)
    core, ground = cpu(lambda: planner.core(objects, state))
    planner.choose(obs)                                               # warm-up
    times = [cpu(lambda: planner.choose(obs))[1] for _ in range(repeats)]
    timer = Timer()
    saved = {name: getattr(prada_core, name) for name in ("rule_probabilities", "transition", "action_weights",
                                                            "sample_rows")}
    timer.wrap(prada_core, "rule_probabilities", "inference")
    timer.wrap(prada_core, "transition", "inference")
    timer.wrap(prada_core, "action_weights", "sampling")
    timer.wrap(prada_core, "sample_rows", "sampling")
    reward = core.reward

    def timed_reward(b):
        t = time.perf_counter()
        try:
            return reward(b)
        finally:
            timer.spent["reward"] = timer.spent.get("reward", 0.0) + time.perf_counter() - t
    core.reward = timed_reward
    t = time.perf_counter()
    for _ in range(repeats):
        planner.choose(obs)
    total = time.perf_counter() - t
    core.reward = reward
    for name, fn in saved.items():
        setattr(prada_core, name, fn)
    g = core.g
    shares = {k: v / total for k, v in timer.spent.items()}
    return {"objects": m, "ground_atoms": int(g.n_vars), "ground_rules": int(len(g.rule_group)),
            "ground_actions": int(len(g.actions)), "grounding_cpu_s": ground,
            "decision_cpu_s": float(np.median(times)), "shares": shares}


def transition_modes(pm: PlanningModel, m: int, repeats: int) -> dict[str, Any]:
    """PRADA's ``transition`` option (``tables``, ``auto``, ``segments``) at ``m`` objects: CPU
    seconds of a decision and of its transition steps for each, in turns, each decision from the
    same seed, and whether ``auto`` decides exactly as ``tables`` (the code before) does."""
    objects = tuple(f"o{i + 1}" for i in range(m))
    obs = Observation(objects, (), frozenset())
    planners = {mode: PradaPlanner(pm, {"horizon": "4", "samples": "500", "transition": mode}, seed=0)
                for mode in TRANSITION_MODES}
    for p in planners.values():
        p.choose(obs)                                                    # grounding and warm-up
    decision = {mode: 0.0 for mode in planners}
    step = {mode: 0.0 for mode in planners}
    made: dict[str, list] = {mode: [] for mode in planners}
    original = prada_core.transition
    for r in range(repeats):
        for mode, planner in planners.items():
            planner.rng = np.random.default_rng(r)

            def timed(*a, _mode=mode):
                t = time.process_time()
                try:
                    return original(*a)
                finally:
                    step[_mode] += time.process_time() - t
            prada_core.transition = timed
            try:
                d, spent = cpu(lambda: planner.choose(obs))
            finally:
                prada_core.transition = original
            decision[mode] += spent / repeats
            made[mode].append((d.action, d.expected_value, d.info))
    return {"objects": m, "decision_cpu_s": decision, "transition_cpu_s": {k: v / repeats for k, v in step.items()},
            "auto_same_as_tables": made["auto"] == made["tables"],
            "segments_same_as_tables": made["segments"] == made["tables"]}


def tower_dataset(m: int, transitions: int, seed: int):
    """``transitions`` random-walk transitions of the PPDDL tower on ``m`` cubes, all on the table."""
    from groundsym.ppddl.parser import load, parse_problem
    from groundsym.ppddl.simulate import Task, simulate_traces

    domain, _ = load(TOWER_DOMAIN)
    names = " ".join(f"o{i + 1}" for i in range(m))
    init = " ".join(f"(clear o{i + 1}) (ontable o{i + 1})" for i in range(m))
    problem = parse_problem(f"(define (problem tower-{m}) (:domain tower-cell) (:objects {names}) "
                            f"(:init {init}) (:goal (on o1 o2)) (:goal-reward 1) (:metric maximize (reward)))",
                            domain)
    task = Task(domain, problem)
    ds = simulate_traces(task, -(-transitions // TRACE_LENGTH), TRACE_LENGTH, np.random.default_rng(seed),
                         inapplicable=0.25)
    from examples.rule_recovery import trim

    return trim(ds, transitions)


def rules_row(m: int, transitions: int, seed: int) -> dict[str, Any]:
    from groundsym.rules.learner import examples_from_dataset, learn_rules

    ds = tower_dataset(m, transitions, seed)
    examples, t_examples = cpu(lambda: list(examples_from_dataset(ds)))
    (rs, _), t_learn = cpu(lambda: learn_rules(examples, ds.predicates, seed=0, progress=False))
    return {"objects": m, "transitions": ds.n_transitions, "rules": len(rs.rules),
            "examples_cpu_s": t_examples, "learn_cpu_s": t_learn}


def rules_profile(m: int, transitions: int, seed: int, top: int = 8) -> list[tuple[str, float]]:
    """The project's functions with the most time (their callees' included) in one rule-learning
    run on ``m`` objects, as shares of the run (cProfile; nested functions overlap)."""
    from groundsym.rules.learner import examples_from_dataset, learn_rules

    ds = tower_dataset(m, transitions, seed)
    prof = cProfile.Profile()
    prof.enable()
    learn_rules(examples_from_dataset(ds), ds.predicates, seed=0, progress=False)
    prof.disable()
    stats = pstats.Stats(prof).stats
    total = sum(s[2] for s in stats.values())                          # own times add up to the run
    ours = [(k, s) for k, s in stats.items() if k[0].startswith(str(ROOT / "groundsym"))
            and k[2] not in ("learn_rules", "learn", "_best_of")]     # the whole run, or most of it
    ranked = sorted(ours, key=lambda kv: -kv[1][3])[:top]
    return [(f"{Path(f).relative_to(ROOT)}:{line} {name}", s[3] / total) for (f, line, name), s in ranked]


def objects_png(doc: dict[str, Any]) -> bytes:
    """The curve: CPU seconds against the object count, both axes logarithmic."""
    import io

    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.0), dpi=100)
    ax = fig.add_subplot()
    p, r = doc["prada"], doc["rules"]
    ax.plot([x["objects"] for x in p], [x["decision_cpu_s"] for x in p], "o-", label="PRADA decision (h 4, 500 samples)")
    ax.plot([x["objects"] for x in p], [x["grounding_cpu_s"] for x in p], "s--", label="PRADA grounding (once)")
    ax.plot([x["objects"] for x in r], [x["learn_cpu_s"] for x in r], "^-",
            label=f"rule learning ({r[0]['transitions'] if r else 0} transitions)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xticks([x["objects"] for x in p], [str(x["objects"]) for x in p])
    ax.minorticks_off()
    ax.set(xlabel="objects M", ylabel="CPU seconds", title="PRADA and the rule learner against the number of objects")
    ax.legend(fontsize=8)
    fig.tight_layout()
    out = io.BytesIO()
    fig.savefig(out, format="png")
    return out.getvalue()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", default="7,10,14,20,30,40", help="object counts, comma-separated")
    ap.add_argument("--repeats", type=int, default=5, help="PRADA decisions timed per object count (median)")
    ap.add_argument("--transitions", type=int, default=160, help="transitions the rule learner learns from")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--no-profile", action="store_true", help="skip the rule learner's profile")
    ap.add_argument("--compare", action="store_true", help="also PRADA's transition options (tables, auto, "
                    "segments) against each other, in turns, and whether they decide alike")
    ap.add_argument("--out", type=Path, default=None, help="folder for objects.json and objects.png")
    args = ap.parse_args()
    counts = [int(x) for x in args.objects.split(",") if x.strip()]
    if not counts or min(counts) < 2 or args.repeats < 1 or args.transitions < 1:
        print("bench_objects: --objects needs counts of at least 2, --repeats and --transitions at least 1",
              file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        pm, _, _ = build_model(args.seed, Path(tmp) / "model")
    print(f"model: {len(pm.rules.rules)} rules learned on the 7-cube tower cell (true inhand, on)")
    doc: dict[str, Any] = {"prada": [], "rules": [], "profile": []}
    prada_row(pm, counts[0], 1)                                     # warm-up: first calls, imports
    print(f"{'M':>3} {'atoms':>6} {'g.rules':>8} {'actions':>7} {'ground s':>9} {'decision s':>10}  shares")
    for m in counts:
        row = prada_row(pm, m, args.repeats)
        doc["prada"].append(row)
        shares = ", ".join(f"{k} {v:.0%}" for k, v in sorted(row["shares"].items()))
        print(f"{m:>3} {row['ground_atoms']:>6} {row['ground_rules']:>8} {row['ground_actions']:>7} "
              f"{row['grounding_cpu_s']:>9.3f} {row['decision_cpu_s']:>10.3f}  {shares}", flush=True)
    if args.compare:
        doc["transition"] = []
        print(f"\n{'M':>3}  decision CPU s (transition steps) per --planner-opt transition=...; same decisions as tables")
        for m in counts:
            row = transition_modes(pm, m, args.repeats)
            doc["transition"].append(row)
            cells = "  ".join(f"{k} {row['decision_cpu_s'][k]:.3f} ({row['transition_cpu_s'][k]:.3f})"
                              for k in TRANSITION_MODES)
            print(f"{m:>3}  {cells};  auto {row['auto_same_as_tables']}, segments {row['segments_same_as_tables']}",
                  flush=True)
    print(f"\n{'M':>3} {'transitions':>11} {'rules':>5} {'examples s':>10} {'learn s':>8}")
    for m in counts:
        row = rules_row(m, args.transitions, args.seed)
        doc["rules"].append(row)
        print(f"{m:>3} {row['transitions']:>11} {row['rules']:>5} {row['examples_cpu_s']:>10.3f} "
              f"{row['learn_cpu_s']:>8.2f}", flush=True)
    if not args.no_profile:
        doc["profile"] = rules_profile(max(counts), args.transitions, args.seed)
        print(f"\nrule learning at M = {max(counts)}, time by function, callees included (cProfile):")
        for name, share in doc["profile"]:
            print(f"  {share:6.1%}  {name}")
    if args.out:
        atomic_write_json(args.out / "objects.json", doc)
        atomic_write_bytes(args.out / "objects.png", objects_png(doc))
        print(f"wrote {args.out / 'objects.json'} and objects.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
