"""Run the README's pipeline and more on one revision, and compare two such runs file by file.

A change that only moves code (a refactoring) must leave every result as it was: the traces a
simulation records, the learned symbols, rules and reward, a planned episode, an evaluation's
results.json, an exported domain. This script runs one fixed set of commands and keeps their
outputs; ``compare`` then says which files differ between two runs.

    python tools/same_outputs.py run before --rev HEAD~5   # a worktree of that revision
    python tools/same_outputs.py run after                 # this checkout
    python tools/same_outputs.py compare before after

The simulation's physics round in the last bits differently on another CPU, so compare runs made
on one machine. ``run`` also writes ``times.json``: wall and CPU seconds per command (the CPU of
the command and of every worker process it waited for), the figures the README's table quotes.
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

#: (label, arguments to ``groundsym``): run in this order in one working directory.
PIPELINE: list[tuple[str, list[str]]] = [
    ("collect", ["collect", "--sim", "tower", "--traces", "16", "--length", "10", "--seed", "1",
                 "-o", "traces.json"]),
    ("learn", ["learn", "traces.json", "-o", "model", "--seed", "1"]),
    ("show", ["show", "model", "--plot", "symbols.png"]),
    ("plan", ["plan", "--sim", "tower", "--model", "model", "--planner", "prada", "--seed", "1",
              "-o", "episode.json", "--render-dir", "frames"]),
    ("report", ["report", "model", "-o", "report.html", "--episode", "episode.json", "--frames", "frames"]),
    ("export-domain", ["export-domain", "model", "-o", "domain"]),
    ("export-most-likely", ["export-domain", "model", "-o", "domain-ml", "--determinize", "most-likely"]),
    ("plan-nn", ["plan", "--sim", "tower", "--model", "model", "--planner", "symbolic-nn", "--seed", "2",
                 "-o", "episode-nn.json"]),
    ("plan-ppddl", ["plan", "--domain", "domain/domain.ppddl", "--problem", "domain/problem.ppddl",
                    "--planner", "prada", "--seed", "3", "--episodes", "3", "-o", "episode-ppddl.json"]),
    ("evaluate", ["evaluate", "--sim", "tower", "--runs", "2", "--symbol-data", "40", "--model-traces", "3",
                  "--evals", "3000", "--restarts", "1", "--starts", "1", "--steps", "4", "--workers", "2",
                  "--seed", "5", "-o", "eval", "--quiet"]),
    ("collect-bowling", ["collect", "--sim", "bowling", "--traces", "3", "--length", "4", "--seed", "2",
                         "-o", "bowling.json"]),
    ("learn-bowling", ["learn", "bowling.json", "-o", "bowling-model", "--seed", "2", "--evals", "3000",
                       "--restarts", "1"]),
]

#: JSON keys that hold measurements of the run itself (wall time), not results; left out when two
#: JSON files are compared. Every other byte of every output is deterministic given the seed.
TIMING_KEYS = {"seconds"}


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run(out: Path, rev: str | None) -> int:
    """Run :data:`PIPELINE` with the code of ``rev`` (default: this checkout) into ``out``."""
    repo = Path(__file__).resolve().parent.parent
    if out.exists():
        print(f"same_outputs: {out} exists; choose a new directory", file=sys.stderr)
        return 2
    out.mkdir(parents=True)
    code, cleanup = repo, None
    if rev is not None:
        cleanup = Path(tempfile.mkdtemp(prefix="same-outputs-"))
        code = cleanup / "tree"
        subprocess.run(["git", "-C", str(repo), "worktree", "add", "--detach", str(code), rev], check=True,
                       stdout=subprocess.DEVNULL)
    env = dict(os.environ, PYTHONPATH=str(code))
    times: dict[str, dict[str, float]] = {}
    try:
        for label, args in PIPELINE:
            cpu0, t0 = _children_cpu(), time.perf_counter()
            cmd = [sys.executable, "-c", "import sys; from groundsym.cli import main; sys.exit(main())", *args]
            proc = subprocess.run(cmd, cwd=out, env=env, capture_output=True, text=True)
            wall, cpu = time.perf_counter() - t0, _children_cpu() - cpu0
            (out / f"{label}.stdout").write_text(proc.stdout)
            times[label] = {"wall_s": round(wall, 2), "cpu_s": round(cpu, 2)}
            print(f"{label:20s} rc {proc.returncode}  {wall:7.1f} s wall  {cpu:7.1f} s CPU", flush=True)
            if proc.returncode != 0:
                print(proc.stderr, file=sys.stderr)
                return 1
    finally:
        if cleanup is not None:
            subprocess.run(["git", "-C", str(repo), "worktree", "remove", "--force", str(code)], check=False)
            shutil.rmtree(cleanup, ignore_errors=True)
    (out / "times.json").write_text(json.dumps(times, indent=1) + "\n")
    return 0


def _files(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()} - {"times.json"}


def _without_timings(doc: Any) -> Any:
    if isinstance(doc, dict):
        return {k: _without_timings(v) for k, v in doc.items() if k not in TIMING_KEYS}
    if isinstance(doc, list):
        return [_without_timings(v) for v in doc]
    return doc


def same(a: Path, b: Path) -> bool:
    """Equal bytes, or for JSON files equal documents once :data:`TIMING_KEYS` are left out."""
    if filecmp.cmp(a, b, shallow=False):
        return True
    if a.suffix != ".json":
        return False
    try:
        return _without_timings(json.loads(a.read_text())) == _without_timings(json.loads(b.read_text()))
    except ValueError:
        return False


def compare(a: Path, b: Path) -> int:
    """Print every file that is missing on one side or differs; exit 1 if any."""
    fa, fb = _files(a), _files(b)
    bad = sorted(fa ^ fb)
    for name in bad:
        print(f"only in {'first' if name in fa else 'second'}: {name}")
    differ = sorted(n for n in fa & fb if not same(a / n, b / n))
    for name in differ:
        print(f"differs: {name}")
    print(f"{len(fa & fb) - len(differ)} of {len(fa | fb)} files identical")
    return 1 if bad or differ else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="cmd", required=True)
    p_run = sub.add_parser("run", help="run the pipeline into a new directory")
    p_run.add_argument("out", type=Path)
    p_run.add_argument("--rev", help="git revision to run (a temporary worktree); default this checkout")
    p_cmp = sub.add_parser("compare", help="compare two run directories file by file")
    p_cmp.add_argument("a", type=Path)
    p_cmp.add_argument("b", type=Path)
    args = parser.parse_args()
    return run(args.out, args.rev) if args.cmd == "run" else compare(args.a, args.b)


if __name__ == "__main__":
    sys.exit(main())
