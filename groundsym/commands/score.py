"""``groundsym score MODEL DATA``: how well a model explains held-out symbolic transitions.

MODEL is a learned model directory (its NID rules) or a PPDDL domain file (its true dynamics), so
a user can validate a learned model against data, or data against the domain it came from.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..errors import UserError
from ..rules.calibration import calibration, write_reliability_png
from ..rules.evaluate import ScoreReport, score_dataset, score_ruleset
from ..rules.model import P_MIN
from ..symbolic_traces import SymbolicDataset, read_symbolic_traces, require_transitions
from ._common import writable_output

NAME = "score"
HELP = "mean log-likelihood per transition of symbolic traces under a model directory or PPDDL domain"
ORDER = 40


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("model", help="a model directory (rules.json) or a PPDDL domain file")
    p.add_argument("data", help="symbolic traces (groundsym.symbolic-traces/1)")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    p.add_argument("--reliability", default=None, metavar="PNG",
                   help="write the reliability diagram of the rules' outcome probabilities (a model directory only)")


def run(args: argparse.Namespace) -> int:
    ds = read_symbolic_traces(args.data)
    require_transitions(ds, args.data)
    model = Path(args.model)
    png = writable_output(args.reliability) if args.reliability else None
    if png is not None and not model.is_dir():
        raise UserError(f"{model}: --reliability needs a model directory (its rules' outcome probabilities)")
    if model.is_dir():
        doc = _score_model_dir(model, ds, args.data, png)
    elif model.is_file():
        doc = _score_ppddl(model, ds, args.data)
    else:
        raise UserError(f"{model}: no such model directory or PPDDL file")
    if args.json:
        sys.stdout.write(json.dumps(doc, indent=1) + "\n")
    else:
        _print(doc)
    return 0


def _report_doc(rep: ScoreReport, model: Path, data: str, p_min: float, rules: list[dict]) -> dict:
    return {"model": str(model), "data": str(data), "mean_log_likelihood": rep.mean_log_likelihood,
            "transitions": rep.transitions, "impossible": rep.impossible, "p_min": p_min,
            "default_covered": rep.default_covered, "rules": rules}


def _score_model_dir(model: Path, ds: SymbolicDataset, data: str, png: Path | None = None) -> dict:
    from ..modeldir import load_model

    m = load_model(model)
    check_vocabulary(m.predicates, m.primitives, set(), ds, data, model)
    rep = score_ruleset(m.rules, ds)
    rules = [{"rule": i + 1, "action": str(r.action), "context": [str(l) for l in r.context],
              "covers": rep.covers.get(i, 0)} for i, r in enumerate(m.rules.rules)]
    cal = calibration(m.rules, ds)
    if png is not None:
        write_reliability_png(png, cal, f"{model.name} on {Path(data).name}")
    return {**_report_doc(rep, model, data, m.rules.p_min, rules), "calibration": cal.to_doc()}


def _score_ppddl(path: Path, ds: SymbolicDataset, data: str) -> dict:
    from ..ppddl.parser import load
    from ..ppddl.simulate import Task, transition_model  # true transition probabilities of a PPDDL domain

    domain, _ = load(path)
    probe = Task(domain, {})
    types = {probe.type_predicate(t.name) for t in domain.types} | {"object"}
    preds = {p.name: len(p.params) for p in domain.predicates} | {t: 1 for t in types}
    check_vocabulary(preds, probe.primitives, types, ds, data, path)
    prob, names = transition_model(path, ds)
    rep = score_dataset(prob, ds, P_MIN)
    rules = [{"rule": str(key), "action": names.get(key, str(key)), "covers": n}
             for key, n in sorted(rep.covers.items(), key=lambda kv: str(kv[0]))]
    return _report_doc(rep, path, data, P_MIN, rules)


def check_vocabulary(preds: dict[str, int], prims: dict[str, int], optional: set[str], ds: SymbolicDataset,
                     data: str, model: Path) -> None:
    """The data must speak the model's language: the same predicates (type predicates of a PPDDL
    domain may be absent) and primitives the model knows, with the same arities. Scoring data
    from another domain gives a number that means nothing, so it is refused."""
    for kind, mine, theirs in (("predicates", preds, ds.predicates), ("primitives", prims, ds.primitives)):
        if not mine:
            continue
        foreign = sorted(f"{n}/{k}" for n, k in theirs.items() if mine.get(n) != k)
        absent = sorted(f"{n}/{k}" for n, k in mine.items() if n not in theirs and n not in optional) \
            if kind == "predicates" else []
        if foreign or absent:
            what = (f"{', '.join(foreign)} not in the model" if foreign else "") + \
                   ("; " if foreign and absent else "") + (f"{', '.join(absent)} missing" if absent else "")
            raise UserError(f"{data}: {kind}: do not match those of {model} ({what}): "
                            f"the data is from another domain")


def _print(doc: dict) -> None:
    print(f"{doc['data']}: mean log-likelihood {doc['mean_log_likelihood']:.4f} nats per transition "
          f"({doc['transitions']} transitions, {doc['impossible']} impossible, priced with p_min {doc['p_min']:g})")
    print(f"  {doc['default_covered']} transitions covered by default rules")
    cal = doc.get("calibration")
    if cal is not None:
        print(f"  expected calibration error {cal['ece']:.4f} (a calibrated model: {cal['floor']:.4f}; "
              f"{cal['predictions']} outcome predictions, {cal['bins']} bins); noise mass {cal['noise_predicted']:.3f} predicted, "
              f"{cal['noise_observed']:.3f} of covered transitions unexplained")
    for r in doc["rules"]:
        ctx = " ".join(r.get("context", []))
        print(f"  rule {r['rule']}: {r['action']} {ctx}: covers {r['covers']}")
