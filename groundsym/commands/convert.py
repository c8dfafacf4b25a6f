"""``groundsym convert DOMAIN PROBLEM -o OUT --format rddl|fond``: a PPDDL problem in another format.

For the IPPC 2006/2008 competition files (and any PPDDL our parser reads): RDDL for pyRDDLGym and
its planners, FOND PDDL for FOND planners. The translation is the one ``export-domain --format``
uses for learned models (docs/rddl.md); this command only reads the PPDDL instead of a model.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import UserError
from ..fileio import atomic_write_text
from ..limits import MAX_STEPS
from ..ppddl.fond import fond_domain_text, fond_problem_text
from ..ppddl.parser import load
from ..rddl.writer import RddlOptions, rddl_files
from ._common import Count

NAME = "convert"
HELP = "write a PPDDL domain and problem as RDDL (domain.rddl, instance.rddl) or FOND PDDL"
ORDER = 46


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("domain", help="PPDDL domain file")
    p.add_argument("problem", help="PPDDL problem file (may hold the domain too)")
    p.add_argument("-o", "--output", required=True, help="directory to write into")
    p.add_argument("--format", choices=("rddl", "fond"), required=True,
                   help="rddl: domain.rddl and instance.rddl; fond: domain.pddl and problem.pddl with oneof")
    p.add_argument("--horizon", type=Count(1, MAX_STEPS, "steps"),
                   help="with --format rddl: the instance's horizon (default 40)")


def run(args: argparse.Namespace) -> int:
    if args.horizon is not None and args.format != "rddl":
        raise UserError("--horizon: only with --format rddl (FOND has no horizon)")
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a directory")
    domain, problem = load(args.domain, args.problem)
    if args.format == "rddl":
        options = RddlOptions() if args.horizon is None else RddlOptions(horizon=args.horizon)
        files = rddl_files(domain, problem, options=options)
    else:
        files = {"domain.pddl": fond_domain_text(domain), "problem.pddl": fond_problem_text(problem)}
    for name, text in files.items():
        atomic_write_text(out / name, text)
    print(f"{out}: wrote {', '.join(files)} ({len(domain.actions)} actions, {len(problem.objects)} objects)")
    return 0
