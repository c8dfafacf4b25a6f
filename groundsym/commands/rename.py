"""``groundsym rename MODEL u1=inhand b1=on``: give learned predicates names a person reads.

The symbols, the rules (``rules.json`` and ``rules.txt``), the reward model and the symbolic
training data are renamed together, so the model stays consistent. The renamed model is written
through :func:`groundsym.modeldir.model_transaction` (a sibling staging folder swapped in whole)
and checked as any model load checks it before it takes the model's place.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import UserError
from ..modeldir import SYMBOLS, load_model, model_transaction
from ..ppddl.names import check_renames, parse_renames, write_renamed

NAME = "rename"
HELP = "rename learned predicates (u1=inhand) in a model: symbols, rules, reward and data together"
ORDER = 47


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("model", type=Path, help="model directory")
    p.add_argument("renames", nargs="+", metavar="OLD=NEW", help="e.g. u1=inhand b1=on")


def check_model(path: Path) -> None:
    """Load everything a model directory holds, so that a bad rename fails here, not later."""
    model = load_model(path)
    if (path / SYMBOLS).exists():
        model.symbols.predicates                      # noqa: B018 (reads and validates symbols.json)
    sds = model.symbolic_traces
    if sds is not None:
        known = dict(model.predicates)
        unknown = sorted({a.predicate for tr in sds.traces for s in tr.states for a in s} - set(known))
        if unknown:
            raise UserError(f"{path}: symbolic-traces.json: predicate {unknown[0]!r} is in no other model file")


def run(args: argparse.Namespace) -> int:
    model_dir: Path = args.model
    model = load_model(model_dir)
    mapping = parse_renames(args.renames)
    prims = list(model.primitives) or sorted({r.action.predicate for r in model.rules.rules})
    check_renames(mapping, model.predicates, prims, str(model_dir))
    with model_transaction(model_dir) as stage:      # the old model stays until the new one is checked
        write_renamed(model_dir, stage, mapping)
        check_model(stage)
    print(f"{model_dir}: renamed " + ", ".join(f"{o} -> {n}" for o, n in mapping.items()))
    return 0
