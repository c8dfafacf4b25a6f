"""What the depth camera saw, as a picture: the cell, the depth image and the segmented clouds.

``groundsym render`` (and ``plan --render-dir``) on a cell with ``features=pointcloud`` writes three
panels side by side: the usual view of the cell with object ids, the camera's depth image (metres;
white where there is no depth), and each object's visible points in 3-D, one colour per object,
labelled with its id and number of points; unseen objects are listed.
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
    right = fig.add_axes((2 / 3, 0.0, 1 / 3, 0.95), projection="3d")
    _clouds_3d(right, clouds, objects, unseen)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    atomic_write_bytes(path, buf.getvalue())


def _clouds_3d(ax, clouds: list[np.ndarray], objects: tuple[str, ...], unseen: tuple[str, ...]) -> None:
    """Each object's points in 3-D, seen from the camera's side of the table, one colour per object,
    labelled with its id and number of points (equal scales on all axes)."""
    pts = [c for c in clouds if len(c)]
    for k, (name, c) in enumerate(zip(objects, clouds)):
        if len(c):
            ax.scatter(c[:, 0], c[:, 1], c[:, 2], s=1, color=f"C{k % 10}", depthshade=False)
            top = c[np.argmax(c[:, 2])]
            ax.text(top[0], top[1], top[2] + 0.015, f"{name} ({len(c)})", fontsize=7)
    if pts:
        allp = np.vstack(pts)
        lo, hi = allp.min(0), allp.max(0)
        mid, half = (lo + hi) / 2, max((hi - lo).max() / 2, 0.05)
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(0.0, 2 * half)
    ax.view_init(elev=25, azim=20)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x (m)", fontsize=7)
    ax.set_ylabel("y (m)", fontsize=7)
    ax.set_zlabel("z (m)", fontsize=7)
    ax.tick_params(labelsize=6)
    ax.set_title("segmented point clouds" + (f" (unseen: {', '.join(unseen)})" if unseen else ""), fontsize=9)
