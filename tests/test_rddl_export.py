"""RDDL export checked by pyRDDLGym itself, the IPPC competition files converted, ``--format`` options.

The independent truth is pyRDDLGym 2.7's own parser and simulator: its successor distributions and
rewards, sampled from every reachable state x ground primitive (up to a cap), must equal our PPDDL
simulator's within Hoeffding's bound at false-alarm rate 1e-3 (groundsym/rddl/roundtrip.py); a
successor ours gives probability 0 fails outright. A wrongly written model must fail the same check.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from fractions import Fraction
from pathlib import Path

import pytest

from groundsym.cli import main
from groundsym.export import ExportOptions, build_export
from groundsym.modeldir import load_model
from groundsym.ppddl.ast import AndEffect, Probabilistic
from groundsym.ppddl.parser import load
from groundsym.ppddl.simulate import Task

pytest.importorskip("pyRDDLGym", reason="pyRDDLGym is not installed (pip install -e '.[rddl]')")

from groundsym.rddl.roundtrip import PyRddlStepper, check, reachable  # noqa: E402
from groundsym.rddl.writer import RddlWriter, without_state_reward  # noqa: E402

from test_export_cli import bw_model, tower_model  # noqa: E402,F401  (the PPDDL export's learned models)

IPPC = Path(__file__).parent / "data" / "ippc"
PROBLEMS = sorted(IPPC.glob("*/*/p*.pddl"))




@pytest.mark.parametrize("problem", PROBLEMS, ids=lambda p: f"{p.parent.parent.name}-{p.parent.name}-{p.stem}")
def test_every_ippc_problem_loads_and_steps_in_pyrddlgym(problem, tmp_path):
    """Every IPPC 2006/2008 file of the test data: pyRDDLGym loads the RDDL and steps an applicable
    action from the initial state to a successor our simulator gives positive probability."""
    domain, prob = load(problem.parent / "domain.pddl", problem)
    writer = RddlWriter(domain, prob)
    stepper = PyRddlStepper(writer, tmp_path, seed=0)
    task = Task(domain, prob)
    s = task.initial_state
    prim = task.applicable_primitives(s)[0]
    after, _ = stepper.step(s, prim)
    assert any(succ.state == after for succ in task.distribution(s, prim))


@pytest.mark.parametrize("name", ["ippc2006/tireworld/p01", "ippc2008/triangle-tireworld/p01",
                                  pytest.param("ippc2006/blocksworld/p01", marks=pytest.mark.slow),
                                  pytest.param("ippc2006/ex-blocksworld/p01", marks=pytest.mark.slow),
                                  pytest.param("ippc2008/blocksworld/p01", marks=pytest.mark.slow)])
def test_ippc_distributions_equal_ours(name, tmp_path):
    domain, prob = load(IPPC / Path(name).parent / "domain.pddl", IPPC / f"{name}.pddl")
    r = check(domain, prob, tmp_path, max_states=8, samples=120)
    assert r.ok, r.failures[:3]
    assert r.states >= 6 and r.outcomes > r.pairs    # probabilistic outcomes were compared, not only no-ops


def test_goal_reward_is_paid_on_arrival_and_ends_the_episode(tmp_path):
    """Triangle tireworld p01: the goal (vehicle-at l-1-3) pays its :goal-reward 100 when reached."""
    d = IPPC / "ippc2008" / "triangle-tireworld"
    domain, prob = load(d / "domain.pddl", d / "p01.pddl")
    writer = RddlWriter(domain, prob)
    stepper = PyRddlStepper(writer, tmp_path, seed=0)
    task = Task(domain, prob)
    from groundsym.logic import parse_atom
    s = frozenset((task.initial_state - {parse_atom("(vehicle-at l-1-1)")}) | {parse_atom("(vehicle-at l-1-2)")})
    after, reward = stepper.step(s, parse_atom("(move-car l-1-2 l-1-3)"))
    assert parse_atom("(vehicle-at l-1-3)") in after and reward == 100.0
    assert "termination" in writer.domain_text()


def test_learned_blocks_world_steps_as_ours_in_a_few_states(bw_model, tmp_path):
    """The fast version of the next test: three states of the learned blocks world."""
    ex = build_export(load_model(bw_model), ExportOptions())
    r = check(ex.domain, ex.problem, tmp_path, state_reward=ex.reward, max_states=2, samples=80)
    assert r.ok, r.failures[:3]
    assert r.pairs >= 6 and r.outcomes > r.pairs


@pytest.mark.slow
@pytest.mark.parametrize("which", ["bw", "tower", "rbf"])
def test_learned_models_distributions_and_rewards_equal_ours(which, bw_model, tower_model, tmp_path):
    """The blocks world (with a fitted reward model), the tower learned from symbolic data, and
    RBF symbols learned from the tower cell's continuous traces."""
    if which == "rbf":
        path = tmp_path / "rbf"
        data = Path(__file__).parent / "data" / "tower_small.json"
        assert main(["learn", str(data), "-o", str(path), "--evals", "120", "--restarts", "1", "--workers", "1",
                     "--quiet"]) == 0
    else:
        path = bw_model if which == "bw" else tower_model
    model = load_model(path)
    ex = build_export(model, ExportOptions())
    r = check(ex.domain, ex.problem, tmp_path / "rddl", state_reward=ex.reward, max_states=10, samples=120,
              derived=model.rules.derived)
    assert r.ok, r.failures[:3]
    assert r.pairs > 20 and r.outcomes > r.pairs


def test_derived_predicates_are_declared_once_and_step_as_ours(tower_model, tmp_path):
    """The tower learned from symbolic data uses ``no-inhand``: RDDL declares it once as a fluent
    (the PPDDL writes it out in every precondition) and still steps as our simulator."""
    model = load_model(tower_model)
    assert any(d.name == "no-inhand" for d in model.rules.derived)
    assert main(["export-domain", str(tower_model), "-o", str(tmp_path / "out"), "--format", "rddl"]) == 0
    text = (tmp_path / "out" / "domain.rddl").read_text()
    assert text.count("no_inhand = ~(exists_{?z1 : obj}[inhand(?z1)]);") == 1 and "?derived" not in text
    assert "(not (exists (?derived-z1) (inhand ?derived-z1)))" in str(build_export(model, ExportOptions()).domain)
    ex = build_export(model, ExportOptions())
    r = check(ex.domain, ex.problem, tmp_path / "rddl", state_reward=ex.reward, max_states=2, samples=80,
              derived=model.rules.derived)
    assert r.ok, r.failures[:3]
    assert r.pairs >= 6


def test_a_wrong_translation_fails_the_check(bw_model, tmp_path):
    """The check's power: the RDDL of a domain whose first outcome lost half its mass (at most 0.5;
    moved to no change) must be told apart from ours with 100 samples per pair."""
    model = load_model(bw_model)
    ex = build_export(model, ExportOptions())
    actions = list(ex.domain.actions)
    a = actions[0]
    prob = next(x for x in a.effect.effects if isinstance(x, Probabilistic))
    (p0, e0), *rest = prob.branches
    wrong = Probabilistic(((p0 - min(p0 / 2, Fraction(1, 2)), e0), *rest))
    actions[0] = replace(a, effect=AndEffect(tuple(wrong if x is prob else x for x in a.effect.effects)))
    r = check(ex.domain, ex.problem, tmp_path, state_reward=ex.reward, max_states=2, samples=100,
              written=replace(ex.domain, actions=tuple(actions)))
    assert not r.ok and "outcome share" in r.failures[0]


def test_reward_is_written_once_and_equals_the_reward_model(bw_model, tmp_path):
    """pyRDDLGym's reward in each reachable state equals the reward model's own prediction
    (groundsym.reward, numpy arrays: an implementation apart from the RDDL text), within the
    export's rounding to 4 significant digits."""
    assert main(["export-domain", str(bw_model), "-o", str(tmp_path), "--format", "rddl"]) == 0
    text = (tmp_path / "domain.rddl").read_text()
    assert text.count("reward =") == 1 and "sum_{?a : obj, ?b : obj}" in text
    model = load_model(bw_model)
    ex = build_export(model, ExportOptions())
    stepper = PyRddlStepper(RddlWriter(without_state_reward(ex.domain, ex.reward), ex.problem, ex.reward),
                            tmp_path / "check", 0)
    task = Task(ex.domain, ex.problem)
    states = reachable(task, 12)
    assert len(states) == 12
    for s in states:
        _, got = stepper.step(s, task.primitive_actions()[0])
        assert got == pytest.approx(model.reward.predict(s, ex.objects), abs=1e-3)


def test_format_options_refuse_meaningless_combinations(bw_model, tmp_path, capsys):
    for extra, message in ((["--format", "rddl", "--determinize", "all-outcomes"], "--determinize: only with --format ppddl"),
                           (["--format", "fond", "--determinize", "most-likely"], "--determinize: only with --format ppddl"),
                           (["--horizon", "5"], "--horizon: only with --format rddl"),
                           (["--format", "rddl", "--operators"], "--operators: only with --format ppddl"),
                           (["--operators", "--axioms"], "--axioms: not with --operators"),
                           (["--format", "rddl", "--horizon", "0"], "argument --horizon: must be at least 1"),
                           (["--format", "rdl"], "invalid choice")):
        with pytest.raises(SystemExit) if message.startswith(("argument", "invalid")) else _returns(2):
            assert main(["export-domain", str(bw_model), "-o", str(tmp_path / "x"), *extra]) == 2
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err and len(err.strip().splitlines()) <= 3
    assert not (tmp_path / "x").exists()


class _returns:
    """A context that expects nothing to be raised (the status is checked inside)."""

    def __init__(self, status: int) -> None:
        self.status = status

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> bool:
        return False


def test_rddl_export_writes_domain_and_instance_and_clears_stale_files(bw_model, tmp_path):
    assert main(["export-domain", str(bw_model), "-o", str(tmp_path), "--determinize", "all-outcomes"]) == 0
    assert (tmp_path / "domain.pddl").exists()
    assert main(["export-domain", str(bw_model), "-o", str(tmp_path), "--format", "rddl", "--horizon", "12"]) == 0
    assert (tmp_path / "domain.rddl").exists() and not (tmp_path / "domain.pddl").exists()
    instance = (tmp_path / "instance.rddl").read_text()
    assert "horizon = 12;" in instance and "max-nondef-actions = 1;" in instance
    first = (tmp_path / "domain.rddl").read_text()
    assert main(["export-domain", str(bw_model), "-o", str(tmp_path), "--format", "rddl", "--horizon", "12"]) == 0
    assert (tmp_path / "domain.rddl").read_text() == first            # deterministic


def test_constant_training_reward_exports_no_reward(tower_model, tmp_path):
    """All training rewards equal (0 here), but a reward.json with terms of 1e-5 (what a fit to
    rounding noise leaves): no reward is written, and the header says why."""
    model = tmp_path / "model"
    shutil.copytree(tower_model, model)
    doc = json.loads((model / "reward.json").read_text())
    doc["intercept"] = 1e-5
    doc["terms"] = [{"weight": 2e-5, "atoms": ["(on ?a ?b)"], "feature": "#(?a ?b): (on ?a ?b)"}]
    (model / "reward.json").write_text(json.dumps(doc))
    for fmt, name in (("ppddl", "domain.ppddl"), ("rddl", "domain.rddl")):
        out = tmp_path / fmt
        assert main(["export-domain", str(model), "-o", str(out), "--format", fmt]) == 0
        text = " ".join(line.strip().lstrip(";/ ") for line in (out / name).read_text().splitlines())
        assert "reward: none (every training state has reward 0" in text and "2 fitted term(s) left out" in text
        assert "increase" not in text and "0.00002" not in text and "2e-05" not in text
    assert "reward = 0.0;" in (tmp_path / "rddl" / "domain.rddl").read_text()


def test_convert_writes_the_competition_file_as_rddl_and_fond(tmp_path, capsys):
    d = IPPC / "ippc2006" / "ex-blocksworld"
    assert main(["convert", str(d / "domain.pddl"), str(d / "p02.pddl"), "-o", str(tmp_path), "--format", "rddl"]) == 0
    domain, prob = load(d / "domain.pddl", d / "p02.pddl")
    writer = RddlWriter(domain, prob)
    assert (tmp_path / "domain.rddl").read_text() == writer.domain_text()
    assert (tmp_path / "instance.rddl").read_text() == writer.instance_text()
    assert main(["convert", str(d / "domain.pddl"), str(d / "p02.pddl"), "-o", str(tmp_path), "--format", "fond"]) == 0
    assert "oneof" in (tmp_path / "domain.pddl").read_text()


@pytest.mark.parametrize("domain, message", [
    ("(define (domain t) (:types block - thing thing) (:predicates (p ?x - block)) "
     "(:action a :parameters (?x - block) :effect (p ?x)))", "the RDDL export writes flat types only"),
    ("(define (domain t) (:predicates (p ?x)) (:action a :parameters (?x) :effect (p ?x)))", None),
])
def test_what_rddl_cannot_say_is_refused_in_one_line(domain, message, tmp_path, capsys):
    (tmp_path / "d.pddl").write_text(domain)
    goal = "(:goal (or (p a) (p b)))" if message is None else "(:goal (p a))"
    (tmp_path / "p.pddl").write_text(f"(define (problem p) (:domain t) (:objects a b{' - block' if message else ''}) "
                                     f"(:init) {goal})")
    assert main(["convert", str(tmp_path / "d.pddl"), str(tmp_path / "p.pddl"), "-o", str(tmp_path / "o"),
                 "--format", "rddl"]) == 2
    err = capsys.readouterr().err
    assert (message or "the RDDL export writes a conjunction of literals only") in err and "Traceback" not in err
