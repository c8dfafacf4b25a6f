"""PPDDL domains, problems, formulas and effects as small immutable values that print as PPDDL.

Why our own tree: the parser, the simulator, the rule converter and the determiniser all need
the same view of a domain, and the writer must be deterministic (sorted declarations, exact
probabilities). Probabilities and rewards are :class:`fractions.Fraction`, so ``1/3`` stays exact
and sums are checked without rounding; they print as decimals when the decimal is exact
(``3/4`` -> ``0.75``) and as ``p/q`` otherwise.

Formulas reuse :class:`groundsym.logic.Atom` (equality is the atom ``(= ?x ?y)``); effects reuse
:class:`groundsym.logic.Literal` for adds and deletes. One tree walker (:func:`to_sexp`) turns any
node into nested lists, and :func:`layout` prints those lists; every node's ``str`` goes through it.
"""

from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Union

from ..logic import Atom, Literal

OBJECT = "object"


@dataclass(frozen=True, order=True)
class Typed:
    """A typed name: a parameter ``?x - block``, an object ``b1 - block`` or a type ``block - object``."""

    name: str
    type: str = OBJECT


# ------------------------------------------------------------------------------------ formulas
@dataclass(frozen=True)
class Not:
    arg: "Formula"


@dataclass(frozen=True)
class And:
    args: tuple["Formula", ...] = ()


@dataclass(frozen=True)
class Or:
    args: tuple["Formula", ...] = ()


@dataclass(frozen=True)
class Imply:
    left: "Formula"
    right: "Formula"


@dataclass(frozen=True)
class Forall:
    params: tuple[Typed, ...]
    body: "Formula"


@dataclass(frozen=True)
class Exists:
    params: tuple[Typed, ...]
    body: "Formula"


Formula = Union[Atom, Not, And, Or, Imply, Forall, Exists]
TRUE = And(())


# ------------------------------------------------------------------------------------- effects
@dataclass(frozen=True)
class AndEffect:
    effects: tuple["Effect", ...] = ()


@dataclass(frozen=True)
class Probabilistic:
    """``(probabilistic p1 e1 ... pk ek)``; the missing mass ``1 - sum(p)`` means no change."""

    branches: tuple[tuple[Fraction, "Effect"], ...]

    @property
    def rest(self) -> Fraction:
        return 1 - sum((p for p, _ in self.branches), Fraction(0))


@dataclass(frozen=True)
class When:
    condition: Formula
    effect: "Effect"


@dataclass(frozen=True)
class ForallEffect:
    params: tuple[Typed, ...]
    effect: "Effect"


@dataclass(frozen=True)
class RewardEffect:
    """``(increase (reward) n)``; a decrease is stored as a negative amount."""

    amount: Fraction


Effect = Union[Literal, AndEffect, Probabilistic, When, ForallEffect, RewardEffect]
NO_EFFECT = AndEffect(())


# ---------------------------------------------------------------------------- domain & problem
@dataclass(frozen=True)
class Predicate:
    """A declared predicate; ``comment`` is printed after it (learned symbols say what they mean)."""

    name: str
    params: tuple[Typed, ...] = ()
    comment: str = field(default="", compare=False)   # printed, not parsed back

    @property
    def arity(self) -> int:
        return len(self.params)


@dataclass(frozen=True)
class Action:
    name: str
    parameters: tuple[Typed, ...] = ()
    precondition: Formula = TRUE
    effect: Effect = NO_EFFECT
    comment: str = field(default="", compare=False)   # printed, not parsed back


@dataclass(frozen=True)
class Axiom:
    """``(:derived (head ?x..) body)``: the head holds exactly when the body does (PDDL 2.2
    derived predicates, Edelkamp and Hoffmann 2004); a reader may put the body in its place."""

    head: Atom
    body: "Formula"


@dataclass(frozen=True)
class Domain:
    name: str
    requirements: tuple[str, ...] = ()
    types: tuple[Typed, ...] = ()          # (type, parent type)
    constants: tuple[Typed, ...] = ()
    predicates: tuple[Predicate, ...] = ()
    actions: tuple[Action, ...] = ()
    comment: str = field(default="", compare=False)   # printed, not parsed back
    functions: tuple[Predicate, ...] = ()
    axioms: tuple[Axiom, ...] = ()

    def __post_init__(self) -> None:
        # canonical order, so that equal domains compare equal whatever order a file used
        _set(self, "requirements", tuple(sorted(set(self.requirements))))
        _set(self, "types", tuple(sorted(self.types, key=lambda t: (t.type, t.name))))
        _set(self, "constants", tuple(sorted(self.constants, key=lambda t: (t.type, t.name))))
        _set(self, "predicates", tuple(sorted(self.predicates, key=lambda p: p.name)))
        _set(self, "actions", tuple(sorted(self.actions, key=lambda a: _natural(a.name))))
        _set(self, "functions", tuple(sorted(self.functions, key=lambda p: p.name)))
        _set(self, "axioms", tuple(sorted(self.axioms, key=lambda x: x.head.predicate)))

    def predicate(self, name: str) -> Predicate | None:
        return next((p for p in self.predicates if p.name == name), None)

    def action(self, name: str) -> Action | None:
        return next((a for a in self.actions if a.name == name), None)

    def __str__(self) -> str:
        return layout(to_sexp(self)) + "\n"


@dataclass(frozen=True)
class Problem:
    name: str
    domain: str
    objects: tuple[Typed, ...] = ()
    init: tuple[Atom, ...] = ()
    goal: Formula | None = None
    goal_reward: Fraction | None = None
    metric: tuple[str, str] | None = None   # ("maximize", "reward")
    requirements: tuple[str, ...] = ()
    comment: str = field(default="", compare=False)   # printed, not parsed back

    def __post_init__(self) -> None:
        _set(self, "requirements", tuple(sorted(set(self.requirements))))
        _set(self, "objects", tuple(sorted(self.objects, key=lambda t: (t.type, t.name))))
        _set(self, "init", tuple(sorted(set(self.init))))

    def __str__(self) -> str:
        return layout(to_sexp(self)) + "\n"


def _natural(name: str) -> tuple:
    """Sort key that puts ``stack_r2`` before ``stack_r10``."""
    return tuple((0, int(t), "") if t.isdigit() else (1, 0, t) for t in re.split(r"(\d+)", name))


def _set(obj: object, name: str, value: object) -> None:
    object.__setattr__(obj, name, value)


# ---------------------------------------------------------------------------------- the writer
class Commented:
    """An s-expression element followed by a ``;`` comment on its line."""

    def __init__(self, item: object, comment: str) -> None:
        self.item, self.comment = item, comment


def number(x: Fraction | int | float) -> str:
    """Exact PPDDL text of a number: a decimal when it terminates, else ``p/q``."""
    f = Fraction(x)
    d = f.denominator
    while d % 2 == 0:
        d //= 2
    while d % 5 == 0:
        d //= 5
    if d != 1:
        return f"{f.numerator}/{f.denominator}"
    if f.denominator == 1:
        return str(f.numerator)
    digits = 0
    while (f * 10 ** digits).denominator != 1:
        digits += 1
    sign = "-" if f < 0 else ""
    scaled = abs(f.numerator * 10 ** digits // f.denominator)
    text = str(scaled).rjust(digits + 1, "0")
    return f"{sign}{text[:-digits]}.{text[-digits:]}"


def typed_list(items: tuple[Typed, ...]) -> list[str]:
    """``?a ?b - block ?c``: consecutive names of one type share a ``- type`` tag; ``object``
    goes untagged only at the end (elsewhere PDDL would read the next group's tag for it too)."""
    out: list[str] = []
    for i, t in enumerate(items):
        out.append(t.name)
        last_of_group = i + 1 == len(items) or items[i + 1].type != t.type
        if last_of_group and (t.type != OBJECT or i + 1 < len(items)):
            out += ["-", t.type]
    return out


def typed_groups(items: tuple[Typed, ...], width: int = 80) -> list[str]:
    """Like :func:`typed_list`, as lines of at most about ``width`` characters (a long object list
    prints as a block of lines; the ``- type`` tag ends its group's last line)."""
    lines: list[str] = []
    line: list[str] = []
    words = typed_list(items)
    for i, w in enumerate(words):
        line.append(w)
        group_ends = i + 1 < len(words) and words[i + 1] != "-" and (len(line) >= 3 and line[-2] == "-")
        if group_ends or sum(len(x) + 1 for x in line) >= width and (i + 1 == len(words) or words[i + 1] != "-") \
                and w != "-":
            lines.append(" ".join(line))
            line = []
    if line:
        lines.append(" ".join(line))
    return lines


def to_sexp(node: object) -> object:
    """The one tree walker: any AST node -> nested lists of strings (and :class:`Commented`)."""
    if isinstance(node, (Atom, Literal)):
        return str(node)
    if isinstance(node, Not):
        return ["not", to_sexp(node.arg)]
    if isinstance(node, (And, Or)):
        return ["and" if isinstance(node, And) else "or", *map(to_sexp, node.args)]
    if isinstance(node, Imply):
        return ["imply", to_sexp(node.left), to_sexp(node.right)]
    if isinstance(node, (Forall, Exists, ForallEffect)):
        head = "exists" if isinstance(node, Exists) else "forall"
        body = node.effect if isinstance(node, ForallEffect) else node.body
        return [head, typed_list(node.params), to_sexp(body)]
    if isinstance(node, AndEffect):
        return ["and", *map(to_sexp, node.effects)]
    if isinstance(node, Probabilistic):
        out: list = ["probabilistic"]
        for p, e in node.branches:
            out += [number(p), to_sexp(e)]
        return out
    if isinstance(node, When):
        return ["when", to_sexp(node.condition), to_sexp(node.effect)]
    if isinstance(node, RewardEffect):
        op = "increase" if node.amount >= 0 else "decrease"
        return [op, ["reward"], number(abs(node.amount))]
    if isinstance(node, Domain):
        return _domain_sexp(node)
    if isinstance(node, Problem):
        return _problem_sexp(node)
    raise TypeError(f"not a PPDDL node: {node!r}")


def _comment_lines(text: str) -> list[Commented]:
    return [Commented(None, line) for line in text.splitlines()] if text else []


def _domain_sexp(d: Domain) -> list:
    out: list = ["define", ["domain", d.name], *_comment_lines(d.comment)]
    if d.requirements:
        out.append([":requirements", *sorted(set(d.requirements))])
    if d.types:
        out.append([":types", *typed_groups(tuple(sorted(d.types, key=lambda t: (t.type, t.name))))])
    if d.constants:
        out.append([":constants", *typed_groups(tuple(sorted(d.constants, key=lambda t: (t.type, t.name))))])
    preds: list = [":predicates"]
    for p in sorted(d.predicates, key=lambda p: p.name):
        item = [p.name, *typed_list(p.params)]
        preds.append(Commented(item, p.comment) if p.comment else item)
    out.append(preds)
    if d.functions:
        out.append([":functions", *([f.name, *typed_list(f.params)] for f in sorted(d.functions, key=lambda f: f.name))])
    for x in d.axioms:
        out.append([":derived", str(x.head), to_sexp(x.body)])
    for a in d.actions:
        act: list = [":action", a.name, *_comment_lines(a.comment), ":parameters", typed_list(a.parameters)]
        # always written, ``(and)`` when empty: some readers (plado) fail on an action without one
        act += [":precondition", to_sexp(a.precondition)]
        act += [":effect", to_sexp(a.effect)]
        out.append(act)
    return out


def _problem_sexp(p: Problem) -> list:
    out: list = ["define", ["problem", p.name], *_comment_lines(p.comment), [":domain", p.domain]]
    if p.requirements:
        out.append([":requirements", *sorted(set(p.requirements))])
    out.append([":objects", *typed_groups(tuple(sorted(p.objects, key=lambda t: (t.type, t.name))))])
    out.append([":init", *(str(a) for a in sorted(set(p.init)))])
    if p.goal is not None:
        out.append([":goal", to_sexp(p.goal)])
    if p.goal_reward is not None:
        out.append([":goal-reward", number(p.goal_reward)])
    if p.metric is not None:
        out.append([":metric", p.metric[0], [p.metric[1]]])
    return out


WIDTH = 100
_KEYS_WITH_VALUE = {":parameters", ":precondition", ":effect"}


def _flat(x: object) -> str | None:
    """One-line text of an s-expression, or None if it holds a comment."""
    if isinstance(x, str):
        return x
    if isinstance(x, Commented):
        return None
    parts = [_flat(y) for y in x]  # type: ignore[union-attr]
    if any(p is None for p in parts):
        return None
    return "(" + " ".join(parts) + ")"  # type: ignore[arg-type]


def _commented(item: Commented, pad: str) -> list[str]:
    """An element with its comment: on one line when that fits in :data:`WIDTH`, else the comment
    wrapped into lines of its own above the element."""
    text = "" if item.item is None else layout(item.item, len(pad))
    if len(pad) + len(text) + 4 + len(item.comment) <= WIDTH and "\n" not in text:
        return [pad + (text + "  " if text else "") + "; " + item.comment]
    wrapped = textwrap.wrap(item.comment, WIDTH - len(pad) - 2, break_long_words=False, break_on_hyphens=False)
    return [pad + "; " + line for line in wrapped or [""]] + ([pad + text] if text else [])


def layout(x: object, indent: int = 0) -> str:
    """Print an s-expression: on one line when it fits, else one element per line, indented."""
    flat = _flat(x)
    if isinstance(x, str) or flat is not None and indent + len(flat) <= WIDTH:
        return flat
    assert isinstance(x, list)
    pad = " " * (indent + 2)
    head = x[0] if isinstance(x[0], str) else layout(x[0], indent + 1)
    lines = ["(" + head]
    i = 1
    while i < len(x):
        item = x[i]
        if isinstance(item, Commented):
            lines += _commented(item, pad)
        elif head == "probabilistic" and isinstance(item, str) and i + 1 < len(x):
            lines.append(pad + item + " " + layout(x[i + 1], indent + 3 + len(item)))
            i += 1
        elif isinstance(item, str) and item in _KEYS_WITH_VALUE and i + 1 < len(x):
            value = layout(x[i + 1], indent + 3 + len(item))
            lines.append(pad + item + " " + value)
            i += 1
        elif i == 1 and head in ("define", ":action", "forall", "exists"):
            lines[0] += " " + (item if isinstance(item, str) else _flat(item) or "")
        else:
            lines.append(pad + layout(item, indent + 2))
        i += 1
    if isinstance(x[-1], Commented):
        lines.append(" " * indent + ")")
    else:
        lines[-1] += ")"
    return "\n".join(lines)


# every node prints itself through the one walker (assigned here, after the walker is defined)
for _cls in (Not, And, Or, Imply, Forall, Exists, AndEffect, Probabilistic, When, ForallEffect, RewardEffect):
    _cls.__str__ = lambda self: layout(to_sexp(self))  # type: ignore[method-assign]
Action.__str__ = lambda self: layout(_domain_sexp(Domain("_", actions=(self,)))[-1])  # type: ignore[method-assign]
