"""Calibration of outcome probabilities (groundsym/rules/calibration.py, ``groundsym score``):
against cases computed by hand, and the property that the true model of a simulated domain is
calibrated in the limit of data."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from groundsym.cli import main
from groundsym.logic import Atom, Literal
from groundsym.modeldir import learn_symbolic_model, load_model
from groundsym.ppddl.parser import load
from groundsym.ppddl.simulate import Task, simulate_traces
from groundsym.ppddl.to_rules import domain_to_rules
from groundsym.rules.calibration import calibration, expected_calibration_error
from groundsym.rules.model import DefaultRule, Outcome, Rule, RuleSet
from groundsym.symbolic_traces import SymbolicDataset, SymbolicTrace, write_symbolic_traces

BLOCKS = Path(__file__).resolve().parents[1] / "domains" / "reference" / "blocksworld"


def A(p: str, *args: str) -> Atom:
    return Atom(p, tuple(args))


def test_binned_error_by_hand():
    # bins: [0, .1): p .05, none happened -> .05; [.1, .2): mean p .15, half happened -> .35;
    # [.9, 1]: p .95 and p 1.0 (1.0 belongs to the last bin), both happened -> mean p .975, gap .025
    ece, count, mean_p, observed = expected_calibration_error(
        np.array([0.05, 0.15, 0.15, 0.95, 1.0]), np.array([0, 1, 0, 1, 1]))
    assert ece == pytest.approx((0.05 + 2 * 0.35 + 2 * 0.025) / 5)
    assert count.tolist() == [1, 2, 0, 0, 0, 0, 0, 0, 0, 2]
    assert mean_p[9] == pytest.approx(0.975) and observed[1] == pytest.approx(0.5)
    with pytest.raises(ValueError):
        expected_calibration_error(np.array([0.5]), np.array([1, 0]))


def grasp_rules() -> RuleSet:
    """grab(X) with X clear: 0.7 X in hand, 0.2 nothing changes, noise 0.1."""
    rule = Rule(A("grab", "?x"), (Literal(A("clear", "?x")),),
                (Outcome((Literal(A("held", "?x")), Literal(A("clear", "?x"), False))), Outcome(())),
                (0.7, 0.2), 0.1)
    return RuleSet((rule,), (("grab", DefaultRule(0.5)),))


def test_a_rule_set_on_five_transitions_by_hand():
    clear, held = frozenset({A("clear", "a")}), frozenset({A("held", "a")})
    odd = frozenset({A("clear", "a"), A("held", "a")})            # neither outcome: noise
    succs = [held, held, clear, odd]
    states = [clear] * 4 + [held]                                 # the last one is not covered
    traces = [SymbolicTrace(("a",), [s, s2], [A("grab", "a")], [0.0]) for s, s2 in zip(states, succs + [held])]
    ds = SymbolicDataset(traces, {"clear": 1, "held": 1}, {"grab": 1}, {})
    cal = calibration(grasp_rules(), ds)
    # predictions: 4 x p .7 (happened 2 of 4) in bin 7, 4 x p .2 (happened 1 of 4) in bin 2
    assert (cal.predictions, cal.covered, cal.default_covered) == (8, 4, 1)
    assert cal.ece == pytest.approx(0.5 * abs(0.7 - 0.5) + 0.5 * abs(0.2 - 0.25))
    assert cal.count[7] == 4 and cal.count[2] == 4 and sum(cal.count) == 8
    assert cal.noise_predicted == pytest.approx(0.1) and cal.noise_observed == pytest.approx(0.25)
    assert 0 < cal.floor < 0.5


def test_the_floor_is_what_a_calibrated_model_scores_by_chance():
    from groundsym.rules.calibration import resampled_floor
    assert resampled_floor([(1.0,), (0.0, 1.0)]) == 0.0          # certain outcomes never scatter
    # one outcome of p = .5 (the rest noise), n times: E|share - .5| = sqrt(2 / pi) sd = sqrt(1 / (2 pi n))
    for n in (10, 1000):
        assert resampled_floor([(0.5,)] * n, draws=400) == pytest.approx(np.sqrt(1 / (2 * np.pi * n)), rel=0.15)


def test_the_true_model_of_a_simulated_domain_is_calibrated_as_data_grow():
    domain, problem = load(BLOCKS / "domain.ppddl", BLOCKS / "p01.ppddl")
    true, task = domain_to_rules(domain), Task(domain, problem)
    eces = [calibration(true, simulate_traces(task, n, 20, np.random.default_rng(7), inapplicable=0.25)).ece
            for n in (10, 100, 1000)]
    assert eces[2] < eces[1] < eces[0] and eces[2] < 0.005
    big = simulate_traces(task, 1000, 20, np.random.default_rng(7), inapplicable=0.25)
    assert calibration(true, big).ece < 2 * calibration(true, big).floor
    # a model whose probabilities are off is not: pickup slips 1 in 5, this one says never
    wrong = RuleSet(tuple(r if r.action.predicate != "pickup" else
                          Rule(r.action, r.context, r.outcomes, tuple(1.0 if p > 0.5 else 0.0 for p in r.probs), 0.0)
                          for r in true.rules), true.defaults, true.p_min, true.p_min_default, true.injective,
                    true.derived)
    off = calibration(wrong, big)
    assert off.ece > 0.02 and off.ece > 10 * off.floor


@pytest.fixture(scope="module")
def blocks_model(tmp_path_factory):
    d = tmp_path_factory.mktemp("calibration")
    domain, problem = load(BLOCKS / "domain.ppddl", BLOCKS / "p01.ppddl")
    task = Task(domain, problem)
    learn_symbolic_model(simulate_traces(task, 10, 20, np.random.default_rng(1), inapplicable=0.25),
                         d / "model", seed=0, argv=["groundsym", "learn"], progress=False)
    write_symbolic_traces(d / "test.json", simulate_traces(task, 40, 20, np.random.default_rng(99), inapplicable=0.25))
    return d


def test_score_reports_calibration_and_draws_the_diagram(blocks_model, capsys):
    d = blocks_model
    assert main(["score", str(d / "model"), str(d / "test.json"), "--json", "--reliability", str(d / "rel.png")]) == 0
    doc = json.loads(capsys.readouterr().out)
    from groundsym.symbolic_traces import read_symbolic_traces
    expect = calibration(load_model(d / "model").rules, read_symbolic_traces(d / "test.json")).to_doc()
    assert doc["calibration"] == expect
    assert doc["calibration"]["covered"] + doc["calibration"]["default_covered"] == doc["transitions"]
    assert sum(b["count"] for b in doc["calibration"]["reliability"]) == doc["calibration"]["predictions"]
    assert (d / "rel.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["score", str(d / "model"), str(d / "test.json")]) == 0
    assert "expected calibration error" in capsys.readouterr().out


def test_a_reliability_diagram_needs_a_model_directory(blocks_model, capsys):
    d = blocks_model
    code = main(["score", str(BLOCKS / "domain.ppddl"), str(d / "test.json"), "--reliability", str(d / "x.png")])
    err = capsys.readouterr().err
    assert code == 2 and "--reliability needs a model directory" in err and "Traceback" not in err
    assert not (d / "x.png").exists()
