"""The loss's neighbourhood passes replayed: this code against another git revision, interleaved in
one process.

A loss evaluation spends most of its CPU in one compiled neighbourhood pass per abstraction
(``NumbaBackend.neighbours``: canonical forms, classes, nearest classes). This benchmark records
the passes of one annealing restart (``--evals`` evaluations on ``--traces``, or the kinematic
fixture world of ``tests/test_loss.py``), then replays the recorded inputs on fresh backends
(empty memos, so every replay does the same work) of this code and, with ``--before REV``, of the
code of REV, loaded side by side in the same process as two copies of the package, and alternates
them ``--rounds`` times. Two copies taking turns in one process share whatever else the machine is
doing, so their ratio is steadier than the ratio of separate processes (``bench_loss.py
--before``): on a machine at load 16, repeated runs of this one agreed within about 4%. Kernel changes that should not change the work (bit-identical results) are
compared this way; changes to the search itself, which change what an annealing run visits, need
``bench_loss.py``.

    .venv/bin/python benchmarks/bench_pass.py --traces tower7.json --evals 3000 --before 5e1a969 --rounds 5
"""

from __future__ import annotations

import argparse
import importlib
import io
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from groundsym import backends  # noqa: E402
from groundsym.anneal import AnnealConfig, advance, start_restart  # noqa: E402
from groundsym.loss import Loss, prepare  # noqa: E402
from bench_loss import benchmark_dataset  # noqa: E402


def record_passes(traces: Path | None, evals: int) -> list[tuple]:
    """The inputs of every neighbourhood pass of one annealing restart on this code."""
    data = prepare(benchmark_dataset(traces))
    calls: list[tuple] = []
    original = backends.NumbaBackend.neighbours

    def recording(self, u, b, lock, label):
        calls.append(tuple(np.array(x) for x in (u, b, lock, label)))
        return original(self, u, b, lock, label)

    backends.NumbaBackend.neighbours = recording
    try:
        cfg = AnnealConfig(evals=evals * 4, restarts=4)
        loss = Loss(data)
        advance(start_restart(0, 0, loss, cfg), loss, cfg, evals)
    finally:
        backends.NumbaBackend.neighbours = original
    return calls


def copy_package(rev: str, into: Path, name: str) -> None:
    """``groundsym`` of revision ``rev`` as package ``name`` under ``into``. The package imports
    itself relatively, so the copy loads beside the original; numba compiles it afresh (a minute
    or two) and caches its machine code in the copy's own ``__pycache__``."""
    blob = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "groundsym"], capture_output=True, check=True).stdout
    with tarfile.open(fileobj=io.BytesIO(blob)) as tar:
        tar.extractall(into / "_archive", filter="data")
    (into / "_archive" / "groundsym").rename(into / name)


def replay(backend_module, calls: list[tuple]) -> float:
    """CPU seconds of every recorded pass on a fresh backend."""
    be = backend_module.NumbaBackend()
    t0 = time.process_time()
    for call in calls:
        be.neighbours(*call)
    return time.process_time() - t0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--traces", type=Path, help="continuous traces (default: the 7-object fixture world)")
    parser.add_argument("--evals", type=int, default=3000, help="evaluations of the recorded annealing restart")
    parser.add_argument("--before", metavar="REV", help="also the code of this git revision, taking turns")
    parser.add_argument("--rounds", type=int, default=5, help="replays of each code (medians are reported)")
    args = parser.parse_args()
    if args.evals < 1 or args.rounds < 1:
        parser.error("--evals and --rounds must be at least 1")
    if args.traces is not None and not args.traces.is_file():
        parser.error(f"--traces: no such file: {args.traces}")
    calls = record_passes(args.traces, args.evals)
    print(f"recorded {len(calls)} neighbourhood passes of {args.evals} evaluations", flush=True)
    modules = {"this code": backends}      # the checkout itself (numba's cache is warm)
    with tempfile.TemporaryDirectory() as tmp:
        if args.before:
            copy_package(args.before, Path(tmp), "gs_before")
            sys.path.insert(0, tmp)
            t0 = time.perf_counter()
            importlib.import_module("gs_before.compiled").warm_up()
            modules[f"code at {args.before}"] = importlib.import_module("gs_before.backends")
            print(f"code at {args.before}: compiled in {time.perf_counter() - t0:.1f} s", flush=True)
        for module in modules.values():
            replay(module, calls[:20])     # the kernels' first calls
        times: dict[str, list[float]] = {label: [] for label in modules}
        for _ in range(args.rounds):
            for label, module in modules.items():
                times[label].append(replay(module, calls))
    for label, ts in times.items():
        print(f"{label}: {len(calls) / statistics.median(ts):.0f} passes per CPU second (median of {len(ts)})")
    if args.before:
        now, before = times["this code"], times[f"code at {args.before}"]
        ratio = statistics.median(b / a for a, b in zip(now, before))
        print(f"now / {args.before}: {ratio:.3f}x the speed (median of {args.rounds} paired rounds)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
