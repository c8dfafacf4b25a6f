"""Typed ``key=value`` options of simulations and planners: one declaration type, one parser.

A simulation (``--sim-opt``) and a planner (``--planner-opt``) both declare their options as a
tuple of :class:`Option` (name, value parser, default, meaning) and read what the user typed with
:func:`parse_options`; so an unknown name or a bad value gives the same one-line user error for
both, naming the flag, the option and why the value was refused (docs/reliability.md). The value
parsers shared by several owners (:func:`parse_bool`, :func:`one_of`, :func:`positive`,
:func:`unit_interval`, :func:`nonnegative`) live here too: their ``__name__`` is what the error says was expected.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any, Callable, Mapping

from .errors import UserError


@dataclass(frozen=True)
class Option:
    """One ``--sim-opt``/``--planner-opt`` ``key=value`` option: its type, default and meaning."""

    name: str
    kind: Callable[[str], Any]
    default: Any
    doc: str
    recorded_at_default: bool = True     # False: an option added later, left out of files at its default


def parse_options(flag: str, owner_kind: str, owner_name: str, spec: tuple[Option, ...],
                  given: Mapping[str, Any]) -> dict[str, Any]:
    """Typed options from strings (or values) given by the user, the defaults filled in.

    ``flag`` (``--sim-opt``) and ``owner_kind owner_name`` (``sim 'tower'``) only word the errors:
    an unknown name lists the known ones; a value the option's parser refuses says what was
    expected and the parser's own reason (``at most 100000``)."""
    known = {o.name: o for o in spec}
    out = {o.name: o.default for o in spec}
    for key, raw in given.items():
        if key not in known:
            raise UserError(f"{flag} {key}: unknown option for {owner_kind} {owner_name!r} "
                            f"(known: {', '.join(sorted(known)) or 'none'})")
        parse = whole_number if known[key].kind is int else known[key].kind
        try:
            out[key] = parse(raw)
        except (TypeError, ValueError) as exc:
            kind = getattr(parse, "__name__", "a value")
            raise UserError(f"{flag} {key}={raw}: expected {kind} ({exc})") from None
    return out


def split_key_values(items: list[str] | None, flag: str) -> dict[str, str]:
    """``["a=1", "b=x"]`` -> ``{"a": "1", "b": "x"}``; malformed items are user errors."""
    out: dict[str, str] = {}
    for item in items or []:
        for part in item.split():
            if "=" not in part:
                raise UserError(f"{flag} {part}: expected key=value")
            k, v = part.split("=", 1)
            out[k.strip()] = v.strip()
    return out


def whole_number(value: str | int) -> int:
    """A whole number from text (``"4"``) or given as one (a Gymnasium keyword, ``cubes=4``); the
    parser of every option declared ``int``. ``int()`` alone would make ``cubes=3.5`` three cubes
    and ``cubes=True`` one, silently; a float (even ``3.0``) or a bool is refused instead."""
    if isinstance(value, bool) or not isinstance(value, (str, numbers.Integral)):
        raise ValueError(f"got {type(value).__name__} {value!r}")
    try:
        return int(value)
    except ValueError:
        raise ValueError(f"got {value!r}") from None


whole_number.__name__ = "a whole number"


def parse_bool(text: str | bool) -> bool:
    """``1/true/yes/on`` or ``0/false/no/off`` (any case), or a bool given as a value (gym)."""
    if isinstance(text, bool):
        return text
    t = str(text).strip().lower()
    if t in ("1", "true", "yes", "on"):
        return True
    if t in ("0", "false", "no", "off"):
        return False
    raise ValueError(text)


parse_bool.__name__ = "bool"


def one_of(*choices: str) -> Callable[[str], str]:
    """A value that must be one of ``choices`` (a variant, a mode), returned as given; the error
    names the choices (``expected max or top10``)."""
    def parse(text: str) -> str:
        if text not in choices:
            raise ValueError("no such choice")
        return text
    parse.__name__ = " or ".join(choices) if len(choices) <= 2 else "one of " + ", ".join(choices)
    return parse


def unit_interval(text: str) -> float:
    """A probability-like option value in [0, 1]."""
    v = float(text)
    if not 0.0 <= v <= 1.0:
        raise ValueError("must be between 0 and 1")
    return v


def nonnegative(text: str) -> float:
    """A finite number >= 0 (a threshold or a weight that may be switched off with 0)."""
    value = float(text)
    if not math.isfinite(value) or value < 0:
        raise ValueError("expected a number >= 0")
    return value


def positive(kind: Callable[[str], Any], most: float | None = None) -> Callable[[str], Any]:
    """Wrap ``int``/``float`` so values below 1 (ints) or at most 0 (floats) are refused, and,
    with ``most``, values above it (a size that would allocate terabytes is a typo, not a plan)."""
    def parse(text: str) -> Any:
        v = (whole_number if kind is int else kind)(text)
        if (kind is int and v < 1) or (kind is not int and v <= 0):
            raise ValueError("must be positive")
        if most is not None and v > most:
            raise ValueError(f"at most {most:g}")
        return v
    parse.__name__ = f"positive {kind.__name__}"
    parse.most = most                      # type: ignore[attr-defined]  (tests walk the bounds)
    return parse
