"""PRADA's decision time and the rule learner's time against the number of objects (issue 35).

For each object count M: 16 traces of 10 steps of the kinematic fixture world
(``tests/test_loss.py``, the world ``bench_loss.py --curve`` uses; the table grows with the cubes)
abstracted by the intended ``inhand`` and ``on`` symbols, NID rules and the reward learned from
them as ``groundsym learn`` does (CPU seconds of this process), then PRADA decisions at horizon 4
with 500 samples from the first scene of a fresh episode of the world (CPU seconds, median of
``--repeats``; the grounding of the rules over the M objects is timed apart, once). Inside a
decision the time is split by where it goes: the rule probabilities (which rule applies in each
sample), the transition (the marginals after the chosen actions), the reward, and the rest
(sampling, bookkeeping). With ``--compare`` each decision is made twice more, alternating, with
the transition over every ground rule (``frontier.transition``'s product with the whole tables:
the code before the per-action segments) and with the segments, from the same generator state,
and the ratio of their transition times and whether the two give the same bits are printed.

    .venv/bin/python benchmarks/bench_prada_objects.py --sizes 7,10,14,20,30 --repeats 3 --compare
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import planners.prada.core as prada_core  # noqa: E402
import planners.prada.frontier as frontier  # noqa: E402
from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.modeldir import learn_symbolic_model, load_model  # noqa: E402
from groundsym.planner import Observation, PlanningModel, make_planner  # noqa: E402
from groundsym.symbols import SymbolSet  # noqa: E402

PARTS = (("rule_probabilities", "rule probabilities"), ("transition", "transition"))


class CpuTimer:
    """Adds up the CPU seconds spent in wrapped module functions (by label)."""

    def __init__(self) -> None:
        self.spent: dict[str, float] = {}

    def wrap(self, module, name: str, label: str) -> None:
        fn = getattr(module, name)

        def timed(*a, **k):
            t = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                self.spent[label] = self.spent.get(label, 0.0) + time.process_time() - t
        setattr(module, name, timed)


def model_for(objects: int, seed: int) -> tuple[PlanningModel, frozenset, tuple[str, ...], float, int]:
    """The planning model learned at this many objects, the first state of a fresh episode, the
    rule learner's CPU seconds and its number of rules."""
    from test_loss import intended_symbols, kinematic_tower

    data = kinematic_tower(16, seed=seed, n_cubes=objects)
    symbols = SymbolSet(tuple(intended_symbols()), data.feature_names)
    sds = symbols.to_symbolic_dataset(data)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.process_time()
        learn_symbolic_model(sds, Path(tmp), seed=seed, argv=[], progress=False, mode="nid")
        learn_cpu = time.process_time() - t0
        m = load_model(Path(tmp))
    start = kinematic_tower(1, seed=seed + 1000, n_cubes=objects).traces[0]
    pm = PlanningModel(dict(data.primitives), predicates=symbols.predicates, rules=m.rules, reward=m.reward)
    return pm, symbols.abstract_scene(start.scenes[0]), tuple(start.objects), learn_cpu, len(m.rules.rules)


def learned_model_at(model_dir: Path, objects: int) -> tuple[PlanningModel, frozenset, tuple[str, ...], float, int]:
    """A learned model's rules and reward over ``objects`` objects: its first recorded state's
    objects, fewer, or more, the added ones with no true atom (cubes alone on the table)."""
    m = load_model(model_dir)
    tr = m.symbolic_traces.traces[0]
    names = tuple(tr.objects[:objects]) + tuple(f"extra{i}" for i in range(max(0, objects - len(tr.objects))))
    state = frozenset(a for a in tr.states[0] if set(a.args) <= set(names))
    pm = PlanningModel(m.primitives, predicates=m.predicates, rules=m.rules, reward=m.reward)
    return pm, state, names, float("nan"), len(m.rules.rules)


def measure(objects: int, repeats: int, seed: int, compare: bool, model_dir: Path | None = None) -> dict:
    pm, state, names, learn_cpu, n_rules = (model_for(objects, seed) if model_dir is None
                                            else learned_model_at(model_dir, objects))
    planner = make_planner("prada", pm, {"horizon": "4", "samples": "500"}, seed)
    obs = Observation(names, (), state)
    t0 = time.process_time()
    core = planner.core(names, state)
    ground_cpu = time.process_time() - t0
    planner.choose(obs)                                         # warm-up (the restricted core's grounding)
    timer = CpuTimer()
    timer.wrap(prada_core, "rule_probabilities", "rule probabilities")
    timer.wrap(prada_core, "transition", "transition")
    reward_fn = core.reward
    timer_reward = {"reward": 0.0}

    def timed_reward(B):
        t = time.process_time()
        try:
            return reward_fn(B)
        finally:
            timer_reward["reward"] += time.process_time() - t
    cpu = []
    for _ in range(repeats):
        core.reward = timed_reward
        for sub in core._subs.values():
            sub.reward = timed_reward
        t = time.process_time()
        planner.choose(obs)
        cpu.append(time.process_time() - t)
    spent = dict(timer.spent, **timer_reward)
    total = sum(cpu)
    row = {"objects": objects, "rules": n_rules, "ground_rules": int(len(core.g.rule_group)),
           "atoms": int(core.g.n_vars), "learn_cpu_s": learn_cpu, "ground_cpu_s": ground_cpu,
           "decision_cpu_s": float(np.median(cpu)),
           "shares": {k: v / total for k, v in spent.items()}}
    if compare:
        row.update(compare_transitions(core, planner, obs, repeats, seed))
    return row


def compare_transitions(core, planner, obs, repeats: int, seed: int) -> dict:
    """Decisions with the whole-table transition and with the per-action segments, alternating,
    from the same generator state: their transition CPU seconds and whether they agree bit for bit."""
    spent = {"whole": 0.0, "segments": 0.0}
    same = True
    for r in range(repeats):
        results = {}
        for label, whole in (("whole", True), ("segments", False)):
            planner.rng = np.random.default_rng(seed + r)
            original = frontier.transition

            def timed(g, B, U, chosen, _whole=whole, _label=label):
                t = time.process_time()
                try:
                    return original(g, B, U, chosen, segments=not _whole)
                finally:
                    spent[_label] += time.process_time() - t
            prada_core.transition = timed
            try:
                results[label] = planner.choose(obs)
            finally:
                prada_core.transition = original
        same &= (results["whole"].action == results["segments"].action
                 and results["whole"].expected_value == results["segments"].expected_value
                 and results["whole"].info == results["segments"].info)
    return {"transition_whole_cpu_s": spent["whole"] / repeats, "transition_segments_cpu_s": spent["segments"] / repeats,
            "transition_ratio": spent["whole"] / max(spent["segments"], 1e-9), "same_decisions": bool(same)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="7,10,14,20", help="object counts, comma-separated")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--compare", action="store_true", help="also time the whole-table transition against the segments")
    ap.add_argument("--model", type=Path, help="plan with this learned model's rules and reward, grounded over "
                    "each size (no rule learning timed); default: learn them from the fixture world at each size")
    ap.add_argument("--json", type=Path, help="write the rows here too")
    args = ap.parse_args()
    try:
        sizes = [int(s) for s in args.sizes.split(",")]
    except ValueError:
        print(f"--sizes: expected whole numbers separated by commas, got {args.sizes!r}", file=sys.stderr)
        return 2
    if any(s < 2 or s > 62 for s in sizes) or args.repeats < 1:
        print("--sizes: each in 2..62; --repeats: at least 1", file=sys.stderr)
        return 2
    if args.model is not None and not (args.model / "symbols.json").exists() and not args.model.is_dir():
        print(f"--model: {args.model}: not a model directory", file=sys.stderr)
        return 2
    rows = []
    for m in sizes:
        row = measure(m, args.repeats, args.seed, args.compare, args.model)
        rows.append(row)
        shares = ", ".join(f"{k} {v:.0%}" for k, v in sorted(row["shares"].items(), key=lambda kv: -kv[1]))
        line = (f"{m:>3} objects  {row['rules']:>3} rules  {row['ground_rules']:>7} ground rules  {row['atoms']:>5} atoms  "
                f"learn {row['learn_cpu_s']:7.2f} CPU s  ground {row['ground_cpu_s']:6.2f} s  "
                f"decision {row['decision_cpu_s'] * 1e3:8.1f} CPU ms ({shares})")
        if args.compare:
            line += (f"  transition whole/segments {row['transition_ratio']:.1f}x, "
                     f"same decisions: {row['same_decisions']}")
        print(line, flush=True)
        if args.json:
            atomic_write_json(args.json, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
