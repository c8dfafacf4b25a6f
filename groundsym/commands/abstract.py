"""``groundsym abstract``: continuous traces -> symbolic traces through learned symbols."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import UserError
from ..provenance import provenance
from ..fileio import file_sha256
from ..symbolic_traces import write_symbolic_traces
from ..symbols import load_symbols
from ..traces import read_traces
from ._common import output_path
from .show import symbols_path

NAME = "abstract"
HELP = "abstract continuous traces to symbolic traces with learned symbols"
ORDER = 22


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("data", type=Path, help="continuous traces (groundsym.traces/1)")
    p.add_argument("--symbols", type=Path, required=True, metavar="MODEL",
                   help="model directory or symbols.json")
    p.add_argument("-o", "--output", type=output_path, required=True,
                   help="symbolic traces to write (groundsym.symbolic-traces/1)")


def run(args: argparse.Namespace) -> int:
    path = symbols_path(args.symbols)
    if not path.exists():
        raise UserError(f"{path}: no such file")
    ds = read_traces(args.data)
    symbols = load_symbols(path)
    symbols.check_features(ds.feature_names, f"{args.data}: meta")
    sds = symbols.to_symbolic_dataset(ds)
    sds.meta["provenance"] = provenance(args.argv, data_sha256=file_sha256(args.data),
                                        symbols_sha256=file_sha256(path))
    write_symbolic_traces(args.output, sds)
    print(f"abstract: {sds.n_transitions} transitions over {', '.join(sds.predicates) or 'no predicates'}",
          file=sys.stderr)
    return 0
