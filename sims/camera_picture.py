"""What the depth camera saw, as a picture: the cell, the depth image and the segmented clouds.

``groundsym render`` (and ``plan --render-dir``) on a cell with ``features=pointcloud`` writes three
panels side by side: the usual view of the cell with object ids, the camera's depth image (metres;
white where there is no depth), and each object's visible points seen from above the table, one
colour per object, labelled with its id and number of points; unseen objects are listed.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from groundsym.fileio import atomic_write_bytes

from .tower_camera import Frame

DEPTH_SHOWN = 1.6                  # m: the colour scale ends here (the cell is nearer; the floor far beyond)


def write_camera_png(path: str | Path, view: np.ndarray, labels: list[tuple[float, float, str]], frame: Frame,
                     clouds: list[np.ndarray], objects: tuple[str, ...], unseen: tuple[str, ...]) -> None:
    """Save the three panels as one PNG, atomically (each panel as tall as ``view``)."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    h, w = view.shape[:2]
    fig = Figure(figsize=(w * 3 / 100, h / 100), dpi=100)
    left = fig.add_axes((0, 0, 1 / 3, 1))
    left.imshow(view)
    left.set_axis_off()
    for x, y, text in labels:
        left.text(x, y, text, ha="left", va="center", fontsize=8,
                  bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.7})
    mid = fig.add_axes((1 / 3 + 0.01, 0.1, 1 / 3 - 0.06, 0.82))
    shown = mid.imshow(frame.depth, cmap="viridis", vmin=0.5, vmax=DEPTH_SHOWN)
    mid.set_title(f"depth image {frame.depth.shape[1]} x {frame.depth.shape[0]} (m; white: no depth)", fontsize=9)
    mid.set_axis_off()
    fig.colorbar(shown, ax=mid, fraction=0.04, pad=0.02)
    right = fig.add_axes((2 / 3 + 0.04, 0.12, 1 / 3 - 0.06, 0.78))
    _clouds_from_above(right, clouds, objects, unseen)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    atomic_write_bytes(path, buf.getvalue())


def _clouds_from_above(ax, clouds: list[np.ndarray], objects: tuple[str, ...], unseen: tuple[str, ...]) -> None:
    """Each object's points in the table plane (x up, y to the left, as the arm sees the table),
    one colour per object, labelled with its id and number of points."""
    for k, (name, c) in enumerate(zip(objects, clouds)):
        if len(c):
            ax.scatter(-c[:, 1], c[:, 0], s=1, color=f"C{k % 10}")
            ax.annotate(f"{name} ({len(c)})", (-c[:, 1].mean(), c[:, 0].mean()), xytext=(6, 6), textcoords="offset points",
                        fontsize=7)
    ax.set_xlabel("-y (m)", fontsize=8)
    ax.set_ylabel("x (m)", fontsize=8)
    ax.set_title("segmented point clouds, seen from above"
                 + (f"\nunseen: {', '.join(unseen)}" if unseen else ""), fontsize=9)
    ax.set_aspect("equal", adjustable="datalim")
    ax.tick_params(labelsize=7)
