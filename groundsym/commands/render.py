"""``groundsym render``: a PNG of a simulation's scene, so a person can see the cell."""

from __future__ import annotations

import argparse

from ..collect import collect_trace, trace_seeds
from ..registry import make_sim
from ._common import add_sim_args, nonneg_int, positive_int, sim_options
from ._common import writable_output

NAME = "render"
HELP = "draw a simulation's scene as a PNG"
DESCRIPTION = (HELP + ". It shows the start state of the first trace that `groundsym collect` records with the "
               "same --seed and options, or with --steps K the scene after its first K random primitives.")
ORDER = 11


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_sim_args(p)
    p.add_argument("--seed", type=nonneg_int, default=0, help="random seed (default 0)")
    p.add_argument("--steps", type=nonneg_int, default=0, help="random primitives to run first (default 0)")
    p.add_argument("--width", type=positive_int, default=640, help="image width in pixels (default 640)")
    p.add_argument("--height", type=positive_int, default=480, help="image height in pixels (default 480)")
    p.add_argument("-o", "--output", required=True, help="PNG file to write")


def run(args: argparse.Namespace) -> int:
    out = writable_output(args.output)
    sim = make_sim(args.sim, sim_options(args))
    try:
        reset_seed, rng = trace_seeds(args.seed, 1)[0]
        if args.steps:
            collect_trace(sim, args.steps, reset_seed, rng)
        else:
            sim.reset(reset_seed)
        sim.render(out, args.width, args.height)
    finally:
        sim.close()
    return 0
