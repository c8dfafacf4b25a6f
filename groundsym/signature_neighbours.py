"""Nearest neighbours of ``local:1`` views by signature assignment: the prediction term of
``distance=signature`` (docs/symbol-search.md, "The signature distance").

``local:1`` (:mod:`groundsym.relational.local`) keeps every unary literal and the binary literals
with an action argument at one end. With the arguments pinned, the exact distance of two such
views is a linear assignment of the free objects by their signatures
(:mod:`groundsym.compiled.signatures`), which costs a merge and a small Hungarian method per pair
of views instead of a quadratic-assignment search over all M objects. The classes and the
nearest distances are those of the exact search on the same views; where several orders attain
the nearest distance the prediction goes through the assignment's, so the loss values may differ
from ``local:1``'s there (measured on docs/symbol-search.md).
"""

from __future__ import annotations

import numpy as np

from .compiled.signatures import MAX_SIGNATURE_BITS, nearest_by_signature, view_keys
from .neighbourhood import Neighbourhood, group_rows


def signature_bits(n_unary: int, n_binary: int, n_args: int) -> int:
    """Bits of one free object's signature: its unary literals, and per argument and binary
    symbol the relation to and from it."""
    return n_unary + 2 * n_args * n_binary


def signature_neighbours(u: np.ndarray, b: np.ndarray, lock: np.ndarray, label: np.ndarray) -> Neighbourhood:
    """Leave-one-out nearest neighbours (all ties) of each item, ``u`` (N, M, K) and ``b``
    (N, M, M, L) being ``local:1`` views (every binary literal with an argument, ``lock`` != 0,
    at one end), among the items of the same primitive (``label``) and lock values."""
    n, m, k = u.shape
    n_args = int((lock != 0).sum(axis=1).max()) if n else 0
    bits = signature_bits(k, b.shape[3], n_args)
    if bits > MAX_SIGNATURE_BITS:
        raise ValueError(f"distance=signature: {k} unary and {b.shape[3]} binary symbols with {n_args} "
                         f"arguments need {bits} signature bits, at most {MAX_SIGNATURE_BITS}")
    lock = np.ascontiguousarray(lock, dtype=np.int64)
    perms, sigs, keys = view_keys(np.ascontiguousarray(u), np.ascontiguousarray(b), lock,
                                  np.ascontiguousarray(label, dtype=np.int64), n_args)
    first, cls = group_rows(keys)
    sizes = np.bincount(cls, minlength=len(first))
    lone = np.flatnonzero(sizes == 1).astype(np.int64)
    arg_lo = 1 + n_args
    arg_hi = arg_lo + n_args * k + n_args * n_args * b.shape[3]
    n_free = m - (lock != 0).sum(axis=1)
    best, hq, hc, hs = nearest_by_signature(keys, sigs, n_free.astype(np.int64), first.astype(np.int64), lone,
                                            arg_lo, arg_hi, bits)
    return Neighbourhood(cls.astype(np.int64), perms, lone, best, hq, hc, hs)
