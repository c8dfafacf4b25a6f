"""The domain's language for successful-only contexts (docs/amlgym.md, The domain's language).

Data of successful actions cannot tell a negated precondition from a literal that plans merely
never contradict, nor a constant from an object that happens to recur, so what a context may say
is the domain's to declare: its constants (PDDL ``:constants``), whether negated literals are
offered (``:negative-preconditions``) and its object types (unary predicates, static, declared
with the objects: Juba, Le & Stern 2021, "Safe learning of lifted action models", KR).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from ..errors import UserError


@dataclass(frozen=True)
class Language:
    """The domain's language for successful-only contexts: ``constants`` a context may name beside
    the action's arguments (PDDL ``:constants``), ``negative`` whether negated literals are offered
    (PDDL ``:negative-preconditions``; see :func:`learn_from_successes` for why it matters)."""

    constants: tuple[str, ...] = ()
    negative: bool = True


def trace_language(meta: dict, objects: set[str], where: str, constants: Sequence[str] | None = None,
                   negative: bool | None = None) -> Language:
    """The language a symbolic traces file declares (``meta.constants``: a list of object names;
    ``meta.negative_preconditions``: true or false), each part overridden by the caller's option
    (``groundsym learn --constants``, ``--negative-preconditions``). A constant must be an object
    of the traces: a misspelt one would silently name nothing (docs/amlgym.md, The domain's language)."""
    if constants is None:
        constants = meta.get("constants", [])
        if not isinstance(constants, list) or not all(isinstance(c, str) and c for c in constants):
            raise UserError(f"{where}: meta.constants: expected a list of object names, got {constants!r}")
        field_name = f"{where}: meta.constants"
    else:
        field_name = "--constants"
    unknown = sorted(set(constants) - objects)
    if unknown:
        raise UserError(f"{field_name}: {', '.join(map(repr, unknown))} is no object of the traces in {where}")
    if negative is None:
        negative = meta.get("negative_preconditions", True)
        if not isinstance(negative, bool):
            raise UserError(f"{where}: meta.negative_preconditions: expected true or false, got {negative!r}")
    return Language(tuple(sorted(set(constants))), negative)


def types_of(state: frozenset, types: frozenset) -> dict[str, set[str]]:
    """Each object's types in ``state``: the unary atoms over it whose predicate is in ``types``."""
    out: dict[str, set[str]] = {}
    for a in state:
        if a.predicate in types and a.arity == 1:
            out.setdefault(a.args[0], set()).add(a.predicate)
    return out
