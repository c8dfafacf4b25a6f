"""``groundsym score``: held-out log-likelihood per transition and rule coverage, and bad input."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from examples.rule_recovery import KNOWN, REFERENCE, simulate
from groundsym.cli import main
from groundsym.logic import Atom
from groundsym.modeldir import learn_symbolic_model, load_model
from groundsym.rules.io import read_rules
from groundsym.symbolic_traces import read_symbolic_traces, write_symbolic_traces


@pytest.fixture(scope="module")
def learned(tmp_path_factory):
    d = tmp_path_factory.mktemp("score")
    true, meta = read_rules(KNOWN["blocks"])
    train = simulate(true, meta, 300, np.random.default_rng(0))
    test = simulate(true, meta, 300, np.random.default_rng(1))
    learn_symbolic_model(train, d / "model", seed=0, argv=["groundsym", "learn"], progress=False)
    write_symbolic_traces(d / "test.json", test)
    return d, test


def test_json_report_matches_the_model_semantics(learned, capsys):
    d, test = learned
    assert main(["score", str(d / "model"), str(d / "test.json"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    rs = load_model(d / "model").rules
    logs = [math.log(max(rs.likelihood(s, a, s2, tr.objects), rs.p_min))
            for tr in test.traces for s, a, s2 in tr.transitions()]
    assert doc["transitions"] == len(logs) == test.n_transitions
    assert doc["mean_log_likelihood"] == pytest.approx(sum(logs) / len(logs), rel=1e-12)
    assert doc["impossible"] == sum(rs.likelihood(s, a, s2, tr.objects) == 0
                                    for tr in test.traces for s, a, s2 in tr.transitions())
    assert len(doc["rules"]) == len(rs.rules)
    assert sum(r["covers"] for r in doc["rules"]) + doc["default_covered"] == doc["transitions"]
    assert all(set(r) >= {"rule", "action", "context", "covers"} for r in doc["rules"])


def test_text_report_and_model_directory_files(learned, capsys):
    d, _ = learned
    assert main(["score", str(d / "model"), str(d / "test.json")]) == 0
    out = capsys.readouterr().out
    assert "mean log-likelihood" in out and "rule 1:" in out
    names = sorted(p.name for p in (d / "model").iterdir())
    assert names == ["reward.json", "rules.json", "rules.txt", "symbolic-traces.json"]
    m = load_model(d / "model")
    assert m.symbols is None and m.traces is None and m.symbolic_traces.n_transitions == 300
    prov = json.loads((d / "model" / "rules.json").read_text())["provenance"]
    assert prov["seed"] == 0 and len(prov["data_sha256"]) == 64 and prov["command"] == "groundsym learn"


def test_a_transition_the_model_calls_impossible_is_priced_with_p_min(tmp_path, capsys):
    true, meta = read_rules(KNOWN["blocks"])        # the true domain has no noise: some data is impossible
    data = simulate(true, meta, 40, np.random.default_rng(0))
    tr = data.traces[0]
    tr.states[1] = tr.states[0] | {Atom("on", tr.objects[:2])}   # appears from nowhere
    write_symbolic_traces(tmp_path / "d.json", data)
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "rules.json").write_text((KNOWN["blocks"]).read_text())
    assert main(["score", str(tmp_path / "m"), str(tmp_path / "d.json"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["impossible"] >= 1 and math.isfinite(doc["mean_log_likelihood"])


@pytest.mark.parametrize("case", ["no-model", "bad-rules", "bad-data"])
def test_bad_input_gives_one_line_and_status_2(learned, tmp_path, capsys, case):
    d, _ = learned
    model, data = str(d / "model"), str(d / "test.json")
    if case == "no-model":
        model = str(tmp_path / "nothing")
    elif case == "bad-rules":
        (tmp_path / "m").mkdir()
        doc = json.loads((d / "model" / "rules.json").read_text())
        doc["rules"][0]["noise"] = 0.9
        (tmp_path / "m" / "rules.json").write_text(json.dumps(doc))
        model = str(tmp_path / "m")
    else:
        (tmp_path / "t.json").write_text('{"schema": "groundsym.symbolic-traces/1", "predicates": {}}')
        data = str(tmp_path / "t.json")
    assert main(["score", model, data]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    want = {"no-model": "nothing: no such", "bad-rules": "rules.json: rules[0].outcomes: probabilities",
            "bad-data": "t.json: primitives: missing"}[case]
    assert want in err


def test_a_ppddl_domain_is_scored_with_its_true_dynamics(tmp_path, capsys):
    """The reference blocks world is in the rule subset, so its PPDDL semantics (the simulator's)
    and its NID rules (domain_to_rules) are two independent ways to the same likelihood."""
    from groundsym.ppddl.to_rules import domain_to_rules
    from groundsym.ppddl.parser import load
    from groundsym.rules.evaluate import score_ruleset

    domain_file = REFERENCE / "blocksworld" / "domain.ppddl"
    problem_file = REFERENCE / "blocksworld" / "p01.ppddl"
    data = tmp_path / "bw.json"
    assert main(["simulate", "--domain", str(domain_file), "--problem", str(problem_file), "--traces", "6",
                 "--length", "15", "--inapplicable", "0.25", "--seed", "4", "-o", str(data)]) == 0
    capsys.readouterr()
    assert main(["score", str(domain_file), str(data), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    ds = read_symbolic_traces(data)
    want = score_ruleset(domain_to_rules(load(domain_file)[0]), ds)
    assert doc["transitions"] == ds.n_transitions == want.transitions
    assert doc["impossible"] == 0
    assert doc["mean_log_likelihood"] == pytest.approx(want.mean_log_likelihood, abs=1e-9)
    assert sum(r["covers"] for r in doc["rules"]) + doc["default_covered"] == doc["transitions"]
    # a transition the domain cannot produce is counted and priced with p_min
    tr = ds.traces[0]
    tr.states[1] = tr.states[0] | {Atom("on", tr.objects[:2])}
    write_symbolic_traces(tmp_path / "odd.json", ds)
    assert main(["score", str(domain_file), str(tmp_path / "odd.json"), "--json"]) == 0
    odd = json.loads(capsys.readouterr().out)
    assert odd["impossible"] >= 1 and math.isfinite(odd["mean_log_likelihood"])


def test_model_directory_loads_symbols_and_continuous_traces_when_present(learned, tmp_path):
    import shutil

    from conftest import DATA
    from groundsym.symbols import Symbol, SymbolSet, save_symbols

    d, _ = learned
    model = tmp_path / "model"
    shutil.copytree(d / "model", model)
    names = ("x", "y", "z", "size")
    save_symbols(model / "symbols.json", SymbolSet((Symbol("clear", 1, np.zeros(4), np.ones(4)),), names))
    shutil.copy(DATA / "tower_small.json", model / "traces.json")
    m = load_model(model)
    assert "symbols" not in m.__dict__                     # lazy: nothing read yet
    assert m.symbols.predicates == {"clear": 1}   # a predicate of the rules (load_model checks)
    assert len(m.traces.traces) == 4 and m.rules.rules == load_model(d / "model").rules.rules


@pytest.mark.parametrize("kw, want", [({"alpha": -1.0}, "--alpha"), ({"p_min": 2.0}, "--p-min")])
def test_learn_symbolic_model_refuses_bad_options(tmp_path, kw, want):
    from groundsym.errors import UserError

    true, meta = read_rules(KNOWN["blocks"])
    ds = simulate(true, meta, 20, np.random.default_rng(0))
    with pytest.raises(UserError, match=want):
        learn_symbolic_model(ds, tmp_path / "m", seed=0, argv=[], progress=False, **kw)
    assert not (tmp_path / "m").exists()
