"""SIGTERM and SIGHUP (a scheduler's stop, a closed terminal) end every long command as Ctrl-C
does: one line, exit status 128 + the signal's number (143, 129), every worker process ended, no
temporary file or hidden staging folder left (docs/reliability.md)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import DATA, ROOT, descendants, outliving
from groundsym.cli import main

STOPS = [(signal.SIGTERM, 143, "terminated"), (signal.SIGHUP, 129, "hung up")]
BLOCKS = ROOT / "domains" / "reference" / "blocksworld"
PPDDL = ["--domain", str(BLOCKS / "domain.ppddl"), "--problem", str(BLOCKS / "p01.ppddl")]
EVALUATE = ["evaluate", "--sim", "tower", "--methods", "random", "--symbol-data", "10", "--model-traces", "1",
            "--steps", "3", "--starts", "1", "--truth-symbols", "inhand,on", "--quiet"]
LEARN = ["learn", str(DATA / "tower_small.json"), "--evals", "2000", "--restarts", "2", "--workers", "2",
         "--unary", "1", "--binary", "1", "--seed", "5", "--quiet"]


@pytest.fixture(scope="module")
def symbolic_model(blocks_traces, tmp_path_factory) -> Path:
    """A model of rules and reward learned from blocksworld's symbolic traces (for ``report``)."""
    out = tmp_path_factory.mktemp("model") / "M"
    assert main(["learn", str(blocks_traces), "-o", str(out), "--quiet"]) == 0
    return out


def commands(tmp: Path, model: Path) -> dict[str, tuple[list[str], str]]:
    """Each long command, and the part of the name of the file whose atomic write it is stopped at."""
    return {
        "collect": (["collect", "--sim", "tower", "--traces", "2", "--length", "3", "-o", str(tmp / "out.json"),
                     "--quiet"], ""),
        "learn": (["learn", str(DATA / "tower_small.json"), "--evals", "40", "--restarts", "2", "--workers", "1",
                   "-o", str(tmp / "M"), "--quiet"], "symbols.json"),
        "evaluate": ([*EVALUATE, "--runs", "3", "--workers", "2", "-o", str(tmp / "E")], "runs"),
        "plan": (["plan", *PPDDL, "--episodes", "2", "--quiet", "-o", str(tmp / "out.json")], ""),
        "simulate": (["simulate", *PPDDL, "--traces", "3", "-o", str(tmp / "out.json")], ""),
        "report": (["report", str(model), "-o", str(tmp / "out.html")], ""),
    }


def hidden(folder: Path) -> list[str]:
    """Temporary files and staging folders (hidden names) anywhere under ``folder``."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob(".*"))


@pytest.fixture(autouse=True)
def stop_signals_as_a_terminal_gives_them():
    """The tests that run a command in this process need the stop signals as a terminal gives them:
    under ``nohup``, or in a script's background job, SIGHUP or SIGINT arrive ignored, and a command
    rightly keeps an ignored signal ignored (so the tests would measure how they were started)."""
    saved = {s: signal.getsignal(s) for s in (signal.SIGHUP, signal.SIGINT, signal.SIGTERM)}
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    yield
    for s, handler in saved.items():
        signal.signal(s, handler)


@pytest.mark.parametrize("sig,status,said", STOPS, ids=["SIGTERM", "SIGHUP"])
@pytest.mark.parametrize("name", ["collect", "learn", "evaluate", "plan", "simulate", "report"])
def test_a_stop_signal_in_every_long_command_is_one_line_and_its_status(
        name, sig, status, said, symbolic_model, tmp_path, monkeypatch, capsys):
    """The signal arrives as the command is about to put its output (or, in ``learn``, the model's
    symbols, in ``evaluate`` a finished unit) in place: the command ends with one line and
    128 + the signal's number; no output, no temporary file, no staging folder, no worker is left."""
    argv, where = commands(tmp_path, symbolic_model)[name]
    replace = os.replace
    sent: list[str] = []

    def replace_after_a_signal(src, dst, *a, **kw):
        if not sent and where in str(dst):
            sent.append(str(dst))
            if signal.getsignal(sig) in (signal.SIG_DFL, None):   # would kill the test run itself
                pytest.fail(f"{name} has no handler for {sig.name}")
            os.kill(os.getpid(), sig)
            for _ in range(1000):     # the handler runs at the interpreter's next check
                pass
        return replace(src, dst, *a, **kw)

    monkeypatch.setattr(os, "replace", replace_after_a_signal)
    previous = signal.getsignal(sig)
    assert main(argv) == status
    assert sent, "the command wrote nothing"
    err = capsys.readouterr().err
    lines = err.splitlines()                        # simulate has no --quiet: its progress lines come first
    assert lines[-1].startswith(f"groundsym {name}: {said}") and "groundsym" not in "".join(lines[:-1]), err
    assert "Traceback" not in err
    assert signal.getsignal(sig) is previous        # in-process: the handler before is back
    assert hidden(tmp_path) == []
    assert not (tmp_path / "out.json").exists() and not (tmp_path / "out.html").exists()
    assert not (tmp_path / "M").exists() and not list((tmp_path / "E").glob("runs/*.json"))
    assert descendants(os.getpid()) == set()


def default_stop_signals() -> None:
    """In the child: the stop signals at their defaults, whatever the test runner inherited (under
    ``nohup`` SIGHUP arrives ignored, and a command rightly keeps an ignored signal ignored)."""
    for sig in (signal.SIGHUP, signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_DFL)


def start(args: list[str], **kw) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    kw.setdefault("preexec_fn", default_stop_signals)
    return subprocess.Popen([sys.executable, "-m", "groundsym.cli", *args], cwd=ROOT, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True, **kw)


def stop_when(p: subprocess.Popen, ready, sig: int, group: bool, limit: float = 120) -> tuple[int, str, set[int]]:
    """Once ``ready()`` holds, send ``sig`` to the process (or its whole group, as a scheduler
    stopping a job may); the status, stderr and the processes it had started."""
    workers: set[int] = set()
    try:
        deadline = time.monotonic() + limit
        while not ready() and p.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        workers = descendants(p.pid)
        assert p.poll() is None and ready(), "the command should be working"
        os.killpg(p.pid, sig) if group else os.kill(p.pid, sig)
        _, err = p.communicate(timeout=60)
    finally:                                  # never leave a process behind, whatever failed
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.communicate()
    return p.returncode, err, workers


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process table from /proc")
@pytest.mark.parametrize("sig,status,said,group", [(*STOPS[0], True), (*STOPS[1], False)],
                         ids=["SIGTERM-to-the-group", "SIGHUP-to-the-main-process"])
def test_learn_stopped_by_a_signal_ends_its_workers_and_keeps_the_checkpoint(sig, status, said, group, tmp_path):
    out, ck = tmp_path / "M", tmp_path / "ck.json"
    p = start([*LEARN, "-o", str(out), "--checkpoint", str(ck)])
    rc, err, workers = stop_when(p, lambda: ck.exists() and len(descendants(p.pid)) == 2, sig, group)
    assert len(workers) == 2
    assert rc == status and err == (f"groundsym learn: {said}; {out} unchanged; the search state is in {ck}; "
                                    "the same command resumes it\n"), err
    assert outliving(workers, 5) == set()
    assert hidden(tmp_path) == [] and not out.exists() and ck.is_file()


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process table from /proc")
def test_evaluate_stopped_by_sigterm_ends_its_workers(tmp_path):
    out = tmp_path / "E"
    p = start([*EVALUATE, "--runs", "40", "--workers", "2", "-o", str(out)])
    rc, err, workers = stop_when(p, lambda: len(descendants(p.pid)) == 2, signal.SIGTERM, group=False)
    assert rc == 143 and err == "groundsym evaluate: terminated\n", err
    assert len(workers) == 2 and outliving(workers, 5) == set()
    assert hidden(tmp_path) == [] and not (out / "results.json").exists()


def test_a_signal_ignored_at_the_start_stays_ignored(tmp_path):
    """``nohup groundsym ...`` ignores SIGHUP: the command must go on, not stop with 129."""
    out = tmp_path / "out.json"

    def ignore_sighup() -> None:
        signal.signal(signal.SIGHUP, signal.SIG_IGN)

    p = start(["collect", "--sim", "tower", "--traces", "8", "--length", "10", "-o", str(out)],
              preexec_fn=ignore_sighup)
    t = time.monotonic()
    rc, err, _ = stop_when(p, lambda: time.monotonic() - t > 1.5, signal.SIGHUP, group=False)
    assert rc == 0 and out.is_file(), err


def test_a_checkpoint_is_named_only_once_it_exists(tmp_path, monkeypatch, capsys):
    """Interrupted before the search's first round, ``learn --checkpoint CK`` has written no CK:
    its line must not send the user to a file that does not exist."""
    import groundsym.commands.learn as learn

    def interrupted_while_preparing(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(learn, "prepare", interrupted_while_preparing)
    out, ck = tmp_path / "M", tmp_path / "M3.ck"
    assert main([*LEARN, "-o", str(out), "--checkpoint", str(ck)]) == 130
    assert not ck.exists()
    assert capsys.readouterr().err == (f"groundsym learn: interrupted; {out} unchanged; no search state was saved "
                                       f"yet ({ck} was not written); the same command starts again\n")


@pytest.mark.parametrize("sig,status,said", [(signal.SIGINT, 130, "interrupted"), *STOPS],
                         ids=["SIGINT", "SIGTERM", "SIGHUP"])
def test_a_stop_that_lands_in_a_callback_from_c_still_stops_the_command(sig, status, said, tmp_path, monkeypatch,
                                                                        capsys):
    """Python drops an exception raised inside a ctypes callback, a ``__del__`` or a weakref
    callback ("Exception ignored in ..."), and with it a KeyboardInterrupt the signal's handler
    raised there. llvmlite calls back into Python while numba loads a kernel
    (``ExecutionEngine._raw_object_cache_notify``): a Ctrl-C early in a short ``learn --workers 2``
    was lost there in 3 of 30 runs, which then finished with status 0. The stop must reach the
    command all the same, while it still works (here: a second more before its output goes in
    place): one line, its status, no output."""
    import ctypes

    out = tmp_path / "out.json"
    replace = os.replace

    @ctypes.CFUNCTYPE(None)
    def callback_from_c() -> None:          # the signal's handler runs in here
        os.kill(os.getpid(), sig)
        for _ in range(1000):
            pass

    def replace_after_a_callback(src, dst, *a, **kw):
        if str(dst) == str(out):
            if signal.getsignal(sig) in (signal.SIG_DFL, None):   # would kill the test run itself
                pytest.fail(f"no handler for {sig.name}")
            callback_from_c()
            time.sleep(1)                   # still working
        return replace(src, dst, *a, **kw)

    monkeypatch.setattr(os, "replace", replace_after_a_callback)
    monkeypatch.setattr(sys, "unraisablehook", sys.__unraisablehook__)   # as outside pytest
    assert main(["collect", "--sim", "tower", "--traces", "1", "--length", "2", "-o", str(out), "--quiet"]) == status
    assert capsys.readouterr().err == f"groundsym collect: {said}\n"
    assert not out.exists() and hidden(tmp_path) == []
