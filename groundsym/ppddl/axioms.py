"""Derived predicates (``:derived`` axioms) put in place: every derived atom replaced by its body.

Why: the export may declare a derived predicate once (``--axioms``, readable for a person, and Fast
Downward reads axioms), but our simulator, the rule reader and the determiniser work on formulas
over the state's atoms. Reading an axiom domain through :func:`inline` gives exactly the domain the
export writes without ``--axioms`` (the bodies use the same ``?derived-z`` variables), so every
reader downstream sees one semantics. Axioms here are not recursive (a body names base predicates
only), as the rule sets' derived predicates are; a recursive one is refused by the parser.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Mapping

from ..logic import Atom
from .ast import (Action, And, AndEffect, Axiom, Domain, Effect, Exists, Forall, ForallEffect, Formula, Imply, Not,
                  Or, Probabilistic, When)
from .ground import substitute


def expand(f: Formula, axioms: Mapping[str, Axiom]) -> Formula:
    """``f`` with each derived atom replaced by its axiom's body, arguments substituted."""
    if isinstance(f, Atom):
        x = axioms.get(f.predicate)
        return f if x is None else _instance(x, f.args)
    if isinstance(f, Not):
        return Not(expand(f.arg, axioms))
    if isinstance(f, (And, Or)):
        return type(f)(tuple(expand(g, axioms) for g in f.args))
    if isinstance(f, Imply):
        return Imply(expand(f.left, axioms), expand(f.right, axioms))
    if isinstance(f, (Forall, Exists)):
        return type(f)(f.params, expand(f.body, axioms))
    raise TypeError(f"not a formula: {f!r}")


def _instance(x: Axiom, args: tuple[str, ...]) -> Formula:
    """The body of ``x`` with its head's variables set to ``args`` (bound variables renamed where
    an argument would be captured)."""
    return substitute(x.body, dict(zip(x.head.args, args)))


def _effect(e: Effect, axioms: Mapping[str, Axiom]) -> Effect:
    if isinstance(e, AndEffect):
        return AndEffect(tuple(_effect(x, axioms) for x in e.effects))
    if isinstance(e, Probabilistic):
        return Probabilistic(tuple((p, _effect(x, axioms)) for p, x in e.branches))
    if isinstance(e, When):
        return When(expand(e.condition, axioms), _effect(e.effect, axioms))
    if isinstance(e, ForallEffect):
        return ForallEffect(e.params, _effect(e.effect, axioms))
    return e


def inline(domain: Domain) -> Domain:
    """``domain`` without axioms: derived atoms replaced by their bodies, their declarations gone."""
    if not domain.axioms:
        return domain
    axioms = {x.head.predicate: x for x in domain.axioms}
    actions = tuple(replace(a, precondition=expand(a.precondition, axioms), effect=_effect(a.effect, axioms))
                    for a in domain.actions)
    preds = tuple(p for p in domain.predicates if p.name not in axioms)
    return replace(domain, predicates=preds, actions=actions, axioms=(),
                   requirements=tuple(r for r in domain.requirements if r != ":derived-predicates"))


def action_inlined(a: Action, domain: Domain) -> Action:
    """One action of ``domain`` with its derived atoms in place."""
    axioms = {x.head.predicate: x for x in domain.axioms}
    return replace(a, precondition=expand(a.precondition, axioms), effect=_effect(a.effect, axioms))
