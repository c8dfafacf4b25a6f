"""Nearest neighbours of ``local:1`` views by signature assignment: the prediction term of
``distance=signature`` (docs/symbol-search.md, "The signature distance").

``local:1`` (:mod:`groundsym.relational.local`) keeps every unary literal and the binary literals
with an action argument at one end. With the arguments pinned, the exact distance of two such
views is a linear assignment of the free objects by their signatures
(:mod:`groundsym.compiled.signatures`), which costs a merge and a small Hungarian method per pair
of views instead of a quadratic-assignment search over all M objects. The views are handed to the
mixtures in the same form (each kept relation a bit of one object, :func:`argument_view`), so
the mixtures count the same mispredictions as on the ``local:1`` views without walking M x M
pairs. The classes and the nearest distances are those of the exact search on the same views;
where several orders attain the nearest distance the prediction goes through the assignment's,
so the loss values may differ from ``local:1``'s there (measured on docs/symbol-search.md).
"""

from __future__ import annotations

import numpy as np

from .compiled.signatures import MAX_SIGNATURE_BITS, argument_literals, signature_classes
from .neighbourhood import Neighbourhood


def most_arguments(lock: np.ndarray) -> int:
    """The most action arguments of any transition (``lock`` (T, M), != 0 on arguments)."""
    return int((lock != 0).sum(axis=1).max()) if len(lock) else 0


def signature_bits(n_unary: int, n_binary: int, lock: np.ndarray) -> int:
    """The bits of one object's signature: its unary literals and, per argument, its relation to
    and from it per binary symbol."""
    return n_unary + 2 * most_arguments(lock) * n_binary


def argument_view(u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray,
                  lock: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each transition's ``local:1`` view with every kept literal as one object's bit, as scene
    arrays ``(u', b', pre', post')`` like :func:`groundsym.relational.local.local_view`'s, ``b'``
    with no binary columns (:func:`groundsym.compiled.signatures.argument_literals`)."""
    n_args = most_arguments(lock)
    bits = signature_bits(u.shape[2], b.shape[3], lock)
    if bits > MAX_SIGNATURE_BITS:
        raise ValueError(f"distance=signature: {u.shape[2]} unary and {b.shape[3]} binary symbols with "
                         f"{n_args} arguments need {bits} signature bits, at most {MAX_SIGNATURE_BITS}")
    n, m = len(pre), u.shape[1]
    su = argument_literals(np.ascontiguousarray(u), np.ascontiguousarray(b), np.asarray(pre, dtype=np.int64),
                           np.asarray(post, dtype=np.int64), np.ascontiguousarray(lock, dtype=np.int64), n_args)
    return su, np.zeros((2 * n, m, m, 0), dtype=np.uint8), np.arange(n), np.arange(n, 2 * n)


def signature_neighbours(u: np.ndarray, b: np.ndarray, lock: np.ndarray, label: np.ndarray) -> Neighbourhood:
    """Leave-one-out nearest neighbours (all ties) of each item among the items of the same
    primitive (``label``) and lock values; ``u`` (N, M, B) the states before of
    :func:`argument_view` (``b``, without binary columns, is not read)."""
    n_args = most_arguments(lock)
    fields = signature_classes(np.ascontiguousarray(u), np.ascontiguousarray(lock, dtype=np.int64),
                               np.ascontiguousarray(label, dtype=np.int64), n_args)
    return Neighbourhood(*fields)
