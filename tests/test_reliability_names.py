"""Nothing silently wrong: a duplicated rule, a name that PDDL reads as another (PDDL ignores case)
and a name that is no PDDL name are refused in one line, exit status 2, where they enter: when a
model part is read, and when ``rename`` or ``export-domain --rename`` would make them."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from groundsym.errors import UserError
from groundsym.rules.io import doc_to_rules
from groundsym.symbols import load_symbols
from tests.test_reliability import REFERENCE, cli, one_line_error


@pytest.fixture(scope="module")
def bw_model(tmp_path_factory) -> Path:
    """Rules and reward learned from blocks-world data (predicates clear, handempty, holding, on,
    ontable; actions pickup, putdown, stack, unstack): learning from symbolic data takes a second."""
    root = tmp_path_factory.mktemp("names")
    data, model = root / "bw.json", root / "BW"
    assert cli(["simulate", "--domain", str(REFERENCE / "domain.ppddl"), "--problem", str(REFERENCE / "p01.ppddl"),
                "--traces", "4", "--length", "8", "--seed", "1", "-o", str(data)]) == 0
    assert cli(["learn", str(data), "-o", str(model), "--quiet"]) == 0
    return model


def files_of(directory: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(directory.iterdir())}


def hand_edited(bw_model: Path, tmp_path: Path, name: str, edit) -> Path:
    """A copy of the model with ``name`` edited and no manifest (as a hand-made directory)."""
    model = tmp_path / "M"
    shutil.copytree(bw_model, model)
    (model / "manifest.json").unlink()
    doc = json.loads((model / name).read_text())
    edit(doc)
    (model / name).write_text(json.dumps(doc))
    return model


def test_a_duplicated_rule_is_refused_naming_both(bw_model, tmp_path, capsys):
    """The copy, even with its variables renamed, made the score fall from -0.048 to -6.93 nats
    (neither copy covers any state any more) and exited 0."""
    def duplicate(doc):
        rule = json.loads(json.dumps(doc["rules"][1]).replace("?x1", "?y"))
        doc["rules"].append(rule)
    model = hand_edited(bw_model, tmp_path, "rules.json", duplicate)
    k = len(json.loads((model / "rules.json").read_text())["rules"]) - 1
    assert cli(["export-domain", str(model), "-o", str(tmp_path / "out")]) == 2
    one_line_error(capsys, f"{model / 'rules.json'}: rules[{k}]: ", "the same rule as rules[1]")
    assert not (tmp_path / "out").exists()


def test_rules_that_differ_are_not_duplicates(bw_model):
    doc = json.loads((bw_model / "rules.json").read_text())
    rules, _ = doc_to_rules(doc, "rules.json")
    assert len(rules.rules) == len(doc["rules"]) >= 4


@pytest.mark.parametrize("rename, message", [
    ("on=CLEAR", "two predicates would be called 'CLEAR' and 'clear'"),
    ("on=Clear", "two predicates would be called 'Clear' and 'clear'"),
    ("on=PICKUP", "'PICKUP' is the action 'pickup' of"),
    ("on=NO-CLEAR", "'NO-CLEAR' is the predicate 'no-clear' derived from 'clear'"),
    ("on=no-clear", "'no-clear' is the predicate 'no-clear' derived from 'clear'"),
    ("on=Either", "'Either' is a PDDL keyword"),
])
def test_renames_that_pddl_reads_as_another_name_are_refused(bw_model, tmp_path, capsys, rename, message):
    model = tmp_path / "M"
    shutil.copytree(bw_model, model)
    before = files_of(model)
    assert cli(["rename", str(model), rename]) == 2
    one_line_error(capsys, f"rename {rename}" if "keyword" in message else "rename: ", message)
    assert files_of(model) == before
    assert cli(["export-domain", str(model), "-o", str(tmp_path / "out"), "--rename", rename]) == 2
    one_line_error(capsys, message)
    assert not (tmp_path / "out").exists()


def test_a_rename_that_only_changes_case_is_accepted(bw_model, tmp_path, capsys):
    model = tmp_path / "M"
    shutil.copytree(bw_model, model)
    assert cli(["rename", str(model), "on=ON", "clear=free"]) == 0
    assert json.loads((model / "rules.json").read_text())["predicates"] == {
        "ON": 2, "free": 1, "handempty": 0, "holding": 1, "ontable": 1}


@pytest.mark.parametrize("name, edit, field, message", [
    ("rules.json", lambda d: d["predicates"].__setitem__("(u1)", 1), "predicates", "'(u1)' is not a PDDL name"),
    ("rules.json", lambda d: d["predicates"].__setitem__("u1\n", 1), "predicates", "'u1\\n' is not a PDDL name"),
    ("rules.json", lambda d: d["predicates"].__setitem__("CLEAR", 1), "predicates",
     "'CLEAR' and 'clear' are one name in PDDL"),
    ("rules.json", lambda d: d["predicates"].__setitem__("and", 1), "predicates", "'and' is a PDDL keyword"),
    ("rules.json", lambda d: d["primitives"].__setitem__("pick up", 1), "primitives", "'pick up' is not a PDDL name"),
    ("rules.json", lambda d: d["primitives"].__setitem__("Stack", 2), "primitives",
     "'Stack' and 'stack' are one name in PDDL"),
    ("rules.json", lambda d: d.__setitem__("derived", [{"name": "no on", "holds_when_no": "(on ?x _)"}]),
     "derived[0].name", "'no on' is not a PDDL name"),
    ("rules.json", lambda d: d.__setitem__("derived", [{"name": "Clear", "holds_when_no": "(on ?x _)"}]),
     "derived[0].name", "'Clear' and 'clear' are one name in PDDL"),
    ("rules.json", lambda d: d["primitives"].__setitem__("ONtable", 1), "primitives",
     "'ONtable' is also the predicate 'ontable' (one name in PDDL, which ignores case)"),
    ("rules.json", lambda d: d.__setitem__("derived", [{"name": "no-on", "holds_when_no": "(on ?x _)"},
                                                       {"name": "NO-ON", "holds_when_no": "(on _ ?x)"}]),
     "derived", "'NO-ON' and 'no-on' are one name in PDDL"),
    ("reward.json", lambda d: d["predicates"].__setitem__("u\n1", 1), "predicates", "'u\\n1' is not a PDDL name"),
    ("reward.json", lambda d: d["predicates"].__setitem__("Holding", 1), "predicates",
     "'Holding' and 'holding' are one name in PDDL"),
])
def test_a_model_part_with_a_name_that_is_no_pddl_name_is_refused_at_load(bw_model, tmp_path, capsys,
                                                                          name, edit, field, message):
    """Such a name used to load; the failure came later, as a syntax error in "<exported domain>" or
    a message of two lines."""
    model = hand_edited(bw_model, tmp_path, name, edit)
    assert cli(["export-domain", str(model), "-o", str(tmp_path / "out")]) == 2
    one_line_error(capsys, f"{model / name}: {field}: {message}")
    assert not (tmp_path / "out").exists()


def symbols_doc(*names: str) -> dict:
    return {"schema": "groundsym.symbols/1", "feature_names": ["x", "y"],
            "symbols": [{"name": n, "arity": 1, "centre": [0.0, 0.0], "widths": [1.0, 1.0]} for n in names]}


@pytest.mark.parametrize("names, message", [
    (("u1\n",), "symbols[0].name: 'u1\\n' is not a PDDL name"),
    (("u1", "U1"), "symbols[1].name: 'U1' and 'u1' are one name in PDDL"),
    (("not",), "symbols[0].name: 'not' is a PDDL keyword"),
])
def test_symbols_with_names_that_are_no_pddl_names_are_refused(tmp_path, names, message):
    path = tmp_path / "symbols.json"
    path.write_text(json.dumps(symbols_doc(*names)))
    with pytest.raises(UserError) as info:
        load_symbols(path)
    assert str(info.value).startswith(f"{path}: {message}") and "\n" not in str(info.value), str(info.value)
    path.write_text(json.dumps(symbols_doc("u1", "u2")))
    assert [s.name for s in load_symbols(path).symbols] == ["u1", "u2"]
