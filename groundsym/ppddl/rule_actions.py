"""The form of a rule's PPDDL action: what :mod:`.from_rules` writes and :mod:`.to_rules` reads.

Why a module of its own: the writer and the reader must agree on it, and code that knows
nothing of rules needs it too (:mod:`.simulate` and :mod:`.determinize` ask which robot primitive
an action runs). A rule of primitive ``p`` is action ``p_r<k>`` (the ``k``-th rule of ``p``), its
parameters are the action's variables followed by the deictic references, and a uniqueness
conjunct ``(forall (?z..) (or .. (= ?z ?y) ..))`` pins each reference down (docs/ppddl.md).
"""

from __future__ import annotations

import re
from typing import Sequence

from ..logic import Atom
from ..rules.model import Rule
from .ast import Action, And, Forall, Formula, Or

NOISE_PREDICATE = "noise-happened"
NOISE_MODES = ("no-change", "pessimistic")
#: ``<primitive>_r<k>``: the name of a rule's action
RULE_NAME = re.compile(r"^(.+)_r(\d+)$")


def rule_action_name(primitive: str, k: int) -> str:
    """The action of the ``k``-th rule (counted from 1) of ``primitive``."""
    return f"{primitive}_r{k}"


def rule_action_names(rules: Sequence[Rule]) -> list[str]:
    """The action name of each rule, in order (:func:`rule_action_name`)."""
    count: dict[str, int] = {}
    out = []
    for r in rules:
        count[r.action.predicate] = count.get(r.action.predicate, 0) + 1
        out.append(rule_action_name(r.action.predicate, count[r.action.predicate]))
    return out


def conjuncts(f: Formula) -> list[Formula]:
    """The conjuncts of ``f``, nested ``and`` flattened (``f`` itself when it is no ``and``)."""
    return [g for x in f.args for g in conjuncts(x)] if isinstance(f, And) else [f]


def unique_refs(f: Formula, params: Sequence[str]) -> list[str]:
    """The parameters a uniqueness conjunct ``(forall (?z..) (or .. (= ?z ?y) ..))`` pins down."""
    if not isinstance(f, Forall) or not isinstance(f.body, Or):
        return []
    zs = {p.name for p in f.params}
    for d in f.body.args:
        eqs = conjuncts(d)
        if eqs and all(isinstance(e, Atom) and e.predicate == "=" and e.args[0] in zs and e.args[1] in params
                       for e in eqs):
            return [e.args[1] for e in eqs]  # type: ignore[union-attr]
    return []


def primitive_of(action: Action) -> tuple[str, int]:
    """(primitive name, its arity) that a PPDDL action runs: ``puton_r2 ?x ?y`` with deictic ``?y``
    runs ``puton`` on ``?x``; an ordinary action runs itself on all its parameters."""
    names = [p.name for p in action.parameters]
    m = RULE_NAME.match(action.name)
    if not m:
        return action.name, len(names)
    refs = {y for c in conjuncts(action.precondition) for y in unique_refs(c, names)}
    n = next((i for i, v in enumerate(names) if v in refs), len(names))
    return m.group(1), n
