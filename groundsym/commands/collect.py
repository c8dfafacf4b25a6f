"""``groundsym collect``: experience traces of random primitives from a simulation.

The paper's data: ``N`` traces of ``T`` uniformly random primitives, each from a fresh random start
state, written as ``groundsym.traces/1`` JSON (docs/formats.md) with the sim, its options, the seed
and the command line in ``meta``. With ``--explore counts`` the ``N`` traces come in ``--rounds``
rounds, each after the first choosing the primitives the model learned so far knows least
(``groundsym.explore``; Lang, Toussaint & Kersting 2012), resumable from ``--work``; with
``--explore glib`` each round babbles goals the data has never shown and plans to them with a
planner found by name (``groundsym.glib``; Chitnis et al. 2021). docs/explore.md.
"""

from __future__ import annotations

import argparse

from pathlib import Path

from ..collect import collect_traces
from ..errors import UserError
from ..explore import MODES, ExploreConfig, explore_traces
from ..glib import GlibOptions, planner_check
from ..options import split_key_values
from ..provenance import provenance
from ..registry import make_sim
from ..traces import write_traces
from ..limits import MAX_EVALS, MAX_LENGTH, MAX_TRACES
from ._common import SEED, Count, add_sim_args, sim_options, writable_output

NAME = "collect"
HELP = "record traces of random primitives from a simulation"
DESCRIPTION = (HELP + ". Trace i starts from a random start state and runs --length uniformly random primitives; "
               "everything derives from --seed, so the same seed and options give the same file.")
ORDER = 10


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_sim_args(p)
    p.add_argument("--traces", type=Count(1, MAX_TRACES, "traces"), default=10, help="number of traces N (default 10)")
    p.add_argument("--length", type=Count(1, MAX_LENGTH, "primitives"), default=10,
                   help="primitives per trace T (default 10)")
    p.add_argument("--seed", type=SEED, default=0, help="random seed (default 0)")
    p.add_argument("-o", "--output", required=True, help="traces JSON to write (groundsym.traces/1)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--explore", choices=MODES, default=None,
                   help="directed exploration: 'counts' runs a primitive whose covering rule of the model learned "
                        "so far explained fewest transitions, while fewer than 3 (Lang, Toussaint & Kersting "
                        "2012); 'glib' babbles a novel goal (an action in a context it was never run in) and plans "
                        "to it with the model learned so far (GLIB, Chitnis et al. 2021); needs --rounds and --work")
    p.add_argument("--rounds", type=Count(2, MAX_TRACES, "rounds"), default=None, metavar="R",
                   help="--explore: the traces come in R rounds (R divides --traces); a model is learned after each")
    p.add_argument("--work", type=Path, default=None, metavar="DIR",
                   help="--explore: folder for each round's traces and model; an interrupted run resumes from it")
    p.add_argument("--explore-evals", type=Count(1, MAX_EVALS, "loss evaluations"), default=15_000, metavar="E",
                   help="--explore: loss evaluations of each round's symbol search (default 15000)")
    p.add_argument("--explore-planner", default=None, metavar="NAME",
                   help="--explore glib: the planner that plans to babbled goals, by name (default prada)")
    p.add_argument("--explore-planner-opt", action="append", default=[], metavar="KEY=VALUE",
                   help="--explore glib: an option of that planner (default for prada: samples=200, retries=1)")


def explore_config(args: argparse.Namespace) -> ExploreConfig | None:
    """The exploration options, checked together before the simulation starts."""
    if args.explore is None:
        if args.rounds is not None or args.work is not None:
            raise UserError("--rounds/--work: only with --explore")
        return None
    if args.rounds is None or args.work is None:
        raise UserError("--explore: needs --rounds and --work")
    if args.traces % args.rounds:
        raise UserError(f"--rounds: {args.rounds} does not divide --traces {args.traces}")
    glib = glib_options(args)
    writable_output(args.work / "explore.json")
    return ExploreConfig(args.rounds, args.traces // args.rounds, args.length, evals=args.explore_evals,
                         mode=args.explore, glib=glib)


def glib_options(args: argparse.Namespace) -> GlibOptions:
    """The planner for ``--explore glib``, found by name and its options checked now."""
    if args.explore != "glib":
        if args.explore_planner is not None or args.explore_planner_opt:
            raise UserError("--explore-planner/--explore-planner-opt: only with --explore glib")
        return GlibOptions()
    opts = GlibOptions()
    if args.explore_planner is not None or args.explore_planner_opt:
        given = split_key_values(args.explore_planner_opt, "--explore-planner-opt")
        opts = GlibOptions(planner=args.explore_planner or opts.planner,
                           planner_opts=tuple(sorted(given.items())) if args.explore_planner_opt else
                           (opts.planner_opts if args.explore_planner in (None, opts.planner) else ()))
    planner_check(opts)
    return opts


def run(args: argparse.Namespace) -> int:
    out = writable_output(args.output)
    cfg = explore_config(args)
    sim = make_sim(args.sim, sim_options(args))
    try:
        meta = provenance(args.argv, seed=args.seed)
        if cfg is None:
            ds = collect_traces(sim, args.traces, args.length, args.seed, progress=not args.quiet, meta=meta)
        else:
            ds = explore_traces(sim, cfg, args.seed, args.work, progress=not args.quiet, meta=meta)
    finally:
        sim.close()
    write_traces(out, ds)
    return 0
