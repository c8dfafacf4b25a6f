"""PRADA's transition over the chosen action's rules only (compiled).

A sample's marginals after its chosen action depend only on the ground rules of that action
(``U * (rule_group == chosen)`` is zero elsewhere), yet the product with the whole rule tables
(:func:`planners.prada.frontier.transition`) costs every ground rule for every sample; at 20 and
more objects the tables hold tens of thousands of rules and a few dozen belong to one action. Here
each sample walks the rows of its own action's segment (``starts[g]:starts[g+1]``) in the rules'
CSR form and adds ``probability x table entry`` to each column it touches.

Same bits as the whole-table product where that product is scipy's sparse one (the tables of
more than 2e6 entries, :attr:`~planners.prada.grounding.Grounding.changing`): scipy adds, for
each column, the rules' terms one after another in increasing rule order, starting from 0, with
a multiplication and an addition each; a rule outside the segment adds ``x * 0 = 0``, which
changes no sum. This kernel adds the same terms in the same order (numba does not fuse the
multiplication and the addition without ``fastmath``). Dense tables go through BLAS, whose
blocking and fused multiply-adds give other last bits, so they keep the whole-table product
(``tests/test_prada_segments.py`` checks both).
"""

from __future__ import annotations

import numpy as np

from groundsym.compiled.base import AVAILABLE, njit


@njit(cache=True)
def segment_products(U, chosen, starts, n_rules, indptr, indices, touched, set_true, n_cols):
    """``off[n] = sum_r U[n, r] touched[r]`` and ``on[n] = sum_r U[n, r] set_true[r]`` over the
    rules ``r`` of sample n's chosen action (none for -1), both tables as one CSR structure
    (``indptr``, ``indices``; values ``touched`` and ``set_true``, 0 where a rule sets no atom
    true), each column's terms added in rule order."""
    n = U.shape[0]
    off = np.zeros((n, n_cols))
    on = np.zeros((n, n_cols))
    n_groups = len(starts)
    for s in range(n):
        g = chosen[s]
        if g < 0:
            continue
        end = starts[g + 1] if g + 1 < n_groups else n_rules
        for r in range(starts[g], end):
            u = U[s, r]
            for k in range(indptr[r], indptr[r + 1]):
                c = indices[k]
                off[s, c] += touched[k] * u
                on[s, c] += set_true[k] * u
    return off, on


def csr_union(touched, set_true) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Both tables (sparse, same shape) on one CSR structure, the union of their non-zeros with
    each row's columns in increasing order: (indptr, indices, touched values, set_true values)."""
    t, s = touched.tocsr(), set_true.tocsr()
    t.sort_indices()
    s.sort_indices()
    return _merge_rows(t.indptr.astype(np.int64), t.indices.astype(np.int64), t.data.astype(float),
                       s.indptr.astype(np.int64), s.indices.astype(np.int64), s.data.astype(float))


@njit(cache=True)
def _merge_rows(tp, ti, tv, sp, si, sv):
    """The union of two CSR structures' rows (sorted columns), with both values per entry."""
    n = len(tp) - 1
    indptr = np.zeros(n + 1, dtype=np.int64)
    cap = len(ti) + len(si)
    indices = np.empty(cap, dtype=np.int64)
    a = np.zeros(cap)
    b = np.zeros(cap)
    e = 0
    for r in range(n):
        i, j = tp[r], sp[r]
        while i < tp[r + 1] or j < sp[r + 1]:
            if j >= sp[r + 1] or (i < tp[r + 1] and ti[i] < si[j]):
                indices[e], a[e] = ti[i], tv[i]
                i += 1
            elif i >= tp[r + 1] or si[j] < ti[i]:
                indices[e], b[e] = si[j], sv[j]
                j += 1
            else:
                indices[e], a[e], b[e] = ti[i], tv[i], sv[j]
                i += 1
                j += 1
            e += 1
        indptr[r + 1] = e
    return indptr, indices[:e].copy(), a[:e].copy(), b[:e].copy()


__all__ = ["AVAILABLE", "csr_union", "segment_products"]
