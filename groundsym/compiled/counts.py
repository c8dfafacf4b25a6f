"""The linear reward term's relational counts, compiled (reference: ``count_features`` of
:mod:`groundsym.reward_term`). Every value is a count of 0/1 products, an exact integer, so the
two give the same floats in the same columns whatever the order of summation."""

from __future__ import annotations

import numpy as np

from .base import njit


@njit(cache=True)
def count_features(u, b):
    """(T, F) counts of states ``u`` (T, M, K) and ``b`` (T, M, M, L), uint8, in the column order of
    the numpy reference."""
    t_n, m, k = u.shape
    n_bin = b.shape[3]
    n_feat = k + n_bin + k * (k - 1) // 2
    if n_bin:
        n_feat += 2 * n_bin * k + n_bin * (n_bin - 1) // 2 + n_bin * (n_bin + 1) // 2 + n_bin * n_bin + n_bin
        n_feat += n_bin * (1 + 2 * k)
    out = np.zeros((t_n, n_feat))
    indeg = np.zeros((m, n_bin))
    outdeg = np.zeros((m, n_bin))
    rev = np.zeros((n_bin, n_bin))
    reach = np.zeros((m, m), dtype=np.bool_)
    for t in range(t_n):
        col = 0
        for i in range(k):
            s = 0
            for a in range(m):
                s += u[t, a, i]
            out[t, col] = s
            col += 1
        for p in range(n_bin):
            s = 0
            for a in range(m):
                for c in range(m):
                    s += b[t, a, c, p]
            out[t, col] = s
            col += 1
        for i in range(k):
            for j in range(i + 1, k):
                s = 0
                for a in range(m):
                    s += u[t, a, i] * u[t, a, j]
                out[t, col] = s
                col += 1
        if n_bin == 0:
            continue
        for first in range(2):          # (p ?a ?b) (q ?a), then (p ?a ?b) (q ?b)
            for p in range(n_bin):
                for i in range(k):
                    s = 0
                    for a in range(m):
                        for c in range(m):
                            if b[t, a, c, p]:
                                s += u[t, a, i] if first == 0 else u[t, c, i]
                    out[t, col] = s
                    col += 1
        for p in range(n_bin):
            for q in range(n_bin):
                same = 0
                back = 0
                for a in range(m):
                    for c in range(m):
                        if b[t, a, c, p]:
                            same += b[t, a, c, q]
                            back += b[t, c, a, q]
                rev[p, q] = back
                if q > p:
                    out[t, col] = same
                    col += 1
        for p in range(n_bin):
            for q in range(p, n_bin):
                out[t, col] = rev[p, q]
                col += 1
        indeg[:] = 0.0
        outdeg[:] = 0.0
        for a in range(m):
            for c in range(m):
                for p in range(n_bin):
                    if b[t, a, c, p]:
                        indeg[c, p] += 1.0
                        outdeg[a, p] += 1.0
        for p in range(n_bin):
            for q in range(n_bin):
                s = 0.0
                for c in range(m):
                    s += indeg[c, p] * outdeg[c, q]
                out[t, col] = s - rev[p, q]
                col += 1
        for p in range(n_bin):         # chains (p ?a ?b) (p ?b ?c) (p ?c ?d) over distinct objects
            s = 0.0
            for x in range(m):
                for y in range(m):
                    if b[t, x, y, p]:
                        back = float(b[t, y, x, p])
                        common = 0.0
                        for z in range(m):
                            common += b[t, z, x, p] * b[t, y, z, p]
                        s += (indeg[x, p] - back) * (outdeg[y, p] - back) - common
            out[t, col] = s
            col += 1
        col = _closure_counts(u, b, t, reach, out, col)
    return out


@njit(cache=True)
def _closure_counts(u, b, t, reach, out, col):
    """State ``t``'s counts of pairs joined by a ``p``-path (Warshall), alone and with each unary
    symbol on the first, then the second object; returns the next column."""
    m, k = u.shape[1], u.shape[2]
    n_bin = b.shape[3]
    base = col
    for p in range(n_bin):
        for x in range(m):
            for y in range(m):
                reach[x, y] = b[t, x, y, p] != 0
        for z in range(m):
            for x in range(m):
                if reach[x, z]:
                    for y in range(m):
                        if reach[z, y]:
                            reach[x, y] = True
        total = 0.0
        for x in range(m):
            for y in range(m):
                if x != y and reach[x, y]:
                    total += 1.0
                    for i in range(k):
                        out[t, base + n_bin + p * k + i] += u[t, x, i]
                        out[t, base + n_bin + n_bin * k + p * k + i] += u[t, y, i]
        out[t, base + p] = total
    return base + n_bin * (1 + 2 * k)
