"""PPDDL formulas as RDDL boolean expressions (Sanner 2010, section "Expressions").

Why a translator of its own rather than text substitution: a PPDDL variable may be renamed (the
head variables of a conditional probability function replace an action's parameters), and a
quantifier's own variables must then shadow the renaming; RDDL also spells equality, constants
and quantifiers differently (``(?x == @b1)``, ``exists_{?z : obj}[...]``).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Callable, Mapping, Sequence

from ..logic import Atom, is_variable
from ..ppddl.ast import OBJECT, And, Exists, Forall, Formula, Imply, Not, Or, Typed
from .names import Identifiers, variable

OBJECT_TYPE = "obj"          # the RDDL type of PPDDL's untyped ``object``


@dataclass(frozen=True)
class Pick:
    """``draw(args)`` fell in ``[low, high)``: the branch of a ``probabilistic`` effect that
    happened (one uniform draw per probabilistic block keeps its outcomes joint)."""

    draw: str
    args: tuple[str, ...]
    low: Fraction
    high: Fraction


Condition = Formula | Pick


def real(x: Fraction | float) -> str:
    """A real number as RDDL reads it: exact decimals stay short (``0.7692``), the rest get the
    17 significant digits that read back as the same double."""
    f = float(x)
    text = repr(f)
    return text if "e" not in text else f"{f:.17f}".rstrip("0")


class Expressions:
    """Writes formulas over one translation's names. ``fluent(predicate, primed)`` gives the
    written name of a predicate (a state fluent primed in the next state, a non-fluent never)."""

    def __init__(self, ids: Identifiers, types: Callable[[str], str],
                 fluent: Callable[[str, bool], str]) -> None:
        self.ids = ids
        self.types = types
        self.fluent = fluent

    def term(self, t: str, ren: Mapping[str, str]) -> str:
        if is_variable(t):
            return ren.get(t, variable(t))
        return "@" + self.ids(t)

    def typed(self, params: Sequence[Typed], ren: Mapping[str, str] | None = None) -> str:
        return ", ".join(f"{self.term(p.name, ren or {})} : {self.types(p.type)}" for p in params)

    def atom(self, a: Atom, ren: Mapping[str, str], primed: bool = False) -> str:
        if a.predicate == "=":
            x, y = (self.term(t, ren) for t in a.args)
            return f"({x} == {y})"
        name = self.fluent(a.predicate, primed)
        return f"{name}({', '.join(self.term(t, ren) for t in a.args)})" if a.args else name

    def formula(self, f: Condition, ren: Mapping[str, str] | None = None, primed: bool = False) -> str:
        """``f`` as RDDL; ``ren``: free variables to write as other variables."""
        ren = ren or {}
        if isinstance(f, Pick):
            d = f"{f.draw}({', '.join(self.term(a, ren) for a in f.args)})" if f.args else f.draw
            parts = ([f"{d} >= {real(f.low)}"] if f.low > 0 else []) + ([f"{d} < {real(f.high)}"] if f.high < 1 else [])
            return "(" + " ^ ".join(parts) + ")" if parts else "true"
        if isinstance(f, Atom):
            return self.atom(f, ren, primed)
        if isinstance(f, Not):
            return "~" + self.formula(f.arg, ren, primed)
        if isinstance(f, (And, Or)):
            if not f.args:
                return "true" if isinstance(f, And) else "false"
            if len(f.args) == 1:
                return self.formula(f.args[0], ren, primed)
            op = " ^ " if isinstance(f, And) else " | "
            return "(" + op.join(self.formula(g, ren, primed) for g in f.args) + ")"
        if isinstance(f, Imply):
            return f"({self.formula(f.left, ren, primed)} => {self.formula(f.right, ren, primed)})"
        if isinstance(f, (Forall, Exists)):
            inner = {k: v for k, v in ren.items() if k not in {p.name for p in f.params}}
            head = "forall_" if isinstance(f, Forall) else "exists_"
            # in parentheses: RDDL's quantifiers reach as far right as they can
            return f"({head}{{{self.typed(f.params)}}}[{self.formula(f.body, inner, primed)}])"
        raise TypeError(f"not a formula: {f!r}")


def type_namer(ids: Identifiers) -> Callable[[str], str]:
    """PPDDL type -> RDDL type (``object`` is :data:`OBJECT_TYPE`)."""
    return lambda t: OBJECT_TYPE if t == OBJECT else ids(t)
