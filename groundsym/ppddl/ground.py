"""Grounding PPDDL formulas and effects: substitution, constant equalities decided, literals read off.

Pure functions of the syntax tree, apart from the simulator (:mod:`groundsym.ppddl.simulate`) that
compiles each ground action with them once and then only tests atom sets: grounding decides what
can be decided without a state (``(= a b)`` between constants, ``(and)`` and ``(or)`` absorbed), so
the per-state work is as small as the domain allows.
"""

from __future__ import annotations

from typing import Callable, Iterable, Mapping, Sequence

from ..logic import Atom, Literal, is_variable
from .ast import (OBJECT, TRUE, Action, And, AndEffect, Effect, ForallEffect, Formula, Imply, Not, Or, Probabilistic,
                  Typed, When)

Outcome = tuple[float, frozenset, frozenset, float]          # probability, adds, dels, reward
FALSE = Or(())                                               # the empty disjunction
NOTHING: Outcome = (1.0, frozenset(), frozenset(), 0.0)       # the outcome that changes nothing


def substitute(f: Formula, ren: Mapping[str, str]) -> Formula:
    """``f`` with its free variables renamed by ``ren`` (a quantifier's own variables are kept,
    and renamed where a variable ``ren`` brings in would be captured by them); unlike
    :func:`ground_formula`, nothing is decided or simplified."""
    if isinstance(f, Atom):
        return f.substitute(ren)
    if isinstance(f, Not):
        return Not(substitute(f.arg, ren))
    if isinstance(f, (And, Or)):
        return type(f)(tuple(substitute(g, ren) for g in f.args))
    if isinstance(f, Imply):
        return Imply(substitute(f.left, ren), substitute(f.right, ren))
    inner = {k: v for k, v in ren.items() if k not in {p.name for p in f.params}}
    taken = {v for v in inner.values() if is_variable(v)}
    params = []
    for p in f.params:
        name = p.name
        while name in taken:                  # an argument would be captured: rename the bound one
            name += "_"
        if name != p.name:
            inner[p.name] = name
        params.append(Typed(name, p.type))
    return type(f)(tuple(params), substitute(f.body, inner))


def ground_formula(f: Formula, b: Mapping[str, str]) -> Formula:
    """``f`` with ``b`` substituted and equalities between constants decided (True: ``(and)``,
    False: ``(or)``); quantifiers stay (their variables are not in ``b``)."""
    if isinstance(f, Atom):
        g = f.substitute(b)
        if g.predicate == "=" and g.is_ground():
            return TRUE if g.args[0] == g.args[1] else FALSE
        return g
    if isinstance(f, Not):
        x = ground_formula(f.arg, b)
        return FALSE if x == TRUE else TRUE if x == FALSE else Not(x)
    if isinstance(f, (And, Or)):
        parts = [ground_formula(g, b) for g in f.args]
        absorbing, unit = (FALSE, TRUE) if isinstance(f, And) else (TRUE, FALSE)
        if absorbing in parts:
            return absorbing
        kept = tuple(x for x in parts if x != unit)
        return kept[0] if len(kept) == 1 else type(f)(kept)
    if isinstance(f, Imply):
        return ground_formula(Or((Not(f.left), f.right)), b)
    inner = {k: v for k, v in b.items() if k not in {p.name for p in f.params}}
    return type(f)(f.params, ground_formula(f.body, inner))


def ground_literals(f: Formula) -> list[tuple[Atom, bool]] | None:
    """A ground conjunction of literals as (atom, positive) pairs; None for any other formula."""
    parts = f.args if isinstance(f, And) else (f,)
    out = []
    for g in parts:
        if isinstance(g, Atom) and g.predicate != "=":
            out.append((g, True))
        elif isinstance(g, Not) and isinstance(g.arg, Atom) and g.arg.predicate != "=":
            out.append((g.arg, False))
        else:
            return None
    return out


def ground_effect(e: Effect, b: Mapping[str, str], groundings: Callable[[Sequence[Typed]], Iterable[tuple[str, ...]]]) -> Effect:
    """``e`` with ``b`` substituted; a ``forall`` becomes one conjunct per grounding of its parameters."""
    if isinstance(e, Literal):
        return e.substitute(b)
    if isinstance(e, AndEffect):
        return AndEffect(tuple(ground_effect(x, b, groundings) for x in e.effects))
    if isinstance(e, Probabilistic):
        return Probabilistic(tuple((p, ground_effect(x, b, groundings)) for p, x in e.branches))
    if isinstance(e, When):
        return When(ground_formula(e.condition, b), ground_effect(e.effect, b, groundings))
    if isinstance(e, ForallEffect):
        names = [p.name for p in e.params]
        return AndEffect(tuple(ground_effect(e.effect, dict(b, **dict(zip(names, vals))), groundings)
                               for vals in groundings(e.params)))
    return e


def effect_literals(e: Effect) -> list[Literal]:
    """Every literal an effect may set (under any branch or condition)."""
    if isinstance(e, Literal):
        return [e]
    if isinstance(e, AndEffect):
        return [l for x in e.effects for l in effect_literals(x)]
    if isinstance(e, Probabilistic):
        return [l for _, x in e.branches for l in effect_literals(x)]
    if isinstance(e, (When, ForallEffect)):
        return effect_literals(e.effect)
    return []


def has_when(e: Effect) -> bool:
    if isinstance(e, When):
        return True
    if isinstance(e, AndEffect):
        return any(has_when(x) for x in e.effects)
    if isinstance(e, Probabilistic):
        return any(has_when(x) for _, x in e.branches)
    return False


def distinct_pairs(action: Action, n: int) -> list[tuple[int, int]]:
    """Index pairs among the first ``n`` parameters that a top-level ``(not (= ?x ?y))`` keeps apart."""
    names = [p.name for p in action.parameters[:n]]
    pre = action.precondition
    out = []
    for c in (pre.args if isinstance(pre, And) else (pre,)):
        if isinstance(c, Not) and isinstance(c.arg, Atom) and c.arg.predicate == "=":
            x, y = c.arg.args
            if x in names and y in names:
                out.append((names.index(x), names.index(y)))
    return out


def product_of(parts: list[list[Outcome]]) -> list[Outcome]:
    """Independent effects combined: probabilities multiply, changes and rewards add up."""
    out: list[Outcome] = [NOTHING]
    for part in parts:
        out = [(p * q, a1 | a2, d1 | d2, r1 + r2) for p, a1, d1, r1 in out for q, a2, d2, r2 in part]
    return out


def is_a(tname: str, ancestor: str, parents: Mapping[str, str]) -> bool:
    seen = set()
    while tname not in seen:
        if tname == ancestor or ancestor == OBJECT:
            return True
        seen.add(tname)
        tname = parents.get(tname, OBJECT)
    return False
