"""Does the ``pddl`` package (PyPI; Favorito, Fuggitti et al.) read our FOND export with the outcomes we meant?

Both sides are brought to one normal form: an action's effect as the set of its outcomes, each
outcome the set of its changes (a literal, or a ``when``/``forall`` with its own outcome set);
``oneof`` is a union of outcome sets, ``and`` their product. A FOND export is right when, for every
action, the ``pddl`` package's outcome set equals the one our PPDDL (:mod:`.ast`) says, with rewards
left out. Names compare in lower case (PDDL is case-insensitive; a reader may fold them).
``pddl`` is imported only when a check runs (it pins ``lark<1.2``, so it is an optional extra).
"""

from __future__ import annotations

from itertools import product
from pathlib import Path

from ..logic import Atom, Literal
from .ast import (AndEffect, Domain, Effect, Exists, Forall, ForallEffect, Formula, Imply, Not, Or, Probabilistic,
                  RewardEffect, When, And)

Outcomes = frozenset          # of frozensets of changes


def _name(x: str) -> str:
    return x.lstrip("?").lower()


def _combine(parts: list[Outcomes]) -> Outcomes:
    return frozenset(frozenset().union(*combo) for combo in product(*parts)) if parts else frozenset({frozenset()})


def _junction(kind: str, parts) -> tuple:
    """An ``and``/``or`` with nested ones of the same kind flattened (a reader may flatten them)."""
    flat: set = set()
    for p in parts:
        flat |= p[1] if p[0] == kind else {p}
    return next(iter(flat)) if len(flat) == 1 else (kind, frozenset(flat))


# ------------------------------------------------------------------------------ our side
def our_formula(f: Formula) -> tuple:
    if isinstance(f, Atom):
        return ("=" if f.predicate == "=" else _name(f.predicate), tuple(map(_name, f.args)))
    if isinstance(f, Not):
        return ("not", our_formula(f.arg))
    if isinstance(f, (And, Or)):
        return _junction("and" if isinstance(f, And) else "or", map(our_formula, f.args))
    if isinstance(f, Imply):
        return ("imply", our_formula(f.left), our_formula(f.right))
    if isinstance(f, (Forall, Exists)):
        kind = "forall" if isinstance(f, Forall) else "exists"
        return (kind, tuple(_name(p.name) for p in f.params), our_formula(f.body))
    raise TypeError(f"not a formula: {f!r}")


def our_outcomes(e: Effect) -> Outcomes:
    """The all-outcomes view of a PPDDL effect (rewards left out, the unassigned mass: no change)."""
    if isinstance(e, Literal):
        return frozenset({frozenset({("lit", e.positive, our_formula(e.atom))})})
    if isinstance(e, RewardEffect):
        return frozenset({frozenset()})
    if isinstance(e, AndEffect):
        return _combine([our_outcomes(x) for x in e.effects])
    if isinstance(e, Probabilistic):
        out = frozenset().union(*(our_outcomes(x) for p, x in e.branches if p > 0))
        return out | ({frozenset()} if e.rest > 0 else set())
    if isinstance(e, When):
        inner = our_outcomes(e.effect)
        return frozenset({frozenset()}) if inner == {frozenset()} else \
            frozenset({frozenset({("when", our_formula(e.condition), inner)})})
    if isinstance(e, ForallEffect):
        inner = our_outcomes(e.effect)
        return frozenset({frozenset()}) if inner == {frozenset()} else \
            frozenset({frozenset({("forall", tuple(_name(p.name) for p in e.params), inner)})})
    raise TypeError(f"not an effect: {e!r}")


# ------------------------------------------------------------------------------ the pddl package's side
def their_formula(f) -> tuple:
    kind = type(f).__name__
    if kind == "Predicate":
        return (_name(f.name), tuple(_name(str(t.name)) for t in f.terms))
    if kind == "EqualTo":
        return ("=", (_name(str(f.left.name)), _name(str(f.right.name))))
    if kind == "Not":
        return ("not", their_formula(f.argument))
    if kind in ("And", "Or"):
        return _junction(kind.lower(), map(their_formula, f.operands))
    if kind == "Imply":
        return ("imply", their_formula(f.operands[0]), their_formula(f.operands[1]))
    if kind in ("ForallCondition", "ExistsCondition"):
        return (kind[:-9].lower(), tuple(_name(v.name) for v in f.variables), their_formula(f.condition))
    raise TypeError(f"pddl package: unexpected formula {kind}: {f}")


def their_outcomes(e) -> Outcomes:
    kind = type(e).__name__
    if kind == "Predicate" or kind == "Not" and type(e.argument).__name__ == "Predicate":
        positive = kind == "Predicate"
        return frozenset({frozenset({("lit", positive, their_formula(e if positive else e.argument))})})
    if kind == "And":
        return _combine([their_outcomes(x) for x in e.operands])
    if kind == "OneOf":
        return frozenset().union(*(their_outcomes(x) for x in e.operands))
    if kind == "When":
        return frozenset({frozenset({("when", their_formula(e.condition), their_outcomes(e.effect))})})
    if kind == "Forall":
        return frozenset({frozenset({("forall", tuple(_name(v.name) for v in e.variables), their_outcomes(e.effect))})})
    raise TypeError(f"pddl package: unexpected effect {kind}: {e}")


def compare_fond(domain: Domain, fond_domain_file: str | Path) -> list[str]:
    """Differences between our PPDDL ``domain``'s outcome sets and what the ``pddl`` package reads
    from its FOND export (an empty list: they agree, action by action)."""
    import pddl
    theirs = {a.name.lower(): a for a in pddl.parse_domain(str(fond_domain_file)).actions}
    problems = []
    for a in domain.actions:
        t = theirs.pop(a.name.lower(), None)
        if t is None:
            problems.append(f"{a.name}: missing")
            continue
        if [_name(p.name) for p in a.parameters] != [_name(v.name) for v in t.parameters]:
            problems.append(f"{a.name}: parameters differ")
        if our_outcomes(a.effect) != their_outcomes(t.effect):
            problems.append(f"{a.name}: outcome sets differ")
        if our_formula(a.precondition) != their_formula(t.precondition) and a.precondition != And(()):
            problems.append(f"{a.name}: preconditions differ")
    problems += [f"{name}: an action ours does not have" for name in theirs]
    return problems
