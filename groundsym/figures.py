"""Figures as PNG bytes: what a person would rather see than read.

Every figure is drawn with matplotlib's non-interactive Agg backend into bytes, so callers decide
where the picture goes (a file written atomically, a data URI in the HTML report). Drawing is
deterministic: the same inputs give the same bytes.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .fileio import atomic_write_bytes
from .symbols import SymbolSet


# ============================================================================== symbols
# The learned symbols over the data, like the paper's Fig. 3 (groundsym show --plot, groundsym report).
def _selective_dims(widths: np.ndarray, spread: np.ndarray) -> tuple[int, int]:
    """The two dimensions where the symbol is narrowest against the data's spread: where a picture
    shows best what decides it."""
    order = np.argsort(widths / np.maximum(spread, 1e-12), kind="stable")
    return (int(order[0]), int(order[1])) if len(order) > 1 else (0, 0)


def plot_symbols(symbols: SymbolSet, features: np.ndarray, pairs: np.ndarray, path: Path,
                 max_points: int = 4000) -> None:
    """Write :func:`symbols_png` to ``path`` (atomically)."""
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
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


# ============================================================================== evaluation
# The comparison of planners, like the paper's Fig. 2 (groundsym evaluate's results.png).
def bar_chart(results: Mapping[str, Any]) -> bytes:
    """One panel per model-trace count, bars per method over symbol-data sizes (like Fig. 2)."""
    # matplotlib is imported when a chart is drawn: it takes most of a second, and the CLI imports
    # every command, and so this module, to build its parser
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = results["methods"]
    cfg = results["meta"]["config"]
    methods, Ns, ns = cfg["methods"], cfg["symbol_data"], cfg["model_traces"]
    fig, axes = plt.subplots(1, len(ns), figsize=(4.5 * len(ns), 3.6), squeeze=False, sharey=True)
    width = 0.8 / max(len(methods), 1)
    for ax, n in zip(axes[0], ns):
        for i, m in enumerate(methods):
            got = {r["symbol_data"]: r for r in rows if r["method"] == m and r["model_traces"] == n}
            xs = [j + (i - (len(methods) - 1) / 2) * width for j, N in enumerate(Ns) if N in got]
            ys = [got[N]["mean"] for N in Ns if N in got]
            es = [got[N]["stderr"] or 0.0 for N in Ns if N in got]
            ax.bar(xs, ys, width, yerr=es, capsize=2, label=m)
        if results.get("optimum"):
            ax.axhline(results["optimum"], color="k", ls="--", lw=1, label="optimum")
        ax.set_xticks(range(len(Ns)), [str(N) for N in Ns])
        ax.set_xlabel("data for symbol learning")
        ax.set_title(f"{cfg['sim']}: {n} model trace(s)")
    axes[0][0].set_ylabel("episode value")
    axes[0][-1].legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()
