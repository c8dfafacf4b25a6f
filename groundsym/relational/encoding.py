"""Symbolic states as arrays (:class:`Encoded`): unary, binary and nullary bits, the action's
label and each object's lock; and the constants the distances share."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..logic import Atom

INF = math.inf
FORBIDDEN_COST = 1e9  # cost of a forbidden match (other locks) inside a linear assignment


@dataclass(frozen=True, eq=False)
class Encoded:
    """One symbolic state(-action) as arrays (see the module docstring)."""

    unary: np.ndarray     # (M, K) uint8
    binary: np.ndarray    # (M, M, L) uint8, zero diagonal
    nullary: np.ndarray   # (P0,) uint8
    lock: np.ndarray      # (M,) int64: bit k set if the object is the action's k-th argument
    label: int = -1       # primitive id, -1 when no action constrains the match

    @property
    def n_objects(self) -> int:
        return self.unary.shape[0]

    def __repr__(self) -> str:
        return (f"Encoded(M={self.n_objects}, unary={int(self.unary.sum())}, binary={int(self.binary.sum())}, "
                f"nullary={int(self.nullary.sum())}, label={self.label})")


def lock_vector(objects: Sequence[str], action: Atom | None, size: int) -> np.ndarray:
    """Per object (padded to ``size``): the bit mask of the action argument positions it fills.
    Symbolic states and continuous scenes pin their arguments by it alike."""
    lock = np.zeros(size, dtype=np.int64)
    if action is not None:
        index = {o: i for i, o in enumerate(objects)}
        for k, arg in enumerate(action.args):
            if arg not in index:
                raise ValueError(f"action argument {arg!r} of {action} is not one of the objects")
            lock[index[arg]] |= 1 << k
    return lock


def encode_state(state: frozenset, objects: Sequence[str], predicates: dict[str, int],
                 action: Atom | None = None, labels: dict[str, int] | None = None,
                 size: int | None = None) -> Encoded:
    """Encode a symbolic state over ``objects`` (padded with empty objects up to ``size``).

    ``predicates`` fixes the column order (name -> arity, arities 0, 1 or 2); atoms of other
    predicates raise ValueError. ``labels`` maps primitive names to ids (default: ``{name: 0}``
    for the given action).
    """
    size = len(objects) if size is None else size
    order = {a: sorted(p for p, n in predicates.items() if n == a) for a in (0, 1, 2)}
    col = {a: {p: k for k, p in enumerate(order[a])} for a in (0, 1, 2)}
    unary = np.zeros((size, len(order[1])), dtype=np.uint8)
    binary = np.zeros((size, size, len(order[2])), dtype=np.uint8)
    nullary = np.zeros(len(order[0]), dtype=np.uint8)
    index = {o: i for i, o in enumerate(objects)}
    for atom in state:
        arity = predicates.get(atom.predicate)
        if arity is None or arity != atom.arity or arity > 2:
            raise ValueError(f"atom {atom} does not fit the predicates {predicates}")
        idx = [index[a] for a in atom.args]
        if arity == 0:
            nullary[col[0][atom.predicate]] = 1
        elif arity == 1:
            unary[idx[0], col[1][atom.predicate]] = 1
        elif idx[0] != idx[1]:  # diagonals stay zero: binary symbols hold for distinct objects only
            binary[idx[0], idx[1], col[2][atom.predicate]] = 1
    label = -1
    if action is not None:
        label = (labels or {action.predicate: 0})[action.predicate]
    return Encoded(unary, binary, nullary, lock_vector(objects, action, size), label)


def predicates_of(*states: frozenset) -> dict[str, int]:
    """Name -> arity of every predicate the states' atoms use (ValueError on two arities)."""
    preds: dict[str, int] = {}
    for s in states:
        for a in s:
            if preds.setdefault(a.predicate, a.arity) != a.arity:
                raise ValueError(f"predicate {a.predicate} used with arities {preds[a.predicate]} and {a.arity}")
    return preds
