"""``show --against`` suggests names from the ground-truth matches (hand-made matches, and the
fixture world's intended symbols through the command line)."""

import pytest

from groundsym.cli import main
from groundsym.grounding import Match, suggested_names
from groundsym.symbols import SymbolSet, save_symbols
from groundsym.traces import write_traces
from tests.test_loss import intended_symbols, kinematic_tower


def M(sym, arity, best, order, f1, neg=None, neg_f1=None):
    return Match(sym, arity, best, order, f1, f1, f1, neg, neg_f1)


def test_suggested_names():
    matches = [M("u1", 1, "inhand", "same", 0.95), M("u2", 1, "inhand", "same", 0.6),    # the better one wins
               M("u3", 1, "ontable", "same", 0.2, "inhand", 0.97),                       # learned "not in hand"
               M("b1", 2, "on", "swapped", 0.99), M("b2", 2, "above", "same", 0.3)]       # swapped / poor: none
    assert suggested_names(matches) == {"u1": "inhand", "u3": "not-inhand"}


@pytest.fixture(scope="module")
def traces(tmp_path_factory):
    path = tmp_path_factory.mktemp("data") / "traces.json"
    write_traces(path, kinematic_tower(5, seed=8))
    return path


@pytest.mark.parametrize("swap, names", [(False, "b1=on u1=inhand"), (True, "u1=inhand")])
def test_show_against_prints_the_suggested_rename_command(traces, tmp_path, capsys, swap, names):
    """The fixture world's intended symbols (inhand as u1, on as b1) against the traces' ground
    truth: both are suggested; with b1 drawn as "under" (on with its arguments swapped) b1 gets no
    name, since ``on`` would read its arguments the wrong way round."""
    model = tmp_path / "m"
    model.mkdir()
    save_symbols(model / "symbols.json", SymbolSet(tuple(intended_symbols(swap=swap)), ("x", "y", "z", "size")))
    (model / "traces.json").write_bytes(traces.read_bytes())
    capsys.readouterr()
    assert main(["show", str(model), "--against", str(traces)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [l for l in lines if l.startswith("suggested names:")] == [
        f"suggested names: groundsym rename {model} {names}"]
