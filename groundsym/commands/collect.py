"""``groundsym collect``: experience traces of random primitives from a simulation.

The paper's data: ``N`` traces of ``T`` uniformly random primitives, each from a fresh random start
state, written as ``groundsym.traces/1`` JSON (docs/formats.md) with the sim, its options, the seed
and the command line in ``meta``.
"""

from __future__ import annotations

import argparse

from ..collect import collect_traces
from ..provenance import provenance
from ..registry import make_sim
from ..traces import write_traces
from ..limits import MAX_LENGTH, MAX_TRACES
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


def run(args: argparse.Namespace) -> int:
    out = writable_output(args.output)
    sim = make_sim(args.sim, sim_options(args))
    try:
        ds = collect_traces(sim, args.traces, args.length, args.seed, progress=not args.quiet,
                            meta=provenance(args.argv, seed=args.seed))
    finally:
        sim.close()
    write_traces(out, ds)
    return 0
