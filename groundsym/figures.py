"""Figures as PNG bytes: what a person would rather see than read.

Every figure is drawn with matplotlib's non-interactive Agg backend into bytes, so callers decide
where the picture goes (a file written atomically, a data URI in the HTML report). Drawing is
deterministic: the same inputs give the same bytes.
"""

from __future__ import annotations

import io
from pathlib import Path

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
