"""``groundsym render``: a PNG of a simulation's scene, so a person can see the cell."""

from __future__ import annotations

import argparse

from ..collect import collect_trace, trace_seeds
from ..errors import UserError
from ..registry import make_sim
from ..limits import MAX_PIXELS, MAX_STEPS
from ._common import SEED, Count, add_sim_args, sim_options
from ._common import writable_output

NAME = "render"
HELP = "draw a simulation's scene as a PNG"
DESCRIPTION = (HELP + ". It shows the start state of the first trace that `groundsym collect` records with the "
               "same --seed and options, or with --steps K the scene after its first K random primitives.")
ORDER = 11
MAX_SIZE = MAX_PIXELS
image_size = Count(1, MAX_PIXELS, "pixels")   # a side: the software renderer's time and memory grow with the area


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_sim_args(p)
    p.add_argument("--seed", type=SEED, default=0, help="random seed (default 0)")
    p.add_argument("--steps", type=Count(0, MAX_STEPS, "primitives"), default=0,
                   help=f"random primitives to run first (default 0, at most {MAX_STEPS})")
    p.add_argument("--width", type=image_size, default=640,
                   help=f"image width in pixels (default 640, at most {MAX_SIZE})")
    p.add_argument("--height", type=image_size, default=480,
                   help=f"image height in pixels (default 480, at most {MAX_SIZE})")
    p.add_argument("-o", "--output", required=True, help="PNG file to write")


def run(args: argparse.Namespace) -> int:
    out = writable_output(args.output)
    if out.suffix.lower() != ".png":
        raise UserError(f"{out}: render writes PNG images; give a file name ending in .png")
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
