"""Rule contexts as the learner builds them: lifting a state's atoms to literals over variables,
deictic references, validity, unique binding, and stable names.

These are the small pieces of the search's operators (ExplainExamples builds a context from an
example, AddLits/AddRefs extend one, the result is named ``?y1, ?y2, ...`` in order): functions of
a context and a state alone, apart from the search state the learner keeps.
"""

from __future__ import annotations

from itertools import permutations, product
from typing import Iterable, Sequence

from ..logic import Atom, Literal, is_variable
from .coverage import Example
from .model import Rule
from .outcomes import OutcomeFit


def make_rule(action: Atom, ctx: tuple[Literal, ...], of: OutcomeFit) -> Rule:
    """The rule of context ``ctx`` with the fitted outcomes ``of``."""
    return Rule(action, ctx, of.outcomes, of.probs, of.noise, of.noise_changes)


def deictic_refs(ctx: Iterable[Literal], action: Atom) -> list[str]:
    """The variables of ``ctx`` that are not the action's arguments, in sorted-literal order."""
    out: list[str] = []
    for l in sorted(ctx):
        for a in l.atom.args:
            if is_variable(a) and a not in action.args and a not in out:
                out.append(a)
    return out


def valid_context(ctx: tuple[Literal, ...], action: Atom, maxdeictic_refs: int) -> bool:
    """No contradictions, few references. A reference that only negated literals mention is allowed
    ("the one object that is not u1"): under the closed world and the exactly-one-binding rule it
    names an object as well as a positive one does (Pasula et al. allow negated literals in
    deictic references)."""
    atoms = {l.atom for l in ctx}
    if len(atoms) != len(ctx):
        return False
    return len(deictic_refs(ctx, action)) <= maxdeictic_refs


def lift_atoms(state: frozenset, sigma: dict[str, str], positive: bool) -> list[Literal]:
    """Atoms of ``state`` whose arguments are all bound by ``sigma``, over variables."""
    return [Literal(a.substitute(sigma), positive) for a in sorted(state) if all(x in sigma for x in a.args)]


def atoms_over(variables: Sequence[str], predicates: dict[str, int], injective: bool) -> list[Atom]:
    """Every atom of ``predicates`` over ``variables`` (distinct arguments if ``injective``)."""
    out = []
    for p, k in sorted(predicates.items()):
        gen = permutations(variables, k) if injective else product(variables, repeat=k)
        out.extend(Atom(p, tuple(args)) for args in gen)
    return out


def absent_literals(state: frozenset, sigma: dict[str, str], predicates: dict[str, int],
                     injective: bool) -> list[Literal]:
    """Negated literals for the atoms over ``sigma``'s objects that are false in ``state``."""
    inv = {v: o for o, v in sigma.items()}
    return [Literal(a, False) for a in atoms_over(sorted(inv), predicates, injective)
            if a.substitute(inv) not in state]


def binds_uniquely(state: frozenset, ex: Example, action: Atom, ctx: set[Literal], injective: bool) -> bool:
    """The context binds exactly one way in ``state`` (example ``ex``'s, with its derived atoms)."""
    probe = Rule(action, tuple(sorted(ctx)), (), (), 1.0)
    return probe.covers(state, ex.action, injective, ex.objects) is not None


def fresh_variable(rule: Rule) -> str:
    """The first ``?yK`` the rule does not use."""
    k = 1
    while f"?y{k}" in rule.variables:
        k += 1
    return f"?y{k}"


def canonical_names(rule: Rule) -> Rule:
    """Rename deictic references ?y1, ?y2, ... in order of first appearance (readable, stable)."""
    ren = {v: f"?y{i + 1}" for i, v in enumerate(rule.deictic)}
    if all(k == v for k, v in ren.items()):
        return rule
    ctx = tuple(sorted(l.substitute(ren) for l in rule.context))
    outs = tuple(type(o)(tuple(l.substitute(ren) for l in o.changes)) for o in rule.outcomes)
    return Rule(rule.action, ctx, outs, rule.probs, rule.noise, rule.noise_changes)
