"""`groundsym learn` is reproducible from its seed: the same symbols.json for any number of workers,
after a run stopped with SIGINT or killed with SIGKILL and resumed from its checkpoint, and a
recorded loss that a fresh Loss gives again."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import DATA, as_foreground_job
from groundsym.cli import main
from groundsym.loss import Loss, LossConfig, prepare
from groundsym.symbols import Symbol
from groundsym.traces import read_traces

TRACES = DATA / "tower_16.json"
CLI = [sys.executable, "-m", "groundsym.cli"]


def _learn_cmd(out: Path, evals: int, *extra: str) -> list[str]:
    return [*CLI, "learn", str(TRACES), "-o", str(out), "--evals", str(evals), "--restarts", "2",
            "--seed", "7", "--quiet", *extra]


def _symbols(out: Path) -> dict:
    doc = json.loads((out / "symbols.json").read_text())
    doc.pop("provenance")
    return doc


def _rescore(out: Path) -> float:
    """The symbols.json candidate (kept and pruned symbols, by arity, as the search held them)
    scored on a new Loss."""
    doc = json.loads((out / "symbols.json").read_text())
    syms = [Symbol(s["name"], int(s["arity"]), np.array(s["centre"], float), np.array(s["widths"], float))
            for s in doc["symbols"] + doc["pruned"]]
    syms = [s for s in syms if s.arity == 1] + [s for s in syms if s.arity == 2]
    config = LossConfig(**doc["config"]["loss"])
    return Loss(prepare(read_traces(TRACES), config), config)(syms).total


def test_recorded_loss_equals_a_fresh_rescore(tmp_path):
    out = tmp_path / "m"
    assert main(_learn_cmd(out, 80, "--workers", "1")[len(CLI):]) == 0
    assert _rescore(out) == json.loads((out / "symbols.json").read_text())["loss"]["total"]


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    out = tmp_path_factory.mktemp("full") / "m"
    subprocess.run(_learn_cmd(out, 5000, "--workers", "1"), check=True)
    return out


@pytest.mark.slow
def test_workers_do_not_change_the_symbols(uninterrupted, tmp_path):
    out = tmp_path / "m"
    subprocess.run(_learn_cmd(out, 5000, "--workers", "2"), check=True)
    assert _symbols(out) == _symbols(uninterrupted)
    assert _rescore(out) == _symbols(out)["loss"]["total"]


def _interrupt(cmd: list[str], checkpoint: Path, sig: int, after_done: int) -> None:
    """Start ``cmd``, wait until its checkpoint records ``after_done`` evaluations, send ``sig``."""
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=as_foreground_job)
    deadline = time.time() + 600
    try:
        while time.time() < deadline and proc.poll() is None:
            try:
                done = sum(r["done"] for r in json.loads(checkpoint.read_text())["restarts"])
            except (OSError, ValueError, KeyError):
                done = 0
            if done >= after_done:
                break
            time.sleep(0.05)
        assert proc.poll() is None, "the run ended before it could be interrupted"
        os.kill(proc.pid, sig)
        assert proc.wait(timeout=120) == (130 if sig == signal.SIGINT else -sig)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.slow
@pytest.mark.parametrize("sig,workers", [(signal.SIGINT, "1"), (signal.SIGKILL, "1"), (signal.SIGKILL, "2")])
def test_interrupted_and_resumed_runs_end_where_the_uninterrupted_run_ends(uninterrupted, tmp_path, sig, workers):
    out, ck = tmp_path / "m", tmp_path / "ck.json"
    cmd = _learn_cmd(out, 5000, "--workers", workers, "--checkpoint", str(ck))
    _interrupt(cmd, ck, sig, after_done=2000)
    assert not (out / "symbols.json").exists()
    subprocess.run(cmd, check=True)
    assert _symbols(out) == _symbols(uninterrupted)
