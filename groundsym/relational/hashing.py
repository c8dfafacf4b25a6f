"""The 64-bit hashing of colour refinement: one finaliser and six odd constants.

Canonical forms (:mod:`.canonical`) colour objects by hashing; their compiled twins
(:mod:`groundsym.compiled.canonical`) must compute the very same integers, so both take the
constants from here. Every product wraps modulo 2^64, in numpy as in numba. The finaliser's two
multipliers are those of MurmurHash3's 64-bit finaliser (Appleby, 2011).
"""

from __future__ import annotations

import numpy as np

__all__ = ["HASH_PRIMES", "MIX_M1", "MIX_M2", "mix"]

#: The multipliers of :func:`mix`.
MIX_M1, MIX_M2 = np.uint64(0xFF51AFD7ED558CCD), np.uint64(0xC4CEB9FE1A85EC53)

#: Odd constants that keep the parts of one refinement round apart: ``[0]`` seeds the initial
#: colours, ``[1]``/``[2]`` weigh out- and in-edges, ``[3]``/``[4]`` a neighbour's and an object's
#: own colour, ``[5]`` moves an individualised object's colour out of its class.
HASH_PRIMES = tuple(np.uint64(v) for v in (0x9E3779B97F4A7C15, 0xBF58476D1CE4E5B9, 0x94D049BB133111EB,
                                           0xD6E8FEB86659FD93, 0x2545F4914F6CDD1D, 0x7F4A7C159E3779B9))


def mix(x: np.ndarray) -> np.ndarray:
    """A 64-bit finaliser: spreads bits so that sums of mixed values behave as multiset hashes."""
    x = x ^ (x >> np.uint64(33))
    x = x * MIX_M1
    x = x ^ (x >> np.uint64(33))
    x = x * MIX_M2
    return x ^ (x >> np.uint64(33))
