"""Symbolic states as fixed-length 0/1 vectors, the form reinforcement-learning code expects.

A learner's policy network or Q-table needs the same position to mean the same ground atom in
every observation, whatever the state. :class:`AtomIndex` fixes that order once (sorted atoms:
by predicate name, then arguments as strings) and converts between symbolic states (frozensets of
:class:`~groundsym.logic.Atom`) and ``int8`` vectors over that order, which is what a
``gymnasium.spaces.MultiBinary`` observation holds.
"""

from __future__ import annotations

from itertools import permutations, product
from typing import Iterable, Mapping, Sequence

import numpy as np
from gymnasium import spaces

from ..errors import UserError
from ..logic import Atom


class AtomIndex:
    """A fixed, sorted list of ground atoms and the position of each."""

    def __init__(self, atoms: Iterable[Atom], where: str = "atoms"):
        self.atoms: tuple[Atom, ...] = tuple(sorted(set(atoms)))
        if not self.atoms:
            raise UserError(f"{where}: there are no ground atoms to observe")
        self.position = {a: k for k, a in enumerate(self.atoms)}
        self.where = where

    def __len__(self) -> int:
        return len(self.atoms)

    def space(self) -> spaces.MultiBinary:
        return spaces.MultiBinary(len(self.atoms))

    def vector(self, state: Iterable[Atom]) -> np.ndarray:
        """The 0/1 vector of a state; an atom outside the index is an error, never silently dropped."""
        out = np.zeros(len(self.atoms), dtype=np.int8)
        for atom in state:
            k = self.position.get(atom)
            if k is None:
                raise UserError(f"{self.where}: the state holds {atom}, which is not among the observed "
                                f"ground atoms (an argument outside its predicate's declared type?)")
            out[k] = 1
        return out

    def state(self, vector: np.ndarray) -> frozenset:
        """The symbolic state a vector stands for (the inverse of :meth:`vector`)."""
        return frozenset(self.atoms[k] for k in np.flatnonzero(np.asarray(vector)))


def symbol_atoms(predicates: Mapping[str, int], objects: Sequence[str]) -> list[Atom]:
    """Every ground atom learned symbols can make true: unary ones on each object, binary ones on
    each ordered pair of distinct objects (a symbol never relates an object to itself)."""
    out = []
    for name, arity in predicates.items():
        if arity == 1:
            out += [Atom(name, (o,)) for o in objects]
        else:
            out += [Atom(name, pair) for pair in permutations(objects, 2)]
    return out


def typed_atoms(predicates: Iterable[tuple[str, Sequence[Sequence[str]]]]) -> list[Atom]:
    """Every ground atom of predicates given as ``(name, [objects allowed at each argument])``."""
    return [Atom(name, args) for name, allowed in predicates for args in product(*allowed)]
