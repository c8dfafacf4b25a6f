"""Exactly the PDDL ``:requirements`` flags a domain uses (docs/ppddl.md).

Why computed, not declared: a domain written from rules (:mod:`.from_rules`), with reward effects
added, or determinised (:mod:`.determinize`) must declare what it uses and nothing more, since
classical planners refuse flags they do not support.
"""

from __future__ import annotations

from ..logic import Atom
from .ast import (OBJECT, And, AndEffect, Domain, Effect, Exists, Forall, ForallEffect, Formula, Imply, Not, Or,
                  Probabilistic, RewardEffect, When)


def requirements(domain: Domain) -> tuple[str, ...]:
    """Exactly the PDDL requirement flags the domain's actions use."""
    found: set[str] = set()
    typed = [x.type for p in (*domain.predicates, *domain.functions) for x in p.params]
    if domain.types or any(t != OBJECT for t in typed) or any(c.type != OBJECT for c in domain.constants):
        found.add(":typing")
    for a in domain.actions:
        if any(x.type != OBJECT for x in a.parameters):
            found.add(":typing")
        _formula_features(a.precondition, True, found)
        _effect_features(a.effect, found)
    if domain.axioms:
        found.add(":derived-predicates")
        for x in domain.axioms:
            _formula_features(x.body, True, found)
    return tuple(sorted(found))


def _formula_features(f: Formula, positive: bool, out: set[str]) -> None:
    if isinstance(f, Atom):
        if f.predicate == "=":
            out.add(":equality")
        elif not positive:
            out.add(":negative-preconditions")
    elif isinstance(f, Not):
        _formula_features(f.arg, not positive, out)
    elif isinstance(f, (And, Or)):
        if isinstance(f, Or) == positive and len(f.args) > 1:
            out.add(":disjunctive-preconditions")
        for g in f.args:
            _formula_features(g, positive, out)
    elif isinstance(f, Imply):
        out.add(":disjunctive-preconditions")
        _formula_features(f.left, not positive, out)
        _formula_features(f.right, positive, out)
    elif isinstance(f, (Forall, Exists)):
        # the quantifier as written, and as it acts under an odd number of negations
        out.add(":universal-preconditions" if isinstance(f, Forall) else ":existential-preconditions")
        if not positive:
            out.add(":existential-preconditions" if isinstance(f, Forall) else ":universal-preconditions")
        if any(p.type != OBJECT for p in f.params):
            out.add(":typing")
        _formula_features(f.body, positive, out)


def _effect_features(e: Effect, out: set[str]) -> None:
    if isinstance(e, AndEffect):
        for x in e.effects:
            _effect_features(x, out)
    elif isinstance(e, Probabilistic):
        out.add(":probabilistic-effects")
        for _, x in e.branches:
            _effect_features(x, out)
    elif isinstance(e, When):
        out.add(":conditional-effects")
        _formula_features(e.condition, True, out)
        _effect_features(e.effect, out)
    elif isinstance(e, ForallEffect):
        out.add(":conditional-effects")
        _effect_features(e.effect, out)
    elif isinstance(e, RewardEffect):
        out.add(":rewards")

