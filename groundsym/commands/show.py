"""``groundsym show``: learned symbols in words, as a picture (like the paper's Fig. 3), and against
the ground truth of traces that carry it."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..describe import describe
from ..errors import UserError
from ..figures import plot_symbols
from ..grounding import match_symbols, suggested_names
from ..symbols import dataset_arrays, load_symbols, share_true
from ..traces import read_traces
from ._common import output_path

NAME = "show"
HELP = "print learned symbols in words, plot their groundings, match them to ground truth"
ORDER = 25


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("model", type=Path, help="model directory (or a symbols.json file)")
    p.add_argument("--plot", type=output_path, metavar="PNG", help="draw each symbol's activation region over the data")
    p.add_argument("--against", type=Path, metavar="TRACES",
                   help="continuous traces with ground truth: best-matching relation per symbol, with precision/recall/F1")
    p.add_argument("--json", action="store_true", help="with --against: one JSON document on stdout")


def symbols_path(model: Path) -> Path:
    return model / "symbols.json" if model.is_dir() else model


def run(args: argparse.Namespace) -> int:
    path = symbols_path(args.model)
    if not path.exists():
        raise UserError(f"{path}: no such file (learn symbols first: groundsym learn TRACES -o {args.model})")
    symbols = load_symbols(path)
    if args.json and not args.against:
        raise UserError("--json: needs --against TRACES")
    traces_path = args.model / "traces.json" if args.model.is_dir() else None
    data = None
    if traces_path is not None and traces_path.exists():
        ds = read_traces(traces_path)
        symbols.check_features(ds.feature_names, f"{traces_path}: meta")
        data = dataset_arrays(ds)
    if args.against:
        test = read_traces(args.against)
        symbols.check_features(test.feature_names, f"{args.against}: meta")
        matches = match_symbols(symbols, test)
        if args.json:
            print(json.dumps({"symbols": [m.to_doc() for m in matches]}, indent=1))
            return 0
        if data is None:
            data = dataset_arrays(test)
    shares = share_true(symbols, *data) if data is not None else None
    for line in describe(symbols, *(data or (None, None)), shares=shares):
        print(line)
    if not symbols.symbols:
        print("(no symbols: all were pruned)")
    if args.against:
        print(f"\nagainst the ground truth of {args.against}:")
        for m in matches:
            print("  " + str(m))
        names = suggested_names(matches)
        if names:
            print(f"\nsuggested names: groundsym rename {args.model} " + " ".join(f"{k}={v}" for k, v in names.items()))
    if args.plot:
        if data is None:
            raise UserError(f"--plot: needs the training traces ({args.model}/traces.json) or --against TRACES")
        plot_symbols(symbols, *data, args.plot)
        print(f"wrote {args.plot}", file=sys.stderr)
    return 0
