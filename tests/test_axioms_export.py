"""``export-domain --axioms``: derived predicates declared once as ``(:derived ...)`` axioms.

Independent truths: our parser reads the axiom export back to exactly the domain the default export
writes (every derived atom put back in place); Fast Downward (its own driver, no unified-planning,
which reads no axioms) solves the determinisation with axioms with plans as short as without, and
each plan, replayed by our simulator on the domain without axioms, reaches the goal.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from groundsym.cli import main
from groundsym.errors import UserError
from groundsym.logic import parse_atom
from groundsym.ppddl.parser import load, parse_domain
from groundsym.ppddl.simulate import Task

from test_export_cli import tower_model  # noqa: F401  (the PPDDL export's learned model)



def _export(model: Path, out: Path, *extra: str) -> Path:
    assert main(["export-domain", str(model), "-o", str(out), "--goal", "(on o1 o2)", *extra]) == 0
    return out


def test_axioms_read_back_as_the_written_out_domain(tower_model, tmp_path):
    ax = _export(tower_model, tmp_path / "ax", "--axioms", "--determinize", "all-outcomes")
    plain = _export(tower_model, tmp_path / "plain", "--determinize", "all-outcomes")
    text = (ax / "domain.ppddl").read_text()
    assert text.count("(:derived (no-inhand) (not (exists (?derived-z1) (inhand ?derived-z1))))") == 1
    assert "?derived-z1" not in text.split("(:action", 1)[1] and "(no-inhand)" in text.split("(:action", 1)[1]
    assert ":derived-predicates" in text
    for d, p in (("domain.ppddl", "problem.ppddl"), ("domain.pddl", "problem.pddl")):
        assert load(ax / d, ax / p) == load(plain / d, plain / p), d
    # the option changes nothing by default: the written-out export is what it was
    assert "(:derived" not in (plain / "domain.ppddl").read_text()


def _fast_downward(domain: Path, problem: Path, plan: Path) -> tuple[list[str], str]:
    import up_fast_downward
    driver = Path(up_fast_downward.__file__).parent / "downward" / "fast-downward.py"
    done = subprocess.run([sys.executable, str(driver), "--plan-file", str(plan), str(domain), str(problem),
                           "--search", "astar(blind())"], capture_output=True, text=True, timeout=300,
                          cwd=plan.parent)
    assert "Solution found" in done.stdout, done.stdout[-2000:]
    return [l for l in plan.read_text().splitlines() if not l.startswith(";")], done.stdout


@pytest.mark.parametrize("goal", ["(on o1 o2)", "(inhand o3)"])
def test_fast_downward_solves_the_axiom_determinisation_as_the_plain_one(tower_model, tmp_path, goal):
    lengths = []
    for extra in (["--axioms"], []):
        out = tmp_path / ("ax" if extra else "plain")
        assert main(["export-domain", str(tower_model), "-o", str(out), "--goal", goal,
                     "--determinize", "all-outcomes", *extra]) == 0
        steps, log = _fast_downward(out / "domain.pddl", out / "problem.pddl", out / "plan")
        if extra:       # Fast Downward's translator read the axioms themselves
            assert "(:derived" in (out / "domain.pddl").read_text()
            assert int(re.search(r"Translator axioms: (\d+)", log).group(1)) > 0
        domain, problem = load(out / "domain.pddl", out / "problem.pddl")      # ours: axioms put in place
        task = Task(domain, problem)
        s = task.initial_state
        for step in steps:
            atom = parse_atom(step)
            name = next(a.name for a in domain.actions if a.name.lower() == atom.predicate)
            (succ,) = task.outcomes(s, parse_atom(f"({name} {' '.join(atom.args)})"))
            s = succ.state
        assert task.goal_holds(s)
        lengths.append(len(steps))
    assert lengths[0] == lengths[1] > 0


def test_meaningless_axiom_combinations_are_refused(tower_model, tmp_path, capsys):
    for extra, message in ((["--format", "rddl"], "--axioms: not with --format rddl"),
                           (["--determinize", "all-outcomes", "--strips"], "--axioms: not with --strips")):
        assert main(["export-domain", str(tower_model), "-o", str(tmp_path / "x"), "--axioms", *extra]) == 2
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("text, message", [
    ("(:derived (free ?x) (not (exists (?z) (on ?z ?x))))", "'free' is not declared in :predicates"),
    ("(:derived (clear ?x ?y) (not (h)))", "takes 1 argument(s), the axiom gives 2"),
    ("(:derived (clear ?x) (not (exists (?z) (on ?z ?x)))) (:derived (top ?x) (clear ?x))",
     "its body uses the derived predicate 'clear'"),
])
def test_bad_axioms_are_one_clear_error(text, message):
    domain = f"""(define (domain t) (:requirements :derived-predicates)
      (:predicates (on ?x ?y) (clear ?x) (top ?x) (h)) {text}
      (:action a :parameters (?x) :precondition (clear ?x) :effect (h)))"""
    with pytest.raises(UserError, match=re.escape(message)):
        parse_domain(domain, "t.pddl")


def test_an_argument_is_not_captured_by_the_axiom_body():
    """``(free ?z)`` with body ``(not (exists (?z) (on ?z ?x)))``: the body's own ``?z`` is renamed."""
    d = parse_domain("""(define (domain t) (:requirements :derived-predicates) (:predicates (on ?x ?y) (free ?x) (h))
      (:derived (free ?x) (not (exists (?z) (on ?z ?x))))
      (:action a :parameters (?z) :precondition (free ?z) :effect (h)))""", "t.pddl")
    task = Task(d, ["a", "b"])
    on = parse_atom("(on a b)")
    assert task.applicable(frozenset(), parse_atom("(a a)")) and task.applicable(frozenset({on}), parse_atom("(a a)"))
    assert not task.applicable(frozenset({on}), parse_atom("(a b)"))
