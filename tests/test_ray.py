"""Evaluation units and annealing rounds as Ray tasks give the numbers local processes give.

Fast: bad input (Ray missing, an unreachable or malformed address) in one line; one real local Ray
instance on which `learn --executor ray` gives the symbols of one process, and an evaluation
folder is passed between processes and Ray. Slow: results.json for processes with 1 and 2 workers
and Ray; a Ray worker killed in a task; the driver killed and rerun; Ctrl-C on Ray; a real
two-node cluster started with `ray start` and joined through `--ray-address`.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from conftest import DATA, as_foreground_job, descendants
from groundsym.cli import main
from groundsym.evaluation.config import EvalConfig
from groundsym.evaluation.protocol import evaluate
from groundsym.evaluation.store import unit_path

ray = pytest.importorskip("ray", reason="Ray is not installed here (pip install 'groundsym[ray]'); "
                                        "the Ray executor's tests need it")

CLI = [sys.executable, "-m", "groundsym.cli"]
RAY = str(Path(sys.executable).with_name("ray"))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def one_line_error(capsys, text: str) -> None:
    err = capsys.readouterr().err.strip()
    assert text in err and len(err.splitlines()) == 1, err


def without_command(results: dict) -> dict:
    """results.json less what may differ between executors: the command line."""
    doc = json.loads(json.dumps(results))
    (doc["meta"].get("provenance") or {}).pop("command", None)
    return doc


def units(out: Path) -> dict[str, dict]:
    """Every unit record less its timing."""
    got = {}
    for p in sorted((out / "runs").glob("*.json")):
        doc = json.loads(p.read_text())
        doc.pop("seconds"), doc.pop("cpu_seconds", None)   # the timings
        got[p.name] = doc
    return got


def models(out: Path) -> dict[str, str]:
    return {str(p.relative_to(out)): p.read_text() for p in sorted((out / "models").rglob("*")) if p.is_file()}


# ----------------------------------------------------------------------------- bad input (no Ray started)

EVAL = ["evaluate", "--sim", "tower", "--methods", "random", "--runs", "1", "--quiet"]


def test_ray_missing_is_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)       # `import ray` now fails as if not installed
    assert main([*EVAL, "-o", str(tmp_path / "E"), "--executor", "ray"]) == 2
    one_line_error(capsys, "Ray is not installed (pip install 'groundsym[ray]')")
    assert not (tmp_path / "E").exists()
    assert main(["learn", str(DATA / "tower_16.json"), "-o", str(tmp_path / "m"), "--executor", "ray"]) == 2
    one_line_error(capsys, "Ray is not installed")


@pytest.mark.parametrize("address, message", [
    (None, "unreachable"),                 # a free port: nothing listens there
    ("nohost", "expected HOST:PORT"),
    ("127.0.0.1:http", "expected HOST:PORT"),
])
def test_a_bad_address_is_one_line_before_any_work(tmp_path, capsys, address, message):
    address = address or f"127.0.0.1:{free_port()}"
    t0 = time.monotonic()
    assert main([*EVAL, "-o", str(tmp_path / "E"), "--executor", "ray", "--ray-address", address]) == 2
    one_line_error(capsys, f"--ray-address {address}: {message}")
    assert time.monotonic() - t0 < 30 and not (tmp_path / "E").exists()


def test_an_address_without_ray_is_refused(tmp_path, capsys):
    assert main([*EVAL, "-o", str(tmp_path / "E"), "--ray-address", "127.0.0.1:6379"]) == 2
    one_line_error(capsys, "--ray-address: only with --executor ray")


# ----------------------------------------------------------------------------- one real local Ray

@pytest.fixture(scope="module")
def local_ray():
    """A local Ray instance started the way `--executor ray` starts one; commands in this process
    use it as it is (RayExecutor reuses a running instance)."""
    from groundsym.executors import RayExecutor

    with RayExecutor(cpus=2) as ex:
        assert ex._temp_dir and Path(ex._temp_dir).is_dir() and "2 CPU(s) on 1 node(s)" in ex.description
        temp = ex._temp_dir
        yield ex
    assert not ray.is_initialized() and not Path(temp).exists()


def test_annealing_rounds_on_ray_end_where_one_process_ends(local_ray):
    """Restarts started, then advanced over several rounds (chunk 50) as Ray tasks: the same
    search, evaluation for evaluation, as in this process."""
    from groundsym.anneal import AnnealConfig, anneal
    from groundsym.loss import LossConfig, prepare
    from groundsym.traces import read_traces

    loss_cfg = LossConfig()
    data = prepare(read_traces(DATA / "tower_small.json"), loss_cfg, "tower_small.json")
    cfg = AnnealConfig(evals=300, restarts=2, chunk=50)
    rounds = []
    here = anneal(data, loss_cfg, cfg, 7)
    there = anneal(data, loss_cfg, cfg, 7, executor=local_ray, report=lambda done, *_: rounds.append(done))
    assert [s.to_doc() for s in there.candidate] == [s.to_doc() for s in here.candidate]
    assert there.terms == here.terms and there.restarts == here.restarts and there.evaluations == 300
    assert len(rounds) == 4          # after the start and after each of 3 rounds of 50 per restart


def _symbols(out: Path) -> dict:
    doc = json.loads((out / "symbols.json").read_text())
    doc["provenance"].pop("command")
    return doc


@pytest.mark.slow
def test_learn_on_ray_gives_the_symbols_of_one_process(tmp_path):
    args = [*CLI, "learn", str(DATA / "tower_16.json"), "--evals", "2000", "--restarts", "2", "--seed", "7",
            "--quiet"]
    subprocess.run([*args, "-o", str(tmp_path / "p"), "--workers", "1"], check=True)
    subprocess.run([*args, "-o", str(tmp_path / "r"), "--executor", "ray", "--workers", "2"], check=True)
    assert _symbols(tmp_path / "r") == _symbols(tmp_path / "p")
    assert _symbols(tmp_path / "r")["evaluations"] == 2000


TINY = EvalConfig(sim="tower", methods=("random",), symbol_data=(10,), model_traces=(1,), seed=3, steps=2,
                  starts=1, truth_symbols=("inhand", "on"), trace_length=6)


def test_a_folder_passes_between_processes_and_ray(local_ray, tmp_path):
    """Run 0 with processes; run 1 on Ray in the same folder; the same run 1 with processes in a
    copy: the same unit, models and table. The Ray-made folder then resumes with processes."""
    mixed, local = tmp_path / "mixed", tmp_path / "local"
    evaluate(TINY, 1, mixed, progress=False)
    shutil.copytree(mixed, local)
    run0 = unit_path(mixed, 10, 0).read_text()
    on_ray = evaluate(TINY, 2, mixed, progress=False, executor=local_ray)
    here = evaluate(TINY, 2, local, progress=False)
    assert unit_path(mixed, 10, 0).read_text() == run0                  # resumed, not run again
    assert on_ray == here and [r["n"] for r in on_ray["methods"]] == [2]
    assert units(mixed) == units(local) and models(mixed) == models(local) and len(models(local)) == 8
    again = evaluate(TINY, 2, mixed, progress=False, workers=2)         # back to processes: nothing to do
    assert again == on_ray and unit_path(mixed, 10, 0).read_text() == run0


# ----------------------------------------------------------------------------- slow: the CLI end to end

SMALL = ["evaluate", "--sim", "tower", "--methods", "random,prada", "--symbol-data", "20", "--model-traces", "1",
         "--runs", "3", "--evals", "400", "--restarts", "2", "--starts", "1", "--steps", "3",
         "--planner-opt", "prada:samples=100", "--seed", "11", "--quiet"]


def small(out: Path, *extra: str) -> list[str]:
    return [*CLI, *SMALL, "-o", str(out), *extra]


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("reference") / "E"
    subprocess.run(small(out, "--workers", "1"), check=True)
    return out


def same_as(out: Path, ref: Path) -> None:
    assert without_command(json.loads((out / "results.json").read_text())) == \
        without_command(json.loads((ref / "results.json").read_text()))
    assert units(out) == units(ref) and len(units(out)) == 3
    assert models(out) == models(ref)


@pytest.mark.slow
def test_results_are_the_same_for_processes_and_ray(reference, tmp_path):
    subprocess.run(small(tmp_path / "p2", "--workers", "2"), check=True)
    subprocess.run(small(tmp_path / "ray", "--executor", "ray", "--workers", "2"), check=True)
    same_as(tmp_path / "p2", reference)
    same_as(tmp_path / "ray", reference)


def _title(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()
    except OSError:
        return ""


def _wait_for(cond, proc: subprocess.Popen, what: str, timeout: float = 600):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        got = cond()
        if got:
            return got
        assert proc.poll() is None, f"{proc.args[:3]}... ended before {what}"
        time.sleep(0.1)
    raise AssertionError(f"timed out waiting for {what}")


def _ray_temp_dir(pids: set[int]) -> Path:
    """The temporary folder of the local Ray whose processes are ``pids`` (from their command lines)."""
    temp = {m.group(1) for p in pids for m in re.finditer(r"(/[^\s=]*/groundsym-ray-[^/\s]+)", _title(p))}
    assert len(temp) == 1, temp
    return Path(temp.pop())


def _end(pids: set[int], timeout: float) -> set[int]:
    """Wait for ``pids`` to exit; kill (by pid) those still alive after ``timeout``; return those."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and any(Path(f"/proc/{p}").exists() for p in pids):
        time.sleep(0.5)
    alive = {p for p in pids if Path(f"/proc/{p}").exists()}
    for p in alive:
        os.kill(p, signal.SIGKILL)
    return alive


@pytest.mark.slow
def test_a_ray_worker_killed_in_a_task_is_retried(reference, tmp_path):
    out = tmp_path / "E"
    proc = subprocess.Popen(small(out, "--executor", "ray", "--workers", "2"))
    try:
        def running_unit():
            return [p for p in descendants(proc.pid) if _title(p).startswith("ray::run_unit")]
        victim = _wait_for(running_unit, proc, "a unit ran")[0]
        os.kill(victim, signal.SIGKILL)
        assert proc.wait(timeout=900) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
    assert not Path(f"/proc/{victim}").exists()
    same_as(out, reference)          # every unit once, the killed one run again by Ray


@pytest.mark.slow
def test_a_killed_driver_resumes_from_its_finished_units(reference, tmp_path):
    out = tmp_path / "E"
    proc = subprocess.Popen(small(out, "--executor", "ray", "--workers", "2"))
    try:
        _wait_for(lambda: list((out / "runs").glob("*.json")) if (out / "runs").exists() else [], proc,
                  "a unit was written")
        ray_processes = descendants(proc.pid)
        temp_dir = _ray_temp_dir(ray_processes)
        proc.kill()
        proc.wait()
    finally:
        if proc.poll() is None:
            proc.kill()
    done = {p.name: p.read_text() for p in (out / "runs").glob("*.json")}
    assert 1 <= len(done) < 3
    # Ray's own processes end with the driver that started them (its two agents within ~a minute);
    # its temporary folder stays (docs/scale.md: delete it), here deleted by the test
    assert _end(ray_processes, 150) == set()
    assert temp_dir.is_dir()
    shutil.rmtree(temp_dir)
    subprocess.run(small(out, "--executor", "ray", "--workers", "2"), check=True)
    assert all((out / "runs" / name).read_text() == text for name, text in done.items())
    same_as(out, reference)


@pytest.mark.slow
def test_ctrl_c_on_ray_stops_everything_and_the_rerun_resumes(reference, tmp_path):
    """Ctrl-C at a terminal (SIGINT to the driver's whole process group) while Ray runs a unit:
    the driver exits with 130 and its one 'interrupted' line, writes no half unit, every process
    of the local Ray ends and its temporary folder goes; the same command then finishes the
    evaluation with the results of an uninterrupted run."""
    out = tmp_path / "E"
    proc = subprocess.Popen(small(out, "--executor", "ray", "--workers", "2"), stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=as_foreground_job)
    try:
        def running_unit():
            return [p for p in descendants(proc.pid) if _title(p).startswith("ray::run_unit")]
        _wait_for(running_unit, proc, "a unit ran")
        ray_processes = descendants(proc.pid)
        temp_dir = _ray_temp_dir(ray_processes)
        assert temp_dir.is_dir()
        written = set((out / "runs").glob("*.json")) if (out / "runs").exists() else set()
        os.killpg(proc.pid, signal.SIGINT)
        status = proc.wait(timeout=120)
        err = proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
    assert status == 130, err
    assert err.strip().splitlines()[-1] == "groundsym evaluate: interrupted", err
    assert "Traceback" not in err, err
    assert _end(ray_processes, 120) == set()       # nothing of Ray left running
    assert not temp_dir.exists()
    kept = sorted((out / "runs").glob("*.json")) if (out / "runs").exists() else []
    assert len(kept) < 3 and set(kept) >= written   # no unit was half written (each one parses below)
    for p in kept:
        json.loads(p.read_text())
    subprocess.run(small(out, "--executor", "ray", "--workers", "2"), check=True)
    same_as(out, reference)


@pytest.mark.slow
def test_a_real_two_node_cluster_through_its_address(reference, tmp_path):
    """`ray start --head` on 127.0.0.1 in a temporary directory, one more node joined with
    `ray start --address`; the evaluation joins through --ray-address, the project's code shipped
    as the runtime_env. Each `ray start --block` stops the processes it started on SIGTERM."""
    port = free_port()
    temp = tempfile.mkdtemp(prefix="gsr-", dir="/tmp")       # Ray's socket paths must stay short
    env = {**os.environ, "RAY_AUTH_MODE": "token"}            # Ray's default for new clusters
    common = ["--node-ip-address", "127.0.0.1", "--num-cpus", "1", "--disable-usage-stats", "--block"]
    logs = [tmp_path / "head.log", tmp_path / "node.log"]
    head = subprocess.Popen([RAY, "start", "--head", "--port", str(port), "--temp-dir", temp,
                             "--include-dashboard", "false", *common], env=env, stdout=logs[0].open("w"), stderr=subprocess.STDOUT)
    nodes = [head]
    try:
        addr = f"127.0.0.1:{port}"
        _wait_for(lambda: "Ray runtime started" in logs[0].read_text(), head, "the head started")
        nodes.append(subprocess.Popen([RAY, "start", "--address", addr, *common], env=env,
                                      stdout=logs[1].open("w"), stderr=subprocess.STDOUT))
        _wait_for(lambda: "Ray runtime started" in logs[1].read_text(), nodes[1], "the second node joined")
        out = tmp_path / "E"
        cmd = [a for a in small(out, "--executor", "ray", "--ray-address", addr) if a != "--quiet"]
        run = subprocess.run(cmd, env=env, check=True, stderr=subprocess.PIPE, text=True)
        assert f"running on the Ray cluster at {addr} (2 CPU(s) on 2 node(s))" in run.stderr
        same_as(out, reference)
    finally:
        for node in reversed(nodes):
            node.terminate()
        for node in reversed(nodes):
            try:
                node.wait(timeout=60)
            except subprocess.TimeoutExpired:
                node.kill()
        shutil.rmtree(temp, ignore_errors=True)
