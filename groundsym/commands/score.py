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
from ..rules.evaluate import ScoreReport, score_dataset, score_ruleset
from ..rules.model import P_MIN
from ..symbolic_traces import SymbolicDataset, read_symbolic_traces, require_transitions

NAME = "score"
HELP = "mean log-likelihood per transition of symbolic traces under a model directory or PPDDL domain"
ORDER = 40


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("model", help="a model directory (rules.json) or a PPDDL domain file")
    p.add_argument("data", help="symbolic traces (groundsym.symbolic-traces/1)")
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")


def run(args: argparse.Namespace) -> int:
    ds = read_symbolic_traces(args.data)
    require_transitions(ds, args.data)
    model = Path(args.model)
    if model.is_dir():
        doc = _score_model_dir(model, ds, args.data)
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


def _score_model_dir(model: Path, ds: SymbolicDataset, data: str) -> dict:
    from ..modeldir import load_model

    m = load_model(model)
    rep = score_ruleset(m.rules, ds)
    rules = [{"rule": i + 1, "action": str(r.action), "context": [str(l) for l in r.context],
              "covers": rep.covers.get(i, 0)} for i, r in enumerate(m.rules.rules)]
    return _report_doc(rep, model, data, m.rules.p_min, rules)


def _score_ppddl(path: Path, ds: SymbolicDataset, data: str) -> dict:
    from ..ppddl.simulate import transition_model  # true transition probabilities of a PPDDL domain

    prob, names = transition_model(path, ds)
    rep = score_dataset(prob, ds, P_MIN)
    rules = [{"rule": str(key), "action": names.get(key, str(key)), "covers": n}
             for key, n in sorted(rep.covers.items(), key=lambda kv: str(kv[0]))]
    return _report_doc(rep, path, data, P_MIN, rules)


def _print(doc: dict) -> None:
    print(f"{doc['data']}: mean log-likelihood {doc['mean_log_likelihood']:.4f} nats per transition "
          f"({doc['transitions']} transitions, {doc['impossible']} impossible, priced with p_min {doc['p_min']:g})")
    print(f"  {doc['default_covered']} transitions covered by default rules")
    for r in doc["rules"]:
        ctx = " ".join(r.get("context", []))
        print(f"  rule {r['rule']}: {r['action']} {ctx}: covers {r['covers']}")
