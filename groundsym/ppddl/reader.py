"""A tokenizer-driven reader for PPDDL that builds the very trees ``grammar.lark`` builds, faster.

Why: lark's LALR parser spends most of a large file's time in its Python lexer and parser loop
(about 14 microseconds a token, so 100,000 actions took over a minute). Here the text is split
into words with ``str`` methods (C speed), each distinct word is classified once with the
grammar's own terminal patterns, and a recursive descent over the word list follows the grammar
rule by rule, building the ``lark.Tree``/``lark.Token`` objects lark would build, so the one
walker in :mod:`.parser` turns either into the AST.

The lark grammar stays the reference: whatever this reader does not accept (a syntax error, or a
spelling lark's lexer splits differently, such as ``?x -t`` or ``(=?a ?b)``) raises
:class:`NotFast`, and the caller hands the text to lark, whose verdict and message stand. A test
checks that where this reader accepts, lark gives the same tree with the same positions.

Positions cost nothing until an error is reported: a token keeps its index in the word list as
``start_pos`` and a tree the index of its first word in ``meta`` (:class:`Mark`);
:meth:`Reader.locate` turns an index into lark's line and column by scanning the text again.
"""

from __future__ import annotations

import re
from typing import Callable

import lark

NAME, VARIABLE, NUMBER, REQUIREMENT = "NAME", "VARIABLE", "NUMBER", "REQUIREMENT"
_WORD = r"[a-zA-Z][a-zA-Z0-9_\-]*"        # grammar.lark's NAME; VARIABLE and REQUIREMENT prefix it
_KINDS = re.compile(rf"(\?{_WORD})|(:{_WORD})|(-?(?:\d+/\d+|\d*\.\d+|\d+))|({_WORD})|(-)|(=)|([()])")
_KIND_OF_GROUP = (None, VARIABLE, REQUIREMENT, NUMBER, NAME, "-", "=", "paren")
_COMMENT = re.compile(r";[^\n]*")
_OTHER_SPACE = re.compile(r"[^\S \t\f\r\n]")   # white space str.split() skips but the grammar does not
_WORDS_AGAIN = re.compile(r";[^\n]*|[()]|[^\s();]+")   # the same words, with their offsets
_END = ""                                       # after the last word; no word is empty

_GD = {"and": "and_", "or": "or_", "not": "not_", "imply": "imply", "exists": "exists", "forall": "forall"}
_EFFECT = {"and", "not", "when", "forall", "probabilistic", "increase", "decrease"}
_DOMAIN_ITEMS = {":requirements", ":types", ":constants", ":predicates", ":functions", ":action"}
_ACTION_PARTS = {":parameters", ":precondition", ":effect"}
_PROBLEM_ITEMS = {":domain", ":requirements", ":objects", ":init", ":goal", ":goal-reward", ":metric"}
_token = lark.Token._future_new               # the constructor without its deprecated-keyword check


class NotFast(Exception):
    """This reader does not accept the text: lark (the reference) decides and words the error."""


class Mark:
    """A tree's position: the index of its first word (lark's meta holds line and column)."""

    __slots__ = ("index",)

    def __init__(self, index: int) -> None:
        self.index = index


def words(text: str) -> list[str]:
    """The words of ``text`` (parentheses, names, numbers...), comments dropped."""
    if ";" in text:
        text = _COMMENT.sub("", text)
    if _OTHER_SPACE.search(text):
        raise NotFast
    return text.replace("(", " ( ").replace(")", " ) ").split()


def kinds(ws: list[str]) -> dict[str, str]:
    """The terminal of every distinct word; a word no terminal matches whole is lark's to judge."""
    out = {}
    for w in set(ws):
        m = _KINDS.fullmatch(w)
        if m is None:
            raise NotFast
        out[w] = _KIND_OF_GROUP[m.lastindex or 0]
    return out


class Reader:
    """Recursive descent over the words, one method per rule of grammar.lark."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.t = words(text)
        self.k = kinds(self.t)
        self.t.append(_END)
        self.i = 0
        self._offsets: list[int] | None = None

    # ------------------------------------------------------------------ positions
    def locate(self, node: lark.Tree | lark.Token) -> tuple[int | str, int | str]:
        """Line and column (1-based, as lark counts) of a node this reader built."""
        index = node.start_pos if isinstance(node, lark.Token) else getattr(node._meta, "index", None)
        if index is None or index >= len(self.t) - 1:
            return "?", "?"
        if self._offsets is None:
            self._offsets = [m.start() for m in _WORDS_AGAIN.finditer(self.text) if m.group()[0] != ";"]
        at = self._offsets[index]
        return self.text.count("\n", 0, at) + 1, at - self.text.rfind("\n", 0, at)

    # ------------------------------------------------------------------ words
    def expect(self, word: str) -> None:
        if self.t[self.i] != word:
            raise NotFast
        self.i += 1

    def keyword(self, options: set[str] | dict[str, str]) -> str:
        low = self.t[self.i].lower()
        if low not in options:
            raise NotFast
        self.i += 1
        return low

    def terminal(self, kind: str) -> lark.Token:
        w = self.t[self.i]
        if self.k.get(w) != kind:
            raise NotFast
        self.i += 1
        return _token(kind, w, self.i - 1)

    def term(self) -> lark.Token:
        w = self.t[self.i]
        kind = self.k.get(w)
        if kind is not NAME and kind is not VARIABLE:
            raise NotFast
        self.i += 1
        return _token(kind, w, self.i - 1)

    # ------------------------------------------------------------------ file structure
    def start(self) -> lark.Tree:
        defines = []
        while self.t[self.i] is not _END:
            defines.append(self.define())
        return lark.Tree("start", defines)

    def define(self) -> lark.Tree:
        at = self.i
        self.expect("(")
        self.keyword({"define"})
        self.expect("(")
        kind = self.keyword({"domain", "problem"})
        children: list = [self.terminal(NAME)]
        self.expect(")")
        item = self.domain_item if kind == "domain" else self.problem_item
        while self.t[self.i] == "(":
            children.append(item())
        self.expect(")")
        return lark.Tree(kind, children, Mark(at))

    def domain_item(self) -> lark.Tree:
        at = self.i
        self.i += 1
        key = self.keyword(_DOMAIN_ITEMS)
        if key == ":requirements":
            tree = self.requirements(at)
        elif key in (":types", ":constants"):
            tree = lark.Tree(key[1:], [self.typed(NAME, "typed_names")], Mark(at))
        elif key == ":predicates":
            tree = lark.Tree("predicates", self.declarations("predicate_decl", False), Mark(at))
        elif key == ":functions":
            tree = lark.Tree("functions", self.declarations("function_decl", True), Mark(at))
        else:
            return self.action(at)
        self.expect(")")
        return tree

    def requirements(self, at: int) -> lark.Tree:
        reqs = []
        while self.k.get(self.t[self.i]) is REQUIREMENT:
            reqs.append(self.terminal(REQUIREMENT))
        return lark.Tree("requirements", reqs, Mark(at))

    def declarations(self, data: str, typed_value: bool) -> list[lark.Tree]:
        out = []
        while self.t[self.i] == "(":
            at = self.i
            self.i += 1
            children = [self.terminal(NAME), self.typed(VARIABLE, "typed_vars")]
            self.expect(")")
            if typed_value and self.t[self.i] == "-":
                children.append(self.type_tag())
            out.append(lark.Tree(data, children, Mark(at)))
        return out

    def typed(self, kind: str, data: str) -> lark.Tree:
        """``?a ?b - t ?c`` as it stands (parser.py assigns the types)."""
        at = self.i
        items: list = []
        t, k = self.t, self.k
        while True:
            w = t[self.i]
            if k.get(w) is kind:
                items.append(_token(kind, w, self.i))
                self.i += 1
            elif w == "-":
                items.append(self.type_tag())
            else:
                return lark.Tree(data, items, Mark(at) if items else None)

    def type_tag(self) -> lark.Tree:
        at = self.i
        self.i += 1
        if self.t[self.i] != "(":
            return lark.Tree("type_tag", [self.terminal(NAME)], Mark(at))
        either_at = self.i
        self.i += 1
        self.keyword({"either"})
        names = [self.terminal(NAME)]
        while self.k.get(self.t[self.i]) is NAME:
            names.append(self.terminal(NAME))
        self.expect(")")
        return lark.Tree("type_tag", [lark.Tree("either", names, Mark(either_at))], Mark(at))

    def action(self, at: int) -> lark.Tree:
        children: list = [self.terminal(NAME)]
        while self.t[self.i].lower() in _ACTION_PARTS:
            part_at = self.i
            part = self.keyword(_ACTION_PARTS)
            if part == ":parameters":
                self.expect("(")
                children.append(lark.Tree("parameters", [self.typed(VARIABLE, "typed_vars")], Mark(part_at)))
                self.expect(")")
            elif part == ":precondition":
                children.append(lark.Tree("precondition", [self.gd()], Mark(part_at)))
            else:
                children.append(lark.Tree("effect_part", [self.effect()], Mark(part_at)))
        self.expect(")")
        return lark.Tree("action", children, Mark(at))

    # ------------------------------------------------------------------ formulas and effects
    def atom(self, at: int) -> lark.Tree:
        """The rest of ``(NAME term*)`` once its parenthesis (at word ``at``) is read (the hot
        path of a large file, so with local names)."""
        t, k, i = self.t, self.k, self.i
        w = t[i]
        if k.get(w) is not NAME:
            raise NotFast
        children = [_token(NAME, w, i)]
        while True:
            i += 1
            w = t[i]
            kind = k.get(w)
            if kind is NAME or kind is VARIABLE:
                children.append(_token(kind, w, i))
            elif w == ")":
                self.i = i + 1
                return lark.Tree("atom", children, Mark(at))
            else:
                raise NotFast

    def opening(self) -> tuple[int, str, lark.Tree | None]:
        """Reads ``(``: its index, the word after it, and the ``empty`` tree if that is ``)``."""
        at = self.i
        self.expect("(")
        w = self.t[self.i]
        if w != ")":
            return at, w, None
        self.i += 1
        return at, w, lark.Tree("empty", [], Mark(at))

    def until_closed(self, rule: Callable[[], lark.Tree]) -> list[lark.Tree]:
        """``rule*`` up to the next ``)`` (not read)."""
        out = []
        while self.t[self.i] != ")":
            out.append(rule())
        return out

    def gd(self) -> lark.Tree:
        at, w, empty = self.opening()
        if empty is not None:
            return empty
        if w == "=":
            self.i += 1
            children = [self.term(), self.term()]
            self.expect(")")
            return lark.Tree("equal", children, Mark(at))
        data = _GD.get(w.lower()) if self.k.get(w) is NAME else None
        if data is None:
            return self.atom(at)
        self.i += 1
        if data in ("and_", "or_"):
            children = self.until_closed(self.gd)
        elif data == "not_":
            children = [self.gd()]
        elif data == "imply":
            children = [self.gd(), self.gd()]
        else:
            children = [self.variables(), self.gd()]
        self.expect(")")
        return lark.Tree(data, children, Mark(at))

    def variables(self) -> lark.Tree:
        self.expect("(")
        tree = self.typed(VARIABLE, "typed_vars")
        self.expect(")")
        return tree

    def effect(self) -> lark.Tree:
        at, w, empty = self.opening()
        if empty is not None:
            return empty
        low = w.lower() if self.k.get(w) is NAME else None
        if low not in _EFFECT:
            return self.atom(at)
        self.i += 1
        if low == "and":
            children, data = self.until_closed(self.effect), "and_effect"
        elif low == "not":
            inner = self.i
            self.expect("(")
            children, data = [self.atom(inner)], "delete"
        elif low == "when":
            children, data = [self.gd(), self.effect()], "when"
        elif low == "forall":
            children, data = [self.variables(), self.effect()], "forall_effect"
        elif low == "probabilistic":
            children, data = self.branches(), "probabilistic"
        else:
            children, data = self.reward(w), "reward_effect"
        self.expect(")")
        return lark.Tree(data, children, Mark(at))

    def branches(self) -> list:
        children: list = []
        while self.k.get(self.t[self.i]) is NUMBER:
            children += [self.terminal(NUMBER), self.effect()]
        if not children:
            raise NotFast
        return children

    def reward(self, op: str) -> list:
        """``increase`` or ``decrease`` (read at the previous word), the fluent and the amount."""
        children: list = [_token(op.upper(), op, self.i - 1)]
        at = self.i
        if self.t[self.i] == "(":
            self.i += 1
            children.append(lark.Tree("fluent", [self.terminal(NAME)], Mark(at)))
            self.expect(")")
        else:
            children.append(lark.Tree("fluent", [self.terminal(NAME)], Mark(at)))
        children.append(self.terminal(NUMBER))
        return children

    # ------------------------------------------------------------------ problems
    def problem_item(self) -> lark.Tree:
        at = self.i
        self.i += 1
        key = self.keyword(_PROBLEM_ITEMS)
        if key == ":requirements":
            tree = self.requirements(at)
        elif key == ":domain":
            tree = lark.Tree("problem_domain", [self.terminal(NAME)], Mark(at))
        elif key == ":objects":
            tree = lark.Tree("objects", [self.typed(NAME, "typed_names")], Mark(at))
        elif key == ":init":
            tree = lark.Tree("init", self.init_items(), Mark(at))
        elif key == ":goal":
            tree = lark.Tree("goal", [self.gd()], Mark(at))
        elif key == ":goal-reward":
            tree = lark.Tree("goal_reward", [self.terminal(NUMBER)], Mark(at))
        else:
            children = [self.terminal(NAME)]
            self.expect("(")
            children.append(self.terminal(NAME))
            self.expect(")")
            tree = lark.Tree("metric", children, Mark(at))
        self.expect(")")
        return tree

    def init_items(self) -> list[lark.Tree]:
        items = []
        while self.t[self.i] == "(":
            at = self.i
            self.i += 1
            if self.t[self.i] != "=":
                items.append(self.atom(at))
                continue
            self.i += 1
            self.expect("(")
            children = [self.terminal(NAME)]
            self.expect(")")
            children.append(self.terminal(NUMBER))
            self.expect(")")
            items.append(lark.Tree("init_fluent", children, Mark(at)))
        return items


def read(text: str) -> tuple[lark.Tree, Reader]:
    """The tree of ``text`` and the reader (for :meth:`Reader.locate`); NotFast if it is lark's to read."""
    reader = Reader(text)
    return reader.start(), reader
