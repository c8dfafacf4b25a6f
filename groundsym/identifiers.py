"""Names that go into PDDL files: identifiers, keywords, and names PDDL reads as one.

Why here: a predicate, action or domain name is pasted into a PDDL file as is, so a name such as
``x) (:requirements`` (or one that ends in a newline) would change the file's meaning, and PDDL
names ignore case (the PDDL 1.2 manual, McDermott et al. 1998), so ``CLEAR`` beside ``clear``
is one predicate to a planner while groundsym would hold two. Every name a user gives and every
name a model part holds passes these checks (docs/reliability.md); this module depends on nothing
else of the project, so every reader can use it.
"""

from __future__ import annotations

import re
from typing import Iterable

from .errors import UserError

_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")
# words that PDDL or PPDDL give a meaning, and names the exporter uses itself
RESERVED = frozenset({
    "and", "or", "not", "imply", "exists", "forall", "when", "either", "probabilistic", "increase",
    "decrease", "reward", "total-cost", "define", "domain", "problem", "object", "noise-happened",
})


def check_identifier(name: str, what: str) -> str:
    """``name`` if it is a PDDL identifier (a letter, then letters, digits, ``-`` or ``_``) and
    not a PDDL keyword; else a :class:`UserError` that says why, naming ``what``."""
    if not isinstance(name, str) or not name:
        raise UserError(f"{what}: the name is empty")
    if not _IDENTIFIER.fullmatch(name):          # fullmatch: "u1\n" is no name (``$`` allows the newline)
        bad = next((c for c in name if not (c.isascii() and (c.isalnum() or c in "_-"))), None)
        why = (f"it contains {bad!r}" if bad is not None else f"it starts with {name[0]!r}")
        raise UserError(f"{what}: {name!r} is not a PDDL name ({why}; use a letter, then letters, "
                        "digits, '-' or '_')")
    if name.lower() in RESERVED:
        raise UserError(f"{what}: {name!r} is a PDDL keyword; choose another name")
    return name


def check_names(names: Iterable[str], what: str, taken: Iterable[str] = ()) -> None:
    """Each of ``names`` is a PDDL identifier and no two of them, nor one of them and one of
    ``taken``, are the same name to PDDL (which ignores case): ``'CLEAR' and 'clear' are one name``."""
    seen = {t.lower(): t for t in taken}
    for name in names:
        check_identifier(name, what)
        other = seen.setdefault(name.lower(), name)
        if other is not name:
            raise UserError(f"{what}: {name!r} and {other!r} are one name in PDDL (it ignores case)")
