"""Formulas made shorter without changing their truth: what a student reads in an exported domain.

Why: the rule export builds preconditions mechanically (one exclusion per other rule, each a
conjunction), which leaves ``(not (and (not (u1 ?x))))``, repeated literals, and exclusions that
are always false. :func:`simplify` removes double negations, flattens nested ``and``/``or``,
drops repeated and trivially true parts, and returns :data:`FALSE` for a formula that can never
hold (a conjunction with a literal and its negation, ``(not (and))``). Quantifiers are kept as
written; a quantified body that is always true or false decides the quantifier (the object set of
a PDDL problem is never empty).
"""

from __future__ import annotations

from .ast import TRUE, And, Exists, Forall, Formula, Imply, Not, Or
from ..logic import Atom, is_variable

FALSE = Or(())


def _negate(f: Formula) -> Formula:
    return f.arg if isinstance(f, Not) else Not(f)


def _equality(a: Atom) -> Formula:
    x, y = a.args
    if x == y:
        return TRUE
    if not is_variable(x) and not is_variable(y):
        return FALSE                      # two different object names
    return a


def _junction(f: And | Or) -> Formula:
    """``and``/``or``: flattened, constants absorbed, repeats dropped, ``x`` with ``(not x)`` decided."""
    is_and = isinstance(f, And)
    unit, zero = (TRUE, FALSE) if is_and else (FALSE, TRUE)
    out: list[Formula] = []
    for g in f.args:
        s = simplify(g)
        parts = s.args if type(s) is type(f) else (s,)
        for p in parts:
            if p == zero:
                return zero
            if p != unit and p not in out:
                out.append(p)
    if any(_negate(p) in out for p in out):
        return zero
    if len(out) == 1:
        return out[0]
    return And(tuple(out)) if is_and else Or(tuple(out))


def simplify(f: Formula) -> Formula:
    """An equivalent, shorter formula; :data:`TRUE` (``(and)``) or :data:`FALSE` (``(or)``) when decided."""
    if isinstance(f, Atom):
        return _equality(f) if f.predicate == "=" and f.arity == 2 else f
    if isinstance(f, Not):
        s = simplify(f.arg)
        if s == TRUE:
            return FALSE
        if s == FALSE:
            return TRUE
        return _negate(s)
    if isinstance(f, (And, Or)):
        return _junction(f)
    if isinstance(f, Imply):
        return simplify(Or((Not(f.left), f.right)))
    if isinstance(f, (Forall, Exists)):
        body = simplify(f.body)
        if body in (TRUE, FALSE):
            return body
        return type(f)(f.params, body)
    raise TypeError(f"not a formula: {f!r}")
