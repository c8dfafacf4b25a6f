"""A staging folder that a hard-killed ``learn`` left (``kill -9``) is removed by the next ``learn``
of the same model directory, only once its owner is dead; a live writer's folder is never touched
(docs/reliability.md)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import DATA, ROOT
from groundsym.cli import main

LEARN = ["learn", str(DATA / "tower_small.json"), "--evals", "20000", "--restarts", "2", "--workers", "1",
         "--seed", "5", "--quiet"]

pytestmark = pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process table from /proc")


@pytest.fixture(scope="module")
def data(blocks_traces) -> Path:
    """Symbolic traces: ``learn`` on them takes a second or two and needs no search."""
    return blocks_traces


def stages(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith(".M.new-"))


def start_learn(out: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "groundsym.cli", *LEARN, "-o", str(out)], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)


def wait_for_a_stage(p: subprocess.Popen, folder: Path) -> str:
    deadline = time.monotonic() + 60
    while not stages(folder) and p.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert p.poll() is None and len(stages(folder)) == 1, "learn should be building its model"
    return stages(folder)[0]


def test_the_folder_a_killed_learn_left_is_removed_by_the_next_learn(data, tmp_path):
    out = tmp_path / "M"
    p = start_learn(out)
    try:
        left = wait_for_a_stage(p, tmp_path)
        (tmp_path / left / "symbols.json").write_text("half")      # as if the search had begun writing
    finally:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
    assert stages(tmp_path) == [left]                              # SIGKILL leaves it: nothing can run
    assert main(["learn", str(data), "-o", str(out), "--quiet"]) == 0
    assert stages(tmp_path) == [] and (out / "rules.json").is_file()


def test_a_live_writers_folder_is_kept(data, tmp_path):
    """Two writers of one path: the second one's run leaves the first one's staging folder alone,
    and the first still puts its model in place (a later writer wins, whole)."""
    out = tmp_path / "M"
    p = start_learn(out)
    try:
        theirs = wait_for_a_stage(p, tmp_path)
        assert main(["learn", str(data), "-o", str(out), "--quiet"]) == 0
        assert stages(tmp_path) == [theirs] and p.poll() is None
    finally:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()


def test_owners_are_judged_by_pid_start_time_and_machine(data, tmp_path):
    """Names made as the writer makes them: a dead PID's folder goes; a live PID whose start time
    differs (the PID was reused) goes; the live owner's stays, and so do folders whose owner
    cannot be judged here (another machine or boot, an older version's name)."""
    from groundsym import staging

    dead = subprocess.Popen(["true"])
    dead.wait()
    me, started = os.getpid(), staging.start_time(os.getpid())
    assert started and staging.start_time(dead.pid) is None
    names = {
        "dead": f".M.new-{staging.machine()}-{dead.pid}-{started}-abc",
        "reused": f".M.new-{staging.machine()}-{me}-{started + 1}-abc",
        "live": f".M.new-{staging.machine()}-{me}-{started}-abc",
        "elsewhere": f".M.new-00000000-{dead.pid}-{started}-abc",
        "older": ".M.new-k2j4_x9q",
        "other model": f".N.new-{staging.machine()}-{dead.pid}-{started}-abc",
    }
    for name in names.values():
        (tmp_path / name).mkdir()
        (tmp_path / name / "rules.json").write_text("{}")
    assert main(["learn", str(data), "-o", str(tmp_path / "M"), "--quiet"]) == 0
    kept = {k for k, name in names.items() if (tmp_path / name).is_dir()}
    assert kept == {"live", "elsewhere", "older", "other model"}
    assert staging.prefix("M").startswith(f".M.new-{staging.machine()}-{me}-{started}-")
