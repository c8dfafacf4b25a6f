"""``groundsym show``: learned symbols in words, as a picture (like the paper's Fig. 3), and against
the ground truth of traces that carry it."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ..describe import describe
from ..errors import UserError
from ..grounding import match_symbols
from ..symbols import SymbolSet, dataset_arrays, load_symbols, share_true
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


def suggested_names(matches: list, good: float = 0.5) -> dict[str, str]:
    """Symbol -> the relation it matches (same argument order, F1 >= ``good``), or ``not-<relation>``
    when its negation matches better; a relation two symbols match goes to the better one."""
    best: dict[str, tuple[float, str]] = {}
    for m in matches:
        options = []
        if m.best_match and m.argument_order == "same" and m.f1 >= good:
            options.append((m.f1, m.best_match))
        if m.negation_of and (m.negation_f1 or 0) >= max(good, m.f1):
            options.append((m.negation_f1, f"not-{m.negation_of}"))
        if options:
            f1, name = max(options)
            if name != m.symbol and (name not in best or best[name][0] < f1):
                best[name] = (f1, m.symbol)
    return {sym: name for name, (_, sym) in sorted(best.items(), key=lambda kv: kv[1][1])}


def _selective_dims(widths: np.ndarray, spread: np.ndarray) -> tuple[int, int]:
    order = np.argsort(widths / np.maximum(spread, 1e-12), kind="stable")
    return (int(order[0]), int(order[1])) if len(order) > 1 else (0, 0)


def plot_symbols(symbols: SymbolSet, features: np.ndarray, pairs: np.ndarray, path: Path,
                 max_points: int = 4000) -> None:
    """Write :func:`symbols_png` to ``path`` (atomically)."""
    from ..fileio import atomic_write_bytes

    atomic_write_bytes(path, symbols_png(symbols, features, pairs, max_points))


def symbols_png(symbols: SymbolSet, features: np.ndarray, pairs: np.ndarray, max_points: int = 4000) -> bytes:
    """One panel per symbol over its two most selective dimensions: data coloured by the symbol's
    truth, and the activation boundary g = 0.5 (other dimensions at the centre). A PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Ellipse

    n = max(len(symbols.symbols), 1)
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 4), squeeze=False)
    m = features.shape[1]
    rng = np.random.default_rng(0)
    for ax, s in zip(axes[0], symbols.symbols):
        if s.arity == 1:
            pts, names = features.reshape(-1, features.shape[-1]), symbols.feature_names
        else:
            pts, names = pairs[:, ~np.eye(m, dtype=bool)].reshape(-1, pairs.shape[-1]), symbols.pair_names
        if len(pts) > max_points:
            pts = pts[rng.choice(len(pts), max_points, replace=False)]
        true = s.holds(pts)
        a, b = _selective_dims(s.widths, pts.std(0))
        ax.scatter(pts[~true, a], pts[~true, b], s=6, c="0.7", label="false")
        ax.scatter(pts[true, a], pts[true, b], s=10, c="tab:red", label="true")
        r = np.sqrt(np.log(2.0)) * s.widths
        ax.add_patch(Ellipse((s.centre[a], s.centre[b]), 2 * r[a], 2 * r[b], fill=False, lw=1.5, ec="tab:blue"))
        ax.set_xlabel(names[a])
        ax.set_ylabel(names[b])
        ax.set_title(f"{s.name}/{s.arity}: {int(true.sum())} of {len(pts)} true")
        ax.legend(loc="best", fontsize=7)
    if not symbols.symbols:
        axes[0][0].set_title("no symbols")
    fig.tight_layout()
    import io
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()
