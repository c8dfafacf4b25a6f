"""``groundsym simulate``: random symbolic traces from a PPDDL domain and problem.

Any PPDDL domain becomes data this way: ground truth for teaching and for testing rule learning
(the learned rules can be compared with the domain's own).
"""

from __future__ import annotations

import argparse

import numpy as np

from ..errors import UserError
from ..fileio import file_sha256
from ..ppddl.parser import load
from ..ppddl.simulate import Task, simulate_traces
from ..progress import Progress
from ..provenance import provenance
from ..symbolic_traces import write_symbolic_traces
from ..limits import MAX_LENGTH, MAX_TRACES
from ._common import SEED, Count, output_path, writable_output

NAME = "simulate"
HELP = "sample random symbolic traces from a PPDDL domain and problem"
DESCRIPTION = (HELP + ". Each step tries a uniformly random applicable primitive (or, with --inapplicable, one "
               "whose precondition fails: nothing changes) and samples its outcome; a trace ends at a dead end. "
               "A step's reward is the problem's goal reward when the goal holds in that step's state plus the "
               "reward effects of its action. Type membership is written as unary atoms, e.g. (block b1).")
ORDER = 60


def share(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 1], got {text!r}") from None
    if not 0.0 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a number in [0, 1], got {v}")
    return v


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--domain", required=True, help="PPDDL domain file (may also hold the problem)")
    p.add_argument("--problem", help="PPDDL problem file (default: the first problem in the domain file)")
    p.add_argument("--traces", type=Count(1, MAX_TRACES, "traces"), default=10, help="number of traces (default 10)")
    p.add_argument("--length", type=Count(1, MAX_LENGTH, "steps"), default=20,
                   help="steps per trace at most (default 20)")
    p.add_argument("--seed", type=SEED, default=0, help="random seed (default 0)")
    p.add_argument("--inapplicable", type=share, default=0.0, metavar="SHARE",
                   help="share of steps that try an action whose precondition fails (default 0)")
    p.add_argument("-o", "--output", type=output_path, required=True, help="symbolic traces JSON to write")


def run(args: argparse.Namespace) -> int:
    writable_output(args.output)         # a typo in -o fails before the domain is parsed and sampled
    domain, problem = load(args.domain, args.problem)
    if problem is None:
        raise UserError(f"{args.domain}: holds no problem; give --problem")
    task = Task(domain, problem)
    if not task.primitive_actions():
        raise UserError(f"{args.problem or args.domain}: no action of {domain.name} can be grounded on its objects")
    data_hash = file_sha256(args.domain) if args.problem is None else \
        f"{file_sha256(args.domain)}+{file_sha256(args.problem)}"
    meta = {"domain": domain.name, "problem": problem.name, "traces": args.traces, "length": args.length,
            "inapplicable": args.inapplicable,
            "provenance": provenance(args.argv, seed=args.seed, data_sha256=data_hash)}
    progress = Progress(args.traces, "simulate")
    ds = simulate_traces(task, args.traces, args.length, np.random.default_rng(args.seed), args.inapplicable,
                         meta, progress)
    write_symbolic_traces(args.output, ds)
    print(f"{args.output}: {len(ds.traces)} traces, {ds.n_transitions} transitions")
    return 0
