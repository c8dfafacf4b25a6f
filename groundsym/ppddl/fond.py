"""A PPDDL domain as FOND PDDL: every ``probabilistic`` block becomes ``oneof`` (the all-outcomes view).

Why: fully observable non-deterministic planners (PRP, MyND, FOND-SAT) and the ``pddl`` package
read ``oneof`` but not ``probabilistic`` (Muise, McIlraith and Beck 2012 for the semantics). The
branches keep their joint changes; the mass a block leaves unassigned (a rule's noise, "no
change") is the outcome ``(and)``, since a FOND planner must plan for it too. Rewards have no place
in FOND and are left out; the goal stays.
"""

from __future__ import annotations

from dataclasses import replace

from ..logic import Literal
from .ast import (NO_EFFECT, AndEffect, Domain, Effect, ForallEffect, Probabilistic, Problem, RewardEffect, When, _domain_sexp,
                  layout, to_sexp, typed_list)
from .requirements import requirements

NON_DETERMINISTIC = ":non-deterministic"


def effect_sexp(e: Effect) -> object:
    """``e`` (without rewards) as s-expression lists with ``oneof`` for ``probabilistic``."""
    if isinstance(e, Literal):
        return str(e)
    if isinstance(e, AndEffect):
        parts = [effect_sexp(x) for x in e.effects]
        return parts[0] if len(parts) == 1 else ["and", *parts]
    if isinstance(e, Probabilistic):
        branches = [effect_sexp(x) for p, x in e.branches if p > 0]
        if e.rest > 0:
            branches.append(["and"])
        unique = [b for i, b in enumerate(branches) if b not in branches[:i]]
        return unique[0] if len(unique) == 1 else ["oneof", *unique]
    if isinstance(e, When):
        return ["when", to_sexp(e.condition), effect_sexp(e.effect)]
    if isinstance(e, ForallEffect):
        return ["forall", typed_list(e.params), effect_sexp(e.effect)]
    raise TypeError(f"not an effect: {e!r}")


def fond_domain_text(domain: Domain) -> str:
    """The FOND PDDL text of ``domain`` (module docstring)."""
    bare = replace(domain, actions=tuple(replace(a, effect=_without_rewards(a.effect)) for a in domain.actions))
    reqs = [r for r in requirements(bare) if r not in (":probabilistic-effects", ":rewards")]
    if any(isinstance(x, Probabilistic) for a in bare.actions for x in _nodes(a.effect)):
        reqs.append(NON_DETERMINISTIC)
    sexp = _domain_sexp(replace(bare, requirements=tuple(reqs), actions=()))
    for a in bare.actions:
        act: list = [":action", a.name, ":parameters", typed_list(a.parameters),
                     ":precondition", to_sexp(a.precondition), ":effect", effect_sexp(a.effect)]
        sexp.append(act)
    return layout(sexp) + "\n"


def fond_problem_text(problem: Problem) -> str:
    """The problem without its reward metric (FOND plans reach the goal; they count no reward)."""
    return str(replace(problem, goal_reward=None, metric=None, requirements=()))


def _without_rewards(e: Effect) -> Effect:
    """``e`` with its reward effects, and what only held them (``forall .. when .. increase``), left out."""
    if isinstance(e, RewardEffect):
        return NO_EFFECT
    if isinstance(e, AndEffect):
        kept = tuple(x for x in map(_without_rewards, e.effects) if x != NO_EFFECT)
        return kept[0] if len(kept) == 1 else AndEffect(kept)
    if isinstance(e, Probabilistic):
        return Probabilistic(tuple((p, _without_rewards(x)) for p, x in e.branches))
    if isinstance(e, (When, ForallEffect)):
        inner = _without_rewards(e.effect)
        return NO_EFFECT if inner == NO_EFFECT else replace(e, effect=inner)
    return e


def _nodes(e: Effect):
    yield e
    for x in (e.effects if isinstance(e, AndEffect) else [b for _, b in e.branches] if isinstance(e, Probabilistic)
              else [e.effect] if isinstance(e, (When, ForallEffect)) else []):
        yield from _nodes(x)
