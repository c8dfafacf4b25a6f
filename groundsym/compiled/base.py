"""What every compiled kernel shares: numba itself (or a stand-in where it cannot install), the
hash constants of :mod:`groundsym.relational.hashing`, and four small helpers (a 64-bit mixer, row
equality, a popcount, an insertion step)."""

from __future__ import annotations

import math

import numpy as np

try:  # numba is a dependency; the numpy reference keeps the loss usable without it
    import numba
    from numba import njit
    AVAILABLE = True
except ImportError:  # pragma: no cover - exercised only where numba cannot install
    numba = None
    AVAILABLE = False

    def njit(*args, **kwargs):  # type: ignore[no-redef]
        return (lambda f: f) if not (len(args) == 1 and callable(args[0])) else args[0]

from ..relational.hashing import HASH_PRIMES, MIX_M1, MIX_M2

M1, M2 = np.uint64(MIX_M1), np.uint64(MIX_M2)
P0, P1, P2, P3, P4, P5 = (np.uint64(p) for p in HASH_PRIMES[:6])
INF = np.inf
LN2 = math.log(2.0)   # as symbols.LN2



@njit(cache=True, inline="always")
def mix(x):
    """relational.hashing.mix on one uint64 (multiplication wraps modulo 2^64, as in numpy)."""
    x = x ^ (x >> np.uint64(33))
    x = x * M1
    x = x ^ (x >> np.uint64(33))
    x = x * M2
    return x ^ (x >> np.uint64(33))


@njit(cache=True)
def arrays_equal(a, b):
    """Two 1-D arrays of the same length hold the same values (memo hits are checked by it)."""
    for i in range(len(a)):
        if a[i] != b[i]:
            return False
    return True


@njit(cache=True, inline="always")
def popcount(x):
    """The set bits of a uint64 (the SWAR count: no hardware instruction needed)."""
    x = x - ((x >> np.uint64(1)) & np.uint64(0x5555555555555555))
    x = (x & np.uint64(0x3333333333333333)) + ((x >> np.uint64(2)) & np.uint64(0x3333333333333333))
    x = (x + (x >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (x * np.uint64(0x0101010101010101)) >> np.uint64(56)


@njit(cache=True, inline="always")
def insert_sorted(row, n, v):
    """Insert ``v`` into ``row[:n]``, sorted ascending, shifting larger values right (an
    insertion sort step: for the handful of degrees per class, without allocating)."""
    t = n
    while t > 0 and row[t - 1] > v:
        row[t] = row[t - 1]
        t -= 1
    row[t] = v
