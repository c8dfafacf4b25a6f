"""Why PRADA falls short of the optimum in the tower cell: planner, model data, or motor noise?

PRADA plans on the simulator's ground-truth `inhand` and `on` (no symbol learning involved) with NID
rules and a reward model learned from random traces, at two amounts of model data. For every
episode it counts "undo" grasps: grasping a cube that stands on another one, which takes a tower
apart. Set the results beside `examples/tower_ceiling.py`, a scripted builder that reads the true
state (what any planner could reach under the same motor noise).

    python examples/tower_prada_diagnosis.py --traces 9 --episodes 12 [--shared] [--out DIR]

Without --shared each episode gets its own model data (independent runs, as `groundsym evaluate`);
with --shared one model serves every episode (for large --traces).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.collect import collect_traces  # noqa: E402
from groundsym.episode import SimEnv, run_episode  # noqa: E402
from groundsym.experiment import TruthSymbols  # noqa: E402
from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.logic import parse_atom  # noqa: E402
from groundsym.modeldir import learn_symbolic_model, load_model  # noqa: E402
from groundsym.planner import PlanningModel, make_planner  # noqa: E402
from groundsym.registry import make_sim  # noqa: E402
from groundsym.sim import split_key_values  # noqa: E402
from sims.tower import optimal_episode_value  # noqa: E402


def undo_grasps(ep) -> int:
    """Grasps of a cube that was on another cube in the state the planner saw."""
    n = 0
    for s in ep.steps:
        act = parse_atom(s.action)
        state = {parse_atom(a) for a in s.state or ()}
        if act.predicate == "closeHandAround" and any(a.predicate == "on" and a.args[0] == act.args[0] for a in state):
            n += 1
    return n


def stacked_grasps(sds) -> int:
    """Successful grasps of a stacked cube in the model data (what teaches the rule to drop `on`)."""
    n = 0
    for tr in sds.traces:
        for s, a, s2 in zip(tr.states, tr.actions, tr.states[1:]):
            x = a.args[0]
            if a.predicate == "closeHandAround" and any(t.predicate == "on" and t.args[0] == x for t in s) \
                    and any(t.predicate == "inhand" and t.args[0] == x for t in s2):
                n += 1
    return n


def run_episodes(sim, sym: TruthSymbols, best: float, args: argparse.Namespace, work: Path) -> list[dict]:
    """One PRADA episode per start state; a fresh model per episode unless ``--shared``."""
    rows, model = [], None
    for k in range(args.episodes):
        if model is None or not args.shared:
            md = collect_traces(sim, args.traces, 10, args.seed * 1000 + 100 + k, progress=False)
            sds = sym.to_symbolic_dataset(md)
            learn_symbolic_model(sds, work / f"m{k}", seed=k, argv=[], progress=False)
            m = load_model(work / f"m{k}")
            model = PlanningModel(dict(sim.primitives), predicates=dict(sym.predicates), symbols=sym,
                                  rules=m.rules, reward=m.reward, traces=md, symbolic_traces=sds,
                                  gamma=float(sim.gamma))
            taught = stacked_grasps(sds)
        ep = run_episode(SimEnv(sim, sym), make_planner("prada", model, {}, 1000 + k), 10, 500 + k, "prada")
        rows.append({"value": ep.value, "share": ep.value / best, "undo_grasps": undo_grasps(ep),
                     "stacked_grasps_in_data": taught, "rules": len(model.rules.rules)})
        print(f"episode {k + 1}: {ep.value / best:.1%} of V*, undo grasps {rows[-1]['undo_grasps']}, "
              f"stacked grasps in the model data {taught}", file=sys.stderr, flush=True)
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--traces", type=int, default=9)
    ap.add_argument("--episodes", type=int, default=12)
    ap.add_argument("--shared", action="store_true")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sim-opt", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    opts = split_key_values(args.sim_opt, "--sim-opt")
    sim = make_sim("tower", opts)
    best = optimal_episode_value({k: v for k, v in opts.items() if k != "noise"})
    sym = TruthSymbols(("inhand", "on"), dict(sim.truth_predicates))
    with tempfile.TemporaryDirectory(prefix="prada-diag-") as tmp:
        rows = run_episodes(sim, sym, best, args, Path(tmp))
    share = np.array([r["share"] for r in rows])
    se = share.std(ddof=1) / np.sqrt(len(share)) if len(share) > 1 else float("nan")
    undo = np.mean([r["undo_grasps"] for r in rows])
    print(f"PRADA, true inhand/on, rules from {args.traces} traces{' (one model)' if args.shared else ''}: "
          f"{share.mean():.1%} +- {se:.1%} of V*; {undo:.2f} undo grasps per episode")
    if args.out:
        atomic_write_json(args.out / "diagnosis.json", {"traces": args.traces, "shared": args.shared,
                                                       "options": opts, "rows": rows, "mean_share": float(share.mean()),
                                                       "stderr": float(se), "undo_per_episode": float(undo)})
    return 0


if __name__ == "__main__":
    sys.exit(main())
