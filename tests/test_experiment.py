"""``groundsym evaluate``'s protocol: aggregation by hand, the same table for any number of
workers, resuming from finished runs, stopping its workers when interrupted, refusing to mix
evaluations; on the real tower sim (with its ground-truth relations as the abstraction, so the
test needs no symbol learning)."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from conftest import descendants
from groundsym.errors import UserError
from groundsym.evaluation.config import EvalConfig
from groundsym.evaluation.protocol import evaluate, write_outputs
from groundsym.evaluation.results import aggregate
from groundsym.evaluation.store import unit_path
from groundsym.evaluation.tables import markdown_table
from groundsym.figures import bar_chart

CFG = EvalConfig(sim="tower", methods=("random", "prada"), symbol_data=(10,), model_traces=(1,), seed=5,
                 steps=3, starts=1, truth_symbols=("inhand", "on"), trace_length=6,
                 planner_options={"prada": {"samples": "100"}})


def write_unit(out, cfg, N, run, values):
    entries = [{"model_traces": n, "method": m, "values": [v], "mean": v}
               for (n, m), v in values.items()]
    unit_path(out, N, run).parent.mkdir(parents=True, exist_ok=True)
    unit_path(out, N, run).write_text(json.dumps({"config": cfg.fingerprint(), "symbol_data": N, "run": run,
                                                  "entries": entries, "report": {}}))


def test_aggregate_by_hand(tmp_path):
    cfg = EvalConfig(sim="tower", methods=("random", "prada"), symbol_data=(40,), model_traces=(3,))
    for run, (r, p) in enumerate([(0.01, 0.06), (0.02, 0.08), (0.03, 0.07)]):
        write_unit(tmp_path, cfg, 40, run, {(3, "random"): r, (3, "prada"): p})
    res = aggregate(tmp_path, cfg, 3, optimum=0.1, provenance=None)
    rows = {r["method"]: r for r in res["methods"]}
    assert rows["prada"]["mean"] == pytest.approx(0.07)
    assert rows["prada"]["stderr"] == pytest.approx(np.std([0.06, 0.08, 0.07], ddof=1) / np.sqrt(3))
    assert rows["prada"]["share_of_optimum"] == pytest.approx(0.7) and rows["random"]["n"] == 3
    assert "| 40 | 3 | prada | 0.07 |" in markdown_table(res)
    assert bar_chart(res)[:8] == b"\x89PNG\r\n\x1a\n"
    write_outputs(tmp_path, res)
    assert json.loads((tmp_path / "results.json").read_text())["methods"] == res["methods"]


@pytest.mark.slow
def test_same_table_for_any_number_of_workers(tmp_path):
    a = evaluate(CFG, 2, tmp_path / "a", workers=1, progress=False, optimum=0.1)
    b = evaluate(CFG, 2, tmp_path / "b", workers=2, progress=False, optimum=0.1)
    assert a["methods"] == b["methods"] and len(a["methods"]) == 2
    assert all(r["n"] == 2 for r in a["methods"])


def test_an_interrupt_while_a_unit_is_saved_stops_the_workers_at_once(tmp_path, monkeypatch):
    """Ctrl-C in the driver while it writes a finished unit: the units still running on the
    other worker are not waited for, and no worker outlives the evaluation."""
    from groundsym.evaluation import protocol

    def interrupted(out, result):
        raise KeyboardInterrupt

    others = descendants(os.getpid())
    monkeypatch.setattr(protocol, "save_unit", interrupted)
    with pytest.raises(KeyboardInterrupt):
        evaluate(CFG, 3, tmp_path / "a", workers=2, progress=False)
    assert descendants(os.getpid()) - others == set()
    assert not (tmp_path / "a" / "runs").exists()


def test_resume_from_finished_runs_gives_the_same_table(tmp_path):
    a = evaluate(CFG, 2, tmp_path / "a", workers=1, progress=False, optimum=0.1)
    kept = unit_path(tmp_path / "a", 10, 0)
    before = kept.read_text()
    unit_path(tmp_path / "a", 10, 1).unlink()               # an interrupted evaluation
    c = evaluate(CFG, 2, tmp_path / "a", workers=1, progress=False, optimum=0.1)
    assert c["methods"] == a["methods"] and kept.read_text() == before
    assert (tmp_path / "a" / "results.png").exists() and (tmp_path / "a" / "results.md").exists()
    other = EvalConfig(**{**CFG.__dict__, "seed": 6})
    with pytest.raises(UserError, match="other options"):
        evaluate(other, 2, tmp_path / "a", progress=False)


def test_grounding_summary_counts_runs_that_found_each_relation(tmp_path):
    """By hand: run 0 learned inhand (F1 0.95) and on (0.85); run 1 inhand (0.7) and above (0.9);
    run 2 "not in the hand" (best match ontable 0.6, its negation inhand 0.92) and on (0.5)."""
    cfg = EvalConfig(sim="tower", methods=("random",), symbol_data=(40,), model_traces=(3,))
    reports = [[("u1", "inhand", 0.95, None, None), ("b1", "on", 0.85, None, None)],
               [("u1", "inhand", 0.7, None, None), ("b1", "above", 0.9, None, None)],
               [("u1", "ontable", 0.6, "inhand", 0.92), ("b1", "on", 0.5, None, None)]]
    for run, rep in enumerate(reports):
        write_unit(tmp_path, cfg, 40, run, {(3, "random"): 0.01})
        doc = json.loads(unit_path(tmp_path, 40, run).read_text())
        doc["report"] = {"grounding": [{"symbol": s, "best_match": m, "f1": f, "negation_match": n,
                                        "negation_f1": nf} for s, m, f, n, nf in rep]}
        unit_path(tmp_path, 40, run).write_text(json.dumps(doc))
    res = aggregate(tmp_path, cfg, 3, optimum=None, provenance=None)
    g = res["meta"]["grounding"]["40"]
    assert g["runs"] == 3 and g["found"] == {"above": 1, "inhand": 2, "on": 1, "ontable": 0}
    assert g["matches"]["u1~inhand"] == {"runs": 2, "mean_f1": pytest.approx(0.825)}
    assert "| 40 | 3 | 1 | 2 | 1 | 0 |" in markdown_table(res)


def test_fingerprint_covers_the_search_and_loss_settings(tmp_path, capsys):
    """Results from code with other annealing or loss defaults must not be mixed into one
    evaluation: the stored config carries both; impossible search settings are one line."""
    from groundsym.anneal import AnnealConfig
    from groundsym.cli import main

    learned = EvalConfig(sim="tower", methods=("random",), symbol_data=(40,), model_traces=(3,), evals=800)
    key = learned.key()
    assert key["anneal"] == AnnealConfig(n_unary=1, n_binary=1, evals=800, restarts=4).to_doc()
    assert key["loss"]["noise"] == 0.05
    truth = EvalConfig(**{**learned.__dict__, "truth_symbols": ("inhand", "on")})
    assert truth.key()["anneal"] is None and truth.fingerprint() != learned.fingerprint()
    capsys.readouterr()
    assert main(["evaluate", "--sim", "tower", "--evals", "2", "--restarts", "4", "--runs", "1",
                 "-o", str(tmp_path / "e"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--evals" in err and "Traceback" not in err


def test_fingerprint_covers_the_sims_defaults_and_cell_version(monkeypatch):
    """A resumed folder must not mix units of a cell whose defaults or version changed."""
    import dataclasses

    import sims.tower as tower

    cfg = EvalConfig(sim="tower", methods=("random",), symbol_data=(40,), model_traces=(3,))
    before = cfg.fingerprint()
    assert cfg.key()["sim_cell"]["options"]["noise"] == tower.TowerSim(cubes=1).options["noise"]
    monkeypatch.setattr(tower.TowerSim, "CELL_VERSION", tower.TowerSim.CELL_VERSION + 1)
    assert cfg.fingerprint() != before
    monkeypatch.undo()
    noise = [o for o in tower.OPTIONS if o.name == "noise"][0]
    monkeypatch.setattr(tower, "OPTIONS", tuple(o if o.name != "noise" else dataclasses.replace(o, default=0.02)
                                                for o in tower.OPTIONS))
    monkeypatch.setattr(tower.TowerSim, "OPTIONS", tower.OPTIONS)
    assert noise.default != 0.02 and cfg.fingerprint() != before
