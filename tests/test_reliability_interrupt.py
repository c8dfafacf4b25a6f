"""Ctrl-C: ``learn`` stops at once (workers ignore SIGINT, the main process stops the pool), keeps
its checkpoint and the old model directory, prints one line and exits 130; the same command then
resumes, and the result equals an uninterrupted run's (docs/reliability.md)."""

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

from conftest import DATA, ROOT, alive, as_foreground_job, descendants, outliving

LEARN = ["learn", str(DATA / "tower_small.json"), "--evals", "2000", "--restarts", "2", "--workers", "2",
         "--unary", "1", "--binary", "1", "--seed", "5", "--quiet"]


def groundsym(args: list[str], **kw) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "groundsym.cli", *args], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=as_foreground_job, **kw)


def interrupt_after(args: list[str], delay: float, after: Path | None = None, group: bool = True,
                    limit: float = 60, sig: int = signal.SIGINT) -> tuple[int, str]:
    """Run, then Ctrl-C as a terminal sends it: SIGINT to the whole process group (``group``;
    else to the main process alone, as ``kill -INT PID`` does), ``delay`` seconds after the start
    (or after the file ``after`` appears); the run must end within ``limit`` seconds of it. With
    ``sig`` SIGTERM, as a scheduler stops a job. The processes the run had started when the
    signal came must all have ended within 10 s of it."""
    p = groundsym(args)
    while after is not None and not after.exists() and p.poll() is None:
        time.sleep(0.05)
    time.sleep(delay)
    started: set[int] = set()
    if p.poll() is None:
        started = descendants(p.pid)
        os.killpg(p.pid, sig) if group else os.kill(p.pid, sig)
    try:
        _, err = p.communicate(timeout=limit)
    except subprocess.TimeoutExpired:     # the bug this guards against: a pool waiting forever
        os.killpg(p.pid, signal.SIGKILL)
        pytest.fail(f"{args[0]} did not stop within {limit} s of {signal.Signals(sig).name} ({args})")
    left = outliving(started)
    assert not left, f"processes {left} outlived {args[0]} stopped by {signal.Signals(sig).name}"
    return p.returncode, err


def run_to_the_end(args: list[str]) -> float:
    """Run the command uninterrupted; the seconds it took."""
    t = time.monotonic()
    p = groundsym(args)
    _, err = p.communicate(timeout=900)
    assert p.returncode == 0, err
    return time.monotonic() - t


def symbols_doc(model: Path) -> dict:
    doc = json.loads((model / "symbols.json").read_text())
    doc.pop("provenance")                # the command line names another -o; nothing else may differ
    return doc


def check_interrupted(rc: int, err: str, out: Path, checkpoint: Path, sig: int = signal.SIGINT) -> None:
    if rc == 0:                          # the run had finished before the signal came
        return
    said = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}[sig]
    assert rc == 128 + sig, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    early = err == f"groundsym: {said}\n"      # while the commands were still loading
    assert early or (f"groundsym learn: {said}" in err and str(checkpoint) in err), err
    assert not out.exists()              # no half-written model
    assert not [p for p in out.parent.iterdir() if p.name.startswith(f".{out.name}.")]


def test_an_interrupt_stops_the_pool_and_keeps_the_checkpoint(tmp_path):
    """In-process: KeyboardInterrupt after the first round (as SIGINT in the main process raises
    it) terminates the worker pool at once, and the checkpoint resumes to the uninterrupted result."""
    from groundsym.anneal import AnnealConfig, anneal
    from groundsym.loss import LossConfig, prepare
    from tests.test_loss import kinematic_tower

    data = prepare(kinematic_tower(4, seed=3))
    cfg = AnnealConfig(evals=24, restarts=2, chunk=4)
    ck = tmp_path / "ck.json"

    def stop(done, total, best):
        if done > 0:
            raise KeyboardInterrupt

    t = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        anneal(data, LossConfig(), cfg, seed=2, workers=2, checkpoint=ck, report=stop)
    assert time.monotonic() - t < 30 and ck.exists()
    saved = json.loads(ck.read_text())["restarts"]
    assert 0 < sum(r["done"] for r in saved) < cfg.evals
    resumed = anneal(data, LossConfig(), cfg, seed=2, workers=1, checkpoint=ck)   # any worker count
    whole = anneal(data, LossConfig(), cfg, seed=2, workers=1)
    assert resumed.terms == whole.terms and resumed.evaluations == whole.evaluations == cfg.evals
    assert [s.to_doc() for s in resumed.symbols] == [s.to_doc() for s in whole.symbols]


@pytest.mark.slow
def test_ctrl_c_stops_learn_at_once_with_one_line(tmp_path):
    out, ck = tmp_path / "M", tmp_path / "ck.json"
    t = time.monotonic()
    rc, err = interrupt_after([*LEARN, "-o", str(out), "--checkpoint", str(ck)], 0.2, after=ck)
    assert rc == 130 and time.monotonic() - t < 30, err
    check_interrupted(rc, err, out, ck)


@pytest.mark.slow
def test_sigint_to_the_main_process_alone_stops_learn_promptly(tmp_path):
    """``kill -INT`` of the main process only (the workers never see it): at 12 moments from the
    start to the end of the search, each run stops within 20 s, with one line and status 130,
    and leaves a whole checkpoint (once the first round has written one)."""
    rng = np.random.default_rng(16)
    for k, delay in enumerate(rng.uniform(0.0, 12.0, 12)):
        out, ck = tmp_path / f"M{k}", tmp_path / f"ck{k}.json"
        rc, err = interrupt_after([*LEARN, "-o", str(out), "--checkpoint", str(ck)], float(delay), group=False,
                                  limit=20)
        check_interrupted(rc, err, out, ck)
        if ck.exists():
            assert json.loads(ck.read_text())["restarts"], err


@pytest.mark.slow
@pytest.mark.parametrize("sig,moments,seed", [(signal.SIGINT, 20, 15), (signal.SIGTERM, 10, 17)],
                         ids=["SIGINT", "SIGTERM"])
def test_interrupted_at_20_random_moments_each_resume_equals_the_uninterrupted_run(tmp_path, sig, moments, seed):
    """The signal (Ctrl-C's SIGINT, or a scheduler's SIGTERM) to the whole process group at
    random moments of a 2-worker learn; each run stops with one line (or had finished), leaves no
    process running, and resumes to the uninterrupted run's symbols."""
    span = run_to_the_end([*LEARN, "-o", str(tmp_path / "whole")])
    want = symbols_doc(tmp_path / "whole")
    rng = np.random.default_rng(seed)
    for k, delay in enumerate(rng.uniform(1.0, span, moments)):
        out, ck = tmp_path / f"M{k}", tmp_path / f"ck{k}.json"
        args = [*LEARN, "-o", str(out), "--checkpoint", str(ck)]
        rc, err = interrupt_after(args, float(delay), sig=sig)
        check_interrupted(rc, err, out, ck, sig)
        run_to_the_end(args)
        assert symbols_doc(out) == want, f"resumed after {sig.name} at {delay:.2f} s differs"


EVALUATE = ["evaluate", "--sim", "tower", "--methods", "random,prada", "--symbol-data", "20", "--model-traces", "1",
            "--runs", "3", "--evals", "400", "--restarts", "2", "--starts", "1", "--steps", "3",
            "--planner-opt", "prada:samples=100", "--seed", "11", "--workers", "2", "--quiet"]


def evaluation(out: Path) -> tuple[dict, dict, dict]:
    """An evaluation folder's table (less the command line), units (less their wall times) and models."""
    results = json.loads((out / "results.json").read_text())
    (results["meta"].get("provenance") or {}).pop("command", None)
    units = {}
    for p in sorted((out / "runs").glob("*.json")):
        doc = json.loads(p.read_text())
        doc.pop("seconds"), doc.pop("cpu_seconds", None)
        units[p.name] = doc
    models = {str(p.relative_to(out)): p.read_text() for p in sorted((out / "models").rglob("*")) if p.is_file()}
    return results, units, models


@pytest.mark.slow
@pytest.mark.parametrize("sig,seed", [(signal.SIGINT, 21), (signal.SIGTERM, 22)], ids=["SIGINT", "SIGTERM"])
def test_evaluate_stopped_at_8_random_moments_each_resume_equals_the_uninterrupted_run(tmp_path, sig, seed):
    """``evaluate --workers 2`` (symbols learned, two planners, three units) stopped by the signal
    to its process group at 8 random moments: each run ends with one line and 128 + the signal
    (or had finished), no process it started outlives it, no unit is half written and no
    temporary file stays; the same command then finishes with the uninterrupted run's table,
    units and models. results.json is written last: where a stop lands after it (the workers
    closing), the folder already holds the whole evaluation."""
    span = run_to_the_end([*EVALUATE, "-o", str(tmp_path / "whole")])
    want = evaluation(tmp_path / "whole")
    said = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}[sig]
    for k, delay in enumerate(np.random.default_rng(seed).uniform(1.0, span, 8)):
        out = tmp_path / f"E{k}"
        rc, err = interrupt_after([*EVALUATE, "-o", str(out)], float(delay), sig=sig)
        if rc != 0:
            assert rc == 128 + sig and err in (f"groundsym: {said}\n", f"groundsym evaluate: {said}\n"), err
            if (out / "results.json").exists():      # stopped after the last write (workers closing): whole
                assert (out / "results.md").is_file() and (out / "results.png").is_file()
                assert evaluation(out) == want, f"stopped by {sig.name} at {delay:.2f} s after its results"
            assert not [q for q in tmp_path.rglob(".*")], f"temporary files left after {sig.name} at {delay:.2f} s"
            for q in (out / "runs").glob("*.json") if out.exists() else ():
                json.loads(q.read_text())                     # each kept unit whole
        run_to_the_end([*EVALUATE, "-o", str(out)])
        assert evaluation(out) == want, f"resumed after {sig.name} at {delay:.2f} s differs"


def test_a_ctrl_c_inside_compiled_kernels_is_told_apart_from_errors():
    """A SIGINT that arrives while a numba dispatcher converts arguments or results reaches
    ``learn`` as a SystemError ("returned a result with an exception set", seen in 2 of 3
    interrupted runs of tests/test_learn_reproducible.py before the fix) or a TypeError ("can't
    unbox"), chained to the KeyboardInterrupt: those count as interrupts, errors without one do
    not."""
    from groundsym.errors import interrupted

    def wrapped(kind, how):
        try:
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt as ki:
                if how == "cause":
                    raise kind("returned a result with an exception set") from ki
                raise kind("can't unbox")           # the KeyboardInterrupt as its context
        except Exception as exc:
            return exc

    assert interrupted(KeyboardInterrupt())
    for kind in (SystemError, TypeError):
        for how in ("cause", "context"):
            assert interrupted(wrapped(kind, how))
    for plain in (ValueError("x"), SystemError("no cause"), TypeError("no cause")):
        assert not interrupted(plain)
    try:
        try:
            raise ValueError("inner")
        except ValueError as inner:
            raise SystemError("outer") from inner
    except SystemError as chained_without_interrupt:
        assert not interrupted(chained_without_interrupt)
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise ValueError("unrelated") from None       # explicitly not caused by the Ctrl-C
    except ValueError as unrelated:
        assert not interrupted(unrelated)


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process table from /proc")
def test_workers_end_when_the_main_process_is_killed(tmp_path):
    """``kill -9`` of learn's main process (or the out-of-memory killer): its workers see their
    pipes close and end, busy or idle. Before the fix each forked worker held a copy of the main
    process's end of its own pipe, so the pipe never closed and the workers waited for ever."""
    ck = tmp_path / "ck.json"
    p = groundsym([*LEARN, "--evals", "20000", "-o", str(tmp_path / "M"), "--checkpoint", str(ck)])   # the last --evals counts
    workers: set[int] = set()
    try:
        deadline = time.monotonic() + 60
        while not ck.exists() and p.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        workers = descendants(p.pid)
        assert p.poll() is None and len(workers) == 2, "learn should be searching with its 2 workers"
        os.kill(p.pid, signal.SIGKILL)
        p.wait(timeout=10)
        deadline = time.monotonic() + 20
        while any(alive(w) for w in workers) and time.monotonic() < deadline:
            time.sleep(0.1)
        left = [w for w in workers if alive(w)]
    finally:                          # never leave a worker behind, whatever failed
        for w in workers:
            try:
                os.kill(w, signal.SIGKILL)
            except OSError:
                pass
        p.kill()
        p.communicate()
    assert not left, f"workers {left} outlived their killed main process"
