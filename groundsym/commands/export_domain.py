"""``groundsym export-domain``: a learned model as a PPDDL domain and problem a person can read.

The export itself is :mod:`groundsym.export` (the report shows the same domain); this command
parses the arguments, applies ``--rename``, writes the files and says what it wrote. With
``--determinize`` plain PDDL for classical planners is written too; ``--format rddl|fond`` writes
the same model as RDDL or FOND PDDL instead (:mod:`groundsym.export_formats`).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from ..errors import UserError
from ..export import ExportOptions, build_export, plain_export
from ..export_formats import FORMATS, RDDL_FILES, check_format, format_files
from ..fileio import atomic_write_text
from ..identifiers import check_identifier
from ..limits import MAX_STEPS
from ..modeldir import Model, load_model
from ..ppddl.determinize import MODES
from ..ppddl.names import check_renames, parse_renames, write_renamed
from ..ppddl.rule_actions import NOISE_MODES
from ._common import Count

NAME = "export-domain"
HELP = ("write a learned model as PPDDL (domain.ppddl, problem.ppddl), optionally determinised PDDL too; "
        "or as RDDL or FOND PDDL (--format)")
ORDER = 45


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("model", help="model directory (rules.json, reward.json, symbolic-traces.json, symbols.json)")
    p.add_argument("-o", "--output", required=True, help="directory to write domain.ppddl and problem.ppddl into")
    p.add_argument("--scene", metavar="FILE:TRACE:STEP",
                   help="initial state: the abstraction of this scene of a traces or symbolic traces file "
                        "(default: the first state of the model's first training trace)")
    p.add_argument("--goal", metavar="ATOMS",
                   help='goal literals, e.g. "(on o1 o2) (not (inhand o1))" (default: the highest-reward '
                        "abstract state in the data)")
    p.add_argument("--noise", choices=(*NOISE_MODES, "drop"), default="no-change",
                   help="a rule's noise outcome: no change (default), pessimistic (a dead end) or drop "
                        "(outcome probabilities renormalised without it: noisy data, --determinize most-likely)")
    p.add_argument("--operators", action="store_true",
                   help="one typed operator per action, with the action's name and parameters (rules learned "
                        "from successful-only traces: one rule per action, no deictic references)")
    p.add_argument("--format", choices=FORMATS, default="ppddl",
                   help="ppddl (default: domain.ppddl, problem.ppddl), rddl (domain.rddl, instance.rddl, for "
                        "pyRDDLGym and JaxPlan) or fond (domain.pddl, problem.pddl with oneof effects); docs/rddl.md")
    p.add_argument("--axioms", action="store_true",
                   help="declare derived predicates once as (:derived ...) axioms instead of writing them out in "
                        "every precondition (PPDDL and FOND; Fast Downward reads them, docs/rddl.md)")
    p.add_argument("--horizon", type=Count(1, MAX_STEPS, "steps"),
                   help="with --format rddl: the instance's horizon (default 40)")
    p.add_argument("--determinize", choices=MODES, help="also write plain domain.pddl and problem.pddl")
    p.add_argument("--strips", action="store_true",
                   help="with --determinize: compile domain.pddl to plain STRIPS (grounded; no negative, "
                        "equality or quantified preconditions), for planners such as pyperplan")
    p.add_argument("--strict", action="store_true",
                   help="a warning (no actions to plan with, a goal that cannot be reached) is an error")
    p.add_argument("--rename", action="append", default=[], metavar="OLD=NEW",
                   help="name a learned predicate for this export (repeatable), e.g. --rename u1=inhand")
    p.add_argument("--name", default="learned", help="domain name (default: learned)")


@contextmanager
def _renamed(model: Model, renames: list[str]) -> Iterator[Model]:
    """The model with ``--rename`` applied (a renamed copy in a temporary directory)."""
    if not renames:
        yield model
        return
    mapping = parse_renames(renames, "--rename")
    prims = list(model.primitives) or sorted({r.action.predicate for r in model.rules.rules})
    check_renames(mapping, model.predicates, prims, str(model.path), "--rename")
    with tempfile.TemporaryDirectory(prefix="groundsym-rename-") as tmp:
        write_renamed(model.path, Path(tmp), mapping)
        yield load_model(tmp)


def _warn(message: str, strict: bool) -> None:
    """One line on stderr; with ``--strict`` an error (exit status 2)."""
    if strict:
        raise UserError(message + " (--strict)")
    print(f"groundsym export-domain: warning: {message}", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    check_identifier(args.name, "--name")
    if args.strips and not args.determinize:
        raise UserError("--strips: needs --determinize all-outcomes or most-likely")
    check_format(args.format, args.determinize, args.horizon, args.axioms, args.strips, args.operators)
    with _renamed(load_model(args.model), args.rename) as model:
        return _export(model, args)


def _export(model: Model, args: argparse.Namespace) -> int:
    """Build the export, write its files into ``--output`` and say what was written."""
    options = ExportOptions(scene=args.scene, goal=args.goal, noise=args.noise, name=args.name, axioms=args.axioms,
                            operators=args.operators)
    ex = build_export(model, options, args.model)
    domain, problem, dropped, objects, goal, goal_note = (ex.domain, ex.problem, ex.dropped, ex.objects, ex.goal,
                                                          ex.goal_note)
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a directory")
    files = format_files(ex, args.format, args.horizon, model.rules.derived)
    plain_note = ""
    if args.determinize:
        plain_d, plain_p = plain_export(domain, problem, args.determinize, args.strips,
                                        lambda message: _warn(message, args.strict))
        files["domain.pddl"] = str(plain_d)
        if plain_p is not None and plain_p.goal is not None:
            files["problem.pddl"] = str(plain_p)
        plain_note = f"; domain.pddl: {len(plain_d.actions)} actions"
    for name, text in files.items():
        atomic_write_text(out / name, text)
    for stale in ("domain.pddl", "problem.pddl", *RDDL_FILES):   # from an earlier export: would mislead
        if stale not in files and (out / stale).is_file():
            (out / stale).unlink()
    if (args.determinize or args.format == "fond") and "problem.pddl" not in files:
        print(f"{out}: problem.pddl not written: {goal_note}", file=sys.stderr)
    left = f", {len(dropped)} rule(s) that can never apply or change nothing left out" if dropped else ""
    print(f"{out}: wrote {', '.join(files)} ({len(domain.actions)} actions{left}{plain_note}; "
          f"{len(objects)} objects{', no goal' if not goal else ''})")
    return 0
