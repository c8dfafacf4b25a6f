"""A symbol's truth on the data, compiled: ``Symbol.holds`` (:mod:`groundsym.symbols`, the
reference) over many rows at once, with the same float steps."""

from __future__ import annotations

import numpy as np

from .base import LN2, njit


@njit(cache=True)
def rbf_holds(space, centre, widths):
    """Symbol.holds over the rows of ``space`` (P, n): the same float steps, dimension by dimension."""
    out = np.empty(space.shape[0], dtype=np.bool_)
    n = len(centre)
    for r in range(space.shape[0]):
        z = (space[r, 0] - centre[0]) / widths[0]
        acc = z * z
        for d in range(1, n):
            z = (space[r, d] - centre[d]) / widths[d]
            acc += z * z
        out[r] = acc < LN2
    return out
