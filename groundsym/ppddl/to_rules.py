"""PPDDL -> NID rules: the rules of a domain (docs/ppddl.md); :mod:`.from_rules` writes them.

:func:`domain_to_rules` reads the conjunctive subset: preconditions that are conjunctions of
literals (plus the injectivity, uniqueness and exclusion conjuncts :mod:`.from_rules` writes, which
are implied by the rule-set semantics), effects that are literals, ``and`` and at most one
``probabilistic`` over conjunctions of literals. Mass left unassigned is the noise outcome;
write ``p (and)`` for a no-change outcome. A branch ``(noise-happened)``, or an effect that is
``(noise-happened)`` alone (a rule with no outcomes, exported pessimistically), is noise too.
Reward effects are dropped (rewards are modelled apart). So export -> parse -> the same rules,
and a hand-written reference domain gives PRADA its true rules.
"""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction
from itertools import product
from typing import Mapping, Sequence

from ..errors import UserError
from ..logic import Atom, Literal
from ..rules.model import DefaultRule, Derived, Outcome, Rule, RuleSet
from .ast import (Action, And, AndEffect, Domain, Effect, Exists, ForallEffect, Formula, Not, Probabilistic, RewardEffect,
                  When)
from .coincide import coinciding_variants
from .compare import context_key
from .rule_actions import NOISE_PREDICATE, RULE_NAME, conjuncts, primitive_of, unique_refs


def _reward_only(e: Effect) -> bool:
    """Reward effects, possibly under ``when``/``forall`` (the exported reward model)."""
    if isinstance(e, RewardEffect):
        return True
    if isinstance(e, (When, ForallEffect)):
        return _reward_only(e.effect)
    return isinstance(e, AndEffect) and all(_reward_only(x) for x in e.effects)


def _flat_effects(e: Effect) -> list[Effect]:
    return [y for x in e.effects for y in _flat_effects(x)] if isinstance(e, AndEffect) else [e]


def _literals_of(e: Effect, where: str) -> list[Literal]:
    if isinstance(e, Literal):
        return [e]
    if isinstance(e, AndEffect):
        return [l for x in e.effects for l in _literals_of(x, where)]
    if _reward_only(e):
        return []
    what = "when" if isinstance(e, When) else "forall" if isinstance(e, ForallEffect) else \
        "probabilistic" if isinstance(e, Probabilistic) else type(e).__name__
    raise UserError(f"{where}: effect {what} is outside the rule subset here (only literals, and, one "
                    "probabilistic; when inside probabilistic is read as cases)")


def _split_exclusions(action: Action) -> tuple[list[Formula], list[Formula]]:
    """(the precondition's conjuncts, the exclusion group): a rule action's trailing ``(and ...)``
    conjunct lists the other rules that must not cover (what :meth:`.from_rules.RulesWriter.action`
    writes)."""
    pre = action.precondition
    args = list(pre.args) if isinstance(pre, And) else [pre]
    if RULE_NAME.match(action.name) and args and isinstance(args[-1], And):
        return [g for x in args[:-1] for g in conjuncts(x)], list(args[-1].args)
    return conjuncts(pre), []


def action_to_rule(action: Action, domain_name: str = "domain") -> Rule:
    """The one NID rule of an action in the rule subset (see :func:`action_to_rules` for actions
    whose conditional effects make several)."""
    rules = action_to_rules(action, domain_name)
    if len(rules) != 1:
        raise UserError(f"{domain_name}: action {action.name}: its conditional effects make {len(rules)} rules")
    return rules[0]


def _context_of(action: Action, where: str) -> list[Literal]:
    """The precondition's literals (the implied injectivity, uniqueness and exclusion conjuncts dropped)."""
    names = [p.name for p in action.parameters]
    context: list[Literal] = []
    for c in _split_exclusions(action)[0]:
        derived = _derived_literal(c)
        if derived is not None:
            context.append(derived)
        elif isinstance(c, Atom) and c.predicate != "=":
            context.append(Literal(c, True))
        elif isinstance(c, Not) and isinstance(c.arg, Atom) and c.arg.predicate != "=":
            if c.arg.predicate != NOISE_PREDICATE:
                context.append(Literal(c.arg, False))
        elif isinstance(c, Not) and isinstance(c.arg, Atom):
            continue                          # (not (= ?a ?b)): bindings are injective anyway
        elif unique_refs(c, names) or (isinstance(c, Not) and isinstance(c.arg, (And, Exists))):
            continue                          # uniqueness / exclusion: implied by the rule-set semantics
        else:
            raise UserError(f"{where}: precondition is outside the rule subset (a conjunction of literals)")
    return context


def _derived_literal(c: Formula) -> Literal | None:
    """``(not (exists (?derived-z1) (on ?x ?derived-z1)))`` as written by
    :meth:`.from_rules.RulesWriter.literal`, read back
    as ``(no-on-1 ?x)`` (``(exists ...)``: its negation); None for any other formula. The name is
    the one :meth:`Derived.for_predicates` gives, so :func:`domain_to_rules` finds the definition."""
    positive = isinstance(c, Not)
    e = c.arg if positive else c
    if not isinstance(e, Exists) or not isinstance(e.body, Atom):
        return None
    zs = {t.name for t in e.params}
    if not all(z.startswith("?derived-z") for z in zs):
        return None
    atom = e.body
    keep = tuple(i for i, a in enumerate(atom.args) if a not in zs)
    d = next((d for d in Derived.for_predicates({atom.predicate: atom.arity}) if d.keep == keep), None)
    if d is None:
        return None
    return Literal(Atom(d.name, tuple(atom.args[i] for i in keep)), positive)


def _subset_rule(action: Action, where: str, context: list[Literal]) -> Rule:
    """The rule of an effect in the plain subset (literals, and, one probabilistic), as it was
    always read: a probabilistic block's unassigned mass is the rule's noise."""
    prim, n = primitive_of(action)
    names = [p.name for p in action.parameters]
    fixed: list[Literal] = []
    prob_blocks: list[Probabilistic] = []
    for e in _flat_effects(action.effect):
        if isinstance(e, Probabilistic):
            prob_blocks.append(e)
        else:
            fixed += _literals_of(e, where)
    if len(prob_blocks) > 1:
        raise UserError(f"{where}: more than one probabilistic block is outside the rule subset")
    outcomes: list[Outcome] = []
    probs: list[float] = []
    noise = Fraction(0)
    if prob_blocks:
        for p, e in prob_blocks[0].branches:
            lits = _literals_of(e, where)
            if lits == [Literal(Atom(NOISE_PREDICATE))]:
                noise += p
                continue
            outcomes.append(Outcome(_deletes_first(fixed + lits)))
            probs.append(float(p))
        rest = prob_blocks[0].rest
        if rest > 0 and fixed:
            outcomes.append(Outcome(_deletes_first(fixed)))
            probs.append(float(rest))
        else:
            noise += rest
    elif fixed == [Literal(Atom(NOISE_PREDICATE))]:
        noise = Fraction(1)                   # a rule that is all noise, exported pessimistically
    else:
        outcomes.append(Outcome(_deletes_first(fixed)))
        probs.append(1.0)
    action_atom = Atom(prim, tuple(names[:n]))
    try:
        return Rule(action_atom, tuple(context), tuple(outcomes), tuple(probs), float(noise))
    except ValueError as exc:
        raise UserError(f"{where}: {exc}") from None


def _deletes_first(changes: Sequence[Literal]) -> tuple[Literal, ...]:
    """PPDDL applies deletes before adds: an atom an outcome both adds and deletes ends true
    (``(put-on-block b1 b1)`` adds and deletes ``(clear b1)``)."""
    added = {l.atom for l in changes if l.positive}
    return tuple(l for l in changes if l.positive or l.atom not in added)


def action_to_rules(action: Action, domain_name: str = "domain") -> list[Rule]:
    """The NID rules of a PPDDL action.

    Effects in the plain subset give one rule (:func:`_subset_rule`). Effects with ``when`` whose
    conditions are conjunctions of literals, several (or nested) ``probabilistic`` blocks, and
    ``when`` inside ``probabilistic`` give one rule per truth assignment of the atoms the
    conditions test (those the precondition does not already fix): the assignment joins the
    context, each ``when`` is resolved under it, and the effect's outcome distribution (the
    product of its independent blocks, deletes before adds, unassigned mass = no change) becomes
    the rule's outcomes, exactly, with no noise. ``(probabilistic 2/5 (when (no-detonated ?b) e))``
    becomes two rules, one with ``(no-detonated ?b)`` in the context. Anything else (a ``forall``
    effect, a condition with ``or`` or a quantifier) is refused naming the construct and the action.
    """
    where = f"{domain_name}: action {action.name}"
    context = _context_of(action, where)
    if not _needs_cases(action.effect):
        try:
            return [_subset_rule(action, where, context)]
        except UserError:
            pass                                  # several probabilistic blocks: read as cases below
    conditions = _when_conditions(action.effect, where)
    fixed = {l.atom: l.positive for l in context}
    tested = sorted({l.atom for c in conditions for l in c if l.atom not in fixed})
    if len(tested) > 8:
        raise UserError(f"{where}: its when conditions test {len(tested)} atoms (more than 8): too many rules")
    prim, n = primitive_of(action)
    names = [p.name for p in action.parameters]
    rules = []
    for values in product((True, False), repeat=len(tested)):
        truth = {**fixed, **dict(zip(tested, values))}
        dist = _outcome_distribution(action.effect, truth, where)
        ctx = tuple(context) + tuple(Literal(a, v) for a, v in zip(tested, values))
        outcomes = tuple(Outcome(tuple(ch)) for ch in dist)
        try:
            rules.append(Rule(Atom(prim, tuple(names[:n])), ctx, outcomes, tuple(float(p) for p in dist.values()), 0.0))
        except ValueError as exc:
            raise UserError(f"{where}: {exc}") from None
    return rules


def _needs_cases(e: Effect) -> bool:
    """True when the effect has a ``when`` (other than a reward's) or a probabilistic inside one."""
    if isinstance(e, When):
        return not _reward_only(e)
    if isinstance(e, AndEffect):
        return any(_needs_cases(x) for x in e.effects)
    if isinstance(e, Probabilistic):
        return any(_needs_cases(x) or isinstance(x, Probabilistic) for _, x in e.branches)
    return False


def _as_literal(c: Formula) -> Literal | None:
    """A formula that is one literal (not an equality) as a Literal; None otherwise."""
    if isinstance(c, Atom) and c.predicate != "=":
        return Literal(c, True)
    if isinstance(c, Not) and isinstance(c.arg, Atom) and c.arg.predicate != "=":
        return Literal(c.arg, False)
    return None


def _condition_literals(f: Formula, where: str) -> list[Literal]:
    out = []
    for c in conjuncts(f):
        lit = _as_literal(c)
        if lit is None:
            raise UserError(f"{where}: a when condition that is not a conjunction of literals is outside the "
                            f"rule subset (got {type(c).__name__.lower()})")
        out.append(lit)
    return out


def _when_conditions(e: Effect, where: str) -> list[list[Literal]]:
    if isinstance(e, When):
        return [] if _reward_only(e) else [_condition_literals(e.condition, where)] + _when_conditions(e.effect, where)
    if isinstance(e, AndEffect):
        return [c for x in e.effects for c in _when_conditions(x, where)]
    if isinstance(e, Probabilistic):
        return [c for _, x in e.branches for c in _when_conditions(x, where)]
    if isinstance(e, ForallEffect) and not _reward_only(e):
        raise UserError(f"{where}: a forall effect is outside the rule subset (NID rules change a fixed set "
                        "of atoms)")
    return []


def _outcome_distribution(e: Effect, truth: Mapping[Atom, bool], where: str) -> dict[tuple[Literal, ...], Fraction]:
    """The effect's outcomes as change lists (deletes before adds: an atom both added and deleted
    ends true) with their probabilities, ``when`` resolved by ``truth``; equal outcomes merged."""
    out: dict[tuple[Literal, ...], Fraction] = {}
    for p, adds, dels in _expand(e, truth, where):
        changes = tuple(sorted({Literal(a, True) for a in adds} | {Literal(a, False) for a in dels - adds}))
        out[changes] = out.get(changes, Fraction(0)) + p
    return {k: v for k, v in out.items() if v > 0}


def _expand(e: Effect, truth: Mapping[Atom, bool], where: str) -> list[tuple[Fraction, frozenset, frozenset]]:
    if isinstance(e, Literal):
        return [(Fraction(1), frozenset({e.atom}), frozenset())] if e.positive else \
            [(Fraction(1), frozenset(), frozenset({e.atom}))]
    if isinstance(e, AndEffect):
        out = [(Fraction(1), frozenset(), frozenset())]
        for x in e.effects:
            out = [(p * q, a | b, d | f) for p, a, d in out for q, b, f in _expand(x, truth, where)]
        return out
    if isinstance(e, Probabilistic):
        res = [(p * q, a, d) for p, sub in e.branches for q, a, d in _expand(sub, truth, where)]
        return res + ([(e.rest, frozenset(), frozenset())] if e.rest > 0 else [])
    if isinstance(e, When):
        holds = all(truth.get(l.atom, False) == l.positive for l in _condition_literals(e.condition, where))
        return _expand(e.effect, truth, where) if holds else [(Fraction(1), frozenset(), frozenset())]
    if _reward_only(e):
        return [(Fraction(1), frozenset(), frozenset())]
    raise UserError(f"{where}: a {type(e).__name__} effect is outside the rule subset")


def _excluded_context(x: Formula) -> list[Literal] | None:
    """The context of the rule an exclusion conjunct ``(not <covers>)`` excludes (after
    simplification a one-literal context's exclusion is that literal negated); None if ``x`` is
    not an exclusion."""
    if isinstance(x, Atom) and x.predicate != "=":
        return [Literal(x, False)]
    if not isinstance(x, Not):
        return None
    a = x.arg
    if isinstance(a, Atom):
        return [Literal(a, True)] if a.predicate != "=" else None
    if not isinstance(a, (And, Exists)):
        return None
    body = a.body if isinstance(a, Exists) else a
    return [lit for lit in map(_as_literal, conjuncts(body)) if lit is not None]



def _blocking_rules(domain: Domain, rules: Sequence[Rule]) -> list[Rule]:
    """Rules that an exclusion names but no action is for (rules that can never apply, which a
    simplified export leaves out), as rules whose one outcome is no change: with them the rule
    set blocks where the domain's exclusions block."""
    known = {context_key(r) for r in rules}
    out = []
    for a in domain.actions:
        conj, group = _split_exclusions(a)
        candidates = group + [c for c in conj if isinstance(c, Not) and isinstance(c.arg, (And, Exists))]
        prim, n = primitive_of(a)
        for x in candidates:
            ctx = _excluded_context(x)
            if ctx is None:
                continue
            try:
                r = Rule(Atom(prim, tuple(p.name for p in a.parameters[:n])), tuple(ctx), (Outcome(()),), (1.0,), 0.0)
            except ValueError:
                continue
            if context_key(r) not in known:
                known.add(context_key(r))
                out.append(r)
    return out


def domain_to_rules(domain: Domain, default_noise: float = 0.0) -> RuleSet:
    """The NID rules of a domain in the rule subset. With no applicable action nothing changes in
    PPDDL, so each primitive's default rule is "no change" (``default_noise`` = 0). Rules that
    only block (named by exclusions, with no action of their own) come back as no-change rules."""
    rules = [r for a in domain.actions for r in action_to_rules(a, domain.name)]
    rules += _coinciding_rules(domain)
    rules += _blocking_rules(domain, rules)
    prims = sorted({r.action.predicate for r in rules})
    named = {l.atom.predicate for r in rules for l in r.context}
    arities = {p.name: len(p.params) for p in domain.predicates}
    derived = tuple(sorted(d for d in Derived.for_predicates(arities) if d.name in named))
    return RuleSet(tuple(rules), tuple((p, DefaultRule(default_noise)) for p in prims), derived=derived)


def _coinciding_rules(domain: Domain) -> list[Rule]:
    """Rules for the moves whose arguments repeat, where the domain allows them (see
    :mod:`groundsym.ppddl.coincide`); the rule-form actions of exported domains bind injectively."""
    out = []
    for a in domain.actions:
        prim, n = primitive_of(a)
        if RULE_NAME.match(a.name):
            continue
        for variant, template in coinciding_variants(a, n, domain):
            out += [replace(r, action=Atom(prim, template)) for r in action_to_rules(variant, domain.name)]
    return out

