"""The PPDDL parser on the IPPC files as published, and its one-line errors with line and column."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest

from groundsym.cli import main
from groundsym.logic import Atom, Literal
from groundsym.ppddl.ast import And, AndEffect, Forall, Not, Probabilistic, RewardEffect, When
from groundsym.ppddl.parser import PPDDLError, load, parse_domain, parse_file, parse_text

DATA = Path(__file__).parent / "data" / "ippc"
REF = Path(__file__).parent.parent / "domains" / "reference"


def test_every_ippc_file_parses():
    seen = 0
    for d in sorted(DATA.glob("*/*")):
        domain, _ = load(d / "domain.pddl")
        for p in sorted(d.glob("p*.pddl")):
            dom2, problem = load(d / "domain.pddl", p)
            assert problem is not None and problem.domain == domain.name and problem.init
            seen += 1
    assert seen == 18


def test_ippc2008_problem_files_hold_domain_and_problem():
    domains, problems = parse_file(DATA / "ippc2008/blocksworld/p02.pddl")
    assert [d.name for d in domains] == ["blocks-domain"] and [p.name for p in problems] == ["p02"]
    assert problems[0].goal_reward == 20 and problems[0].metric == ("maximize", "reward")
    pick = domains[0].action("pick-up")
    assert isinstance(pick.effect, AndEffect)
    assert RewardEffect(Fraction(-1)) in pick.effect.effects       # (decrease reward 1), no parentheses
    # the competition's domain.pddl has no action costs: the problem files' copies differ from it
    plain = load(DATA / "ippc2008/blocksworld/domain.pddl")[0].action("pick-up")
    assert isinstance(plain.effect, Probabilistic)


def test_structure_of_a_parsed_domain():
    d, p = load(DATA / "ippc2006/ex-blocksworld/domain.pddl", DATA / "ippc2006/ex-blocksworld/p01.pddl")
    assert d.requirements == (":conditional-effects", ":equality", ":probabilistic-effects", ":typing")
    assert [t.name for t in d.types] == ["block"] and d.predicate("on").arity == 2
    put = d.action("put-down")
    prob = put.effect.effects[-1]
    assert isinstance(prob, Probabilistic) and prob.branches[0][0] == Fraction(2, 5)
    when = prob.branches[0][1]
    assert isinstance(when, When) and when.condition == Atom("no-detonated", ("?b",))
    assert Literal(Atom("no-destroyed-table"), False) in when.effect.effects
    assert [o.type for o in p.objects] == ["block"] * 5
    assert p.goal == And((Atom("on", ("b3", "b4")), Atom("on", ("b5", "b2"))))


def test_keywords_any_case_names_keep_theirs_quantifiers_and_imply():
    d = parse_domain("""(DEFINE (Domain Q) (:REQUIREMENTS :adl)
      (:types thing) (:constants home - thing)
      (:predicates (At ?x - thing) (not-ready))
      (:action Go :parameters (?x - thing)
        :precondition (AND (imply (At ?x) (not-ready)) (exists (?y - thing) (At ?y))
                           (forall (?z) (or (not (At ?z)) (= ?z home))))
        :effect (and (At home) (not (At ?x)))))""")
    assert d.name == "Q" and d.action("Go") is not None and d.predicate("not-ready").arity == 0
    pre = d.action("Go").precondition
    assert isinstance(pre.args[2], Forall) and isinstance(pre.args[2].body.args[0], Not)
    assert d.constants[0].name == "home"


@pytest.mark.parametrize("text,where,what", [
    ("(define (domain d) (:predicates (p ?x)) (:action a :parameters (?x) :effect (p ?x ?x)))", "1:77",
     "p takes 1 argument(s), got 2"),
    ("(define (domain d)\n  (:predicates (p))\n  (:action a :parameters () :effect (q)))", "3:38",
     "unknown predicate 'q'"),
    ("(define (domain d) (:predicates (p ?x)) (:action a :parameters () :effect (p ?y)))", "1:78",
     "undeclared variable ?y"),
    ("(define (domain d) (:predicates (p) (q))\n (:action a :parameters ()\n  :effect (probabilistic 0.6 (p) 1/2 (q))))",
     "3:11", "probabilities sum to 1.1, above 1"),
    ("(define (domain d) (:predicates (p)) (:action a :parameters () :effect (probabilistic 3/2 (p))))", "1:87",
     "probability 3/2 is outside [0, 1]"),
    ("(define (domain d) (:predicates (p)) (:action a :parameters () :effect (and (p)))", "1:81",
     "syntax error: unexpected end of file"),
    ("(define (domain d) (:predicates (p)) (:action a :parameters () :effect (and (p) ]))", "1:81",
     "syntax error: unexpected character ']'"),
    ("(define (domain d) (:types t) (:predicates (p ?x - u)))", "1:52", "unknown type 'u'"),
])
def test_errors_name_file_line_and_column(text, where, what):
    with pytest.raises(PPDDLError) as exc:
        parse_text(text, "x.ppddl")
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith(f"x.ppddl:{where}: ") and what in msg, msg


def test_unknown_predicate_or_object_in_a_goal(tmp_path):
    dom = REF / "blocksworld/domain.ppddl"
    bad_pred = tmp_path / "p.ppddl"
    bad_pred.write_text("(define (problem p) (:domain noisy-blocksworld) (:objects a b)\n"
                        "  (:init (handempty) (ontable a) (ontable b) (clear a) (clear b))\n"
                        "  (:goal (and (on a b) (tower a))))")
    with pytest.raises(PPDDLError, match=r"p\.ppddl:3:25: unknown predicate 'tower'"):
        load(dom, bad_pred)
    bad_obj = tmp_path / "q.ppddl"
    bad_obj.write_text("(define (problem p) (:domain noisy-blocksworld) (:objects a b)\n"
                       "  (:init (handempty))\n  (:goal (on a c)))")
    with pytest.raises(PPDDLError, match=r"q\.ppddl:3:16: unknown object or constant 'c'"):
        load(dom, bad_obj)


def test_cli_gives_one_line_and_status_2(tmp_path, capsys):
    bad = tmp_path / "d.ppddl"
    bad.write_text("(define (domain d) (:predicates (p) (q))\n (:action a :parameters ()\n"
                   "  :effect (probabilistic 0.7 (p) 0.4 (q))))\n(define (problem x) (:domain d) (:init) (:goal (p)))")
    code = main(["simulate", "--domain", str(bad), "-o", str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "d.ppddl:3:11: probabilities sum to 1.1, above 1" in err
    assert not (tmp_path / "o.json").exists()


def test_problem_for_another_domain_is_refused(tmp_path):
    other = tmp_path / "p.pddl"
    other.write_text("(define (problem p) (:domain elsewhere) (:objects a) (:init) (:goal (and)))")
    with pytest.raises(PPDDLError, match="is for domain 'elsewhere', which is not loaded"):
        load(REF / "blocksworld/domain.ppddl", other)
