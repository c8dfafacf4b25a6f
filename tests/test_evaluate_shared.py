"""``evaluate --model-data-scope run``: a run's symbol-data sizes share its model traces, and the methods
that read no symbols play once per run (docs/planning.md, "What a unit costs"). Checked against the
same units computed without sharing (each size collecting and playing everything itself from the
run's seeds), on the real tower sim with its true relations (no symbol learning needed)."""

from __future__ import annotations

import json

import pytest

from groundsym.cli import main
from groundsym.evaluation.config import EvalConfig
from groundsym.evaluation.protocol import run_run, run_unit, symbol_free, unit_seeds

CFG = EvalConfig(sim="tower", methods=("random", "continuous-nn", "symbolic-nn"), symbol_data=(10, 20),
                 model_traces=(1,), seed=3, steps=2, starts=2, truth_symbols=("inhand", "on"), trace_length=4,
                 rule_data="all", model_data="run")
TIMES = ("seconds", "cpu_seconds", "shared_cpu_seconds")


def without_times(unit: dict) -> dict:
    return {k: v for k, v in unit.items() if k not in TIMES}


def test_a_shared_run_equals_its_sizes_computed_alone():
    """With rules on the model traces only, RANDOM and CONTINUOUS-NN are played once and copied to
    both sizes; every record equals the one the size computes alone, episodes and models alike."""
    cfg = EvalConfig(**{**CFG.__dict__, "rule_data": "model"})
    assert [symbol_free(cfg, m) for m in cfg.methods] == [True, True, False]
    shared = run_run(cfg, 1)
    alone = [run_unit(cfg, N, 1) for N in cfg.symbol_data]
    assert [without_times(u) for u in shared["units"]] == [without_times(a["unit"]) for a in alone]
    assert shared["models"] == {k: v for a in alone for k, v in a["models"].items()}
    base = [[e["values"] for e in u["entries"] if e["method"] != "symbolic-nn"] for u in shared["units"]]
    assert base[0] == base[1] and len(base[0]) == 2            # the same episodes for both sizes


def test_rule_data_all_shares_the_traces_but_not_the_episodes():
    """With ``rule_data=all`` CONTINUOUS-NN reads the size's own symbol data too: nothing is
    shared but the model traces, and the records still equal the sizes computed alone."""
    assert not any(symbol_free(CFG, m) for m in CFG.methods)
    shared = run_run(CFG, 0)
    alone = [run_unit(CFG, N, 0)["unit"] for N in CFG.symbol_data]
    assert [without_times(u) for u in shared["units"]] == [without_times(a) for a in alone]


def test_run_seeds_are_the_runs_and_the_symbols_seeds_the_units():
    unit = EvalConfig(**{**CFG.__dict__, "model_data": "unit"})
    a, b = unit_seeds(CFG, 10, 0), unit_seeds(CFG, 20, 0)
    assert a["model_data"] == b["model_data"] and a["planners"] == b["planners"]
    assert a["symbol_data"] != b["symbol_data"] and a["anneal"] != b["anneal"]
    assert {k: unit_seeds(unit, 10, 0)[k] for k in ("symbol_data", "anneal")} == \
        {k: a[k] for k in ("symbol_data", "anneal")}                 # the same symbols as per unit
    assert unit_seeds(unit, 10, 0)["model_data"] != a["model_data"]
    assert "model_data" not in unit.key() and CFG.fingerprint() != unit.fingerprint()


def test_evaluate_resumes_a_shared_run_from_its_records(tmp_path, capsys):
    """The driver writes one record per size; removing one runs that run again, to the same numbers."""
    argv = ["evaluate", "--sim", "tower", "--methods", "random,symbolic-nn", "--symbol-data", "10,20",
            "--model-traces", "1", "--truth-symbols", "inhand,on", "--steps", "2", "--starts", "1",
            "--runs", "2", "--seed", "4", "--model-data-scope", "run", "--quiet", "-o", str(tmp_path / "e")]
    assert main(argv) == 0
    runs = tmp_path / "e" / "runs"
    first = {p.name: without_times(json.loads(p.read_text())) for p in runs.glob("*.json")}
    assert sorted(first) == ["N10-run000.json", "N10-run001.json", "N20-run000.json", "N20-run001.json"]
    (runs / "N20-run001.json").unlink()
    assert main(argv) == 0
    again = {p.name: without_times(json.loads(p.read_text())) for p in runs.glob("*.json")}
    assert again == first
    capsys.readouterr()


@pytest.mark.parametrize("bad", [["--model-data-scope", "trace"]])
def test_unknown_model_data_is_one_line(tmp_path, capsys, bad):
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", "--sim", "tower", *bad, "-o", str(tmp_path / "e"), "--quiet"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--model-data-scope" in err and "Traceback" not in err and not (tmp_path / "e").exists()
