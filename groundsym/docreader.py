"""Reading a JSON document with checks that name the file and the field in every error.

Every file format of groundsym (continuous traces, symbolic traces, symbols, rules) is read
through one :class:`DocReader`, so a malformed file always ends in one line of the same shape,
``FILE: FIELD: what is wrong`` (a :class:`~groundsym.errors.UserError`, exit status 2), never in a
traceback from deep inside the code that would have used the value.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .errors import UserError
from .identifiers import check_names
from .logic import Atom, Literal, parse_atom, parse_literal

MAX_MAGNITUDE = 1e12   # features and rewards beyond this overflow squares and sums in the loss


class DocReader:
    """Validation helpers that name the file and the field in every error."""

    def __init__(self, path: str | Path):
        self.path = path

    def fail(self, field: str, msg: str) -> UserError:
        return UserError(f"{self.path}: {field}: {msg}")

    def get(self, doc: Any, key: str, field: str, kind: type | tuple[type, ...], default: Any = ...) -> Any:
        """``doc[key]``, checked to be a ``kind`` (a bool is no number); ``default`` if given and missing."""
        where = f"{field}.{key}" if field else key
        if not isinstance(doc, dict):
            raise self.fail(field or "document", "expected a JSON object")
        if key not in doc:
            if default is not ...:
                return default
            raise self.fail(where, "missing")
        val = doc[key]
        if not isinstance(val, kind) or isinstance(val, bool) and kind is not bool:
            names = kind.__name__ if isinstance(kind, type) else "/".join(k.__name__ for k in kind)
            raise self.fail(where, f"expected {names}, got {type(val).__name__}")
        return val

    def arities(self, doc: Any, key: str, field: str = "", default: Any = ...) -> dict[str, int]:
        """``doc[key]`` as a table of PDDL names (:func:`~groundsym.identifiers.check_names`: a
        name that is no PDDL name would surface later as a syntax error in an exported domain) to
        arities (non-negative integers)."""
        table = self.get(doc, key, field, dict, default)
        if table is default:
            return table
        check_names(table, f"{self.path}: {field}.{key}" if field else f"{self.path}: {key}")
        for name, arity in table.items():
            if isinstance(arity, bool) or not isinstance(arity, int) or arity < 0:
                raise self.fail(f"{field}.{key}.{name}" if field else f"{key}.{name}", "expected a non-negative arity")
        return {str(k): int(v) for k, v in table.items()}

    def matrix(self, val: Any, field: str, shape: tuple[int | None, ...]) -> np.ndarray:
        try:
            arr = np.asarray(val, dtype=float)
        except (TypeError, ValueError):
            raise self.fail(field, "expected an array of numbers") from None
        if arr.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, arr.shape)):
            want = " x ".join("?" if s is None else str(s) for s in shape)
            raise self.fail(field, f"expected shape {want}, got {' x '.join(map(str, arr.shape)) or 'scalar'}")
        if not np.all(np.isfinite(arr)):
            raise self.fail(field, "contains NaN or infinite values")
        if arr.size and np.abs(arr).max() > MAX_MAGNITUDE:
            raise self.fail(field, f"a value of magnitude {np.abs(arr).max():.3g} (at most {MAX_MAGNITUDE:g}: "
                                   f"larger ones overflow the arithmetic)")
        return arr

    def number(self, val: Any, field: str) -> float:
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
            raise self.fail(field, f"expected a finite number, got {val!r}")
        if abs(val) > MAX_MAGNITUDE:
            raise self.fail(field, f"{float(val):.3g} is beyond {MAX_MAGNITUDE:g} in magnitude (larger values "
                                   f"overflow the arithmetic)")
        return float(val)

    def atom(self, val: Any, field: str, objects: set[str] | None = None,
             arities: Mapping[str, int] | None = None) -> Atom:
        if not isinstance(val, str):
            raise self.fail(field, f"expected an atom string, got {type(val).__name__}")
        try:
            atom = parse_atom(val)
        except ValueError as exc:
            raise self.fail(field, str(exc)) from None
        self.check_arity(atom, field, arities)
        if objects is not None:
            for a in atom.args:
                if a not in objects:
                    raise self.fail(field, f"unknown object {a!r} in {val}")
        return atom

    def prob(self, val: Any, field: str, lo: float = 0.0) -> float:
        """A probability in ``[lo, 1]``."""
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val) or not lo <= val <= 1:
            raise self.fail(field, f"expected a probability in [{lo:g}, 1], got {val!r}")
        return float(val)

    def literal(self, text: Any, field: str, arities: Mapping[str, int] | None) -> Literal:
        """A literal such as ``(not (on X Y))``, its predicate declared with this arity."""
        if not isinstance(text, str):
            raise self.fail(field, f"expected a literal string, got {type(text).__name__}")
        try:
            lit = parse_literal(text)
        except ValueError as exc:
            raise self.fail(field, str(exc)) from None
        self.check_arity(lit.atom, field, arities)
        return lit

    def check_arity(self, atom: Atom, field: str, arities: Mapping[str, int] | None) -> None:
        """``atom``'s predicate is declared in ``arities`` (when given) with ``atom``'s arity."""
        if arities is None:
            return
        if atom.predicate not in arities:
            raise self.fail(field, f"unknown name {atom.predicate!r} (declared: {', '.join(sorted(arities))})")
        if arities[atom.predicate] != atom.arity:
            raise self.fail(field, f"{atom.predicate} takes {arities[atom.predicate]} arguments, got {atom.arity}")
