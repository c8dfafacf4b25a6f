"""Tower cell speed: primitives per CPU second on one core, side by side with another version.

Runs random traces exactly as ``groundsym collect`` does and prints, from the same run: primitives
per CPU second of the process (target: at least 10; CPU time, not wall time, so other jobs on a
shared machine count less), physics steps per primitive, how many of them one CPU second of
stepping makes and the share of a primitive's time spent stepping the physics; a reset is timed
apart. With ``--against DIR`` (a checkout of another commit, e.g. a ``git worktree``) the same
measurement runs on that code too, alternating rounds so both see the same machine load, and the
ratio is printed, with whether both produced the same traces (bit for bit: a speed change must not
change results)::

    git worktree add /tmp/cell-before <commit>
    python benchmarks/bench_sim.py --traces 6 --rounds 2 --against /tmp/cell-before

With ``--camera`` the same traces also run in the cell seen through its depth camera
(``features=pointcloud``, docs/perception.md), alternating rounds with the others, and the cost of a
primitive with the camera against one without is printed (the limit is 1.5x)::

    python benchmarks/bench_sim.py --traces 3 --rounds 2 --camera

With ``--cells`` the same traces also run in other cells of this code (``;``-separated option
sets, e.g. the larger cells of ``workspace=wide``, docs/tower.md), alternating rounds with the
default cell, and each one's cost of a primitive against the default cell's is printed::

    python benchmarks/bench_sim.py --traces 2 --rounds 2 --cells "cubes=14 workspace=wide;cubes=20 workspace=wide"
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
TARGET = 10.0
CAMERA = "this code, depth camera on"


def measure(root: Path, traces: int, length: int, options: dict[str, str] | None = None) -> dict[str, float]:
    """Random traces on the code under ``root`` (imported from there), timed on this process's CPU,
    in the cell made with ``options`` (the default cell when None)."""
    sys.path.insert(0, str(root))
    from groundsym.collect import trace_seeds
    from sims.tower import TowerSim

    steps = prims = 0
    busy = resets = 0.0
    clock = [0.0]                      # CPU time inside the world's physics steps, running total
    physics = 0.0                      # ... of it, during primitives
    digest = hashlib.sha256()
    with TowerSim(**(options or {})) as sim:
        # every physics step goes through the scene's step (sims/tower_scene.py); a checkout from
        # before the world was split into a scene and the parts above it (--against) steps its world
        physics_world = getattr(sim.world, "scene", sim.world)
        world_step = physics_world.step

        def timed_step(n: int = 1) -> None:
            t = time.process_time()
            world_step(n)
            clock[0] += time.process_time() - t

        physics_world.step = timed_step
        for reset_seed, rng in trace_seeds(0, traces):
            t0 = time.process_time()
            sim.reset(reset_seed)
            t1 = time.process_time()
            physics_world.steps = 0
            before = clock[0]
            choices = sim.actions()
            scenes = [sim.step(choices[int(rng.integers(len(choices)))]) for _ in range(length)]
            busy += time.process_time() - t1
            for scene in scenes:
                digest.update(scene_bytes(scene))
            resets += t1 - t0
            steps += physics_world.steps
            prims += length
            physics += clock[0] - before
    return {"prims": prims, "cpu": busy, "steps": steps, "physics": physics, "reset": resets / traces,
            "traces": digest.hexdigest()}


def scene_bytes(scene) -> bytes:
    """A scene as bytes, for comparing traces: features to the bit, reward, sorted true atoms."""
    truth = ",".join(sorted(str(a) for a in scene.truth))
    return scene.features.tobytes() + repr(scene.reward).encode() + truth.encode()


def run_child(root: Path, traces: int, length: int, options: dict[str, str] | None = None) -> dict[str, float]:
    """One measurement in a fresh process pinned to one core (imports must not mix two trees)."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", str(root), "--traces", str(traces),
           "--length", str(length), "--child-options", json.dumps(options or {})]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=str(root)).stdout
    return json.loads(out.strip().splitlines()[-1])


def summary(label: str, runs: list[dict[str, float]]) -> float:
    prims, cpu, steps, physics = (sum(r[k] for r in runs) for k in ("prims", "cpu", "steps", "physics"))
    rate = prims / cpu
    print(f"{label}: {int(prims)} random primitives in {cpu:.2f} CPU s -> {rate:.1f} primitives per CPU s "
          f"({rate / TARGET:.2f}x the target of {TARGET:g}); {steps / prims:.0f} physics steps per primitive, "
          f"{steps / physics:.0f} steps per CPU s of stepping (physics {physics / cpu:.0%} of a primitive's time), "
          f"reset {sum(r['reset'] for r in runs) / len(runs) * 1000:.0f} ms")
    return rate


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--traces", type=int, default=6, help="random traces per round")
    ap.add_argument("--length", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=1, help="alternating rounds per version")
    ap.add_argument("--against", type=Path, default=None, metavar="DIR", help="also measure the code in DIR")
    ap.add_argument("--camera", action="store_true", help="also this code with the depth camera on "
                    "(features=pointcloud, docs/perception.md), alternating, and the cost ratio")
    ap.add_argument("--cells", default="", metavar="OPTS;OPTS", help="also this code in these cells (option sets "
                    "separated by ';', e.g. \"cubes=20 workspace=wide\"), alternating, and the cost ratios")
    ap.add_argument("--child", type=Path, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--child-options", default="{}", help=argparse.SUPPRESS)
    args = ap.parse_args()
    sys.path.insert(0, str(HERE))
    from groundsym.errors import UserError
    from groundsym.options import split_key_values

    try:
        cells = {c.strip(): split_key_values([c], "--cells") for c in args.cells.split(";") if c.strip()}
    except UserError as exc:
        print(f"bench_sim: {exc}", file=sys.stderr)
        return 2
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    if args.child:
        print(json.dumps(measure(args.child, args.traces, args.length, json.loads(args.child_options))))
        return 0
    versions = {"this code": HERE}
    if args.against:
        versions[f"{args.against}"] = args.against.resolve()
    runs: dict[str, list] = {k: [] for k in versions}
    for _ in range(args.rounds):
        for label, root in versions.items():
            runs[label].append(run_child(root, args.traces, args.length))
        if args.camera:
            runs.setdefault(CAMERA, []).append(run_child(HERE, args.traces, args.length, {"features": "pointcloud"}))
        for label, options in cells.items():
            runs.setdefault(f"this code, {label}", []).append(run_child(HERE, args.traces, args.length, options))
    rates = {label: summary(label, r) for label, r in runs.items()}
    for label in cells:
        print(f"a primitive in the cell {label} costs {rates['this code'] / rates[f'this code, {label}']:.2f}x "
              f"one in the default cell")
    if args.camera:
        print(f"a primitive with the depth camera costs {rates['this code'] / rates[CAMERA]:.2f}x one without "
              f"(limit 1.5x)")
    if args.against:
        mine, other = rates["this code"], rates[str(args.against)]
        print(f"ratio this code / {args.against}: {mine / other:.2f}")
        same = [a["traces"] == b["traces"] for a, b in zip(runs["this code"], runs[str(args.against)])]
        print(f"same traces (features to the bit, rewards, true atoms) in {sum(same)} of {len(same)} rounds: "
              f"{'yes' if all(same) else 'NO'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
