"""Learned rules as one typed operator per action (``export-domain --operators``; docs/amlgym.md).

The default export (:mod:`.from_rules`) writes one action per rule (``board_r1``), with deictic
parameters and the exclusions that keep an action's rules apart: faithful to NID semantics, but
not what a planning benchmark expects. When every action has at most one rule and its rule has
no deictic references, which is what :mod:`groundsym.rules.successful` learns from plan traces,
the rule *is* an operator: the action's own name and parameters, its context as the precondition,
its outcomes as the effect. Object types come from the trace file's type declaration
(:class:`~groundsym.symbolic_traces.SymbolicDataset` ``types``): a positive literal over a type
predicate becomes the parameter's type (the most specific one when several hold).

Noise: ``no-change`` leaves the rule's noise mass unassigned (read as no change, as PPDDL does);
``drop`` conditions on "no noise" and renormalises the outcome probabilities, so the most-likely
determinisation keeps the action's main effect even where noisy data gave the noise outcome most
of the mass (docs/ppddl.md, Determinisation).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Iterable, Mapping, Sequence

from ..errors import UserError
from ..logic import Literal, is_variable
from ..rules.model import Rule, RuleSet
from .ast import OBJECT, And, AndEffect, Domain, Effect, Not, Predicate, Probabilistic, Typed, Action
from .from_rules import rounded_probs
from .requirements import requirements

OPERATOR_NOISE = ("no-change", "drop")


def operator_domain(rules: RuleSet, predicates: Mapping[str, int], *, name: str = "learned",
                    types: Mapping[str, str | None] | None = None, noise: str = "no-change", decimals: int = 4,
                    signatures: Mapping[str, Sequence[Typed]] | None = None,
                    parameters: Mapping[str, Sequence[str]] | None = None,
                    constants: Mapping[str, str] | None = None,
                    parameter_types: Mapping[str, Sequence[str]] | None = None) -> Domain:
    """The domain with one operator per action. ``types``: type -> parent type (None: ``object``);
    ``signatures``: typed parameters of predicates (default untyped); ``parameters``: parameter
    names per action (default ``?x1 ..``), e.g. a reference domain's, so literals compare by text;
    ``constants``: object -> type of the objects rules name (PDDL ``:constants``);
    ``parameter_types``: declared types of each action's parameters, which win over the type
    literals learned (the most specific type every example shows: in 5 of depots' trajectories
    every ``drop`` is onto a pallet, yet the signature every learner is given says surface)."""
    if noise not in OPERATOR_NOISE:
        raise UserError(f"--noise: with --operators expected one of {', '.join(OPERATOR_NOISE)}, got {noise!r}")
    types = dict(types or {})
    by_action: dict[str, list[Rule]] = {}
    for r in rules.rules:
        by_action.setdefault(r.action.predicate, []).append(r)
    actions = []
    for act, rs in sorted(by_action.items()):
        if len(rs) > 1 or rs[0].deictic:
            why = f"{len(rs)} rules" if len(rs) > 1 else f"deictic references {' '.join(rs[0].deictic)}"
            raise UserError(f"--operators: action {act} has {why}; one operator per action needs one rule "
                            "without deictic references (export without --operators: one action per rule)")
        names = list(parameters.get(act, ())) if parameters else []
        declared = list(parameter_types.get(act, ())) if parameter_types else []
        actions.append(_operator(rs[0], types, noise, decimals, names, declared))
    sig = dict(signatures or {})
    preds = tuple(Predicate(p, tuple(sig.get(p, [Typed(f"?a{i + 1}") for i in range(k)])))
                  for p, k in sorted(predicates.items()) if p not in types)
    domain = Domain(name, (), tuple(Typed(t, parent or OBJECT) for t, parent in sorted(types.items())),
                    tuple(Typed(c, t or OBJECT) for c, t in sorted((constants or {}).items())), preds,
                    tuple(actions), "learned rules as one operator per action (groundsym export-domain "
                    f"--operators, noise: {noise})")
    return replace(domain, requirements=requirements(domain))


def _operator(rule: Rule, types: dict[str, str | None], noise: str, decimals: int, names: list[str],
              declared: list[str] | None = None) -> Action:
    variables = list(rule.action.args)
    for given, what in ((names, "names"), (declared or [], "types")):
        if given and len(given) != len(variables):
            raise UserError(f"parameters of {rule.action.predicate}: {len(given)} {what} for {len(variables)} arguments")
    ren = dict(zip(variables, names)) if names else {}
    kinds: dict[str, list[str]] = {v: [] for v in variables}
    pre = []
    for lit in rule.context:
        if lit.atom.predicate in types and lit.atom.arity == 1:
            if lit.positive:
                kinds[lit.atom.args[0]].append(lit.atom.predicate)
            continue
        a = lit.atom.substitute(ren)
        pre.append(a if lit.positive else Not(a))
    params = tuple(Typed(ren.get(v, v), declared[k] if declared else deepest_type(kinds[v], types))
                   for k, v in enumerate(variables))
    return Action(rule.action.predicate, params, And(tuple(pre)), _effect(rule, ren, noise, decimals))


def named_constants(rules: RuleSet, states: Iterable[frozenset], types: dict[str, str | None]) -> dict[str, str]:
    """The objects the rules name (contexts and outcomes), each with its most specific type from
    its type atoms in ``states``: the domain's ``:constants`` (childsnack's ``kitchen``), which the
    problem must then not declare again."""
    named = {x for r in rules.rules for l in r.context + tuple(c for o in r.outcomes for c in o.changes)
             for x in l.atom.args if not is_variable(x)}
    kinds: dict[str, set[str]] = {c: set() for c in named}
    for s in states:
        for a in s:
            if a.arity == 1 and a.predicate in types and a.args[0] in kinds:
                kinds[a.args[0]].add(a.predicate)
    return {c: deepest_type(sorted(k), types) for c, k in sorted(kinds.items())}


def deepest_type(kinds: list[str], types: dict[str, str | None]) -> str:
    """The most specific of the types a parameter has (one whose ancestors include the others)."""
    def ancestors(t: str) -> set[str]:
        out = {t}
        while types.get(t):
            t = types[t]  # type: ignore[assignment]
            out.add(t)
        return out
    best = [t for t in sorted(kinds) if set(kinds) <= ancestors(t)]
    return best[0] if best else OBJECT


def _effect(rule: Rule, ren: dict[str, str], noise: str, decimals: int) -> Effect:
    outs = [(o, p) for o, p in zip(rule.outcomes, rule.probs) if p > 0]
    if noise == "drop":
        total = sum(p for _, p in outs) or 1.0
        outs = [(o, p / total) for o, p in outs]
    probs = rounded_probs([p for _, p in outs], decimals)
    branches = [(q, _changes(o.changes, ren)) for (o, _), q in zip(outs, probs) if o.changes and q > 0]
    if len(branches) == 1 and branches[0][0] == 1:
        return branches[0][1]
    return Probabilistic(tuple(branches)) if branches else AndEffect(())


def _changes(changes: Sequence[Literal], ren: dict[str, str]) -> AndEffect:
    return AndEffect(tuple(Literal(l.atom.substitute(ren), l.positive) for l in changes))


def reference_signatures(domain: Domain) -> tuple[dict[str, tuple[Typed, ...]], dict[str, tuple[str, ...]]]:
    """A reference domain's predicate signatures and operator parameter names (the input every
    learner of a planning benchmark is given), for :func:`operator_domain`."""
    return ({p.name: p.params for p in domain.predicates},
            {a.name: tuple(x.name for x in a.parameters) for a in domain.actions})
