"""NID rules -> PPDDL: a rule set as a domain (docs/ppddl.md); :mod:`.to_rules` reads it back.

:class:`RulesWriter` writes one action ``<primitive>_r<k>`` per non-default rule. Its
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

A derived predicate of the rule set (``no-on-1``) is written out over its base predicate as
``(not (exists ...))`` and never declared; the writer knows the rule set's derived predicates, as
unified-planning's ``PDDLWriter`` keeps its renamings on the writer. With ``axioms`` it is declared
once instead, ``(:derived (no-on-1 ?x1) (not (exists ...)))`` (PDDL 2.2), and named where used;
our parser puts the body back in place (:mod:`.axioms`), so both read as the same rules.
"""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction
from typing import Mapping, Sequence

import numpy as np

from ..errors import UserError
from ..logic import Atom, Literal, is_variable
from ..rules.model import Derived, Rule, RuleSet
from .ast import (NO_EFFECT, TRUE, Action, And, AndEffect, Axiom, Domain, Effect, Exists, Forall, Formula, Not, Or,
                  Predicate, Probabilistic, Typed)
from .requirements import requirements
from .rule_actions import NOISE_MODES, NOISE_PREDICATE, rule_action_name
from .simplify import FALSE, simplify


def probability(p: float) -> Fraction:
    """The shortest decimal that reads back as the same float (so the round trip is exact)."""
    return Fraction(np.format_float_positional(float(p), unique=True, trim="-"))


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


class RulesWriter:
    """Writes one rule set as PPDDL (see the module docstring).

    ``noise``: one of :data:`~.rule_actions.NOISE_MODES`. ``decimals``: round the probabilities
    (None: exact). ``simple``: simplify preconditions (:mod:`.simplify`), put the exclusions in one
    trailing ``(and ...)`` group, and leave out a rule that can never apply (its context
    contradicts itself, or another rule always covers). ``drop_no_change``: leave out actions whose
    effect is empty too (the same as no action; plado fails on an empty effect); a reader gets
    them back from the other actions' exclusions (:func:`.to_rules.domain_to_rules`).
    """

    def __init__(self, rules: RuleSet, noise: str = "no-change", decimals: int | None = None,
                 simple: bool = False, drop_no_change: bool = False, axioms: bool = False) -> None:
        if noise not in NOISE_MODES:
            raise UserError(f"--noise: expected one of {', '.join(NOISE_MODES)}, got {noise!r}")
        self.rules = rules
        self.noise = noise
        self.decimals = decimals
        self.simple = simple
        self.drop_no_change = drop_no_change
        self.injective = rules.injective
        self.derived = {d.name: d for d in rules.derived}     # written as (not (exists ...))
        self.axioms = axioms      # or declared once, (:derived (no-on-1 ?x1) (not (exists ...)))

    # -------------------------------------------------------------------------- the domain
    def domain(self, predicates: Mapping[str, int], name: str = "learned",
               comments: Mapping[str, str] | None = None, comment: str = "") -> tuple[Domain, tuple[str, ...]]:
        """The domain whose actions are the rule set's non-default rules, and the names of the
        rules left out (see the class docstring). ``comments``: a comment per predicate."""
        by_prim: dict[str, list[Rule]] = {}
        for r in self.rules.rules:
            by_prim.setdefault(r.action.predicate, []).append(r)
        actions = []
        dropped = []
        for prim, rs in by_prim.items():
            for k, r in enumerate(rs, 1):
                a = self.action(r, k, [o for o in rs if o is not r])
                if a is not None and not (self.drop_no_change and a.effect == NO_EFFECT):
                    actions.append(a)
                else:
                    dropped.append(rule_action_name(prim, k))
        declared = [p for p in sorted(predicates) if p not in self.derived or self.axioms]
        preds = [Predicate(p, tuple(Typed(f"?x{i + 1}") for i in range(predicates[p])),
                           (comments or {}).get(p, "") or self._derived_comment(p)) for p in declared]
        if self.noise == "pessimistic":
            preds.append(Predicate(NOISE_PREDICATE, (), "a rule's noise outcome happened: a dead end"))
        axioms = tuple(self.axiom(self.derived[p]) for p in declared if p in self.derived)
        domain = Domain(name, (), (), (), tuple(preds), tuple(actions), comment, axioms=axioms)
        return replace(domain, requirements=requirements(domain)), tuple(dropped)

    def _derived_comment(self, name: str) -> str:
        d = self.derived.get(name)
        if d is None:
            return ""
        shown = " ".join(f"?x{d.keep.index(i) + 1}" if i in d.keep else "_" for i in range(d.base_arity))
        return f"derived: no ({d.base}{' ' + shown if shown else ''}) atom holds"

    def axiom(self, d: Derived) -> Axiom:
        """``(:derived (name ?x1..) <written out>)``: the derived predicate declared once."""
        head = Atom(d.name, tuple(f"?x{i + 1}" for i in range(d.arity)))
        return Axiom(head, self._written_out(Literal(head)))

    # -------------------------------------------------------------------------- one rule
    def action(self, rule: Rule, k: int, others: Sequence[Rule]) -> Action | None:
        """The PPDDL action of ``rule`` (the ``k``-th of its primitive); ``others``: its primitive's
        other rules. None when ``simple`` and the rule can never apply."""
        variables = list(rule.variables)
        action_vars = list(rule.action.args)
        deictic = list(rule.deictic)
        taken = set(variables)
        pre: list[Formula] = [self.literal(l) for l in rule.context]
        if self.injective:
            pre += _distinct(variables)
        u = self._unique(rule.context, action_vars, deictic, taken)
        if u is not None:
            pre.append(u)
        excl = self._exclusions(rule, others, action_vars, taken)
        if excl is None:
            return None
        guard = [Not(Atom(NOISE_PREDICATE))] if self.noise == "pessimistic" else []
        if self.simple:
            main = simplify(And(tuple(pre + guard)))
            if main == FALSE:
                return None
            parts = list(main.args) if isinstance(main, And) else [main]
            precondition: Formula = And(tuple(parts + ([And(tuple(excl))] if excl else [])))
        else:
            pre += excl + guard
            precondition = _conj(pre) if pre else TRUE
        effect, rest = self._effect(rule)
        refs = ", ".join(deictic)
        what = (f"; {refs} {'is the one object' if len(deictic) == 1 else 'are the objects'} the context names"
                if refs else "")
        shown = f"{float(rest):.4g}" if self.decimals is not None else f"{float(rule.noise):.4g}"
        comment = (f"rule {k} of {rule.action}{what}; noise {shown}"
                   + (" (no change)" if self.noise == "no-change" else " -> (noise-happened)"))
        return Action(rule_action_name(rule.action.predicate, k), tuple(Typed(v) for v in variables), precondition,
                      effect, comment)

    def _effect(self, rule: Rule) -> tuple[Effect, Fraction]:
        """The rule's outcomes as an effect, and the mass they leave unassigned (the noise)."""
        probs = rounded_probs(rule.probs, self.decimals)
        branches: list[tuple[Fraction, Effect]] = [(p, _changes(o.changes)) for p, o in zip(probs, rule.outcomes)
                                                   if p > 0 or self.decimals is None]
        rest = 1 - sum((p for p, _ in branches), Fraction(0))
        if self.noise == "pessimistic" and rest > 0:
            branches.append((rest, Literal(Atom(NOISE_PREDICATE))))
        if len(branches) == 1 and branches[0][0] == 1:
            return branches[0][1], rest
        return (Probabilistic(tuple(branches)) if branches else NO_EFFECT), rest

    def literal(self, l: Literal) -> Formula:
        """A context literal as a formula; a derived predicate written out over its base (or, with
        ``axioms``, left as its atom: the domain declares it)."""
        if l.atom.predicate in self.derived and not self.axioms:
            return self._written_out(l)
        return l.atom if l.positive else Not(l.atom)

    def _written_out(self, l: Literal) -> Formula:
        """A derived literal over its base predicate."""
        d = self.derived.get(l.atom.predicate)
        if d is not None:        # (no-on-1 ?x) -> (not (exists (?derived-z1) (on ?x ?derived-z1)))
            zs = [f"?derived-z{i + 1}" for i in range(d.base_arity - d.arity)]
            args, it = [], iter(zs)
            for i in range(d.base_arity):
                args.append(l.atom.args[d.keep.index(i)] if i in d.keep else next(it))
            some = Exists(tuple(Typed(z) for z in zs), Atom(d.base, tuple(args)))
            return some if not l.positive else Not(some)
        return l.atom if l.positive else Not(l.atom)

    # -------------------------------------------------------------------------- rule set semantics
    def _unique(self, context: Sequence[Literal], action_vars: Sequence[str], deictic: Sequence[str],
                taken: set[str]) -> Formula | None:
        """No other (injective) binding of the deictic variables satisfies the context."""
        if not deictic:
            return None
        zs = _fresh("z", taken, len(deictic))
        ren = dict(zip(deictic, zs))
        restr = [self.literal(l.substitute(ren)) for l in context if set(l.atom.args) & set(deictic)]
        same = [Atom("=", (z, y)) for z, y in zip(zs, deictic)]
        clash: list[Formula] = []
        if self.injective:
            clash = [Atom("=", (u, v)) for i, u in enumerate(zs) for v in zs[i + 1:]]
            clash += [Atom("=", (z, x)) for z in zs for x in action_vars]
        body = Or((Not(_conj(restr)), _conj(same), *clash))
        return Forall(tuple(Typed(z) for z in zs), body)

    def _covers(self, rule: Rule, action_vars: Sequence[str], taken: set[str]) -> Formula:
        """A formula over ``action_vars`` that holds iff ``rule`` covers the action (a unique
        covering rule, docs/rules.md)."""
        ren = dict(zip(rule.action.args, action_vars))
        deictic = list(rule.deictic)
        ws = _fresh("w", taken, len(deictic))
        ren.update(zip(deictic, ws))
        ctx = [l.substitute(ren) for l in rule.context]
        parts: list[Formula] = [self.literal(l) for l in ctx]
        if not ws:
            return And(tuple(parts))
        if self.injective:
            parts += _distinct(ws, action_vars)
        u = self._unique(ctx, action_vars, ws, taken)
        if u is not None:
            parts.append(u)
        return Exists(tuple(Typed(w) for w in ws), _conj(parts))

    def _exclusions(self, rule: Rule, others: Sequence[Rule], action_vars: Sequence[str],
                    taken: set[str]) -> list[Formula] | None:
        """``(not <rule j covers>)`` for every other rule that can cover together with ``rule``; None
        when one of them always covers (then ``rule`` can never be the unique covering rule)."""
        out: list[Formula] = []
        for other in others:
            if _disjoint(rule, other):
                continue
            x: Formula = Not(self._covers(other, action_vars, set(taken)))
            if self.simple:
                x = simplify(x)
                if x == FALSE:
                    return None
                if x == TRUE or x in out:
                    continue
            out.append(x)
        return out


def rules_to_domain(rules: RuleSet, predicates: Mapping[str, int], name: str = "learned",
                    noise: str = "no-change", comments: Mapping[str, str] | None = None,
                    comment: str = "", decimals: int | None = None, simple: bool = False) -> Domain:
    """A PPDDL domain whose actions are ``rules``' non-default rules, in one call (the options:
    :class:`RulesWriter`; it also says which rules were left out)."""
    return RulesWriter(rules, noise, decimals, simple).domain(predicates, name, comments, comment)[0]


# ------------------------------------------------------------------------------ formula helpers
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


def _conj(items: Sequence[Formula]) -> Formula:
    return items[0] if len(items) == 1 else And(tuple(items))


def _distinct(a: Sequence[str], b: Sequence[str] | None = None) -> list[Formula]:
    """``(not (= u v))`` for every pair within ``a`` (and between ``a`` and ``b``)."""
    pairs = [(u, v) for i, u in enumerate(a) for v in a[i + 1:]] + [(u, v) for u in a for v in (b or ())]
    return [Not(Atom("=", (u, v))) for u, v in pairs]


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


def _changes(changes: Sequence[Literal]) -> Effect:
    """One outcome's changes as an effect (sorted: the same rule prints the same)."""
    lits = tuple(sorted(changes))
    return lits[0] if len(lits) == 1 else AndEffect(lits)
