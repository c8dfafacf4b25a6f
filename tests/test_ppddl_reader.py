"""The tokenizer-driven PPDDL reader against its reference, lark's parser of grammar.lark.

Where the reader accepts a text, lark must build the same tree (every rule, token type and value)
with the same line and column for every node; and the parser's results through either (the AST,
or the one-line error with its position) must be equal, on every file in domains/ and the IPPC
files, on generated domains and problems, and on the fuzzer's mutants.
"""

from __future__ import annotations

from pathlib import Path

import lark
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import DATA, ROOT
from groundsym.ppddl.parser import PPDDLError, _lark, parse_text, parse_text_lark
from groundsym.ppddl.reader import NotFast, read
from test_fuzz import ppddl_mutant

FILES = sorted((ROOT / "domains").rglob("*.ppddl")) + sorted((DATA / "ippc").rglob("*.pddl"))


def same_tree(ref: lark.Tree | lark.Token, mine: lark.Tree | lark.Token, locate) -> None:
    """``mine`` (the reader's) is ``ref`` (lark's, with positions), node by node."""
    if isinstance(ref, lark.Token):
        assert isinstance(mine, lark.Token) and (ref.type, str(ref)) == (mine.type, str(mine)), (ref, mine)
        assert (ref.line, ref.column) == locate(mine), (ref, ref.line, ref.column, locate(mine))
        return
    assert isinstance(mine, lark.Tree) and ref.data == mine.data, (ref, mine)
    assert len(ref.children) == len(mine.children), (ref, mine)
    if ref.data != "start":
        assert (getattr(ref.meta, "line", "?"), getattr(ref.meta, "column", "?")) == locate(mine), ref
    for a, b in zip(ref.children, mine.children):
        same_tree(a, b, locate)


def outcome(parse, text: str):
    try:
        return "parsed", parse(text, "f.ppddl")
    except PPDDLError as exc:
        return "refused", str(exc)


def agree(text: str) -> bool:
    """The reader's tree is lark's where it accepts; the parser's results are the same either way.
    True if the reader accepted."""
    try:
        mine, reader = read(text)
    except NotFast:
        accepted = False
    else:
        same_tree(_lark(positions=True).parse(text), mine, reader.locate)   # lark must accept it too
        accepted = True
    assert outcome(parse_text, text) == outcome(parse_text_lark, text)
    return accepted


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_shipped_file_reads_as_lark_reads_it(path: Path):
    assert agree(path.read_text()), "the reader should accept every shipped file"


# ----------------------------------------------------------------------------- generated texts
def spaced(draw, parts: list[str]) -> str:
    """Words joined by random white space and comments (the reader splits, lark lexes)."""
    out = []
    for p in parts:
        out.append(p)
        out.append(draw(st.sampled_from([" ", " ", "\n", "\t", "  ", " ; note (\n", "\r\n"])))
    return "".join(out)


def cased(draw, word: str) -> str:
    return draw(st.sampled_from([word, word.upper(), word.capitalize()]))


@st.composite
def formula(draw, preds: dict[str, int], variables: list[str], depth: int = 0) -> list[str]:
    kind = draw(st.sampled_from(["atom"] * 3 + (["and", "or", "not", "imply", "forall", "exists", "=", "empty"]
                                                if depth < 3 else [])))
    terms = variables + ["c1"]
    if kind == "atom":
        name = draw(st.sampled_from(sorted(preds)))
        return ["(", name, *[draw(st.sampled_from(terms)) for _ in range(preds[name])], ")"]
    if kind == "empty":
        return ["(", ")"]
    if kind == "=":
        return ["(", "=", draw(st.sampled_from(terms)), draw(st.sampled_from(terms)), ")"]
    inner = variables + ["?q"] if kind in ("forall", "exists") else variables
    sub = [draw(formula(preds, inner, depth + 1)) for _ in range(
        {"and": draw(st.integers(0, 3)), "or": draw(st.integers(0, 3)), "not": 1, "imply": 2}.get(kind, 1))]
    head = ["(", cased(draw, kind)] + (["(", "?q", "-", "t", ")"] if kind in ("forall", "exists") else [])
    return head + [w for s in sub for w in s] + [")"]


@st.composite
def effect(draw, preds: dict[str, int], variables: list[str], depth: int = 0) -> list[str]:
    kind = draw(st.sampled_from(["atom"] * 3 + (["and", "not", "when", "forall", "probabilistic", "reward", "empty"]
                                                if depth < 3 else [])))
    atom = formula(preds, variables, 99)
    if kind == "atom":
        return draw(atom)
    if kind == "empty":
        return ["(", ")"]
    if kind == "not":
        return ["(", cased(draw, "not"), *draw(atom), ")"]
    if kind == "reward":
        fluent = draw(st.sampled_from([["(", "reward", ")"], ["reward"]]))
        return ["(", cased(draw, draw(st.sampled_from(["increase", "decrease"]))), *fluent,
                draw(st.sampled_from(["1", "2.5", "1/3"])), ")"]
    if kind == "when":
        return ["(", cased(draw, "when"), *draw(formula(preds, variables, 2)),
                *draw(effect(preds, variables, depth + 1)), ")"]
    if kind == "forall":
        return ["(", cased(draw, "forall"), "(", "?q", ")", *draw(effect(preds, variables + ["?q"], depth + 1)), ")"]
    if kind == "probabilistic":
        n = draw(st.integers(1, 3))
        probs = draw(st.lists(st.sampled_from(["0.1", "1/4", ".3", "0.25", "0"]), min_size=n, max_size=n))
        return ["(", cased(draw, "probabilistic"),
                *[w for p in probs for w in [p, *draw(effect(preds, variables, depth + 1))]], ")"]
    return ["(", cased(draw, "and"), *[w for _ in range(draw(st.integers(0, 3)))
                                       for w in draw(effect(preds, variables, depth + 1))], ")"]


@st.composite
def generated(draw) -> str:
    """A domain (and sometimes a problem) from the grammar: every construct, keywords in any case,
    meaningful (declared predicates, bound variables), so most texts parse; ``(either ...)``
    types read and are then refused by the parser."""
    preds = {f"p{i}": draw(st.integers(0, 2)) for i in range(draw(st.integers(1, 4)))}
    w = ["(", cased(draw, "define"), "(", cased(draw, "domain"), "d", ")",
         "(", ":requirements", ":adl", ":probabilistic-effects", ")",
         "(", ":types", "t", "u", "-", "t", ")", "(", ":constants", "c1", "-", "t", ")",
         "(", cased(draw, ":predicates"), *[x for name, n in preds.items()
                                            for x in ["(", name, *[f"?a{j}" for j in range(n)], ")"]], ")"]
    if draw(st.booleans()):
        w += ["(", ":functions", "(", "reward", ")", "-", "number", ")"]
    for a in range(draw(st.integers(1, 4))):
        params = ["?x", "?y"][:draw(st.integers(0, 2))]
        typed = draw(st.sampled_from([params, params, [*params, "-", "t"] if params else [],   # either: refused
                                      [*params, "-", "(", "either", "t", "u", ")"] if params else []]))
        w += ["(", cased(draw, ":action"), f"a{a}", cased(draw, ":parameters"), "(", *typed, ")",
              cased(draw, ":precondition"), *draw(formula(preds, params)),
              cased(draw, ":effect"), *draw(effect(preds, params)), ")"]
    w.append(")")
    if draw(st.booleans()):
        atoms = [x for name, n in preds.items() if draw(st.booleans()) for x in ["(", name, *["c1"] * n, ")"]]
        w += ["(", "define", "(", "problem", "p", ")", "(", ":domain", "d", ")", "(", ":objects", "o1", "o2", "-", "u", ")",
              "(", ":init", *atoms, "(", "=", "(", "reward", ")", "0", ")", ")",
              "(", ":goal", *draw(formula(preds, [])), ")", "(", ":goal-reward", "10", ")",
              "(", ":metric", "maximize", "(", "reward", ")", ")", ")"]
    return spaced(draw, w)


def _property(strategy, n: int, must_accept: bool):
    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck), database=None)
    @given(text=strategy)
    def run(text):
        accepted = agree(text)
        assert accepted or not must_accept
    return run


GENERATED = generated()
MUTANTS = st.one_of(ppddl_mutant(), st.text(alphabet="() ?-:=;abnotd01./\n\x0b", max_size=120))


def test_generated_domains_read_as_lark_reads_them():
    _property(GENERATED, 12, True)()


def test_mutants_read_as_lark_reads_them():
    _property(MUTANTS, 40, False)()


@pytest.mark.slow
def test_many_generated_texts_and_mutants_read_as_lark_reads_them():
    _property(GENERATED, 1000, True)()
    _property(MUTANTS, 3000, False)()


@pytest.mark.parametrize("odd,plain", [
    ("(define (domain d) (:predicates (p ?x -t)) (:types t))", "(define (domain d) (:predicates (p ?x - t)) (:types t))"),
    ("(define (domain d) (:constants a) (:predicates (p ?x))"
     " (:action b :parameters (?x) :precondition (=?x a) :effect (p ?x)))",
     "(define (domain d) (:constants a) (:predicates (p ?x))"
     " (:action b :parameters (?x) :precondition (= ?x a) :effect (p ?x)))"),
])
def test_spellings_the_reader_leaves_to_lark_still_parse(odd, plain):
    """``-t`` and ``=?x`` are one word to the reader but two tokens to lark: lark reads them."""
    with pytest.raises(NotFast):
        read(odd)
    assert parse_text(odd) == parse_text(plain)


def test_positions_of_an_error_deep_in_a_large_file():
    body = "".join(f" (:action a{i} :parameters (?x) :effect (p ?x))\n" for i in range(250))
    text = "(define (domain d) (:predicates (p ?x))\n" + body + " (:action late :parameters (?x) :effect (q ?x)))"
    with pytest.raises(PPDDLError, match=r"^f\.ppddl:252:42: unknown predicate 'q'$"):
        parse_text(text, "f.ppddl")
    assert outcome(parse_text, text) == outcome(parse_text_lark, text)
