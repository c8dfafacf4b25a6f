"""NID rules <-> PPDDL (docs/ppddl.md).

Export (:func:`rules_to_domain`): one action ``<primitive>_r<k>`` per non-default rule. Its
parameters are the action's variables followed by the deictic references, and its precondition
states exactly when the NID rule set picks that rule:

* the context;
* injective bindings, ``(not (= ?a ?b))`` for every pair of variables (the rules' default);
* the deictic binding is unique: ``(forall (?z..) (or (not ctx[?z/?y]) (and (= ?z ?y)..) <?z not injective>))``;
* no other rule of the same primitive covers: ``(not <covers_j>)``, where ``covers_j`` is the
  same construction for rule ``j`` under ``exists``. (The set semantics: two covering rules mean
  the default rule, which is not exported; an action with no applicable PPDDL action changes
  nothing.)

The effect is ``(probabilistic p1 o1 .. pn on)``; the noise mass is left unassigned ("no change",
the default) or, with ``noise="pessimistic"``, is an outcome ``(noise-happened)`` that every
precondition forbids, so a planner avoids noisy rules.

Import (:func:`domain_to_rules`) reads back the conjunctive subset: preconditions that are
conjunctions of literals (plus the injectivity, uniqueness and exclusion conjuncts above, which
are implied by the rule-set semantics), effects that are literals, ``and`` and at most one
``probabilistic`` over conjunctions of literals. Mass left unassigned is the noise outcome;
write ``p (and)`` for a no-change outcome. A branch ``(noise-happened)``, or an effect that is
``(noise-happened)`` alone (a rule with no outcomes, exported pessimistically), is noise too.
Reward effects are dropped (rewards are modelled apart). So export -> parse -> the same rules,
and a hand-written reference domain gives PRADA its true rules.
"""

from __future__ import annotations

import re
from dataclasses import replace
from fractions import Fraction
from itertools import permutations, product
from typing import Mapping, Sequence

import numpy as np

from ..errors import UserError
from ..logic import Atom, Literal, is_variable
from ..rules.model import DefaultRule, Derived, Outcome, Rule, RuleSet
from .ast import (NO_EFFECT, OBJECT, TRUE, Action, And, AndEffect, Domain, Effect, Exists, Forall, ForallEffect, Formula,
                  Imply, Not, Or, Predicate, Probabilistic, RewardEffect, Typed, When)
from .coincide import coinciding_variants
from .simplify import FALSE, simplify

NOISE_PREDICATE = "noise-happened"
NOISE_MODES = ("no-change", "pessimistic")
_RULE_NAME = re.compile(r"^(.+)_r(\d+)$")


# ------------------------------------------------------------------------------ requirements
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


# ------------------------------------------------------------------------------ export
def probability(p: float) -> Fraction:
    """The shortest decimal that reads back as the same float (so the round trip is exact)."""
    return Fraction(np.format_float_positional(float(p), unique=True, trim="-"))


def _fresh(base: str, taken: set[str], count: int) -> list[str]:
    out = []
    i = 1
    while len(out) < count:
        name = f"?{base}{i}"
        if name not in taken:
            out.append(name)
            taken.add(name)
        i += 1
    return out


_DERIVED: dict = {}     # name -> groundsym.rules.model.Derived of the rule set rules_to_domain writes


def _lit(l: Literal) -> Formula:
    d = _DERIVED.get(l.atom.predicate)
    if d is not None:        # (no-on-1 ?x) -> (not (exists (?derived-z1) (on ?x ?derived-z1)))
        zs = [f"?derived-z{i + 1}" for i in range(d.base_arity - d.arity)]
        args, it = [], iter(zs)
        for i in range(d.base_arity):
            args.append(l.atom.args[d.keep.index(i)] if i in d.keep else next(it))
        some = Exists(tuple(Typed(z) for z in zs), Atom(d.base, tuple(args)))
        return some if not l.positive else Not(some)
    return l.atom if l.positive else Not(l.atom)


def _conj(items: Sequence[Formula]) -> Formula:
    return items[0] if len(items) == 1 else And(tuple(items))


def _distinct(a: Sequence[str], b: Sequence[str] | None = None) -> list[Formula]:
    """``(not (= u v))`` for every pair within ``a`` (and between ``a`` and ``b``)."""
    pairs = [(u, v) for i, u in enumerate(a) for v in a[i + 1:]] + [(u, v) for u in a for v in (b or ())]
    return [Not(Atom("=", (u, v))) for u, v in pairs]


def _unique(context: Sequence[Literal], action_vars: Sequence[str], deictic: Sequence[str], taken: set[str],
            injective: bool) -> Formula | None:
    """No other (injective) binding of the deictic variables satisfies the context."""
    if not deictic:
        return None
    zs = _fresh("z", taken, len(deictic))
    ren = dict(zip(deictic, zs))
    restr = [_lit(l.substitute(ren)) for l in context if set(l.atom.args) & set(deictic)]
    same = [Atom("=", (z, y)) for z, y in zip(zs, deictic)]
    clash: list[Formula] = []
    if injective:
        clash = [Atom("=", (u, v)) for i, u in enumerate(zs) for v in zs[i + 1:]]
        clash += [Atom("=", (z, x)) for z in zs for x in action_vars]
    body = Or((Not(_conj(restr)), _conj(same), *clash))
    return Forall(tuple(Typed(z) for z in zs), body)


def _covers(rule: Rule, action_vars: Sequence[str], taken: set[str], injective: bool) -> Formula:
    """A formula over ``action_vars`` that holds iff ``rule`` covers the action (a unique covering rule, docs/rules.md)."""
    ren = dict(zip(rule.action.args, action_vars))
    deictic = list(rule.deictic)
    ws = _fresh("w", taken, len(deictic))
    ren.update(zip(deictic, ws))
    ctx = [l.substitute(ren) for l in rule.context]
    parts: list[Formula] = [_lit(l) for l in ctx]
    if not ws:
        return And(tuple(parts))
    if injective:
        parts += _distinct(ws, action_vars)
    u = _unique(ctx, action_vars, ws, taken, injective)
    if u is not None:
        parts.append(u)
    return Exists(tuple(Typed(w) for w in ws), _conj(parts))


def _disjoint(rule: Rule, other: Rule) -> bool:
    """True when the contexts contradict on the action's own arguments (``(clear ?x)`` against
    ``(not (clear ?x))``): then ``other`` can never cover where ``rule`` does, and the exclusion
    conjunct is left out (shorter output, the same semantics)."""
    ren = dict(zip(other.action.args, rule.action.args))
    mine = set(rule.context)
    own = set(rule.action.args)
    for l in other.context:
        if all(a in ren or not is_variable(a) for a in l.atom.args):
            flipped = l.substitute(ren).negate()
            if flipped in mine and all(a in own or not is_variable(a) for a in flipped.atom.args):
                return True
    return False


def _effect(changes: Sequence[Literal]) -> Effect:
    lits = tuple(sorted(changes))
    return lits[0] if len(lits) == 1 else AndEffect(lits)


def rounded_probs(probs: Sequence[float], decimals: int | None) -> list[Fraction]:
    """Outcome probabilities with at most ``decimals`` decimals (None: exact), summing to at most 1
    (float rounding or the rounding here taken off the largest); the rest is read as no change."""
    if decimals is None:
        fr = [probability(p) for p in probs]
    else:
        fr = [Fraction(round(float(p) * 10 ** decimals), 10 ** decimals) for p in probs]
    excess = sum(fr, Fraction(0)) - 1
    if excess > 0:
        i = max(range(len(fr)), key=lambda j: fr[j])
        fr[i] -= excess
    return fr


def _exclusions(rule: Rule, others: Sequence[Rule], action_vars: Sequence[str], taken: set[str],
                injective: bool, simple: bool) -> list[Formula] | None:
    """``(not <rule j covers>)`` for every other rule that can cover together with ``rule``; None
    when one of them always covers (then ``rule`` can never be the unique covering rule)."""
    out: list[Formula] = []
    for other in others:
        if _disjoint(rule, other):
            continue
        x: Formula = Not(_covers(other, action_vars, set(taken), injective))
        if simple:
            x = simplify(x)
            if x == FALSE:
                return None
            if x == TRUE or x in out:
                continue
        out.append(x)
    return out


def rule_to_action(rule: Rule, k: int, others: Sequence[Rule], noise: str = "no-change",
                   injective: bool = True, decimals: int | None = None, simple: bool = False) -> Action | None:
    """The PPDDL action of ``rule`` (the ``k``-th of its primitive); ``others``: its primitive's other rules.

    ``decimals``: round the probabilities (None: exact). ``simple``: simplify the precondition
    (:mod:`.simplify`), put the exclusions in one trailing ``(and ...)`` group, and return None for
    a rule that can never apply (its context contradicts itself, or another rule always covers)."""
    if noise not in NOISE_MODES:
        raise UserError(f"--noise: expected one of {', '.join(NOISE_MODES)}, got {noise!r}")
    variables = list(rule.variables)
    action_vars = list(rule.action.args)
    deictic = list(rule.deictic)
    taken = set(variables)
    pre: list[Formula] = [_lit(l) for l in rule.context]
    if injective:
        pre += _distinct(variables)
    u = _unique(rule.context, action_vars, deictic, taken, injective)
    if u is not None:
        pre.append(u)
    excl = _exclusions(rule, others, action_vars, taken, injective, simple)
    if excl is None:
        return None
    guard = [Not(Atom(NOISE_PREDICATE))] if noise == "pessimistic" else []
    if simple:
        main = simplify(And(tuple(pre + guard)))
        if main == FALSE:
            return None
        parts = list(main.args) if isinstance(main, And) else [main]
        precondition: Formula = And(tuple(parts + ([And(tuple(excl))] if excl else [])))
    else:
        pre += excl + guard
        precondition = _conj(pre) if pre else TRUE
    probs = rounded_probs(rule.probs, decimals)
    branches: list[tuple[Fraction, Effect]] = [(p, _effect(o.changes)) for p, o in zip(probs, rule.outcomes)
                                               if p > 0 or decimals is None]
    rest = 1 - sum((p for p, _ in branches), Fraction(0))
    if noise == "pessimistic" and rest > 0:
        branches.append((rest, Literal(Atom(NOISE_PREDICATE))))
    if len(branches) == 1 and branches[0][0] == 1:
        effect = branches[0][1]
    else:
        effect = Probabilistic(tuple(branches)) if branches else NO_EFFECT
    refs = ", ".join(deictic)
    what = (f"; {refs} {'is the one object' if len(deictic) == 1 else 'are the objects'} the context names"
            if refs else "")
    shown = f"{float(rest):.4g}" if decimals is not None else f"{float(rule.noise):.4g}"
    comment = (f"rule {k} of {rule.action}{what}; noise {shown}"
               + (" (no change)" if noise == "no-change" else " -> (noise-happened)"))
    return Action(f"{rule.action.predicate}_r{k}", tuple(Typed(v) for v in variables), precondition, effect, comment)


def rules_to_domain(rules: RuleSet, predicates: Mapping[str, int], name: str = "learned",
                    noise: str = "no-change", comments: Mapping[str, str] | None = None,
                    comment: str = "", decimals: int | None = None, simple: bool = False,
                    dropped: list[str] | None = None, drop_no_change: bool = False) -> Domain:
    """A PPDDL domain whose actions are ``rules``' non-default rules (see the module docstring).

    ``decimals`` and ``simple``: see :func:`rule_to_action`; the names of rules that can never
    apply (left out) are appended to ``dropped``. ``drop_no_change``: leave out actions whose
    effect is empty too (the same as no action; plado fails on an empty effect); a reader gets
    them back from the other actions' exclusions (:func:`domain_to_rules`)."""
    by_prim: dict[str, list[Rule]] = {}
    for r in rules.rules:
        by_prim.setdefault(r.action.predicate, []).append(r)
    actions = []
    _DERIVED.clear()
    _DERIVED.update({d.name: d for d in getattr(rules, "derived", ())})   # written as (not (exists ...))
    try:
        for prim, rs in by_prim.items():
            for k, r in enumerate(rs, 1):
                a = rule_to_action(r, k, [o for o in rs if o is not r], noise, rules.injective, decimals, simple)
                if a is not None and not (drop_no_change and a.effect == NO_EFFECT):
                    actions.append(a)
                elif dropped is not None:
                    dropped.append(f"{prim}_r{k}")
    finally:
        _DERIVED.clear()
    derived = {d.name for d in getattr(rules, "derived", ())}      # written out, not declared
    preds = [Predicate(p, tuple(Typed(f"?x{i + 1}") for i in range(n)), (comments or {}).get(p, ""))
             for p, n in sorted(predicates.items()) if p not in derived]
    if noise == "pessimistic":
        preds.append(Predicate(NOISE_PREDICATE, (), "a rule's noise outcome happened: a dead end"))
    domain = Domain(name, (), (), (), tuple(preds), tuple(actions), comment)
    return Domain(name, requirements(domain), (), (), domain.predicates, domain.actions, comment)


# ------------------------------------------------------------------------------ import
def _conjuncts(f: Formula) -> list[Formula]:
    return [g for x in f.args for g in _conjuncts(x)] if isinstance(f, And) else [f]


def _unique_refs(f: Formula, params: Sequence[str]) -> list[str]:
    """The parameters a uniqueness conjunct ``(forall (?z..) (or .. (= ?z ?y) ..))`` pins down."""
    if not isinstance(f, Forall) or not isinstance(f.body, Or):
        return []
    zs = {p.name for p in f.params}
    for d in f.body.args:
        eqs = _conjuncts(d)
        if eqs and all(isinstance(e, Atom) and e.predicate == "=" and e.args[0] in zs and e.args[1] in params
                       for e in eqs):
            return [e.args[1] for e in eqs]  # type: ignore[union-attr]
    return []


def primitive_of(action: Action) -> tuple[str, int]:
    """(primitive name, its arity) that a PPDDL action runs: ``puton_r2 ?x ?y`` with deictic ``?y``
    runs ``puton`` on ``?x``; an ordinary action runs itself on all its parameters."""
    names = [p.name for p in action.parameters]
    m = _RULE_NAME.match(action.name)
    if not m:
        return action.name, len(names)
    refs = {y for c in _conjuncts(action.precondition) for y in _unique_refs(c, names)}
    n = next((i for i, v in enumerate(names) if v in refs), len(names))
    return m.group(1), n


def _is_noise_guard(f: Formula) -> bool:
    return isinstance(f, Not) and f.arg == Atom(NOISE_PREDICATE)


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
    conjunct lists the other rules that must not cover (what ``rule_to_action`` writes)."""
    pre = action.precondition
    args = list(pre.args) if isinstance(pre, And) else [pre]
    if _RULE_NAME.match(action.name) and args and isinstance(args[-1], And):
        return [g for x in args[:-1] for g in _conjuncts(x)], list(args[-1].args)
    return _conjuncts(pre), []


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
        elif _unique_refs(c, names) or (isinstance(c, Not) and isinstance(c.arg, (And, Exists))):
            continue                          # uniqueness / exclusion: implied by the rule-set semantics
        else:
            raise UserError(f"{where}: precondition is outside the rule subset (a conjunction of literals)")
    return context


def _derived_literal(c: Formula) -> Literal | None:
    """``(not (exists (?derived-z1) (on ?x ?derived-z1)))`` as written by :func:`_lit`, read back
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
    for c in _conjuncts(f):
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
    return [lit for lit in map(_as_literal, _conjuncts(body)) if lit is not None]


def context_key(rule: Rule) -> tuple:
    """The rule's primitive and context up to the names of its variables (deictic references in
    every order; rules have few)."""
    ren = {v: f"?a{i}" for i, v in enumerate(rule.action.args)}
    best = None
    for perm in permutations(range(len(rule.deictic))):
        ren.update({y: f"?d{perm[j]}" for j, y in enumerate(rule.deictic)})
        key = tuple(sorted(str(l.substitute(ren)) for l in rule.context))
        best = key if best is None or key < best else best
    return rule.action.predicate, len(rule.action.args), best


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
        if _RULE_NAME.match(a.name):
            continue
        for variant, template in coinciding_variants(a, n, domain):
            out += [replace(r, action=Atom(prim, template)) for r in action_to_rules(variant, domain.name)]
    return out


def rules_equal(a: Rule, b: Rule, tol: float = 1e-9) -> bool:
    """Same action, context, outcomes and probabilities; noise equal within ``tol`` (a PPDDL file
    stores the outcome probabilities exactly and the noise as the rest of the mass)."""
    return (a.action == b.action and a.context == b.context and a.outcomes == b.outcomes
            and a.probs == b.probs and abs(a.noise - b.noise) <= tol)


def rules_close(a: Rule, b: Rule, tol: float) -> bool:
    """Same action and context; every outcome's probability and the noise within ``tol`` (an
    outcome missing on one side counts as probability 0): a rule and its rounded export."""
    pa = dict(zip(a.outcomes, a.probs))
    pb = dict(zip(b.outcomes, b.probs))
    return (a.action == b.action and a.context == b.context and abs(a.noise - b.noise) <= tol
            and all(abs(pa.get(o, 0.0) - pb.get(o, 0.0)) <= tol for o in {*pa, *pb}))
