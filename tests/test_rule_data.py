"""``evaluate --rule-data all``: rules and reward learn from the run's symbol data and its model traces
together (docs/planning.md); the default keeps the paper's protocol and the fingerprint of folders
made before the option existed."""

from __future__ import annotations

import pytest

from groundsym.cli import main
from groundsym.collect import collect_traces
from groundsym.evaluation.config import EvalConfig
from groundsym.evaluation.protocol import _sim, run_unit, unit_seeds
from groundsym.evaluation.truth import TruthSymbols
from groundsym.symbolic_traces import read_symbolic_traces

CFG = EvalConfig(sim="tower", methods=("random",), symbol_data=(12,), model_traces=(1,), seed=3,
                 steps=2, starts=1, truth_symbols=("inhand", "on"), trace_length=6)

def test_all_learns_on_the_symbol_data_followed_by_the_model_traces(tmp_path):
    """The model's training data is exactly the unit's symbol traces, then its model traces,
    abstracted with the truth: recollected here from the unit's own seeds."""
    def trained_on(cfg):
        (files,) = run_unit(cfg, 12, 0)["models"].values()
        (tmp_path / "s.json").write_text(files["symbolic-traces.json"])
        return [(tr.states, tr.actions) for tr in read_symbolic_traces(tmp_path / "s.json").traces]

    cfg = EvalConfig(**{**CFG.__dict__, "rule_data": "all"})
    seeds, sim = unit_seeds(cfg, 12, 0), _sim(cfg)
    sym = collect_traces(sim, 2, 6, seeds["symbol_data"], progress=False)
    mod = collect_traces(sim, 1, 6, seeds["model_data"][1], progress=False)
    truth = TruthSymbols(("inhand", "on"), dict(sim.truth_predicates))
    want = [(tr.states, tr.actions) for tr in truth.to_symbolic_dataset(
        type(sym)(sym.traces + mod.traces, sym.feature_names, sym.primitives)).traces]
    got = trained_on(cfg)
    assert len(got) == 3 and got == want
    assert trained_on(CFG) == want[2:]          # the default: the fresh model traces only


def test_default_keeps_the_fingerprint_and_all_changes_it():
    key = CFG.key()
    assert "rule_data" not in key           # folders from before the option resume
    assert EvalConfig(**{**CFG.__dict__, "rule_data": "all"}).fingerprint() != CFG.fingerprint()

def test_unknown_rule_data_is_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", "--sim", "tower", "--rule-data", "every", "-o", str(tmp_path / "e"), "--quiet"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--rule-data" in err and "Traceback" not in err and not (tmp_path / "e").exists()
