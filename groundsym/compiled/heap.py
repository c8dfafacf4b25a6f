"""A binary min-heap of (lower bound, class) pairs in two preallocated arrays, compiled: the order
in which :func:`groundsym.compiled.nearest.nearest_classes` visits candidate classes, ties in the
bound broken by the class index (the order the numpy reference visits them in)."""

from __future__ import annotations

from .base import njit


@njit(cache=True, inline="always")
def _heap_before(lo, c, i, j):
    return lo[i] < lo[j] or (lo[i] == lo[j] and c[i] < c[j])


@njit(cache=True)
def heap_push(lo, c, n, v, x):
    """Push (v, x) on the binary min-heap ``lo``/``c`` of ``n`` entries, ordered by (lo, c)."""
    i = n
    lo[i] = v
    c[i] = x
    while i > 0:
        p = (i - 1) >> 1
        if not _heap_before(lo, c, i, p):
            break
        lo[i], lo[p] = lo[p], lo[i]
        c[i], c[p] = c[p], c[i]
        i = p
    return n + 1


@njit(cache=True)
def heap_pop(lo, c, n):
    """Remove the top of the heap (read it at index 0 before); returns the new size."""
    n -= 1
    lo[0] = lo[n]
    c[0] = c[n]
    i = 0
    while True:
        a = 2 * i + 1
        if a >= n:
            break
        if a + 1 < n and _heap_before(lo, c, a + 1, a):
            a += 1
        if not _heap_before(lo, c, a, i):
            break
        lo[i], lo[a] = lo[a], lo[i]
        c[i], c[a] = c[a], c[i]
        i = a
    return n
