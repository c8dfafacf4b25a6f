"""The probability that each ground rule's context holds, per sample (compiled).

``phi[n, r] = prod_j lit(B[n, ctx[r, j]])`` with ``lit(x) = x`` for a positive literal and
``1 - x`` for a negative one, pruned to 0 below ``min_prob``: the first step of
:func:`planners.prada.frontier.rule_probabilities`. In numpy it is a gather into an
(N, R, L) array, a ``where`` and a product; at 20 objects (7,640 ground rules of a learned tower
model, 500 samples) those temporaries hold 11 million numbers each and the step took most of a
decision. This kernel takes the same float steps per entry (``1 - x`` for a negative literal, the
product from the first literal on, in literal order: numpy multiplies fewer than 8 factors one
after another), so the same bits, without the temporaries
(``tests/test_prada_segments.py``).
"""

from __future__ import annotations

import numpy as np

from groundsym.compiled.base import njit


@njit(cache=True)
def context_probabilities(B, ctx, sign, min_prob):
    """(N, R): each sample's probability that each ground rule's context holds, 0 below ``min_prob``."""
    n = B.shape[0]
    r_count, l_count = ctx.shape
    phi = np.empty((n, r_count))
    for s in range(n):
        for r in range(r_count):
            x = B[s, ctx[r, 0]]
            p = x if sign[r, 0] else 1.0 - x
            for j in range(1, l_count):
                x = B[s, ctx[r, j]]
                p *= x if sign[r, j] else 1.0 - x
            phi[s, r] = 0.0 if p < min_prob else p
    return phi
