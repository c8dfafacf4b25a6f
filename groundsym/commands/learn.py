"""``groundsym learn``: symbols from continuous traces (simulated annealing on the paper's loss), then
NID rules and a reward model on the abstracted data; or the rules alone from symbolic traces."""

from __future__ import annotations

import argparse
import math
import shutil
import sys
from dataclasses import fields
from pathlib import Path

from .. import stopping
from ..anneal import AnnealConfig, anneal
from ..errors import UserError, interrupt_in
from ..executors import add_executor_args, check_executor_options, make_executor
from ..fileio import file_sha256, output_target
from ..modeldir import check_model_output, learn_symbolic_model, model_transaction
from ..loss import LossConfig, prepare
from ..progress import Progress
from ..rules.learner import examples_from_dataset
from ..rules.language import Language, trace_language
from ..rules.successful import has_failures
from ..provenance import provenance
from ..options import split_key_values
from ..sim import warn_if_older_cell
from ..symbolic_traces import SCHEMA as SYMBOLIC_SCHEMA, read_symbolic_traces
from ..symbols import SymbolSet, dataset_arrays, dataset_pair_names, save_symbols, share_true
from ..traces import SCHEMA as TRACES_SCHEMA, Dataset, file_schema, read_traces
from ..workers import default_workers
from ..limits import MAX_EVALS, MAX_HOP_STEPS, MAX_POPULATION, MAX_RESTARTS, MAX_SYMBOLS, MAX_WORKERS
from ._common import SEED, Count

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
    p.add_argument("--unary", type=Count(0, MAX_SYMBOLS, "symbols"), default=1, metavar="K",
                   help="unary symbols to learn (default 1)")
    p.add_argument("--binary", type=Count(0, MAX_SYMBOLS, "symbols"), default=1, metavar="L",
                   help="binary symbols to learn (default 1)")
    p.add_argument("--evals", type=Count(1, MAX_EVALS, "loss evaluations"), default=100_000, metavar="E",
                   help="loss evaluations in total over all restarts (default 100000, the paper's budget)")
    p.add_argument("--restarts", type=Count(1, MAX_RESTARTS, "restarts"), default=4, metavar="R",
                   help="independent restarts (default 4)")
    p.add_argument("--workers", type=Count(1, MAX_WORKERS, "worker processes"), default=None, metavar="W",
                   help="worker processes (default: the number of cores); the result does not depend on it")
    add_executor_args(p, "With ray, each round's restarts are Ray tasks; without --ray-address, Ray "
                      "starts on this machine with --workers CPUs.")
    p.add_argument("--seed", type=SEED, default=0, help="random seed (default 0)")
    p.add_argument("--checkpoint", type=Path, default=None, metavar="FILE",
                   help="save the search state here after every round; an existing file is resumed")
    p.add_argument("--model-data", type=Path, default=None, metavar="FILE",
                   help="continuous traces to abstract and learn rules from (default: DATA)")
    p.add_argument("--loss", action="append", default=[], metavar="KEY=VALUE",
                   help="loss setting, repeatable: " + ", ".join(LOSS_KEYS) + " (defaults: docs/symbols.md; "
                        "bowling needs transition_weight=0.15, docs/bowling.md)")
    p.add_argument("--search", action="append", default=[], metavar="KEY=VALUE",
                   help="search setting, repeatable: " + ", ".join(SEARCH_KEYS) + " (ranges as LO,HI; "
                        "defaults and what each does: docs/symbol-search.md)")
    p.add_argument("--alpha", type=float, default=None, help="rule learning: complexity penalty (passed through)")
    p.add_argument("--p-min", type=float, default=None, help="rule learning: noise outcome floor (passed through)")
    p.add_argument("--constants", type=_names, default=None, metavar="A,B",
                   help="successful-only rules from symbolic traces (plans): objects a precondition may name, "
                        "as PDDL :constants (default: the file's meta.constants; docs/amlgym.md)")
    p.add_argument("--negative-preconditions", choices=("yes", "no"), default=None,
                   help="successful-only rules from symbolic traces: offer negated precondition literals "
                        "(default: the file's meta.negative_preconditions, else yes; docs/amlgym.md)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def _names(text: str) -> tuple[str, ...]:
    names = tuple(x.strip() for x in text.split(","))
    if not all(names):
        raise argparse.ArgumentTypeError(f"expected object names separated by commas, got {text!r}")
    return names


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


# the search's settings other than those with their own flags (--unary, --binary, --evals, --restarts)
SEARCH_KEYS = tuple(f.name for f in fields(AnnealConfig) if f.name not in ("n_unary", "n_binary", "evals", "restarts"))
# the upper bound of each whole-number search setting (groundsym.limits; a test walks them all)
SEARCH_MAX = {"population": (MAX_POPULATION, "candidates"), "chunk": (MAX_EVALS, "evaluations"),
              "hop_steps": (MAX_HOP_STEPS, "steps")}


def anneal_config(args: argparse.Namespace) -> AnnealConfig:
    """The search settings: the flags and ``--search key=value`` over the defaults; a bad key or
    value is one line (exit 2)."""
    types = {f.name: str(f.type) for f in fields(AnnealConfig)}
    values: dict[str, object] = {}
    for key, text in split_key_values(args.search, "--search").items():
        if key not in SEARCH_KEYS:
            raise UserError(f"--search {key}: unknown setting (known: {', '.join(SEARCH_KEYS)})")
        try:
            if types[key] == "str":
                values[key] = text
            elif types[key] == "int":
                values[key] = int(text)
                hi, unit = SEARCH_MAX[key]
                if values[key] > hi:
                    raise UserError(f"--search {key}={text}: at most {hi} {unit}")
            elif types[key].startswith("tuple"):
                lo, hi = (float(x) for x in text.split(","))
                values[key] = (lo, hi)
            else:
                values[key] = float(text)
        except ValueError:
            kind = {"int": "a whole number", "str": "a word"}.get(types[key], "LO,HI" if types[key].startswith("tuple")
                                                                 else "a number")
            raise UserError(f"--search {key}={text}: expected {kind}") from None
    try:
        return AnnealConfig(n_unary=args.unary, n_binary=args.binary, evals=args.evals, restarts=args.restarts,
                            **values)
    except ValueError as exc:
        raise UserError(f"--search: {exc}") from None


def check_options(args: argparse.Namespace) -> str:
    """Every option and input is checked before any work, so nothing fails after minutes of search
    with a half-written model. Returns the data's schema."""
    schema = file_schema(args.data)
    if schema not in (TRACES_SCHEMA, SYMBOLIC_SCHEMA):
        raise UserError(f"{args.data}: schema: expected {TRACES_SCHEMA!r} or {SYMBOLIC_SCHEMA!r}, got {schema!r}")
    check_model_output(args.output)
    if args.alpha is not None and not (math.isfinite(args.alpha) and args.alpha >= 0):
        raise UserError(f"--alpha: must be a finite number of at least 0, got {args.alpha}")
    if args.p_min is not None and not (math.isfinite(args.p_min) and 0 < args.p_min < 1):
        raise UserError(f"--p-min: must be in (0, 1), got {args.p_min}")
    if schema == SYMBOLIC_SCHEMA:
        return schema
    for given, name in ((args.constants, "--constants"), (args.negative_preconditions, "--negative-preconditions")):
        if given is not None:
            raise UserError(f"{name}: only for symbolic traces ({SYMBOLIC_SCHEMA}), whose successful-only "
                            f"rules it sets; {args.data} holds continuous traces")
    check_executor_options(args.executor, args.ray_address)
    if args.unary + args.binary == 0:
        raise UserError("--unary and --binary: need at least one symbol to learn")
    if args.evals < args.restarts:
        raise UserError(f"--evals: {args.evals} is less than one evaluation per restart ({args.restarts})")
    loss_config(args.loss)
    anneal_config(args)
    if args.checkpoint is not None:
        output_target(args.checkpoint)
    if args.model_data is not None:
        file_schema(args.model_data)
    return schema


def run(args: argparse.Namespace) -> int:
    schema = check_options(args)
    try:
        return _learn_model(schema, args)
    except (KeyboardInterrupt, Exception) as exc:   # the CLI prints this as its one 'interrupted' line, exit 130
        stop = interrupt_in(exc)                     # (SIGTERM: 'terminated', 143; groundsym.stopping)
        if stop is None:
            raise
        raise stopping.like(stop, f"{args.output} unchanged; {_what_was_kept(args.checkpoint)}") from None


def _what_was_kept(checkpoint: Path | None) -> str:
    """The interrupted line's advice: the checkpoint is named only once a round has written it."""
    if checkpoint is None:
        return "give --checkpoint FILE to keep the search state and resume"
    if not checkpoint.exists():
        return f"no search state was saved yet ({checkpoint} was not written); the same command starts again"
    return f"the search state is in {checkpoint}; the same command resumes it"


def _learn_model(schema: str, args: argparse.Namespace) -> int:
    """Everything after the checks, into a staging folder that replaces the model directory whole."""
    out: Path = args.output
    with model_transaction(out) as stage:
        if schema == SYMBOLIC_SCHEMA:
            sds = read_symbolic_traces(args.data)
            warn_if_older_cell(sds.meta, str(args.data))
            _learn_rules(sds, stage, args)
            return 0
        model_path = args.model_data or args.data
        model_ds = read_traces(model_path) if args.model_data else None
        if model_ds is not None:
            warn_if_older_cell(model_ds.meta, str(model_path))
        symbols = learn_symbols(args, stage, model_ds)
        model_ds = model_ds or read_traces(model_path)
        symbols.check_features(model_ds.feature_names, f"{model_path}: meta")
        _learn_rules(symbols.to_symbolic_dataset(model_ds), stage, args)
    return 0


def learn_symbols(args: argparse.Namespace, out: Path, model_ds: Dataset | None = None) -> SymbolSet:
    """Anneal, prune, write ``symbols.json`` and the training traces into ``out`` (the staging
    folder of the model directory). The feature spaces are checked first (``model_ds``: the
    --model-data traces, which the symbols must be able to read)."""
    ds = read_traces(args.data)
    warn_if_older_cell(ds.meta, str(args.data))
    dataset_pair_names(ds, str(args.data))
    if model_ds is not None and model_ds.feature_names != ds.feature_names:
        raise UserError(f"{args.model_data}: meta.feature_names {list(model_ds.feature_names)} are not those of "
                        f"{args.data} {list(ds.feature_names)}: symbols learned on one feature space cannot "
                        f"read the other (collect both with the same --sim-opt features=...)")
    loss_cfg = loss_config(args.loss)
    data = prepare(ds, loss_cfg, str(args.data))
    cfg = anneal_config(args)
    sha = file_sha256(args.data)
    workers = min(args.workers or default_workers(), args.restarts)
    with make_executor(args.executor, workers=workers, address=args.ray_address) as ex:
        where = f" on {ex.description}" if args.executor != "processes" else ""
        progress = Progress(cfg.evals, "learn symbols" + where, enabled=not args.quiet)

        def report(done: int, total: int, best) -> None:
            progress.update(done, f"best {best}" if best is not None else "")

        result = anneal(data, loss_cfg, cfg, args.seed, checkpoint=args.checkpoint, data_sha256=sha, report=report,
                        executor=ex)
    progress.close(f"best {result.terms}")
    symbols = SymbolSet.for_dataset(result.symbols, ds)
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
    save_symbols(out / "symbols.json", symbols, shares=share_true(symbols, feats, pairs), extra=extra)
    shutil.copyfile(args.data, out / "traces.json")   # the staging folder: nobody sees it half-copied
    if not args.quiet:
        print(f"learn: {len(result.symbols)} symbols ({len(result.pruned)} pruned), {final}", file=sys.stderr)
    return symbols


def _learn_rules(sds, out: Path, args: argparse.Namespace) -> None:
    learn_symbolic_model(sds, out, seed=args.seed, argv=args.argv, alpha=args.alpha, p_min=args.p_min,
                         progress=not args.quiet, language=_language(sds, args))


def _language(sds, args: argparse.Namespace) -> Language | None:
    """The successful-only language from the trace file's meta and the options (symbolic traces
    only; the options would change nothing where the data's failed actions call for NID rules)."""
    if args.constants is None and args.negative_preconditions is None \
            and not {"constants", "negative_preconditions"} & set(sds.meta):
        return None
    negative = None if args.negative_preconditions is None else args.negative_preconditions == "yes"
    lang = trace_language(sds.meta, {o for tr in sds.traces for o in tr.objects}, str(args.data),
                          args.constants, negative)
    if (args.constants is not None or negative is not None) and has_failures(examples_from_dataset(sds)):
        raise UserError(f"--constants / --negative-preconditions: {args.data} has actions that changed nothing, so "
                        "its rules are NID rules, whose contexts come from those failures; the options are for "
                        "successful-only traces (plans)")
    return lang
