"""Nothing crashes: each input that used to end in a traceback (issue 15's list) now gets one line
naming the file or option, and exit status 2, before any work or output."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from conftest import DATA
from groundsym.errors import UserError
from groundsym.ppddl.parser import MAX_DEPTH, parse_text
from tests.test_reliability import REFERENCE, cli, one_line_error

BW = [str(REFERENCE / "domain.ppddl"), str(REFERENCE / "p01.ppddl")]


@pytest.fixture(scope="module")
def tower_model(tmp_path_factory) -> Path:
    """A small model learned from the committed tower traces (symbols, rules, reward)."""
    out = tmp_path_factory.mktemp("tower") / "M"
    assert cli(["learn", str(DATA / "tower_small.json"), "-o", str(out), "--evals", "40", "--restarts", "1",
                "--workers", "1", "--quiet"]) == 0
    return out


def edited(tmp_path: Path, name: str, edit) -> Path:
    doc = json.loads((DATA / "tower_small.json").read_text())
    edit(doc)
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("edit, field", [
    (lambda d: d["traces"][0]["steps"][0]["features"][0].__setitem__(0, 1e308), "steps[0].features: a value"),
    (lambda d: d["traces"][0]["steps"][1].__setitem__("reward", 1e308), "steps[1].reward: 1e+308 is beyond"),
    (lambda d: d["traces"][1]["steps"][2].__setitem__("reward", -1e300), "steps[2].reward: -1e+300 is beyond"),
])
def test_huge_features_and_rewards_are_refused_where_they_enter(tmp_path, capsys, edit, field):
    path = edited(tmp_path, "t.json", edit)
    assert cli(["learn", str(path), "-o", str(tmp_path / "M"), "--evals", "10", "--restarts", "1", "--quiet"]) == 2
    one_line_error(capsys, str(path), field)
    assert not (tmp_path / "M").exists()


@pytest.mark.parametrize("text, message", [
    ("[" * 100_000 + "]" * 100_000, "JSON nested too deeply to read"),
    ('{"schema": "groundsym.traces/1", "n": ' + "9" * 5000 + "}", "unreadable JSON: a number with too many digits"),
])
def test_pathological_json_is_one_line(tmp_path, capsys, text, message):
    path = tmp_path / "bad.json"
    path.write_text(text)
    for command in (["learn", str(path), "-o", str(tmp_path / "M")], ["score", BW[0], str(path)],
                    ["abstract", str(DATA / "tower_small.json"), "--symbols", str(path), "-o", str(tmp_path / "x.json")]):
        assert cli(command) == 2
        one_line_error(capsys, f"{path}: {message}")


def deep_domain(levels: int) -> str:
    """The reference blocks world with one precondition wrapped in ``levels`` (and ...)."""
    text = (REFERENCE / "domain.ppddl").read_text()
    start = text.index("(", text.index(":precondition"))
    depth, end = 0, start
    while True:
        depth += {"(": 1, ")": -1}.get(text[end], 0)
        end += 1
        if depth == 0:
            break
    return text[:start] + "(and " * levels + text[start:end] + ")" * levels + text[end:]


def test_ppddl_nested_3000_deep_is_one_line_in_every_command(tmp_path, capsys, tower_model):
    deep = tmp_path / "deep.ppddl"
    deep.write_text(deep_domain(3000))
    data = tmp_path / "bw.json"
    assert cli(["simulate", "--domain", *BW[:1], "--problem", BW[1], "--traces", "1", "--length", "2",
                "-o", str(data)]) == 0
    capsys.readouterr()
    for command in (["simulate", "--domain", str(deep), "--problem", BW[1], "-o", str(tmp_path / "x.json")],
                    ["score", str(deep), str(data)],
                    ["plan", "--domain", str(deep), "--problem", BW[1], "--steps", "1"]):
        assert cli(command) == 2
        one_line_error(capsys, f"{deep}:", f"nested more than {MAX_DEPTH} deep")
    # just inside the limit the domain still parses, and means what the flat one means
    (inner,), _ = parse_text(deep_domain(MAX_DEPTH - 20))
    (flat,), _ = parse_text((REFERENCE / "domain.ppddl").read_text())
    assert [a.name for a in inner.actions] == [a.name for a in flat.actions]


@pytest.mark.parametrize("args, message", [
    (["--seed", "-3"], "--seed: must be at least 0"),
    (["--unary", "100000"], "--unary: at most 64"),
    (["--alpha", "nan"], "--alpha: must be a finite number"),
    (["--loss", "nosuch=1"], "--loss nosuch: unknown setting"),
    (["--model-data", "{missing}"], "no such file"),
    (["--checkpoint", "{dir}"], "is a directory"),
    (["--loss", "sigma_factor=0"], "--loss: sigma_factor must be positive, got 0.0"),
    (["--loss", "sigma_factor=-1"], "--loss: sigma_factor must be positive, got -1.0"),
])
def test_learn_checks_every_option_before_any_work(tmp_path, capsys, args, message):
    args = [a.replace("{missing}", str(tmp_path / "nope.json")).replace("{dir}", str(tmp_path)) for a in args]
    out = tmp_path / "M"
    assert cli(["learn", str(DATA / "tower_small.json"), "-o", str(out), "--quiet", *args]) == 2
    one_line_error(capsys, message)
    assert not out.exists() and [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_plan_refuses_a_model_of_another_sim_and_a_file_as_render_dir(tmp_path, capsys, tower_model):
    assert cli(["plan", "--sim", "bowling", "--model", str(tower_model), "--steps", "1"]) == 2
    one_line_error(capsys, "primitives", "not those of --sim bowling")
    (tmp_path / "file").write_text("")
    assert cli(["plan", "--sim", "tower", "--model", str(tower_model), "--steps", "1",
                "--render-dir", str(tmp_path / "file")]) == 2
    one_line_error(capsys, "--render-dir", "is not a directory")
    assert cli(["plan", "--domain", *BW[:1], "--problem", BW[1], "--seed", "-3"]) == 2
    one_line_error(capsys, "--seed: must be at least 0")


@pytest.mark.parametrize("opt, message", [("samples=100000000000", "at most 100000"),
                                          ("horizon=100000000", "at most 100")])
def test_planner_sizes_that_would_exhaust_memory_are_refused(capsys, opt, message):
    assert cli(["plan", "--domain", *BW[:1], "--problem", BW[1], "--steps", "1", "--planner-opt", opt]) == 2
    one_line_error(capsys, f"--planner-opt {opt}", message)


@pytest.mark.parametrize("args, message", [(["--width", "100000"], "at most 4096 pixels"),
                                           (["--height", "5000"], "at most 4096 pixels"),
                                           (["-o", "{tmp}/x.jpg"], "render writes PNG images")])
def test_render_sizes_and_formats(tmp_path, capsys, args, message):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    out = [] if "-o" in args else ["-o", str(tmp_path / "x.png")]
    assert cli(["render", "--sim", "tower", *out, *args]) == 2
    one_line_error(capsys, message)
    assert list(tmp_path.iterdir()) == []


def test_score_refuses_data_of_another_domain(tmp_path, capsys, tower_model):
    """Tower symbolic data scored against the blocks world used to give a number and exit 0."""
    data = tmp_path / "tower-symbolic.json"
    assert cli(["abstract", str(DATA / "tower_small.json"), "--symbols", str(tower_model), "-o", str(data)]) == 0
    bw_model = tmp_path / "bw"
    bw_data = tmp_path / "bw.json"
    assert cli(["simulate", "--domain", *BW[:1], "--problem", BW[1], "--traces", "2", "--length", "5",
                "-o", str(bw_data)]) == 0
    assert cli(["learn", str(bw_data), "-o", str(bw_model), "--quiet"]) == 0
    capsys.readouterr()
    for model in (BW[0], str(bw_model)):
        assert cli(["score", model, str(data)]) == 2
        one_line_error(capsys, f"{data}: predicates: do not match those of {model}", "another domain")
    assert cli(["score", str(tower_model), str(bw_data)]) == 2
    one_line_error(capsys, "predicates: do not match")
    assert cli(["score", BW[0], str(bw_data)]) == 0          # its own domain still scores


def test_plan_on_ppddl_prints_every_episodes_steps(capsys):
    assert cli(["plan", "--domain", *BW[:1], "--problem", BW[1], "--steps", "2", "--episodes", "2",
                "--planner", "random"]) == 0
    out = capsys.readouterr().out
    assert out.count("t=0 ") == 2 and out.count("t=1 ") == 2 and out.count("      do ") == 4


def test_a_tampered_model_is_refused_by_plan(tmp_path, capsys, tower_model):
    model = tmp_path / "M"
    shutil.copytree(tower_model, model)
    doc = json.loads((model / "symbols.json").read_text())
    doc["symbols"][0]["name"] = "renamed"
    (model / "symbols.json").write_text(json.dumps(doc))
    assert cli(["plan", "--sim", "tower", "--model", str(model), "--steps", "1"]) == 2
    one_line_error(capsys, "symbols.json: changed since the model was written")
    (model / "manifest.json").unlink()
    with pytest.raises(UserError, match="'renamed' \\(arity 1\\) is not a predicate of"):
        from groundsym.modeldir import load_model
        load_model(model)


@pytest.mark.parametrize("field, value", [("intercept", 1e308), ("weight", -1e300)])
def test_a_huge_reward_model_is_refused_where_it_is_read(tmp_path, capsys, tower_model, field, value):
    """An intercept of 1e308 was exported as is, and ``plan`` ended in a traceback from PRADA
    (``a cannot be empty unless no samples are taken``)."""
    model = tmp_path / "M"
    shutil.copytree(tower_model, model)
    (model / "manifest.json").unlink()
    doc = json.loads((model / "reward.json").read_text())
    if field == "intercept":
        doc["intercept"] = value
    else:
        doc["terms"][1]["weight"] = value
    (model / "reward.json").write_text(json.dumps(doc))
    where = "intercept" if field == "intercept" else "terms[1].weight"
    message = f"{model / 'reward.json'}: {where}: {value:.3g} is beyond 1e+12 in magnitude"
    assert cli(["export-domain", str(model), "-o", str(tmp_path / "out")]) == 2
    one_line_error(capsys, message)
    assert cli(["plan", "--sim", "tower", "--model", str(model), "--steps", "1"]) == 2
    one_line_error(capsys, message)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("setting", [{"sigma_factor": 0.0}, {"sigma_factor": float("nan")},
                                     {"effect_weight": float("inf")}, {"width_cap": float("nan")}])
def test_loss_settings_that_end_in_a_math_error_are_refused(setting):
    """``learn --loss sigma_factor=0`` ended in ``math domain error`` in the loss's reward term."""
    from groundsym.loss import LossConfig
    (key,) = setting
    with pytest.raises(ValueError, match=f"^{key} must be "):
        LossConfig(**setting)
