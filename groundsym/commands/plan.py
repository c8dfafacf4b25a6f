"""``groundsym plan``: run a planner in a closed loop, in a simulation or on a PPDDL domain."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..episode import Episode, SimEnv, ppddl_model, ppddl_world, run_episode
from ..errors import UserError
from ..fileio import atomic_write_json
from ..options import split_key_values
from ..planner import PlanningModel, make_planner
from ..provenance import provenance
from ..registry import BUILTIN_PLANNERS, get_planner_class, get_sim_class, make_sim
from ..sim import feature_names_for, warn_if_older_cell
from ..limits import MAX_EPISODES, MAX_STEPS
from ._common import SEED, Count, add_sim_args, output_path, sim_options

NAME = "plan"
HELP = "run a planner step by step in a simulation (--sim) or on a PPDDL domain (--domain)"
ORDER = 60
DESCRIPTION = """Close the loop: a planner chooses primitives from a learned model (--model) or a
PPDDL domain (--domain/--problem), a simulator runs them. Prints each step's abstract state,
the chosen primitive, the planner's expected value and the reward."""


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_sim_args(p, required=False)
    p.add_argument("--model", help="a learned model directory (with --sim)")
    p.add_argument("--domain", help="a PPDDL domain file (instead of --sim)")
    p.add_argument("--problem", help="a PPDDL problem file (default: the problem in the domain file)")
    p.add_argument("--planner", default="prada",
                   help=f"{', '.join(sorted(BUILTIN_PLANNERS))} or a plug-in's name; external:ENGINE "
                        "names the engine (default prada)")
    p.add_argument("--planner-opt", action="append", default=[], metavar="KEY=VALUE",
                   help="planner option, repeatable, e.g. horizon=4 samples=500 variant=a-prada")
    p.add_argument("--steps", type=Count(1, MAX_STEPS, "primitives"),
                   help="primitives per episode (default: the sim's episode "
                   "length; on a PPDDL domain 5 per object, at least 50)")
    p.add_argument("--episodes", type=Count(1, MAX_EPISODES, "episodes"), default=1, help="episodes to run (default 1)")
    p.add_argument("--seed", type=SEED, default=0)
    p.add_argument("-o", "--output", type=output_path, help="write the episode(s) as JSON")
    p.add_argument("--render-dir", help="write a PNG per step (simulation only)")
    p.add_argument("--quiet", action="store_true", help="print only the summary")


def check_model_fits_sim(model: Any, sim: Any, where: str, options: dict[str, str] | None = None) -> None:
    """A model learned in another cell (a tower model on bowling) is refused in one line: its
    primitives and the features its symbols read must be the simulation's (class attributes and
    the --sim-opt options, so this runs before the physics engine starts)."""
    if model is None:
        return
    prims = model.primitives
    if prims and prims != dict(sim.primitives):
        raise UserError(f"{where}: primitives {prims} are not those of --sim {sim.name} "
                        f"{dict(sim.primitives)}: the model was learned in another simulation")
    if model.symbols is not None:
        model.symbols.check_features(feature_names_for(sim, options or {}), f"{where}: symbols.json (--sim {sim.name})")


def check_render_dir(text: str | None) -> None:
    """--render-dir must be (or become) a directory, checked before any episode runs."""
    if text is None:
        return
    path = Path(text)
    for anc in (path, *path.parents):
        if anc.exists():
            if not anc.is_dir():
                raise UserError(f"--render-dir {text}: {anc} is not a directory")
            return


def sim_planning_model(model: Any, sim: Any) -> PlanningModel:
    """A learned model directory (groundsym.modeldir.Model) as a PlanningModel for ``sim``."""
    if model is None:
        return PlanningModel(dict(sim.primitives), gamma=float(sim.gamma))
    return PlanningModel(dict(model.primitives or sim.primitives), predicates=model.predicates,
                         symbols=model.symbols, rules=model.rules, reward=model.reward, traces=model.traces,
                         symbolic_traces=model.symbolic_traces, gamma=float(sim.gamma))


def episode_seeds(seed: int, n: int) -> list[int]:
    """Independent seeds per episode (start state and planner), the same for any ``n`` prefix."""
    return [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(n)]


def _printer(quiet: bool):
    def show(step: Any) -> None:
        if quiet:
            return
        state = (" ".join(step.state) or "(no atom true)") if step.state is not None else "-"
        print(f"t={step.t:<3d} state: {state}")
        ev = f"{step.expected_value:.4g}" if np.isfinite(step.expected_value) else "-"
        print(f"      do {step.action}  expected value {ev}  reward {step.reward:.4g}")
    return show


def run(args: argparse.Namespace) -> int:
    if (args.sim is None) == (args.domain is None):
        raise UserError("give either --sim (with --model) or --domain (with --problem)")
    options = split_key_values(args.planner_opt, "--planner-opt")
    cls = get_planner_class(args.planner)
    check_render_dir(args.render_dir)
    if args.sim is not None:
        episodes = _run_sim(args, cls, options)
    else:
        episodes = _run_ppddl(args, cls, options)
    values = [e.value for e in episodes]
    wins = [e.success for e in episodes if e.success is not None]
    summary = {"episodes": len(episodes), "mean_value": float(np.mean(values)),
               "stderr": float(np.std(values, ddof=1) / np.sqrt(len(values))) if len(values) > 1 else 0.0}
    if wins:
        summary["success_rate"] = float(np.mean(wins))
    summary["dead_ends"] = sum(e.dead_end for e in episodes)
    line = f"{args.planner}: {len(episodes)} episode(s), mean value {summary['mean_value']:.4g}"
    if len(values) > 1:
        line += f" +- {summary['stderr']:.2g}"
    if wins:
        line += f", success rate {summary['success_rate']:.2f} ({sum(wins)}/{len(wins)})"
    print(line)
    if args.output:
        doc = {"schema": "groundsym.episodes/1", "summary": summary,
               "episodes": [e.to_doc() for e in episodes],
               "provenance": provenance(args.argv, seed=args.seed)}
        atomic_write_json(args.output, doc)
        print(f"wrote {args.output}", file=sys.stderr)
    return 0


def _run_sim(args: argparse.Namespace, cls: Any, options: dict[str, str]) -> list[Episode]:
    from ..modeldir import load_model

    model = load_model(args.model) if args.model else None
    check_model_fits_sim(model, get_sim_class(args.sim), str(args.model), sim_options(args))   # before physics
    data = model and (model.symbolic_traces or model.traces)
    if data is not None:
        warn_if_older_cell(data.meta, str(args.model))
    sim = make_sim(args.sim, sim_options(args))
    try:
        pm = sim_planning_model(model, sim)
        steps = args.steps or int(sim.episode_length)
        episodes = []
        for k, seed in enumerate(episode_seeds(args.seed, args.episodes)):
            render = Path(args.render_dir) / f"episode-{k:02d}" if args.render_dir and args.episodes > 1 \
                else args.render_dir
            env = SimEnv(sim, pm.symbols, render)
            planner = make_planner(args.planner, pm, options, seed)
            episodes.append(run_episode(env, planner, steps, seed, args.planner, _printer(args.quiet)))
            if not args.quiet:
                print(f"episode {k}: value {episodes[-1].value:.4g} (gamma {env.gamma:g})")
        return episodes
    finally:
        sim.close()


def _run_ppddl(args: argparse.Namespace, cls: Any, options: dict[str, str]) -> list[Episode]:
    from ..ppddl.parser import load
    from ..ppddl.simulate import default_steps

    if args.model:
        raise UserError("--model goes with --sim; on a PPDDL domain the planner uses the domain itself")
    domain, problem = load(args.domain, args.problem)
    where = args.problem or args.domain
    env, task = ppddl_world(domain, problem, where)
    pm = ppddl_model(domain, problem, task, need_rules="rules" in getattr(cls, "NEEDS", ()))
    steps = args.steps or default_steps(task)
    episodes = []
    for k, seed in enumerate(episode_seeds(args.seed, args.episodes)):
        planner = make_planner(args.planner, pm, options, seed)
        ep = run_episode(env, planner, steps, seed, args.planner, _printer(args.quiet))
        episodes.append(ep)
        if not args.quiet:
            print(f"episode {k}: {'goal reached' if ep.success else 'goal not reached'} after "
                  f"{len(ep.steps)} step(s), reward {ep.value:.4g}"
                  + (" (dead end: the planner proved the goal unreachable)" if ep.dead_end else ""))
    return episodes
