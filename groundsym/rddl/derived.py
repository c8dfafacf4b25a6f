"""A rule set's derived predicates as RDDL derived fluents, declared once instead of written out.

The PPDDL export writes ``(no-inhand)`` as ``(not (exists (?derived-z1) (inhand ?derived-z1)))``
in every precondition that uses it (:meth:`groundsym.ppddl.from_rules.RulesWriter.literal`).
RDDL has derived fluents (Sanner 2010), which pyRDDLGym 2.7 reads as interm fluents (it warns on
``derived-fluent``), so they are written as interm fluents: :func:`fold`
puts the derived atom back wherever that exact pattern stands, and :func:`definition` gives the
fluent's one definition, ``no_inhand = ~(exists_{?z1 : obj}[inhand(?z1)])``.
"""

from __future__ import annotations

from typing import Sequence

from ..logic import Atom
from ..ppddl.ast import And, Exists, Forall, Formula, Imply, Not, Or, Typed
from ..rules.model import Derived

PREFIX = "?derived-z"          # the variables RulesWriter.literal quantifies


def _match(e: Exists, derived: Sequence[Derived]) -> Atom | None:
    """The derived atom ``e`` writes out, or None when it is some other ``exists``."""
    if not isinstance(e.body, Atom) or not all(p.name.startswith(PREFIX) for p in e.params):
        return None
    zs = [p.name for p in e.params]
    for d in derived:
        if d.base != e.body.predicate or d.base_arity != e.body.arity or len(zs) != d.base_arity - d.arity:
            continue
        others = [a for i, a in enumerate(e.body.args) if i not in d.keep]
        if others == zs:
            return Atom(d.name, tuple(e.body.args[i] for i in d.keep))
    return None


def fold(f: Formula, derived: Sequence[Derived]) -> Formula:
    """``f`` with every written-out derived predicate put back as its atom."""
    if not derived:
        return f
    if isinstance(f, Not) and isinstance(f.arg, Exists):
        atom = _match(f.arg, derived)
        if atom is not None:
            return atom
    if isinstance(f, Exists):
        atom = _match(f, derived)
        if atom is not None:
            return Not(atom)
    if isinstance(f, Not):
        return Not(fold(f.arg, derived))
    if isinstance(f, (And, Or)):
        return type(f)(tuple(fold(g, derived) for g in f.args))
    if isinstance(f, Imply):
        return Imply(fold(f.left, derived), fold(f.right, derived))
    if isinstance(f, (Forall, Exists)):
        return type(f)(f.params, fold(f.body, derived))
    return f


def definition(d: Derived) -> tuple[tuple[Typed, ...], Formula]:
    """The derived fluent's parameters and defining formula over its base predicate."""
    params = tuple(Typed(f"?x{i + 1}") for i in range(d.arity))
    zs = [f"?z{i + 1}" for i in range(d.base_arity - d.arity)]
    it = iter(zs)
    args = tuple(params[d.keep.index(i)].name if i in d.keep else next(it) for i in range(d.base_arity))
    return params, Not(Exists(tuple(Typed(z) for z in zs), Atom(d.base, args))) if zs else Not(Atom(d.base, args))
