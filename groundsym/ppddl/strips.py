"""A deterministic PDDL domain and problem compiled to plain STRIPS, the textbook way.

Why: exported rule domains need ADL (negative, quantified and equality preconditions), which
STRIPS-only planners such as pyperplan refuse. The compilation (as in Gazen and Knoblock 1997):

* every action is grounded over the problem's objects (and the domain's constants), so equality
  is decided while grounding and ``forall``/``exists`` expand into ``and``/``or`` over objects;
* the precondition is brought into disjunctive normal form (negations pushed to the atoms); each
  disjunct becomes an action of its own, and a grounding whose precondition is false is dropped;
* a negative literal ``(not (p a))`` becomes ``(not-p a)``, a complement predicate that every
  effect keeps in step with ``p`` (deleting ``(p a)`` adds ``(not-p a)`` and the reverse), and the
  initial state holds ``(not-p a)`` for every ``(p a)`` it does not hold;
* a goal that is not one conjunction gets a ``goal-reached`` atom and one action per disjunct.

Conditional effects cannot be compiled this way and are refused in one line. The same grounded
actions give :func:`relaxed_reachable` (delete effects ignored).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product
from typing import Iterable

from ..errors import UserError
from ..logic import Atom, Literal
from .ast import (OBJECT, TRUE, Action, And, AndEffect, Domain, Effect, Forall, Formula, Imply, Not, Or,
                  Predicate, Problem, Typed)
from .ground import substitute

MAX_DISJUNCTS = 4096
Term = frozenset          # frozenset[Literal]: one conjunction of ground literals


@dataclass(frozen=True)
class GroundAction:
    name: str
    pre: Term
    add: frozenset
    delete: frozenset


# ------------------------------------------------------------------------------ DNF
def _minimal(terms: Iterable[Term]) -> list[Term]:
    """Terms without contradictions, and without those another term's literals imply."""
    ok = [t for t in set(terms) if not any(l.negate() in t for l in t)]
    ok.sort(key=len)
    out: list[Term] = []
    for t in ok:
        if not any(s <= t for s in out):
            out.append(t)
    if len(out) > MAX_DISJUNCTS:
        raise OverflowError
    return out


def _product(a: list[Term], b: list[Term]) -> list[Term]:
    return _minimal(x | y for x in a for y in b)


class _Grounder:
    def __init__(self, domain: Domain, objects: tuple[Typed, ...]) -> None:
        self.objects = tuple(objects) + tuple(domain.constants)
        parents = {t.name: t.type for t in domain.types}
        self.is_a = {}
        for o in self.objects:
            kinds, t = {OBJECT, o.type}, o.type
            while t in parents and parents[t] not in kinds:
                t = parents[t]
                kinds.add(t)
            self.is_a[o.name] = kinds

    def of_type(self, t: str) -> list[str]:
        return [o.name for o in self.objects if t in self.is_a[o.name]]

    def bindings(self, params: tuple[Typed, ...]) -> Iterable[dict[str, str]]:
        for combo in product(*(self.of_type(p.type) for p in params)):
            yield dict(zip((p.name for p in params), combo))

    def dnf(self, f: Formula, positive: bool = True) -> list[Term]:
        """The ground formula ``f`` (or its negation) as a list of conjunctions of literals."""
        if isinstance(f, Atom):
            if f.predicate == "=":
                return [Term()] if (f.args[0] == f.args[1]) == positive else []
            return [Term({Literal(f, positive)})]
        if isinstance(f, Not):
            return self.dnf(f.arg, not positive)
        if isinstance(f, Imply):
            return self.dnf(Or((Not(f.left), f.right)), positive)
        if isinstance(f, (And, Or)):
            parts = [self.dnf(g, positive) for g in f.args]
        else:
            parts = [self.dnf(substitute(f.body, b), positive) for b in self.bindings(f.params)]
        conjunctive = isinstance(f, (And, Forall)) == positive
        if conjunctive:
            out = [Term()]
            for p in parts:
                out = _product(out, p)
                if not out:
                    break
            return out
        return _minimal(t for p in parts for t in p)


def _effect_literals(e: Effect, where: str) -> list[Literal]:
    if isinstance(e, Literal):
        return [e]
    if isinstance(e, AndEffect):
        return [l for x in e.effects for l in _effect_literals(x, where)]
    raise UserError(f"--strips: {where}: conditional or probabilistic effects cannot be compiled to STRIPS "
                    "(use the ADL domain.pddl)")


def ground_actions(domain: Domain, problem: Problem) -> list[GroundAction]:
    """Every grounding of every action whose precondition can hold, one per DNF disjunct."""
    g = _Grounder(domain, problem.objects)
    out = []
    for a in domain.actions:
        lits = _effect_literals(a.effect, f"action {a.name}")
        for b in g.bindings(a.parameters):
            args = [b[p.name] for p in a.parameters]
            try:
                terms = g.dnf(substitute(a.precondition, b))
            except OverflowError:
                raise UserError(f"--strips: the precondition of {a.name} {' '.join(args)} expands to more than "
                                f"{MAX_DISJUNCTS} alternatives; use the ADL domain.pddl") from None
            eff = [Literal(l.atom.substitute(b), l.positive) for l in lits]
            add = frozenset(l.atom for l in eff if l.positive)
            delete = frozenset(l.atom for l in eff if not l.positive) - add
            base = "_".join([a.name, *args])
            for i, t in enumerate(sorted(terms, key=lambda t: sorted(t)), 1):
                out.append(GroundAction(base if len(terms) == 1 else f"{base}_d{i}", t, add, delete))
    return out


def _goal_terms(g: _Grounder, problem: Problem) -> list[Term]:
    try:
        return g.dnf(problem.goal if problem.goal is not None else TRUE)
    except OverflowError:
        raise UserError(f"--strips: the goal expands to more than {MAX_DISJUNCTS} alternatives") from None


# ------------------------------------------------------------------------------ STRIPS
def _complement_name(p: str, taken: set[str]) -> str:
    name = f"not-{p}"
    while name in taken:
        name = f"not-{name}"
    return name


def to_strips(domain: Domain, problem: Problem) -> tuple[Domain, Problem]:
    """The STRIPS domain and problem (see the module docstring); raises :class:`UserError` when the
    domain has conditional effects or a precondition too large to expand."""
    actions = ground_actions(domain, problem)
    g = _Grounder(domain, problem.objects)
    goal_terms = _goal_terms(g, problem)
    negated = {l.atom.predicate for a in actions for l in a.pre if not l.positive}
    negated |= {l.atom.predicate for t in goal_terms for l in t if not l.positive}
    arity = {p.name: p.arity for p in domain.predicates}
    taken = set(arity)
    comp = {p: _complement_name(p, taken) for p in sorted(negated)}

    def lit(l: Literal) -> Atom:
        return l.atom if l.positive else Atom(comp[l.atom.predicate], l.atom.args)

    def effects(add: frozenset, delete: frozenset) -> AndEffect:
        eff = [Literal(x) for x in sorted(add)] + [Literal(x, False) for x in sorted(delete)]
        eff += [Literal(Atom(comp[x.predicate], x.args), False) for x in sorted(add) if x.predicate in comp]
        eff += [Literal(Atom(comp[x.predicate], x.args)) for x in sorted(delete) if x.predicate in comp]
        return AndEffect(tuple(eff))

    strips_actions = [Action(a.name, (), And(tuple(lit(l) for l in sorted(a.pre))), effects(a.add, a.delete))
                      for a in actions]
    preds = [Predicate(p.name, p.params, p.comment) for p in domain.predicates]
    preds += [Predicate(comp[p], tuple(Typed(f"?x{i + 1}") for i in range(arity[p])), f"not ({p} ...)")
              for p in sorted(comp)]
    init = set(problem.init)
    objects = [o.name for o in g.objects]
    for p, c in comp.items():
        init |= {Atom(c, args) for args in product(objects, repeat=arity[p]) if Atom(p, args) not in problem.init}
    goal: Formula | None
    if len(goal_terms) == 1:
        goal = And(tuple(lit(l) for l in sorted(goal_terms[0])))
    elif not goal_terms:
        raise UserError("--strips: the goal can never hold")
    else:
        preds.append(Predicate("goal-reached", (), "one of the goal's alternatives holds"))
        strips_actions += [Action(f"reach-goal_{i}", (), And(tuple(lit(l) for l in sorted(t))),
                                  AndEffect((Literal(Atom("goal-reached")),)))
                           for i, t in enumerate(goal_terms, 1)]
        goal = Atom("goal-reached")
    consts = tuple(Typed(o) for o in objects)     # ground actions name objects: domain constants
    d = Domain(domain.name, (":strips",), (), consts, tuple(preds), tuple(strips_actions),
               f"STRIPS compilation of {domain.name} over the objects of problem {problem.name} (now constants): "
               "grounded, negative literals as not-<predicate> complements, equality and quantifiers expanded")
    p = Problem(problem.name, d.name, (), tuple(init), goal, None, None, (), problem.comment)
    return d, p


def _top_atoms(f: Formula) -> tuple[list[Atom], list[tuple[str, str]]]:
    """The positive atoms and the ``(not (= a b))`` pairs among a formula's top-level conjuncts."""
    if not isinstance(f, And):
        if isinstance(f, Atom) and f.predicate != "=":
            return [f], []
        if isinstance(f, Not) and isinstance(f.arg, Atom) and f.arg.predicate == "=":
            return [], [tuple(f.arg.args)]      # type: ignore[list-item]
        return [], []
    atoms: list[Atom] = []
    neq: list[tuple[str, str]] = []
    for x in f.args:
        a, n = _top_atoms(x)
        atoms += a
        neq += n
    return atoms, neq


def relaxed_reachable(domain: Domain, problem: Problem) -> bool | None:
    """Whether the goal's positive atoms can become true when delete effects, negative literals and
    every precondition part but the top-level positive atoms are ignored (an over-approximation,
    so False means the goal is unreachable for sure); None without a goal or for conditional effects."""
    if problem.goal is None:
        return None
    g = _Grounder(domain, problem.objects)
    acts = []
    for a in domain.actions:
        try:
            adds = [l.atom for l in _effect_literals(a.effect, a.name) if l.positive]
        except UserError:
            return None
        acts.append((a, *_top_atoms(a.precondition), adds))
    reached = set(problem.init)
    changed = True
    while changed:
        changed = False
        for a, pre, neq, adds in acts:
            for b in g.bindings(a.parameters):
                if any(b.get(x, x) == b.get(y, y) for x, y in neq):
                    continue
                if all(p.substitute(b) in reached for p in pre):
                    new = {x.substitute(b) for x in adds} - reached
                    if new:
                        reached |= new
                        changed = True
    goal_atoms, _ = _top_atoms(problem.goal)
    return all(x in reached for x in goal_atoms)
