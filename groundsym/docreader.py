"""Reading a JSON document with checks that name the file and the field in every error.

Every file format of groundsym (continuous traces, symbolic traces, symbols, rules) is read
through one :class:`DocReader`, so a malformed file always ends in one line of the same shape,
``FILE: FIELD: what is wrong`` (a :class:`~groundsym.errors.UserError`, exit status 2), never in a
traceback from deep inside the code that would have used the value.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from .errors import UserError
from .logic import Atom, parse_atom

MAX_MAGNITUDE = 1e12   # features and rewards beyond this overflow squares and sums in the loss


class DocReader:
    """Validation helpers that name the file and the field in every error."""

    def __init__(self, path: str | Path):
        self.path = path

    def fail(self, field: str, msg: str) -> UserError:
        return UserError(f"{self.path}: {field}: {msg}")

    def get(self, doc: Any, key: str, field: str, kind: type | tuple[type, ...]) -> Any:
        if not isinstance(doc, dict):
            raise self.fail(field, "expected an object")
        if key not in doc:
            raise self.fail(f"{field}.{key}" if field else key, "missing")
        val = doc[key]
        if not isinstance(val, kind) or isinstance(val, bool) and kind is not bool:
            names = kind.__name__ if isinstance(kind, type) else "/".join(k.__name__ for k in kind)
            raise self.fail(f"{field}.{key}" if field else key, f"expected {names}, got {type(val).__name__}")
        return val

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
             arities: dict[str, int] | None = None) -> Atom:
        if not isinstance(val, str):
            raise self.fail(field, f"expected an atom string, got {type(val).__name__}")
        try:
            atom = parse_atom(val)
        except ValueError as exc:
            raise self.fail(field, str(exc)) from None
        if arities is not None:
            if atom.predicate not in arities:
                raise self.fail(field, f"unknown name {atom.predicate!r} (declared: {', '.join(sorted(arities))})")
            if arities[atom.predicate] != atom.arity:
                raise self.fail(field, f"{atom.predicate} takes {arities[atom.predicate]} arguments, got {atom.arity}")
        if objects is not None:
            for a in atom.args:
                if a not in objects:
                    raise self.fail(field, f"unknown object {a!r} in {val}")
        return atom
