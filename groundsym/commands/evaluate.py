"""``groundsym evaluate``: the paper's comparison of planners under its protocol (Section VI-B)."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Sequence

from ..errors import UserError
from ..evaluation.config import MODEL_DATA, RULE_DATA, EvalConfig
from ..evaluation.protocol import evaluate, optimum_of
from ..evaluation.store import check_config
from ..evaluation.tables import markdown_table
from ..executors import add_executor_args, check_executor_options, make_executor
from ..provenance import provenance
from ..registry import get_sim_class, planner_names
from ..fileio import read_json
from ..options import parse_options, split_key_values
from ..sim import warn_if_older_cell
from ..limits import (MAX_EVALS, MAX_RESTARTS, MAX_RUNS, MAX_STARTS, MAX_STEPS, MAX_SYMBOLS, MAX_TRACES,
                      MAX_TRANSITIONS, MAX_WORKERS)
from ._common import SEED, Count, add_sim_args, sim_options
from .learn import LOSS_KEYS, loss_config

NAME = "evaluate"
HELP = "compare planners under the paper's protocol (runs x start states), results as JSON, Markdown, PNG"
ORDER = 70
DESCRIPTION = """Per run: independent random data for symbol learning (--symbol-data transitions) and for
model learning (--model-traces traces of 10 primitives), symbols learned by annealing (--evals), NID
rules and a reward model on the model data, then every method from --starts new start states with
all objects on the table for --steps primitives. Writes OUT/results.json, results.md, results.png;
finished runs are kept in OUT/runs/ and an interrupted evaluation resumes from them."""


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_sim_args(p, required=True)
    p.add_argument("--methods", default="random,continuous-nn,symbolic-nn,prada",
                   help="planners to compare, comma-separated (default random,continuous-nn,symbolic-nn,prada)")
    p.add_argument("--symbol-data", default="80", help="transitions for symbol learning, comma-separated "
                   "sizes (default 80; the paper: 40,80,160)")
    p.add_argument("--model-traces", default="9", help="traces of 10 primitives for model learning, "
                   "comma-separated counts (default 9; the paper: 3,9); the symbols of a run serve every count")
    p.add_argument("--runs", type=Count(1, MAX_RUNS, "runs"), default=30, help="independent runs (default 30)")
    p.add_argument("--workers", type=Count(1, MAX_WORKERS, "worker processes"), default=None,
                   help="worker processes (default 1; with "
                   "--executor ray and no --ray-address: the CPUs of the local Ray, default all cores); the "
                   "results do not depend on it")
    add_executor_args(p, "With ray, each unit (one run at one symbol-data size) is a Ray task.")
    p.add_argument("--seed", type=SEED, default=0)
    p.add_argument("--evals", type=Count(1, MAX_EVALS, "loss evaluations"), default=100_000,
                   help="symbol-learning budget per run, loss evaluations over all restarts (default 1e5)")
    p.add_argument("--restarts", type=Count(1, MAX_RESTARTS, "restarts"), default=4,
                   help="annealing restarts per run (default 4)")
    p.add_argument("--unary", type=Count(0, MAX_SYMBOLS, "symbols"), default=1,
                   help="unary symbols to learn (default 1)")
    p.add_argument("--binary", type=Count(0, MAX_SYMBOLS, "symbols"), default=1,
                   help="binary symbols to learn (default 1)")
    p.add_argument("--steps", type=Count(1, MAX_STEPS, "primitives"),
                   help="primitives per episode (default: the sim's episode length)")
    p.add_argument("--starts", type=Count(1, MAX_STARTS, "start states"), default=3,
                   help="start states per run (default 3)")
    p.add_argument("--planner-opt", action="append", default=[], metavar="METHOD:KEY=VALUE",
                   help="an option for one method, e.g. prada:samples=500 (repeatable)")
    p.add_argument("--truth-symbols", default="", metavar="PRED,PRED",
                   help="diagnosis only: abstract with the sim's ground-truth relations instead of learned "
                   "symbols (e.g. inhand,on), to separate planning from symbol learning")
    p.add_argument("--rule-data", choices=RULE_DATA, default="model",
                   help="what NID rules, the reward model and the NN baselines learn from: the fresh --model-traces "
                   "(model, the paper's protocol and the default) or the run's symbol data too (all; with "
                   "--truth-symbols the symbol data is then collected too); docs/planning.md")
    p.add_argument("--loss", action="append", default=[], metavar="KEY=VALUE",
                   help="symbol-learning loss setting, repeatable, as groundsym learn takes it: " + ", ".join(LOSS_KEYS))
    p.add_argument("--model-data-scope", dest="model_data", choices=MODEL_DATA, default="unit",
                   help="who collects the model traces: every unit (a run at one symbol-data size; unit, the "
                   "default, so earlier folders resume) or the run (run: its sizes share them, and RANDOM and "
                   "CONTINUOUS-NN, which read no symbols, play once per run and model-trace count; "
                   "docs/planning.md)")
    p.add_argument("-o", "--output", required=True, help="results folder")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def parse_list(text: str, flag: str, most: int | None = None, unit: str = "") -> tuple[int, ...]:
    """``--symbol-data 40,80,160``: positive whole numbers separated by commas, each at most ``most``."""
    try:
        vals = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise UserError(f"{flag} {text}: expected whole numbers separated by commas") from None
    if not vals or any(v < 1 for v in vals):
        raise UserError(f"{flag} {text}: expected positive whole numbers")
    if most is not None and max(vals) > most:
        raise UserError(f"{flag} {text}: at most {most} {unit}, got {max(vals)}")
    return vals


def methods_list(text: str, known: Sequence[str]) -> tuple[str, ...]:
    """``--methods random,prada``: planner names, each among ``known``."""
    ms = tuple(m.strip() for m in text.split(",") if m.strip())
    for m in ms:
        if m.split(":", 1)[0] not in known:
            raise UserError(f"--methods {m}: unknown planner (available: {', '.join(known)})")
    if not ms:
        raise UserError("--methods: name at least one planner")
    return ms


def planner_options(items: list[str]) -> dict[str, dict[str, str]]:
    out: dict[str, dict[str, str]] = {}
    for item in items:
        if ":" not in item.split("=", 1)[0]:
            raise UserError(f"--planner-opt {item}: expected METHOD:KEY=VALUE, e.g. prada:samples=500")
        method, rest = item.split(":", 1)
        out.setdefault(method, {}).update(split_key_values([rest], "--planner-opt"))
    return out


def run(args: argparse.Namespace) -> int:
    sim_cls = get_sim_class(args.sim)
    given = sim_options(args)
    parse_options("--sim-opt", "sim", args.sim, sim_cls.OPTIONS, given)          # unknown options fail before any work
    methods = methods_list(args.methods, planner_names())
    popts = planner_options(args.planner_opt)
    for m in popts:
        if m not in methods:
            raise UserError(f"--planner-opt {m}:...: {m} is not among --methods")
    truth = tuple(p for p in args.truth_symbols.split(",") if p.strip())
    cfg = EvalConfig(sim=args.sim, methods=methods,
                     symbol_data=parse_list(args.symbol_data, "--symbol-data", MAX_TRANSITIONS, "transitions"),
                     model_traces=parse_list(args.model_traces, "--model-traces", MAX_TRACES, "traces"), seed=args.seed,
                     evals=args.evals, steps=args.steps, starts=args.starts, unary=args.unary, binary=args.binary,
                     restarts=args.restarts, sim_options=given, planner_options=popts, truth_symbols=truth,
                     rule_data=args.rule_data, loss=loss_config(args.loss), model_data=args.model_data)
    optimum = optimum_of(args.sim, given)
    _warn_if_resuming_an_older_cell(Path(args.output) / "results.json", args.sim)
    check_executor_options(args.executor, args.ray_address)
    check_config(Path(args.output), cfg)         # a folder of other options is refused before Ray starts
    cores = os.cpu_count() or 1
    workers = min(args.workers or (cores if args.executor == "ray" else 1), cores)
    with make_executor(args.executor, workers=workers, address=args.ray_address) as executor:
        results = evaluate(cfg, args.runs, args.output, progress=not args.quiet, optimum=optimum,
                           provenance=provenance(args.argv, seed=args.seed,
                                                 cell_version=getattr(sim_cls, "CELL_VERSION", None)),
                           executor=executor)
    sys.stdout.write(markdown_table(results))
    print(f"wrote {args.output}/results.json, results.md, results.png", file=sys.stderr)
    return 0


def _warn_if_resuming_an_older_cell(previous: Path, sim: str) -> None:
    """Results already in the output directory (to be resumed) from an older cell: one warning line."""
    if not previous.exists():
        return
    try:
        meta = read_json(previous).get("meta", {})
    except (UserError, AttributeError):       # a damaged results file is the evaluation's own business
        return
    warn_if_older_cell({"sim": sim, **(meta.get("provenance") or {})}, str(previous))
