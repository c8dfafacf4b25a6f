"""Parse PPDDL domains and problems (as the IPPC wrote them) into :mod:`groundsym.ppddl.ast`.

The lark grammar (``grammar.lark``) defines the syntax; :mod:`.reader` builds the same parse tree
several times faster and hands anything it does not accept to lark, whose verdict and message
stand. This module walks the parse tree top-down with the declarations in scope, so that a
misspelt predicate, a wrong arity, an undeclared variable, type or object, a negative probability
or probabilities summing above 1 are reported with the file, line and column of the offending
text, as one line (a :class:`PPDDLError`).

A file may hold several ``define``s: IPPC-2008 problem files repeat their domain.

Why one module of about 450 lines: the walk is one recursive descent over one grammar, each
rule's checks beside the rule, and the scope it carries (declared types, predicates, variables)
is shared by all of them.
"""

from __future__ import annotations

import gc
import re
from contextlib import contextmanager
from fractions import Fraction
from functools import lru_cache
from pathlib import Path
from typing import Callable, Iterable, Iterator, Mapping

import lark
import numpy as np

from ..errors import UserError
from ..fileio import read_text
from ..logic import Atom, Literal
from .ast import (NO_EFFECT, OBJECT, TRUE, Action, And, AndEffect, Axiom, Domain, Effect, Exists, Forall,
                  ForallEffect, Formula, Imply, Not, Or, Predicate, Probabilistic, Problem, RewardEffect,
                  Typed, When)
from .axioms import inline
from .reader import NotFast, read


class PPDDLError(UserError):
    """A PPDDL file that does not parse or does not make sense; the message names file:line:column."""


@lru_cache(maxsize=2)
def _lark(positions: bool = False) -> lark.Lark:
    """The parser; with ``positions`` every tree node knows its line and column. That nearly
    doubles the time of a large file, so files are read without, and a file whose content is
    wrong is read again with positions to say where (parse_text)."""
    grammar = (Path(__file__).with_name("grammar.lark")).read_text(encoding="utf-8")
    return lark.Lark(grammar, parser="lalr", propagate_positions=positions, maybe_placeholders=False)


_TOKEN_NAMES = {"LPAR": "'('", "RPAR": "')'", "NAME": "a name", "VARIABLE": "a ?variable",
                "NUMBER": "a number", "MINUS": "'-'", "REQUIREMENT": "a :requirement", "$END": "end of file"}


def _syntax_error(exc: lark.exceptions.LarkError, path: str) -> PPDDLError:
    line, col = getattr(exc, "line", "?"), getattr(exc, "column", "?")
    if isinstance(exc, lark.exceptions.UnexpectedToken):
        got = "end of file" if exc.token.type == "$END" else repr(str(exc.token))
        nice = sorted({_TOKEN_NAMES.get(e, "") for e in exc.expected} - {""})
        hint = f"; expected {' or '.join(nice)}" if nice and len(nice) <= 4 else ""
        return PPDDLError(f"{path}:{line}:{col}: syntax error: unexpected {got}{hint}")
    if isinstance(exc, lark.exceptions.UnexpectedCharacters):
        return PPDDLError(f"{path}:{line}:{col}: syntax error: unexpected character {exc.char!r}")
    if isinstance(exc, lark.exceptions.UnexpectedEOF):
        return PPDDLError(f"{path}: syntax error: unexpected end of file (unbalanced parentheses?)")
    return PPDDLError(f"{path}: syntax error: {str(exc).splitlines()[0]}")


def _lark_position(node: lark.Tree | lark.Token) -> tuple[int | str, int | str]:
    """Line and column of a node of a tree lark built with positions."""
    meta = node if isinstance(node, lark.Token) else node.meta
    return getattr(meta, "line", "?"), getattr(meta, "column", "?")


Locate = Callable[["lark.Tree | lark.Token"], "tuple[int | str, int | str]"]


@lru_cache(maxsize=4096)
def _fraction(text: str) -> Fraction | None:
    """A number as written (cached: a large file repeats its few probabilities, and Fraction's
    parser is slow); None for ``1/0``."""
    try:
        return Fraction(text)
    except (ValueError, ZeroDivisionError):
        return None


@lru_cache(maxsize=4096)
def _in_unit_interval(text: str) -> bool:
    """Whether a probability as written (a number, see _fraction) is in [0, 1]; cached by its text,
    since Fraction comparisons are slow and a file repeats its few probabilities."""
    value = _fraction(text)
    return value is not None and 0 <= value <= 1


@lru_cache(maxsize=4096)
def _sum_of(texts: tuple[str, ...]) -> Fraction:
    """The exact sum of the probabilities of one ``probabilistic`` (numbers, as written)."""
    return sum((_fraction(t) or Fraction(0) for t in texts), Fraction(0))


class _Walker:
    """Builds AST nodes from the parse tree; knows the file name, and how to find a node's line
    and column (which depends on who built the tree), for its error messages."""

    def __init__(self, path: str, locate: Locate = _lark_position) -> None:
        self.path = path
        self.locate = locate

    def fail(self, node: lark.Tree | lark.Token, msg: str) -> PPDDLError:
        line, col = self.locate(node)
        return PPDDLError(f"{self.path}:{line}:{col}: {msg}")

    # ------------------------------------------------------------------ shared pieces
    def number(self, tok: lark.Token) -> Fraction:
        value = _fraction(str(tok))
        if value is None:
            raise self.fail(tok, f"not a number: {tok}")
        return value

    def typed(self, tree: lark.Tree, types: Mapping[str, str] | None) -> tuple[Typed, ...]:
        """A flat typed list (``?a ?b - t ?c``) -> Typed items; untyped names are ``object``."""
        out: list[Typed] = []
        pending: list[str] = []
        for child in tree.children:
            if isinstance(child, lark.Token):
                pending.append(str(child))
                continue
            type_node = child.children[0]
            if isinstance(type_node, lark.Tree):
                raise self.fail(type_node, "(either ...) types are not supported")
            tname = str(type_node)
            if types is not None and tname != OBJECT and tname not in types:
                raise self.fail(type_node, f"unknown type {tname!r}")
            if not pending:
                raise self.fail(type_node, f"type {tname!r} follows no name")
            out += [Typed(n, tname) for n in pending]
            pending = []
        out += [Typed(n) for n in pending]
        seen: set[str] = set()
        for t in out:
            if t.name in seen:
                raise self.fail(tree, f"{t.name} is declared twice")
            seen.add(t.name)
        return tuple(out)


class _Scope:
    """What a formula may mention: predicates, objects/constants and the variables bound so far."""

    def __init__(self, walker: _Walker, predicates: Mapping[str, Predicate], objects: Mapping[str, str],
                 types: Mapping[str, str], variables: Mapping[str, str] | None = None) -> None:
        self.w, self.predicates, self.objects, self.types = walker, predicates, objects, types
        self.variables = dict(variables or {})

    def bind(self, params: Iterable[Typed]) -> "_Scope":
        return _Scope(self.w, self.predicates, self.objects, self.types,
                      {**self.variables, **{p.name: p.type for p in params}})

    def term(self, tok: lark.Token) -> str:
        name = str(tok)
        if tok.type == "VARIABLE":
            if name not in self.variables:
                raise self.w.fail(tok, f"undeclared variable {name}")
        elif name not in self.objects:
            raise self.w.fail(tok, f"unknown object or constant {name!r}")
        return name

    def atom(self, tree: lark.Tree) -> Atom:
        """(The hot path of a large file: plain strings as keys, the checks of term() inline.)"""
        children = tree.children
        pred = self.predicates.get(str(children[0]))
        if pred is None:
            raise self.w.fail(children[0], f"unknown predicate {str(children[0])!r}")
        if len(children) - 1 != pred.arity:
            raise self.w.fail(tree, f"{pred.name} takes {pred.arity} argument(s), got {len(children) - 1}")
        args = []
        for tok in children[1:]:
            name = str(tok)
            if name not in (self.variables if tok.type == "VARIABLE" else self.objects):
                self.term(tok)                  # raises, naming what is wrong
            args.append(name)
        return Atom(pred.name, tuple(args))

    def formula(self, tree: lark.Tree) -> Formula:
        kind = tree.data
        if kind == "atom":
            return self.atom(tree)
        if kind == "empty":
            return TRUE
        if kind in ("and_", "or_"):
            args = tuple(self.formula(c) for c in tree.children)
            return And(args) if kind == "and_" else Or(args)
        if kind == "not_":
            return Not(self.formula(tree.children[0]))
        if kind == "imply":
            return Imply(self.formula(tree.children[0]), self.formula(tree.children[1]))
        if kind in ("forall", "exists"):
            params = self.w.typed(tree.children[0], self.types)
            body = self.bind(params).formula(tree.children[1])
            return Forall(params, body) if kind == "forall" else Exists(params, body)
        if kind == "equal":
            return Atom("=", tuple(self.term(t) for t in tree.children))
        raise self.w.fail(tree, f"unexpected {kind} in a formula")

    def effect(self, tree: lark.Tree) -> Effect:
        kind = tree.data
        if kind == "atom":
            return Literal(self.atom(tree), True)
        if kind == "delete":
            return Literal(self.atom(tree.children[0]), False)
        if kind == "empty":
            return NO_EFFECT
        if kind == "and_effect":
            return AndEffect(tuple(self.effect(c) for c in tree.children))
        if kind == "when":
            return When(self.formula(tree.children[0]), self.effect(tree.children[1]))
        if kind == "forall_effect":
            params = self.w.typed(tree.children[0], self.types)
            return ForallEffect(params, self.bind(params).effect(tree.children[1]))
        if kind == "probabilistic":
            return self.probabilistic(tree)
        if kind == "reward_effect":
            op, fluent, amount = tree.children
            name = fluent.children[0]
            if str(name) != "reward":
                raise self.w.fail(name, f"only the reward fluent is supported, not {str(name)!r}")
            value = self.w.number(amount)
            return RewardEffect(value if str(op).lower() == "increase" else -value)
        raise self.w.fail(tree, f"unexpected {kind} in an effect")

    def probabilistic(self, tree: lark.Tree) -> Probabilistic:
        kids = tree.children
        branches = []
        for tok, eff in zip(kids[0::2], kids[1::2]):
            p = self.w.number(tok)
            if not _in_unit_interval(str(tok)):
                raise self.w.fail(tok, f"probability {tok} is outside [0, 1]")
            branches.append((p, self.effect(eff)))
        total = _sum_of(tuple(str(t) for t in kids[0::2]))
        if total > 1:
            raise self.w.fail(tree, f"probabilities sum to {float(total):g}, above 1")
        return Probabilistic(tuple(branches))


def _sections(tree: lark.Tree, kinds: Iterable[str]) -> list[lark.Tree]:
    return [c for c in tree.children if isinstance(c, lark.Tree) and c.data in kinds]


def _domain(w: _Walker, tree: lark.Tree) -> Domain:
    name = str(tree.children[0])
    requirements = tuple(str(t).lower() for s in _sections(tree, ["requirements"]) for t in s.children)
    types: dict[str, str] = {}
    for s in _sections(tree, ["types"]):
        for t in w.typed(s.children[0], None):
            types[t.name] = t.type
    for tname, parent in types.items():
        if parent != OBJECT and parent not in types:
            raise w.fail(tree, f"type {tname!r} has an undeclared parent type {parent!r}")
    constants = tuple(t for s in _sections(tree, ["constants"]) for t in w.typed(s.children[0], types))
    predicates: dict[str, Predicate] = {}
    for s in _sections(tree, ["predicates"]):
        for decl in s.children:
            pname = str(decl.children[0])
            if pname in predicates:
                raise w.fail(decl, f"predicate {pname!r} is declared twice")
            predicates[pname] = Predicate(pname, w.typed(decl.children[1], types))
    functions = tuple(Predicate(str(d.children[0]), w.typed(d.children[1], types))
                      for s in _sections(tree, ["functions"]) for d in s.children)
    scope = _Scope(w, predicates, {c.name: c.type for c in constants}, types)
    axioms = tuple(_axiom(w, x, scope) for x in _sections(tree, ["derived"]))
    heads = {x.head.predicate for x in axioms}
    for node, x in zip(_sections(tree, ["derived"]), axioms):
        used = heads & set(re.findall(r"\(([^\s()]+)", str(x.body)))
        if used:
            raise w.fail(node, f"derived predicate {x.head.predicate!r}: its body uses the derived predicate "
                               f"{min(used)!r} (only bodies over base predicates are read)")
    actions: list[Action] = []
    seen: set[str] = set()      # a set, not a scan of the list: 100k actions parse in linear time
    for a in _sections(tree, ["action"]):
        actions.append(_action(w, a, scope))
        if actions[-1].name in seen:
            raise w.fail(a, f"action {actions[-1].name!r} is declared twice")
        seen.add(actions[-1].name)
    return inline(Domain(name, requirements, tuple(Typed(k, v) for k, v in types.items()), constants,
                         tuple(predicates.values()), tuple(actions), functions=functions, axioms=axioms))


def _axiom(w: _Walker, tree: lark.Tree, scope: _Scope) -> Axiom:
    """``(:derived (p ?x..) body)``: ``p`` declared, with those arguments; the body over base
    predicates (put in place by :func:`.axioms.inline`, so a derived predicate may not use one)."""
    name = str(tree.children[0])
    params = w.typed(tree.children[1], scope.types)
    pred = scope.predicates.get(name)
    if pred is None:
        raise w.fail(tree, f"derived predicate {name!r} is not declared in :predicates")
    if len(pred.params) != len(params):
        raise w.fail(tree, f"derived predicate {name!r} takes {len(pred.params)} argument(s), the axiom gives "
                           f"{len(params)}")
    body = scope.bind(params).formula(tree.children[2])
    return Axiom(Atom(name, tuple(p.name for p in params)), body)


def _action(w: _Walker, tree: lark.Tree, scope: _Scope) -> Action:
    name = str(tree.children[0])
    parts: dict[str, list[lark.Tree]] = {"parameters": [], "precondition": [], "effect_part": []}
    for part in tree.children[1:]:           # one pass: a large file has one action after another
        parts[str(part.data)].append(part.children[0])
    params: tuple[Typed, ...] = ()
    for typed in parts["parameters"]:
        params = w.typed(typed, scope.types)
    inner = scope.bind(params)
    pre: Formula = TRUE
    eff: Effect = NO_EFFECT
    for formula in parts["precondition"]:
        pre = inner.formula(formula)
    for effect in parts["effect_part"]:
        eff = inner.effect(effect)
    return Action(name, params, pre, eff)


def _problem(w: _Walker, tree: lark.Tree, domains: Mapping[str, Domain]) -> Problem:
    name = str(tree.children[0])
    dom_sections = _sections(tree, ["problem_domain"])
    if not dom_sections:
        raise w.fail(tree, f"problem {name!r} names no (:domain ...)")
    dname = str(dom_sections[0].children[0])
    domain = domains.get(dname)
    types = {t.name: t.type for t in domain.types} if domain else None
    objects = tuple(t for s in _sections(tree, ["objects"]) for t in w.typed(s.children[0], types))
    scope = None
    if domain is not None:
        known = {**{c.name: c.type for c in domain.constants}, **{o.name: o.type for o in objects}}
        scope = _Scope(w, {p.name: p for p in domain.predicates}, known, types or {})
    init: list[Atom] = []
    for s in _sections(tree, ["init"]):
        for item in s.children:
            if item.data == "atom":
                init.append(scope.atom(item) if scope else _raw_atom(item))
    goal = None
    for s in _sections(tree, ["goal"]):
        goal = scope.formula(s.children[0]) if scope else None
    goal_reward = None
    for s in _sections(tree, ["goal_reward"]):
        goal_reward = w.number(s.children[0])
    metric = None
    for s in _sections(tree, ["metric"]):
        metric = (str(s.children[0]).lower(), str(s.children[1]))
    requirements = tuple(str(t).lower() for s in _sections(tree, ["requirements"]) for t in s.children)
    return Problem(name, dname, objects, tuple(init), goal, goal_reward, metric, requirements)


def _raw_atom(tree: lark.Tree) -> Atom:
    return Atom(str(tree.children[0]), tuple(str(t) for t in tree.children[1:]))


MAX_DEPTH = 200   # parentheses; real domains nest a few dozen deep, and the tree walk recurses per level


def _check_depth(text: str, path: str) -> None:
    """Refuse absurdly deep nesting in one line before the parser and the recursive tree walk meet
    it (3,000 levels used to end in RecursionError). Linear in the text, comments ignored."""
    if text.count("(") <= MAX_DEPTH:
        return
    plain = re.sub(r";[^\n]*", lambda m: " " * len(m.group()), text)
    codes = np.frombuffer(plain.encode("utf-32-le"), dtype=np.uint32)
    depth = np.cumsum((codes == ord("(")).astype(np.int32) - (codes == ord(")")))
    deep = np.flatnonzero(depth > MAX_DEPTH)
    if deep.size:
        at = int(deep[0])
        line = plain.count("\n", 0, at) + 1
        col = at - plain.rfind("\n", 0, at)
        raise PPDDLError(f"{path}:{line}:{col}: parentheses nested more than {MAX_DEPTH} deep")


def parse_text(text: str, path: str | Path = "<string>",
               domains: Mapping[str, Domain] | None = None) -> tuple[list[Domain], list[Problem]]:
    """All domains and problems in ``text``; problems are checked against a domain of the same
    text or of ``domains`` (by its name) when one is known."""
    _check_depth(text, str(path))
    with _no_cycle_collection():
        try:
            tree, reader = read(text)
        except NotFast:
            return parse_text_lark(text, path, domains)
        return _walk(tree, str(path), domains, reader.locate)


@contextmanager
def _no_cycle_collection() -> Iterator[None]:
    """Pause Python's cycle collector: a large file makes millions of tree and AST objects, none in
    a cycle, and the collector's passes over them, triggered by the allocations, took as long as
    the parse itself (a 10,000-action file: 2.7 s of CPU with it, 1.1 s without)."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def parse_text_lark(text: str, path: str | Path = "<string>",
                    domains: Mapping[str, Domain] | None = None) -> tuple[list[Domain], list[Problem]]:
    """:func:`parse_text` with lark's parser alone: the reference :mod:`.reader` is tested against,
    and the judge of every text the reader does not accept."""
    _check_depth(text, str(path))
    try:
        tree = _lark().parse(text)
    except lark.exceptions.LarkError as exc:
        raise _syntax_error(exc, str(path)) from None
    try:
        return _walk(tree, str(path), domains)
    except PPDDLError:                   # the same error again, now with its line and column
        return _walk(_lark(positions=True).parse(text), str(path), domains)


def _walk(tree: lark.Tree, path: str, domains: Mapping[str, Domain] | None,
          locate: Locate = _lark_position) -> tuple[list[Domain], list[Problem]]:
    w = _Walker(path, locate)
    known = dict(domains or {})
    out_d: list[Domain] = []
    out_p: list[Problem] = []
    for node in tree.children:
        if node.data == "domain":
            d = _domain(w, node)
            known[d.name] = d
            out_d.append(d)
        else:
            p = _problem(w, node, known)
            if p.domain not in known:
                raise w.fail(node, f"problem {p.name!r} is for domain {p.domain!r}, which is not loaded")
            out_p.append(p)
    return out_d, out_p


def parse_file(path: str | Path, domains: Mapping[str, Domain] | None = None) -> tuple[list[Domain], list[Problem]]:
    return parse_text(read_text(path), path, domains)


def parse_domain(text: str, path: str | Path = "<string>") -> Domain:
    ds, _ = parse_text(text, path)
    if not ds:
        raise PPDDLError(f"{path}: holds no (define (domain ...))")
    return ds[0]


def parse_problem(text: str, domain: Domain, path: str | Path = "<string>") -> Problem:
    _, ps = parse_text(text, path, {domain.name: domain})
    if not ps:
        raise PPDDLError(f"{path}: holds no (define (problem ...))")
    return ps[0]


def load_domain(path: str | Path) -> Domain:
    return parse_domain(read_text(path), path)


def load(domain_path: str | Path, problem_path: str | Path | None = None) -> tuple[Domain, Problem | None]:
    """The domain of ``domain_path`` and the first problem of ``problem_path`` (or of the domain file).

    A problem file that repeats its domain (IPPC-2008) is fine: its problem is checked against the
    domain of ``domain_path``, which must have the same name.
    """
    ds, ps = parse_file(domain_path)
    if not ds:
        raise PPDDLError(f"{domain_path}: holds no (define (domain ...))")
    domain = ds[0]
    if problem_path is not None and Path(problem_path) != Path(domain_path):
        _, ps = parse_file(problem_path, {domain.name: domain})
        if not ps:
            raise PPDDLError(f"{problem_path}: holds no (define (problem ...))")
    if ps and ps[0].domain != domain.name:
        raise PPDDLError(f"{problem_path or domain_path}: problem {ps[0].name!r} is for domain "
                         f"{ps[0].domain!r}, not {domain.name!r}")
    return domain, (ps[0] if ps else None)
