"""Nothing lost: outputs never replace special files, model directories are replaced whole or not at
all and refuse parts that do not belong together (docs/reliability.md lists what each test holds)."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import pytest

from groundsym.cli import main
from groundsym.errors import UserError
from groundsym.fileio import atomic_write_json, atomic_write_text
from groundsym.modeldir import MANIFEST, load_model, model_transaction, recover

REFERENCE = Path(__file__).resolve().parents[1] / "domains" / "reference" / "blocksworld"


def cli(argv: list[str]) -> int:
    """``groundsym ARGV``'s exit status, whether the command or argparse refused the input."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


def one_line_error(capsys, *want: str) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for w in want:
        assert w in err, err
    return err


@pytest.fixture(scope="module")
def data(blocks_traces) -> Path:
    return blocks_traces


@pytest.fixture(scope="module")
def model(data, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("relm") / "M"
    assert main(["learn", str(data), "-o", str(out), "--quiet"]) == 0
    return out


def snapshot(d: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(d.iterdir())}


# ----------------------------------------------------------------------------- special files
def test_a_fifo_or_directory_is_never_replaced(tmp_path):
    fifo, folder = tmp_path / "f", tmp_path / "d"
    os.mkfifo(fifo)
    folder.mkdir()
    with pytest.raises(UserError, match="not a regular file \\(a FIFO\\)"):
        atomic_write_json(fifo, {"a": 1})
    with pytest.raises(UserError, match="is a directory"):
        atomic_write_text(folder, "x")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and folder.is_dir()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d", "f"]   # no temporary file left behind


def test_a_symlink_is_written_through(tmp_path):
    target = tmp_path / "real.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    atomic_write_json(link, {"a": 1})
    assert link.is_symlink() and json.loads(target.read_text()) == {"a": 1}
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to(tmp_path / "new.json")
    atomic_write_text(dangling, "x")
    assert dangling.is_symlink() and (tmp_path / "new.json").read_text() == "x"
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    (tmp_path / "to-fifo").symlink_to(fifo)
    with pytest.raises(UserError, match="FIFO"):
        atomic_write_text(tmp_path / "to-fifo", "x")


def test_a_parent_that_is_a_file_is_named(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(UserError, match="file is a file, not a directory"):
        atomic_write_text(tmp_path / "file" / "sub" / "x.json", "x")


@pytest.mark.parametrize("command", [
    ["simulate", "--domain", str(REFERENCE / "domain.ppddl"), "--problem", str(REFERENCE / "p01.ppddl")],
    ["collect", "--sim", "tower"],
    ["render", "--sim", "tower"],
])
@pytest.mark.parametrize("kind", ["fifo", "dir"])
def test_commands_refuse_special_outputs_before_any_work(tmp_path, capsys, command, kind):
    out = tmp_path / "out"
    os.mkfifo(out) if kind == "fifo" else out.mkdir()
    assert cli([*command, "-o", str(out)]) == 2
    one_line_error(capsys, "FIFO" if kind == "fifo" else "is a directory")
    assert stat.S_ISFIFO(os.lstat(out).st_mode) if kind == "fifo" else out.is_dir()


# ----------------------------------------------------------------------------- model directories
def test_a_failing_learn_leaves_the_old_model_intact(data, model, capsys):
    before = snapshot(model)
    for bad in (["--p-min", "5"], ["--alpha", "nan"], ["--alpha", "-1"]):
        assert main(["learn", str(data), "-o", str(model), "--quiet", *bad]) == 2
        one_line_error(capsys, bad[0])
    assert snapshot(model) == before
    assert not [p for p in model.parent.iterdir() if p.name.startswith(".")]   # no staging left


def test_a_model_directory_is_replaced_whole(data, tmp_path):
    out = tmp_path / "M"
    assert main(["learn", str(data), "-o", str(out), "--quiet", "--seed", "1"]) == 0
    (out / "checkpoint.json").write_text("{}")        # a file of the user's is carried over
    old = snapshot(out)
    with pytest.raises(KeyboardInterrupt):
        with model_transaction(out) as stage:
            (stage / "rules.json").write_text("half")
            raise KeyboardInterrupt
    assert snapshot(out) == old and sorted(p.name for p in tmp_path.iterdir()) == ["M"]
    assert main(["learn", str(data), "-o", str(out), "--quiet", "--alpha", "2"]) == 0
    new = snapshot(out)
    assert new["checkpoint.json"] == b"{}" and new["rules.json"] != old["rules.json"]
    assert json.loads(new[MANIFEST])["files"].keys() == {"rules.json", "rules.txt", "reward.json",
                                                          "symbolic-traces.json"}


def test_a_crash_between_the_renames_is_recovered(model, tmp_path):
    import shutil

    d = tmp_path / "M"
    shutil.copytree(model, d)
    want = snapshot(d)
    backup = tmp_path / ".M.backup"
    os.rename(d, backup)                    # the state after the first rename, before the second
    assert load_model(d).rules.rules       # the next command restores the old model
    assert snapshot(d) == want and not backup.exists()
    shutil.copytree(d, backup)              # after the second rename, before the backup went
    recover(d)
    assert snapshot(d) == want and not backup.exists()


@pytest.mark.parametrize("setup, message", [
    (lambda t: (t / "file").write_text(""), "file is a file, not a directory"),
    (lambda t: (t / "notes").mkdir() or (t / "notes" / "a.txt").write_text("keep"), "holds no model"),
])
def test_learn_refuses_outputs_it_would_destroy(data, tmp_path, capsys, setup, message):
    setup(tmp_path)
    target = tmp_path / ("file/m" if message.startswith("file") else "notes")
    assert main(["learn", str(data), "-o", str(target), "--quiet"]) == 2
    one_line_error(capsys, message)
    if (tmp_path / "notes").exists():
        assert (tmp_path / "notes" / "a.txt").read_text() == "keep"


def test_learn_into_proc_is_one_line(data, capsys):
    assert main(["learn", str(data), "-o", "/proc/m", "--quiet"]) == 2
    one_line_error(capsys, "/proc/m: cannot write")


def test_loading_refuses_parts_of_different_models(data, model, tmp_path, capsys):
    import shutil

    other = tmp_path / "other"
    assert main(["learn", str(data), "-o", str(other), "--quiet", "--alpha", "3"]) == 0
    mixed = tmp_path / "mixed"
    shutil.copytree(model, mixed)
    shutil.copy(other / "rules.json", mixed / "rules.json")
    with pytest.raises(UserError, match="rules.json: changed since the model was written"):
        load_model(mixed)
    assert main(["export-domain", str(mixed), "-o", str(tmp_path / "x")]) == 2
    one_line_error(capsys, "SHA-256")
    # without a manifest (older or hand-made directories) the vocabularies are still compared
    (mixed / MANIFEST).unlink()
    reward = json.loads((mixed / "reward.json").read_text())
    reward["predicates"]["tower"] = 2
    (mixed / "reward.json").write_text(json.dumps(reward))
    with pytest.raises(UserError, match="predicates.tower: not a predicate of"):
        load_model(mixed)


# ----------------------------------------------------------------------------- evaluate
@pytest.mark.parametrize("bad, message", [
    (["--truth-symbols", "nosuch"], "--truth-symbols: nosuch not among"),
    (["--planner-opt", "prada:samples=x"], "--planner-opt samples=x"),
    (["--planner-opt", "prada:bogus=1"], "unknown option for planner 'prada'"),
    (["--unary", "0", "--binary", "0"], "need at least one symbol"),
    (["--loss", "reward_model=nearest"], "reward_model must be one of neighbour, linear"),
    (["--loss", "bogus=1"], "--loss bogus: unknown setting"),
])
def test_evaluate_validates_before_writing_config(tmp_path, capsys, bad, message):
    from groundsym.evaluation.config import EvalConfig
    from groundsym.evaluation.store import check_config

    out = tmp_path / "E"
    assert main(["evaluate", "--sim", "tower", "--runs", "1", "--quiet", "-o", str(out), *bad]) == 2
    one_line_error(capsys, message)
    assert not out.exists()
    # the corrected options are accepted by the same folder (nothing was left to refuse them)
    good = EvalConfig(sim="tower", methods=("random",), symbol_data=(20,), model_traces=(1,))
    check_config(out, good)
    assert json.loads((out / "config.json").read_text())["fingerprint"] == good.fingerprint()


# ----------------------------------------------------------------------------- smaller items
def test_learn_quiet_is_quiet(data, tmp_path, capsys):
    assert main(["learn", str(data), "-o", str(tmp_path / "M"), "--quiet"]) == 0
    assert capsys.readouterr().err == ""           # the rule-learning bars too


def test_simulate_checks_its_output_before_the_domain(tmp_path, capsys):
    (tmp_path / "file").write_text("")
    (tmp_path / "bad.ppddl").write_text("(define (domain")
    assert cli(["simulate", "--domain", str(tmp_path / "bad.ppddl"), "-o", str(tmp_path / "file" / "x.json")]) == 2
    one_line_error(capsys, "x.json: cannot write", "file is a file, not a directory")


@pytest.mark.parametrize("goal, message", [("", "--goal: expected literals"),
                                           ("(on a b) (not (on a b))", "(on a b) is both required and forbidden")])
def test_export_refuses_empty_and_contradictory_goals(model, tmp_path, capsys, goal, message):
    assert main(["export-domain", str(model), "-o", str(tmp_path / "o"), "--goal", goal]) == 2
    one_line_error(capsys, message)
    assert not (tmp_path / "o").exists()


def test_re_export_without_determinize_leaves_no_stale_pddl(model, tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["export-domain", str(model), "-o", str(out), "--determinize", "all-outcomes",
                 "--goal", "(on a b)"]) == 0
    assert (out / "domain.pddl").exists() and (out / "problem.pddl").exists()
    assert main(["export-domain", str(model), "-o", str(out), "--goal", "(on b a)"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["domain.ppddl", "problem.ppddl"]


def test_a_model_directory_given_as_a_link_is_refused(data, model, tmp_path, capsys):
    link = tmp_path / "link"
    link.symlink_to(model, target_is_directory=True)
    before = snapshot(model)
    assert main(["learn", str(data), "-o", str(link), "--quiet"]) == 2
    one_line_error(capsys, "is a symbolic link; give the model directory itself")
    assert link.is_symlink() and snapshot(model) == before
