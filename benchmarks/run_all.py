"""Run every ``benchmarks/bench_*.py`` in turn (``make bench``); each prints its own ratios.

``--quick`` (``make bench-quick``, run by CI) gives each benchmark the small workload of
:data:`QUICK`: seconds each, the same code paths, so a benchmark that no longer runs fails the
build instead of rotting unseen. Its figures are not measurements. A new benchmark needs a row
there (the run refuses one that has none, rather than running it at full size).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

#: Per benchmark: the arguments of its quick run.
QUICK: dict[str, list[str]] = {
    "bench_bowling.py": ["--games", "2"],
    "bench_camera.py": ["--traces", "1", "--length", "3", "--rounds", "1"],
    "bench_canonical.py": [],
    "bench_distance.py": ["--pairs", "2"],
    "bench_loss.py": ["--evals", "150"],
    "bench_objects.py": ["--objects", "7,10", "--repeats", "1", "--transitions", "40", "--no-profile", "--compare"],
    "bench_parser.py": ["--sizes", "300"],
    "bench_pass.py": ["--evals", "60", "--rounds", "1"],
    "bench_ppddl_sim.py": ["--steps", "100", "--rounds", "1"],
    "bench_prada.py": ["--repeats", "1"],
    "bench_reward_term.py": ["--sets", "20", "--rounds", "1", "--symbols", "1+1"],
    "bench_ray.py": ["--rounds", "1", "--", "--sim", "tower", "--methods", "random", "--runs", "2", "--evals", "150",
                     "--steps", "2", "--starts", "1", "--model-traces", "1", "--symbol-data", "10", "--seed", "0"],
    "bench_rules.py": [],
    "bench_sim.py": ["--traces", "1", "--length", "3"],
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small workloads: checks that every benchmark runs")
    args = parser.parse_args()
    here = Path(__file__).resolve().parent
    scripts = sorted(here.glob("bench_*.py"))
    missing = [s.name for s in scripts if s.name not in QUICK]
    if args.quick and missing:
        print(f"run_all: no quick workload for {', '.join(missing)} (add a row to QUICK)", file=sys.stderr)
        return 2
    failed = []
    for script in scripts:
        extra = QUICK[script.name] if args.quick else []
        print(f"== {script.name} {' '.join(extra)}".rstrip(), flush=True)
        start = time.perf_counter()
        rc = subprocess.call([sys.executable, str(script), *extra], cwd=here.parent)
        print(f"== {script.name}: exit {rc}, {time.perf_counter() - start:.1f} s", flush=True)
        if rc != 0:
            failed.append(script.name)
    if failed:
        print(f"run_all: failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
