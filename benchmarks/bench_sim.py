"""Tower cell speed: primitives per second on one core, and where the time goes.

Runs random traces exactly as ``groundsym collect`` does and prints, from the same run:
primitives per second (target: at least 5), physics steps per primitive, the world's raw stepping
rate (the same world stepped with no controller), and the share of a primitive's time that is
physics. ``python benchmarks/bench_sim.py [--traces N]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.collect import trace_seeds  # noqa: E402
from sims.tower import TowerSim  # noqa: E402

TARGET = 5.0
REFERENCE_RATE = 3000       # physics steps per second of a Panda world on one idle core here


def raw_step_rate(sim: TowerSim, n: int = 600) -> float:
    """Physics steps per second of the same world, motors holding, no controller in the loop."""
    sim.reset(0)
    t = time.perf_counter()
    sim.world.step(n)
    return n / (time.perf_counter() - t)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--traces", type=int, default=6)
    ap.add_argument("--length", type=int, default=10)
    args = ap.parse_args()
    with TowerSim() as sim:
        steps = prims = 0
        busy = resets = 0.0
        for reset_seed, rng in trace_seeds(0, args.traces):
            t0 = time.perf_counter()
            sim.reset(reset_seed)
            t1 = time.perf_counter()
            sim.world.steps = 0
            collect_trace_from_here(sim, args.length, rng)
            busy += time.perf_counter() - t1
            resets += t1 - t0
            steps += sim.world.steps
            prims += args.length
        raw = raw_step_rate(sim)
    rate = prims / busy
    print(f"tower: {prims} random primitives in {busy:.2f} s -> {rate:.1f} primitives/s "
          f"({rate / TARGET:.1f}x the target of {TARGET:g}/s)")
    print(f"  {steps / prims:.0f} physics steps per primitive ({steps / busy:.0f} steps/s in primitives, "
          f"raw stepping {raw:.0f} steps/s: physics is {steps / raw / busy:.0%} of a primitive's time)")
    print(f"  reset (rebuild world, settle): {resets / args.traces * 1000:.0f} ms each")
    ref = rate * REFERENCE_RATE / raw
    print(f"  on a core stepping this world at {REFERENCE_RATE} steps/s (the issue's reference; this run: "
          f"{raw:.0f}), that is {ref:.1f} primitives/s: the machine's load cancels out of this figure")
    return 0


def collect_trace_from_here(sim: TowerSim, length: int, rng) -> None:
    """Random primitives from the current scene (the reset is timed separately)."""
    choices = sim.actions()
    for _ in range(length):
        sim.step(choices[int(rng.integers(len(choices)))])


if __name__ == "__main__":
    sys.exit(main())
