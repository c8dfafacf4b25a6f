"""Vectorised rule coverage over many examples at once (the learner's hot loop).

Rule search fits thousands of candidate rules, and each fit asks "which of these N examples does
the rule cover, and under which binding?". :meth:`groundsym.rules.model.Rule.covers` answers this
for one example by backtracking; here the examples of one action are stored as dense boolean
tensors (one per predicate, ``N x M x ... x M``), so a rule's context is evaluated for every
example and every assignment of its deictic references in a few numpy operations. The semantics
are the same (unique injective binding, closed world; tests check it against ``Rule.covers``).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations, product
from typing import Sequence

import numpy as np

from ..logic import Atom, Literal, is_variable
from .model import Derived, with_derived


@dataclass(frozen=True)
class Example:
    """One transition ``(state, action, succ)`` over ``objects``, with its multiplicity ``weight``."""

    state: frozenset
    action: Atom
    succ: frozenset
    objects: tuple[str, ...]
    weight: float = 1.0

    @property
    def adds(self) -> frozenset:
        return self.succ - self.state

    @property
    def dels(self) -> frozenset:
        return self.state - self.succ

    @property
    def changed(self) -> bool:
        return self.state != self.succ


@dataclass(frozen=True)
class Coverage:
    """Which examples a rule covers: their indices and the object index bound to each variable."""

    index: np.ndarray          # (n,) example indices, ascending
    binding: np.ndarray        # (n, V) object index per rule variable
    variables: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.index)

    def names(self, table: "ExampleTable", row: int) -> dict[str, str]:
        """The binding of covered example ``row`` as variable -> object name."""
        objs = table.examples[int(self.index[row])].objects
        return {v: objs[int(i)] for v, i in zip(self.variables, self.binding[row])}


class ExampleTable:
    """The examples of one action as boolean tensors, for vectorised coverage and outcome checks.

    ``derived`` predicates (:class:`~groundsym.rules.model.Derived`) get tensors computed from
    their base predicates' and are in ``predicates`` (contexts may use them); the examples' states
    and changes hold the base atoms only."""

    def __init__(self, examples: Sequence[Example], predicates: dict[str, int],
                 derived: Sequence[Derived] = ()):
        self.examples = list(examples)
        self.predicates = dict(predicates)
        for e in self.examples:          # predicates the data uses but the caller did not declare
            for a in e.state | e.succ:
                self.predicates.setdefault(a.predicate, a.arity)
        self.derived = tuple(d for d in derived if d.base in self.predicates and d.name not in self.predicates)
        for d in self.derived:
            self.predicates[d.name] = d.arity
        n = len(self.examples)
        self.M = max((len(e.objects) for e in self.examples), default=1) or 1
        self.weights = np.array([e.weight for e in self.examples], dtype=float)
        self.changed = np.array([e.changed for e in self.examples], dtype=bool)
        self.n_changes = np.array([len(e.adds) + len(e.dels) for e in self.examples], dtype=int)
        self.valid = np.zeros((n, self.M), dtype=bool)
        for i, e in enumerate(self.examples):
            self.valid[i, :len(e.objects)] = True
        self.before = self._tensors([e.state for e in self.examples])
        self.after = self._tensors([e.succ for e in self.examples])
        for tens in (self.before, self.after):
            for d in self.derived:
                tens[d.name] = self._derived_tensor(d, tens[d.base])
        arity = max((e.action.arity for e in self.examples), default=0)
        self.args = np.zeros((n, arity), dtype=int)
        self.distinct_args = np.ones(n, dtype=bool)
        for i, e in enumerate(self.examples):
            pos = {o: k for k, o in enumerate(e.objects)}
            self.args[i] = [pos[a] for a in e.action.args]
            self.distinct_args[i] = len(set(e.action.args)) == len(e.action.args)
        self._tuples: dict[tuple[int, bool], np.ndarray] = {}
        self.cache: dict[str, dict] = {}   # memo tables for callers (e.g. lifted changes per binding)

    def __len__(self) -> int:
        return len(self.examples)

    def _tensors(self, states: list[frozenset]) -> dict[str, np.ndarray]:
        n = len(states)
        out = {p: np.zeros((n,) + (self.M,) * k, dtype=bool) for p, k in self.predicates.items()}
        for i, (s, e) in enumerate(zip(states, self.examples)):
            pos = {o: k for k, o in enumerate(e.objects)}
            for a in s:
                out[a.predicate][(i, *(pos[x] for x in a.args))] = True
        return out

    def _derived_tensor(self, d: Derived, base: np.ndarray) -> np.ndarray:
        """``d`` for every example and argument tuple: no base atom with these arguments at ``d.keep``."""
        if d.arity > 1:
            raise ValueError(f"derived predicates of arity {d.arity} are not supported: {d.name}")
        other = tuple(1 + i for i in range(d.base_arity) if i not in d.keep)
        order = (0, *(1 + i for i in d.keep), *other)
        none = ~np.transpose(base, order).reshape(base.shape[:1 + d.arity] + (-1,)).any(axis=-1)
        for j in range(d.arity):            # padding objects are no objects
            none &= self.valid.reshape((len(self.valid),) + (1,) * j + (self.M,) + (1,) * (d.arity - 1 - j))
        return none

    def full_state(self, i: int) -> frozenset:
        """Example ``i``'s state with its derived atoms."""
        e = self.examples[i]
        return with_derived(e.state, self.derived, e.objects)

    def deictic_tuples(self, m: int, injective: bool = True) -> np.ndarray:
        """All ordered m-tuples of object indices (T x m), distinct ones only when injective."""
        key = (m, injective)
        if key not in self._tuples:
            gen = permutations(range(self.M), m) if injective else product(range(self.M), repeat=m)
            rows = list(gen)
            self._tuples[key] = np.array(rows, dtype=int).reshape(len(rows), m)
        return self._tuples[key]

    def literal_truth(self, lit: Literal, values: dict[str, np.ndarray], rows: np.ndarray | None = None,
                      after: bool = False) -> np.ndarray:
        """Truth of ``lit`` for every example (row) and assignment (column) in ``values``."""
        tens = (self.after if after else self.before)[lit.atom.predicate]
        if rows is not None:
            tens = tens[rows]
        ndim = 1 if rows is not None else 2
        r = np.arange(tens.shape[0]).reshape((-1,) + (1,) * (ndim - 1))
        val = tens[(r, *(values[a] for a in lit.atom.args))]
        return val if lit.positive else ~val

    def cover(self, action: Atom, context: Sequence[Literal], injective: bool = True) -> Coverage:
        """Examples covered by a rule with this action template and context (unique binding)."""
        avars = list(action.args)
        dvars: list[str] = []
        for lit in context:
            for a in lit.atom.args:
                if not is_variable(a):
                    raise ValueError(f"constants in rule contexts are not supported here: {lit}")
                if a not in avars and a not in dvars:
                    dvars.append(a)
        n = len(self.examples)
        tuples = self.deictic_tuples(len(dvars), injective)  # T x m
        values: dict[str, np.ndarray] = {v: self.args[:, k][:, None] for k, v in enumerate(avars)}
        for j, v in enumerate(dvars):
            values[v] = tuples[:, j][None, :]
        ok = np.ones((n, len(tuples)), dtype=bool)
        if injective:
            ok &= self.distinct_args[:, None]
            for j in range(len(dvars)):
                col = tuples[:, j]
                ok &= self.valid[:, col]
                for k in range(len(avars)):
                    ok &= self.args[:, k][:, None] != col[None, :]
        else:
            for j in range(len(dvars)):
                ok &= self.valid[:, tuples[:, j]]
        for lit in context:
            ok &= self.literal_truth(lit, values)
        counts = ok.sum(axis=1)
        rows = np.flatnonzero(counts == 1)
        cols = ok[rows].argmax(axis=1)
        binding = np.concatenate([self.args[rows], tuples[cols]], axis=1) if len(rows) else \
            np.zeros((0, len(avars) + len(dvars)), dtype=int)
        return Coverage(rows, binding, tuple(avars + dvars))

    def outcome_covers(self, changes: Sequence[Literal], cov: Coverage) -> np.ndarray:
        """For each covered example: does applying these changes under its binding give ``succ``?

        With an injective binding the grounded changes are distinct atoms, so the outcome covers
        iff every change holds afterwards and the changes that really flipped an atom account for
        all of the example's changes.
        """
        rows = cov.index
        if not len(rows):
            return np.zeros(0, dtype=bool)
        values = {v: cov.binding[:, k] for k, v in enumerate(cov.variables)}
        hold = np.ones(len(rows), dtype=bool)
        flipped = np.zeros(len(rows), dtype=int)
        for lit in changes:
            now = self.literal_truth(lit, values, rows, after=True)
            was = self.literal_truth(lit, values, rows, after=False)
            hold &= now
            flipped += now & ~was
        return hold & (flipped == self.n_changes[rows])
