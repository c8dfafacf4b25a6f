"""Ray's overhead on one machine: the same evaluation with local processes and with a local Ray
instance, alternating (processes, Ray, processes, Ray, ...) so that the load of a shared machine
falls on both alike. Prints each run's wall time, its CPU time (every process the run started,
Ray's own included), the load average, Ray / processes of the medians, Ray's start-up, how far
the progress bar's time estimate at half way was from the time that was actually left, and
checks that every results.json is the same (less the command line).

    .venv/bin/python benchmarks/bench_ray.py [--rounds 2] [--workers 2] [--json OUT] [-- EVALUATE OPTIONS]

Before the timed runs, one small evaluation (not timed) fills numba's disk cache of the compiled
loss, so that neither executor pays the kernels' first compilation.

CPU time: this process becomes a "child subreaper" (Linux), so every process a run starts, Ray's
GCS, raylet and workers included, is reaped here when it ends, however it was detached, and its
CPU time counted; a run counts as over when none of its processes is left.

Default evaluation: 7 cubes, --symbol-data 40 --model-traces 3 --runs 4 --evals 3000, the four
methods (a smaller one after ``--``, e.g. ``-- --sim tower --methods random --runs 4 --evals 300
--steps 2 --starts 1 --model-traces 1 --symbol-data 10``).
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ["--sim", "tower", "--symbol-data", "40", "--model-traces", "3", "--runs", "4", "--evals", "3000",
           "--seed", "0"]
WARM = ["--sim", "tower", "--symbol-data", "10", "--model-traces", "1", "--runs", "1", "--evals", "300",
        "--methods", "random", "--starts", "1", "--steps", "2", "--seed", "0"]
LINE = re.compile(r"\] (\d+)/(\d+) \S+ elapsed, ETA (\S+)")
PR_SET_CHILD_SUBREAPER = 36
LINGER = 180.0          # seconds a run's detached processes may take to end after the command did


def seconds(text: str) -> float | None:
    """Progress's durations: 45s, 3m05s, 1h02m."""
    m = re.fullmatch(r"(?:(\d+)h)?(?:(\d+)m)?(?:(\d+)s)?", text)
    if not m or not any(m.groups()):
        return None
    h, mi, s = (int(x) if x else 0 for x in m.groups())
    return 3600 * h + 60 * mi + s


def become_subreaper() -> None:
    """Orphaned descendants (Ray's daemons and workers) are re-parented to this process, so their
    CPU time reaches ``RUSAGE_CHILDREN`` when they are reaped here."""
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) != 0:
        raise SystemExit(f"prctl(PR_SET_CHILD_SUBREAPER): {os.strerror(ctypes.get_errno())}")


def reap_all(timeout: float) -> int:
    """Reap every child (re-parented orphans included) until none is left; the number still alive
    after ``timeout`` (their CPU time is then missing from the count)."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return 0
        if pid == 0:
            if time.monotonic() > deadline:
                return sum(1 for d in Path("/proc").iterdir() if d.name.isdigit() and _ppid(d) == os.getpid())
            time.sleep(0.2)


def _ppid(d: Path) -> int:
    try:
        return int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, ValueError, IndexError):
        return -1


class Sampler:
    """CPU time of every descendant of this process, read from /proc every ``every`` seconds and
    summed over processes at their last reading: counts Ray's processes whether or not anyone
    reaps them (loses at most ``every`` seconds of each process's last moments)."""

    def __init__(self, every: float = 1.0) -> None:
        self.every, self.last, self._stop = every, {}, threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        tick = os.sysconf("SC_CLK_TCK")
        while not self._stop.is_set():
            stats = {}
            for d in Path("/proc").iterdir():
                if d.name.isdigit():
                    try:
                        f = (d / "stat").read_text().rsplit(")", 1)[1].split()
                    except OSError:
                        continue
                    stats[int(d.name)] = (int(f[1]), int(f[19]), (int(f[11]) + int(f[12])) / tick)  # ppid, start, cpu
            mine, grew = {os.getpid()}, True
            while grew:
                new = {p for p, (pp, _, _) in stats.items() if pp in mine} - mine
                mine |= new
                grew = bool(new)
            for p in mine - {os.getpid()}:
                self.last[(p, stats[p][1])] = stats[p][2]
            self._stop.wait(self.every)

    def total(self) -> float:
        return sum(self.last.values())

    def stop(self) -> float:
        self._stop.set()
        self._thread.join()
        return self.total()


def cpu_of_children() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def run(executor: str, workers: int, args: list[str], out: Path) -> dict:
    """One evaluation: wall and CPU time, and the ETA printed at the first progress line at or past
    half way against the time that was actually left then."""
    cmd = [sys.executable, "-m", "groundsym.cli", "evaluate", *args, "--workers", str(workers),
           "--executor", executor, "-o", str(out)]
    cpu0, t0, load0 = cpu_of_children(), time.monotonic(), os.getloadavg()[0]
    sampler = Sampler()
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
    end, load1 = time.monotonic(), os.getloadavg()[0]
    lingering = reap_all(LINGER)
    sampled = sampler.stop()
    half = next(((t, d, n, eta) for t, d, n, eta in seen if 0 < d < n and d >= n / 2), None)
    units = [json.loads(p.read_text())["seconds"] for p in sorted((out / "runs").glob("*.json"))]
    return {"executor": executor, "wall": end - t0, "cpu": max(cpu_of_children() - cpu0, sampled),
            "cpu_reaped": cpu_of_children() - cpu0, "cpu_sampled": sampled, "lingering": lingering,
            "startup": (first or end) - t0, "load": (load0 + load1) / 2,
            "half": {"done": half[1], "total": half[2], "elapsed": half[0] - t0} if half else None,
            "eta_at_half": half[3] if half else None, "left_at_half": end - half[0] if half else None,
            "unit_seconds": units, "results": json.loads((out / "results.json").read_text())}


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
    ap.add_argument("--json", type=Path, default=None, help="also write every run's figures here")
    ap.add_argument("--executors", default="processes,ray", help="which runs a round makes, in order "
                    "(default processes,ray)")
    ap.add_argument("evaluate", nargs="*", help="evaluate's options after -- (default: the small evaluation)")
    opts = ap.parse_args()
    args = opts.evaluate or DEFAULT
    become_subreaper()
    print(f"groundsym evaluate {' '.join(args)} --workers {opts.workers}, {opts.rounds} round(s), alternating")
    runs: list[dict] = []
    with tempfile.TemporaryDirectory(prefix="bench-ray-") as tmp:
        warm = run("processes", 1, WARM, Path(tmp) / "warm-up")
        print(f"warm-up (numba's disk cache): {warm['wall']:.1f} s wall, {warm['cpu']:.1f} CPU s", flush=True)
        for r in range(opts.rounds):
            for executor in opts.executors.split(","):
                got = run(executor, opts.workers, args, Path(tmp) / f"{executor}-{r}")
                runs.append(got)
                eta = (f"ETA at {got['half']['done']}/{got['half']['total']} units {got['eta_at_half']:.0f} s, "
                       f"actually left {got['left_at_half']:.0f} s ({got['eta_at_half'] / got['left_at_half'] - 1:+.0%})"
                       if got["half"] else "no progress line at half way")
                left = f"; {got['lingering']} process(es) not ended, CPU undercounted" if got["lingering"] else ""
                print(f"round {r + 1} {executor:9s}: {got['wall']:7.1f} s wall, {got['cpu']:7.1f} CPU s (reaped "
                      f"{got['cpu_reaped']:.1f}, sampled {got['cpu_sampled']:.1f}), load "
                      f"{got['load']:.1f}, first progress line after {got['startup']:.1f} s; {eta}{left}", flush=True)
    for key, what in (("wall", "wall"), ("cpu", "CPU")):
        if {g["executor"] for g in runs} == {"processes", "ray"}:
            p = statistics.median(g[key] for g in runs if g["executor"] == "processes")
            q = statistics.median(g[key] for g in runs if g["executor"] == "ray")
            print(f"median {what}: processes {p:.1f} s, local Ray {q:.1f} s; Ray / processes = {q / p:.3f}")
    identical = all(same(runs[0]["results"], g["results"]) for g in runs)
    print(f"results.json identical (less the command line) in all {len(runs)} runs: {identical}")
    if opts.json:
        opts.json.write_text(json.dumps({"evaluate": args, "workers": opts.workers, "identical": identical,
                                         "runs": [{k: v for k, v in g.items() if k != "results"} for g in runs]},
                                        indent=1) + "\n")
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
