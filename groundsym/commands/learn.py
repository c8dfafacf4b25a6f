"""``groundsym learn``: symbols from continuous traces (simulated annealing on the paper's loss), then
NID rules and a reward model on the abstracted data; or the rules alone from symbolic traces."""

from __future__ import annotations

import argparse
import math
import shutil
import sys
from dataclasses import fields
from pathlib import Path

from ..anneal import AnnealConfig, anneal, default_workers
from ..errors import UserError
from ..fileio import file_sha256
from ..loss import LossConfig, prepare
from ..progress import Progress
from ..provenance import provenance
from ..sim import split_key_values
from ..symbolic_traces import SCHEMA as SYMBOLIC_SCHEMA, read_symbolic_traces
from ..symbols import SymbolSet, dataset_arrays, save_symbols, share_true
from ..traces import SCHEMA as TRACES_SCHEMA, file_schema, read_traces
from ._common import nonneg_int, positive_int

NAME = "learn"
HELP = "learn symbols (from continuous traces), NID rules and a reward model into a model directory"
ORDER = 20
DESCRIPTION = (HELP + ". On continuous traces (groundsym.traces/1) it learns --unary and --binary RBF symbols "
               "by simulated annealing on the paper's loss, writes model/symbols.json and a copy of the "
               "training traces (model/traces.json), abstracts the model data and learns rules from it. "
               "On symbolic traces (groundsym.symbolic-traces/1) it learns the rules only.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("data", type=Path, help="training traces (continuous or symbolic JSON)")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="DIR", help="model directory to write")
    p.add_argument("--unary", type=nonneg_int, default=1, metavar="K", help="unary symbols to learn (default 1)")
    p.add_argument("--binary", type=nonneg_int, default=1, metavar="L", help="binary symbols to learn (default 1)")
    p.add_argument("--evals", type=positive_int, default=100_000, metavar="E",
                   help="loss evaluations in total over all restarts (default 100000, the paper's budget)")
    p.add_argument("--restarts", type=positive_int, default=4, metavar="R", help="independent restarts (default 4)")
    p.add_argument("--workers", type=positive_int, default=None, metavar="W",
                   help="worker processes (default: the number of cores); the result does not depend on it")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--checkpoint", type=Path, default=None, metavar="FILE",
                   help="save the search state here after every round; an existing file is resumed")
    p.add_argument("--model-data", type=Path, default=None, metavar="FILE",
                   help="continuous traces to abstract and learn rules from (default: DATA)")
    p.add_argument("--loss", action="append", default=[], metavar="KEY=VALUE",
                   help="loss setting, repeatable: " + ", ".join(LOSS_KEYS) + " (defaults: docs/symbols.md; "
                        "bowling needs transition_weight=0.15, docs/bowling.md)")
    p.add_argument("--alpha", type=float, default=None, help="rule learning: complexity penalty (passed through)")
    p.add_argument("--p-min", type=float, default=None, help="rule learning: noise outcome floor (passed through)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


LOSS_KEYS = tuple(f.name for f in fields(LossConfig))
TEXT_LOSS_KEYS = frozenset(f.name for f in fields(LossConfig) if f.type in (str, "str"))  # e.g. predict


def loss_config(items: list[str]) -> LossConfig:
    """``--loss key=value`` settings over the defaults; a bad key or value is one line (exit 2)."""
    given = split_key_values(items, "--loss")
    values: dict[str, float | str | None] = {}
    for key, text in given.items():
        if key not in LOSS_KEYS:
            raise UserError(f"--loss {key}: unknown setting (known: {', '.join(LOSS_KEYS)})")
        if key in TEXT_LOSS_KEYS:  # checked by LossConfig itself
            values[key] = text
            continue
        try:
            v = None if text.lower() == "none" and key == "reward_sigma" else float(text)
        except ValueError:
            raise UserError(f"--loss {key}={text}: expected a number") from None
        if v is not None and not math.isfinite(v):
            raise UserError(f"--loss {key}={text}: expected a finite number")
        values[key] = v
    try:
        return LossConfig(**values)
    except ValueError as exc:
        raise UserError(f"--loss: {exc}") from None


def run(args: argparse.Namespace) -> int:
    schema = file_schema(args.data)
    out: Path = args.output
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a directory")
    if schema == SYMBOLIC_SCHEMA:
        sds = read_symbolic_traces(args.data)
        _learn_rules(sds, out, args)
        return 0
    if schema != TRACES_SCHEMA:
        raise UserError(f"{args.data}: schema: expected {TRACES_SCHEMA!r} or {SYMBOLIC_SCHEMA!r}, got {schema!r}")
    symbols = learn_symbols(args)
    model_path = args.model_data or args.data
    model_ds = read_traces(model_path)
    symbols.check_features(model_ds.feature_names, f"{model_path}: meta")
    _learn_rules(symbols.to_symbolic_dataset(model_ds), out, args)
    return 0


def learn_symbols(args: argparse.Namespace) -> SymbolSet:
    """Anneal, prune, write ``symbols.json`` and the training traces into the model directory."""
    ds = read_traces(args.data)
    if args.unary + args.binary == 0:
        raise UserError("--unary and --binary: need at least one symbol to learn")
    loss_cfg = loss_config(args.loss)
    data = prepare(ds, loss_cfg, str(args.data))
    if args.evals < args.restarts:
        raise UserError(f"--evals: {args.evals} is less than one evaluation per restart ({args.restarts})")
    cfg = AnnealConfig(n_unary=args.unary, n_binary=args.binary, evals=args.evals, restarts=args.restarts)
    sha = file_sha256(args.data)
    workers = min(args.workers or default_workers(), args.restarts)
    progress = Progress(cfg.evals, "learn symbols", enabled=not args.quiet)

    def report(done: int, total: int, best) -> None:
        progress.update(done, f"best {best}" if best is not None else "")

    result = anneal(data, loss_cfg, cfg, args.seed, workers=workers, checkpoint=args.checkpoint,
                    data_sha256=sha, report=report)
    progress.close(f"best {result.terms}")
    symbols = SymbolSet(tuple(result.symbols), ds.feature_names)
    feats, pairs = dataset_arrays(ds)
    final = result.terms  # over all candidate slots (pruned symbols' literals count as predicted right)
    extra = {
        "loss": final.to_doc(),
        "pruned": [s.to_doc() for s in result.pruned],
        "restarts": result.restarts,
        "evaluations": result.evaluations,
        "config": {"anneal": cfg.to_doc(), "loss": loss_cfg.to_doc(), "reward_sigma": data.sigma},
        "data": {"transitions": data.n_transitions, "objects": int(feats.shape[1])},
        "provenance": provenance(args.argv, seed=args.seed, data_sha256=sha),
    }
    args.output.mkdir(parents=True, exist_ok=True)
    save_symbols(args.output / "symbols.json", symbols, shares=share_true(symbols, feats, pairs), extra=extra)
    traces_copy = args.output / "traces.json"
    if Path(args.data).resolve() != traces_copy.resolve():
        tmp = traces_copy.with_name(".traces.json.tmp")
        shutil.copyfile(args.data, tmp)
        tmp.replace(traces_copy)
    if not args.quiet:
        print(f"learn: {len(result.symbols)} symbols ({len(result.pruned)} pruned), {final}", file=sys.stderr)
    return symbols


def _learn_rules(sds, out: Path, args: argparse.Namespace) -> None:
    try:
        from ..modeldir import learn_symbolic_model
    except ImportError:  # the rules engine is optional in a partial install: symbols only
        print("learn: groundsym.modeldir is not available; wrote symbols only", file=sys.stderr)
        return
    out.mkdir(parents=True, exist_ok=True)
    learn_symbolic_model(sds, out, seed=args.seed, argv=args.argv, alpha=args.alpha, p_min=args.p_min)
