"""NID rules compared as a PPDDL round trip needs: up to variable names, or within a rounding.

Why here: a rule read back from PPDDL (:mod:`.to_rules`) may name its variables otherwise, store
its noise as the rest of the mass, or carry probabilities rounded by the export
(:mod:`.from_rules`); these are the equalities the round-trip checks and the reader use.
"""

from __future__ import annotations

from itertools import permutations

from ..rules.model import Rule


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


def same_rule_key(rule: Rule) -> tuple:
    """The rule's primitive, context and outcomes up to the names of its variables: two rules of a
    rule set with one key cover the same states, so neither covers any (Pasula et al. 2007: a
    state-action pair covered by two rules falls to the default rule)."""
    ren = {v: f"?a{i}" for i, v in enumerate(rule.action.args)}
    best = None
    for perm in permutations(range(len(rule.deictic))):
        ren.update({y: f"?d{perm[j]}" for j, y in enumerate(rule.deictic)})
        key = (tuple(sorted(str(l.substitute(ren)) for l in rule.context)),
               tuple(sorted(tuple(sorted(str(c.substitute(ren)) for c in o.changes)) for o in rule.outcomes)))
        best = key if best is None or key < best else best
    return rule.action.predicate, len(rule.action.args), best


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
