"""Ray's overhead on one machine: the same small evaluation with local processes and with a local
Ray instance, alternating (processes, Ray, processes, Ray, ...) so that the load of a shared
machine falls on both alike. Prints each run's wall time and the load average, the ratio Ray /
processes of the medians, Ray's start-up share, how far the progress bar's time estimate at half way was from the
time that was actually left, and checks that every results.json is the same (less the command
line).

    .venv/bin/python benchmarks/bench_ray.py [--rounds 2] [--workers 2] [-- EVALUATE OPTIONS]

Default evaluation: 7 cubes, --symbol-data 40 --model-traces 3 --runs 4 --evals 3000, the four
methods (17 minutes per evaluation with 2 workers on two cores shared with other work; a smaller
one after ``--``, e.g. ``-- --sim tower --methods random --runs 4 --evals 300 --steps 2 --starts 1
--model-traces 1 --symbol-data 10``).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ["--sim", "tower", "--symbol-data", "40", "--model-traces", "3", "--runs", "4", "--evals", "3000",
           "--seed", "0"]
LINE = re.compile(r"\] (\d+)/(\d+) \S+ elapsed, ETA (\S+)")


def seconds(text: str) -> float | None:
    """Progress's durations: 45s, 3m05s, 1h02m."""
    m = re.fullmatch(r"(?:(\d+)h)?(?:(\d+)m)?(?:(\d+)s)?", text)
    if not m or not any(m.groups()):
        return None
    h, mi, s = (int(x) if x else 0 for x in m.groups())
    return 3600 * h + 60 * mi + s


def run(executor: str, workers: int, args: list[str], out: Path) -> dict:
    """One evaluation; wall time, and the ETA printed at the first progress line at or past half way
    against the time that was actually left then."""
    cmd = [sys.executable, "-m", "groundsym.cli", "evaluate", *args, "--workers", str(workers),
           "--executor", executor, "-o", str(out)]
    t0, load0 = time.monotonic(), os.getloadavg()[0]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    seen = []                      # (time, done, total, eta)
    first = None
    tail: list[str] = []
    for line in proc.stderr:
        now = time.monotonic()
        tail = (tail + [line.rstrip()])[-5:]
        m = LINE.search(line)
        if m:
            first = first if first is not None else now
            seen.append((now, int(m.group(1)), int(m.group(2)), seconds(m.group(3))))
    if proc.wait() != 0:
        raise SystemExit(f"{executor}: evaluate failed:\n" + "\n".join(tail))
    end = time.monotonic()
    half = next(((t, d, n, eta) for t, d, n, eta in seen if 0 < d < n and d >= n / 2), None)
    return {"wall": end - t0, "startup": (first or end) - t0, "load": (load0 + os.getloadavg()[0]) / 2,

            "eta_at_half": half[3] if half else None, "left_at_half": end - half[0] if half else None,
            "results": json.loads((out / "results.json").read_text())}


def same(a: dict, b: dict) -> bool:
    def strip(doc: dict) -> dict:
        doc = json.loads(json.dumps(doc))
        (doc["meta"].get("provenance") or {}).pop("command", None)
        return doc
    return strip(a) == strip(b)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=2, help="pairs of runs (default 2)")
    ap.add_argument("--workers", type=int, default=2, help="processes, and the CPUs of the local Ray (default 2)")
    ap.add_argument("evaluate", nargs="*", help="evaluate's options after -- (default: the small evaluation)")
    opts = ap.parse_args()
    args = opts.evaluate or DEFAULT
    print(f"groundsym evaluate {' '.join(args)} --workers {opts.workers}, {opts.rounds} round(s), alternating")
    times: dict[str, list[float]] = {"processes": [], "ray": []}
    results = []
    with tempfile.TemporaryDirectory(prefix="bench-ray-") as tmp:
        for r in range(opts.rounds):
            for executor in ("processes", "ray"):
                got = run(executor, opts.workers, args, Path(tmp) / f"{executor}-{r}")
                times[executor].append(got["wall"])
                results.append(got["results"])
                eta = (f"ETA at half way {got['eta_at_half']:.0f} s, actually left {got['left_at_half']:.0f} s"
                       if got["eta_at_half"] is not None else "no progress line at half way")
                # (no CPU time: Ray's workers are not reaped by the driver, so this process never sees it)
                print(f"round {r + 1} {executor:9s}: {got['wall']:7.1f} s wall, load {got['load']:.1f} (first "
                      f"progress line after {got['startup']:.1f} s); {eta}", flush=True)
    p, q = statistics.median(times["processes"]), statistics.median(times["ray"])
    print(f"median wall: processes {p:.1f} s, local Ray {q:.1f} s; Ray / processes = {q / p:.3f}")
    print(f"results.json identical (less the command line) in all {len(results)} runs: "
          f"{all(same(results[0], x) for x in results)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
