"""Atoms, literals and symbolic states.

An :class:`Atom` is a predicate applied to arguments, e.g. ``(on o1 o2)``. Arguments are object
names or variables; a variable starts with ``?`` as in PDDL (``(on ?x ?y)``). A symbolic state is a
``frozenset`` of the ground atoms that hold (closed world: anything absent is false).

These types are small, immutable and ordered, so that sets of them print deterministically.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Iterable, Mapping

State = frozenset  # frozenset[Atom]: the true ground atoms of one symbolic state

_NAME = r"[A-Za-z][A-Za-z0-9_\-]*"
_ARG = r"\??[A-Za-z0-9_][A-Za-z0-9_\-]*"
_ATOM_RE = re.compile(rf"^\(\s*({_NAME})((?:\s+{_ARG})*)\s*\)$")
_NAME_RE = re.compile(rf"^{_NAME}$")


def is_variable(term: str) -> bool:
    return term.startswith("?")


def is_name(text: str) -> bool:
    """True if ``text`` is a valid PDDL-style predicate, action or object name."""
    return bool(_NAME_RE.fullmatch(text))     # fullmatch: ``$`` lets a final newline by


@dataclass(frozen=True, order=True)
class Atom:
    """A predicate applied to a tuple of arguments (objects or ``?variables``)."""

    predicate: str
    args: tuple[str, ...] = ()

    def __str__(self) -> str:
        return "(" + " ".join((self.predicate, *self.args)) + ")"

    def pddl(self) -> str:
        return str(self)

    @property
    def arity(self) -> int:
        return len(self.args)

    def substitute(self, binding: Mapping[str, str]) -> "Atom":
        """Replace arguments through ``binding``; arguments not in it stay as they are."""
        return Atom(self.predicate, tuple(binding.get(a, a) for a in self.args))

    def is_ground(self) -> bool:
        return not any(is_variable(a) for a in self.args)


@dataclass(frozen=True, order=True)
class Literal:
    """An atom or its negation."""

    atom: Atom
    positive: bool = True

    def __str__(self) -> str:
        return str(self.atom) if self.positive else f"(not {self.atom})"

    def pddl(self) -> str:
        return str(self)

    def negate(self) -> "Literal":
        return Literal(self.atom, not self.positive)

    def substitute(self, binding: Mapping[str, str]) -> "Literal":
        return Literal(self.atom.substitute(binding), self.positive)

    def holds(self, state: frozenset) -> bool:
        """Closed-world truth of a ground literal in ``state``."""
        return (self.atom in state) == self.positive


def parse_atom(text: str) -> Atom:
    """Parse ``"(on o1 o2)"``; raise ValueError with the offending text otherwise."""
    m = _ATOM_RE.match(text.strip()) if isinstance(text, str) else None
    if not m:
        raise ValueError(f"not an atom: {text!r} (expected e.g. \"(on o1 o2)\")")
    return Atom(m.group(1), tuple(m.group(2).split()))


def parse_literal(text: str) -> Literal:
    """Parse ``"(on a b)"`` or ``"(not (on a b))"``."""
    t = text.strip()
    m = re.match(r"^\(\s*not\s+(\(.*\))\s*\)$", t)
    if m:
        return Literal(parse_atom(m.group(1)), False)
    return Literal(parse_atom(t), True)


def format_state(state: Iterable[Atom]) -> list[str]:
    """Sorted PDDL strings of a state's atoms (deterministic output)."""
    return [str(a) for a in sorted(state)]


def changes(before: frozenset, after: frozenset) -> tuple[frozenset, frozenset]:
    """(adds, dels) of a transition."""
    return after - before, before - after
