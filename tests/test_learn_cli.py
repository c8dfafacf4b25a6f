"""`groundsym learn`, `show` and `abstract` end to end on fixture traces (small budgets)."""

import json

import numpy as np
import pytest

from groundsym.cli import main
from groundsym.symbolic_traces import read_symbolic_traces
from groundsym.symbols import SymbolSet, load_symbols, save_symbols
from groundsym.traces import read_traces, write_traces
from tests.test_loss import intended_symbols, kinematic_tower


@pytest.fixture(scope="module")
def traces(tmp_path_factory):
    path = tmp_path_factory.mktemp("data") / "traces.json"
    write_traces(path, kinematic_tower(5, seed=8))
    return path


def _learn(traces, out, *extra):
    return main(["learn", str(traces), "-o", str(out), "--evals", "120", "--restarts", "2", "--quiet", *extra])


def test_learn_writes_symbols_and_traces_independent_of_workers(traces, tmp_path):
    assert _learn(traces, tmp_path / "a", "--workers", "1", "--seed", "3") == 0
    assert _learn(traces, tmp_path / "b", "--workers", "2", "--seed", "3") == 0
    a = json.loads((tmp_path / "a" / "symbols.json").read_text())
    b = json.loads((tmp_path / "b" / "symbols.json").read_text())
    assert a["symbols"] == b["symbols"] and a["loss"] == b["loss"]
    assert a["schema"] == "groundsym.symbols/1" and a["evaluations"] == 120
    assert set(a["loss"]) == {"total", "effect", "transition", "reward", "regulariser"}
    assert a["provenance"]["seed"] == 3 and len(a["provenance"]["data_sha256"]) == 64
    assert "--workers 1" in a["provenance"]["command"]
    assert len(a["symbols"]) + len(a["pruned"]) == 2
    for s in a["symbols"]:
        assert 0 < s["share"] < 1   # pruned symbols (never/always true) are not listed
    assert (tmp_path / "a" / "traces.json").read_bytes() == traces.read_bytes()
    # the rules engineer's part ran on the abstracted data
    sds = read_symbolic_traces(tmp_path / "a" / "symbolic-traces.json")
    assert sds.predicates == {s["name"]: s["arity"] for s in a["symbols"]}


def test_learn_on_symbolic_traces_learns_rules_only(traces, tmp_path):
    syms = SymbolSet(tuple(intended_symbols()), ("x", "y", "z", "size"))
    sym_path = tmp_path / "s.json"
    save_symbols(tmp_path / "symbols.json", syms)
    assert main(["abstract", str(traces), "--symbols", str(tmp_path / "symbols.json"), "-o", str(sym_path)]) == 0
    sds = read_symbolic_traces(sym_path)
    expect = syms.to_symbolic_dataset(read_traces(traces))
    assert [t.states for t in sds.traces] == [t.states for t in expect.traces]
    out = tmp_path / "model"
    assert main(["learn", str(sym_path), "-o", str(out), "--quiet"]) == 0
    assert (out / "rules.json").exists() and not (out / "symbols.json").exists()


def test_show_json_against_truth(traces, tmp_path, capsys):
    save_symbols(tmp_path / "symbols.json", SymbolSet(tuple(intended_symbols(swap=True)), ("x", "y", "z", "size")))
    capsys.readouterr()
    assert main(["show", str(tmp_path), "--against", str(traces), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    by = {d["symbol"]: d for d in doc["symbols"]}
    assert by["u1"]["best_match"] == "inhand" and by["u1"]["f1"] == 1.0
    assert (by["b1"]["best_match"], by["b1"]["argument_order"], by["b1"]["f1"]) == ("on", "swapped", 1.0)
    assert set(by["b1"]) == {"symbol", "arity", "best_match", "argument_order", "precision", "recall", "f1",
                             "negation_match", "negation_f1"}
    assert by["b1"]["negation_match"] is None and by["u1"]["negation_f1"] is None


def test_show_words_and_plot(traces, tmp_path, capsys):
    model = tmp_path / "m"
    model.mkdir()
    save_symbols(model / "symbols.json", SymbolSet(tuple(intended_symbols()), ("x", "y", "z", "size")))
    (model / "traces.json").write_bytes(traces.read_bytes())
    assert main(["show", str(model), "--plot", str(tmp_path / "sym.png")]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[1].startswith("b1(X,Y): X above Y")
    assert (tmp_path / "sym.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _one_line_error(capsys, argv, *needles):
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    for n in needles:
        assert n in err
    return err


def test_user_errors(traces, tmp_path, capsys):
    ds = kinematic_tower(1, seed=0, steps=1)
    tiny = tmp_path / "tiny.json"
    write_traces(tiny, ds)
    _one_line_error(capsys, ["learn", str(tiny), "-o", str(tmp_path / "x"), "--quiet"], "tiny.json", "need at least 2")
    frozen = kinematic_tower(1, seed=0, steps=3)
    tr = frozen.traces[0]
    tr.scenes[:] = [tr.scenes[0]] * len(tr.scenes)
    still = tmp_path / "still.json"
    write_traces(still, frozen)
    _one_line_error(capsys, ["learn", str(still), "-o", str(tmp_path / "x"), "--quiet"], "still.json", "no transition changes")
    other = SymbolSet(tuple(intended_symbols()), ("x", "y", "z", "mass"))
    save_symbols(tmp_path / "symbols.json", other)
    _one_line_error(capsys, ["show", str(tmp_path), "--against", str(traces)], "traces.json: meta", "do not match")
    _one_line_error(capsys, ["abstract", str(traces), "--symbols", str(tmp_path), "-o", str(tmp_path / "o.json")],
                    "feature_names")
    (tmp_path / "bad.json").write_text('{"schema": "groundsym.symbols/1", "feature_names": ["x"], "symbols": [{"name": "u1"}]}')
    _one_line_error(capsys, ["show", str(tmp_path / "bad.json")], "bad.json: symbols[0].arity: missing")
    _one_line_error(capsys, ["learn", str(traces), "-o", str(tmp_path / "y"), "--unary", "0", "--binary", "0"],
                    "need at least one symbol")


def test_search_settings_reach_the_search(traces, tmp_path, capsys):
    """`--search looks=subset share_range=0.01,0.2 population=3` is the search that anneal runs with
    that AnnealConfig (the same symbols and loss as calling it directly), recorded in symbols.json;
    bad keys and values are one line each, before any work."""
    from groundsym.anneal import AnnealConfig, anneal
    from groundsym.loss import LossConfig, prepare

    assert _learn(traces, tmp_path / "s", "--seed", "2", "--search", "looks=subset share_range=0.01,0.2",
                  "--search", "population=3") == 0
    doc = json.loads((tmp_path / "s" / "symbols.json").read_text())
    cfg = AnnealConfig(evals=120, restarts=2, looks="subset", share_range=(0.01, 0.2), population=3)
    assert doc["config"]["anneal"] == cfg.to_doc()
    want = anneal(prepare(read_traces(traces)), LossConfig(), cfg, 2)
    assert doc["loss"]["total"] == want.terms.total
    assert [s["name"] for s in doc["symbols"]] == [s.name for s in want.symbols]
    assert [s["centre"] for s in doc["symbols"]] == [s.centre.tolist() for s in want.symbols]
    for bad, words in ((["speed=3"], ("--search speed", "unknown setting")),
                       (["population=2.5"], ("--search population=2.5", "whole number")),
                       (["p_reseed=nan"], ("--search", "p_reseed must be in [0, 1]")),
                       (["t_end=0"], ("--search", "t_end must be a finite number above 0")),
                       (["share_range=0.3"], ("--search share_range=0.3", "LO,HI")),
                       (["share_range=0.3,0.1"], ("--search", "0 < lo <= hi")),
                       (["looks=all"], ("--search", "looks must be one of independent, subset"))):
        _one_line_error(capsys, ["learn", str(traces), "-o", str(tmp_path / "x"), "--search", *bad], *words)
    assert not (tmp_path / "x").exists()


def test_loss_settings_reach_the_loss(traces, tmp_path, capsys):
    """`--loss transition_weight=0` removes the prediction term from the loss the search minimises
    and is recorded in symbols.json; the other terms keep their default weights."""
    assert _learn(traces, tmp_path / "w0", "--seed", "1", "--loss", "transition_weight=0 reg_weight=2") == 0
    doc = json.loads((tmp_path / "w0" / "symbols.json").read_text())
    assert doc["config"]["loss"]["transition_weight"] == 0.0 and doc["config"]["loss"]["reg_weight"] == 2.0
    assert doc["config"]["loss"]["effect_weight"] == 1.0
    assert doc["loss"]["transition"] == 0.0
    lt = doc["loss"]
    assert lt["total"] == pytest.approx(lt["effect"] + lt["reward"] + lt["regulariser"])
    _one_line_error(capsys, ["learn", str(traces), "-o", str(tmp_path / "x"), "--loss", "speed=3"],
                    "--loss speed", "unknown setting")
    _one_line_error(capsys, ["learn", str(traces), "-o", str(tmp_path / "x"), "--loss", "noise=0.7"],
                    "--loss", "noise must be in (0, 0.5)")
    _one_line_error(capsys, ["learn", str(traces), "-o", str(tmp_path / "x"), "--loss", "reward_weight=nan"],
                    "--loss reward_weight=nan", "finite")
    _one_line_error(capsys, ["learn", str(traces), "-o", str(tmp_path / "x"), "--loss", "predict=copy"],
                    "--loss", "predict must be one of changes, successor")
