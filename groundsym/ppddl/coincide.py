"""PPDDL actions whose parameters name the same object: one variant per way parameters coincide.

Why: a PPDDL action's parameters may be bound to the same object unless the precondition says
``(not (= ?x ?y))``. The IPPC 2006 blocksworld lets ``(put-on-block b1 b1)`` run, and it has an
effect there. NID rules bind their variables injectively, so the rules read from
``(put-on-block ?b1 ?b2)`` never cover it. Each way of merging parameters (a set partition of
them) gives a variant action: one parameter per block, the others renamed to it, equalities decided
(``(not (= ?b1 ?b1))`` makes the variant impossible), and its rules keep the action's arity with a
repeated variable (``(put-on-block ?b1 ?b1)``), which covers exactly the moves with that repetition.
"""

from __future__ import annotations

from typing import Iterator, Mapping, Sequence

from ..logic import Literal
from .ast import NO_EFFECT, TRUE, Action, AndEffect, Domain, Effect, ForallEffect, Probabilistic, Typed, When
from .simplify import FALSE, simplify
from .ground import substitute


def partitions(items: Sequence[int]) -> Iterator[list[list[int]]]:
    """Every set partition of ``items`` (blocks in order of their first element)."""
    if not items:
        yield []
        return
    first, rest = items[0], items[1:]
    for part in partitions(rest):
        yield [[first], *part]
        for k in range(len(part)):
            yield [*part[:k], [first, *part[k]], *part[k + 1:]]


def coinciding_variants(action: Action, n: int, domain: Domain) -> list[tuple[Action, tuple[str, ...]]]:
    """(variant action, the primitive's argument template with repeated variables) for every way
    two or more of the first ``n`` parameters can name one object; variants whose precondition is
    then false (an inequality between them) or whose types cannot meet are left out."""
    parents = {t.name: t.type for t in domain.types}
    params = list(action.parameters)
    out = []
    for part in partitions(list(range(n))):
        if len(part) == n:
            continue                                    # all distinct: the action itself
        ren: dict[str, str] = {}
        types: dict[str, str] = {}
        for block in part:
            t = _meet([params[i].type for i in block], parents)
            if t is None:
                break
            head = params[min(block)].name
            types[head] = t
            ren.update({params[i].name: head for i in block})
        else:
            pre = simplify(substitute(action.precondition, ren))
            if pre == FALSE:
                continue
            kept = tuple(Typed(p.name, types.get(p.name, p.type)) for p in params if ren.get(p.name, p.name) == p.name)
            variant = Action(action.name, kept, pre, _effect(action.effect, ren), action.comment)
            out.append((variant, tuple(ren[p.name] for p in params[:n])))
    return out


def _meet(types: Sequence[str], parents: Mapping[str, str]) -> str | None:
    """The one of ``types`` that is a subtype of all the others (objects of it can fill every
    parameter), or None."""
    for t in types:
        if all(_is_a(t, u, parents) for u in types):
            return t
    return None


def _is_a(t: str, ancestor: str, parents: Mapping[str, str]) -> bool:
    seen = set()
    while t not in seen:
        if t == ancestor or ancestor == "object":
            return True
        seen.add(t)
        t = parents.get(t, "object")
    return False


def _effect(e: Effect, ren: Mapping[str, str]) -> Effect:
    if isinstance(e, Literal):
        return e.substitute(ren)
    if isinstance(e, AndEffect):
        return AndEffect(tuple(_effect(x, ren) for x in e.effects))
    if isinstance(e, Probabilistic):
        return Probabilistic(tuple((p, _effect(x, ren)) for p, x in e.branches))
    if isinstance(e, When):
        cond = simplify(substitute(e.condition, ren))
        if cond == FALSE:
            return NO_EFFECT
        return _effect(e.effect, ren) if cond == TRUE else When(cond, _effect(e.effect, ren))
    if isinstance(e, ForallEffect):
        inner = {k: v for k, v in ren.items() if k not in {p.name for p in e.params}}
        return ForallEffect(e.params, _effect(e.effect, inner))
    return e
