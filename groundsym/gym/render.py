"""Frames for ``render_mode="rgb_array"``: a simulation's own picture, or a symbolic state as text.

A simulation promises only ``render(path, width, height)`` writing a PNG (the Sim protocol), so
its frame is that PNG read back: every plug-in sim renders without further code, with the object
labels the sims draw. A PPDDL state has no geometry; its frame lists the true atoms in columns,
which is what a person watching a symbolic episode wants to read.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any, Sequence

import numpy as np


def sim_frame(sim: Any, width: int, height: int) -> np.ndarray:
    """The simulation's current picture as an ``(height, width, 3)`` ``uint8`` array."""
    from matplotlib.image import imread

    with tempfile.TemporaryDirectory(prefix="groundsym-frame-") as tmp:
        path = Path(tmp) / "frame.png"
        sim.render(path, width, height)
        img = imread(path)
    if img.dtype != np.uint8:                       # PNGs read as floats in [0, 1]
        img = np.round(img * 255).astype(np.uint8)
    return np.ascontiguousarray(img[..., :3])


def text_frame(title: str, lines: Sequence[str], width: int, height: int) -> np.ndarray:
    """A white ``(height, width, 3)`` image with ``title`` on top and ``lines`` in columns below."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width / 100, height / 100), dpi=100, facecolor="white")
    canvas = FigureCanvasAgg(fig)
    fig.text(0.02, 0.97, title, ha="left", va="top", fontsize=10, weight="bold", family="monospace")
    per_column = max(1, int((height - 40) // 14))
    columns = [lines[k:k + per_column] for k in range(0, len(lines), per_column)] or [["(no atom is true)"]]
    for c, col in enumerate(columns):
        fig.text(0.02 + c / len(columns) * 0.98, 0.90, "\n".join(col), ha="left", va="top",
                 fontsize=8, family="monospace", linespacing=1.25)
    canvas.draw()
    return np.ascontiguousarray(np.asarray(canvas.buffer_rgba())[..., :3])
