"""The ceiling of our ClutteredRetrieval2D skills: a scripted policy over them, counted as KinDER counts.

    python examples/kinder_cluttered_scripted.py --obstructions 10 --episodes 50 --out results/kinder-cluttered

Per episode (the episode seeds of ``kinder_table.py planning``'s seed 0), the scripted policy of
:func:`sims.kinder_cluttered.scripted_episode`: put away the obstructions that block (nearest to
the robot first), then ``putInRegion``. Success is KinDER's: the target block inside the region
within 3,000 environment steps, every step inside a primitive counted. Resumable: finished
episodes in ``scripted-o<N>.json`` are kept. Prints the success rate and the steps used, and draws
them as ``scripted-o<N>.png``. Needs the kinder extra (make kinder; docs/kinder.md).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from groundsym.commands.plan import episode_seeds
from groundsym.fileio import atomic_write_json
from sims.kinder_cluttered import VARIANTS, ClutteredSim, scripted_episode

BUDGET = 3000


def run(obstructions: int, episodes: int, out: Path) -> list[dict]:
    path = out / f"scripted-o{obstructions}.json"
    done = json.loads(path.read_text())["episodes"] if path.exists() else []
    sim = ClutteredSim(obstructions=obstructions)
    for k, seed in enumerate(episode_seeds(1000, episodes)):
        if k < len(done):
            continue
        t0 = time.process_time()
        record = {**scripted_episode(sim, seed, BUDGET), "cpu_s": round(time.process_time() - t0, 2),
                  "step_limit_hits": sim.events["step_limit"]}
        done.append(record)
        atomic_write_json(path, {"obstructions": obstructions, "budget": BUDGET, "episodes": done})
        print(f"o{obstructions} episode {k}: {'solved' if record['success'] else 'not solved'} in "
              f"{record['env_steps']} steps, {len(record['actions'])} primitives", file=sys.stderr)
    sim.close()
    return done


def summary(episodes: list[dict]) -> str:
    wins = [e for e in episodes if e["success"]]
    steps = [e["env_steps"] for e in wins]
    prims = [len(e["actions"]) for e in wins]
    return (f"success {len(wins)}/{len(episodes)} = {len(wins) / len(episodes):.2f}; solved episodes: "
            f"median {np.median(steps):.0f} env steps (max {max(steps)}, of {BUDGET}), "
            f"median {np.median(prims):.0f} primitives")


def plot(episodes: list[dict], obstructions: int, out: Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3))
    for ok, colour in ((True, "tab:green"), (False, "tab:red")):
        steps = [e["env_steps"] for e in episodes if e["success"] == ok]
        ax.hist(steps, bins=np.arange(0, BUDGET + 100, 100), color=colour, alpha=0.8,
                label=f"{'solved' if ok else 'not solved'} ({len(steps)})")
    ax.axvline(BUDGET, color="k", lw=0.8)
    ax.set_xlabel("environment steps used (KinDER's budget 3,000)")
    ax.set_ylabel("episodes")
    ax.set_title(f"ClutteredRetrieval2D-o{obstructions}: scripted policy over our skills", fontsize=9)
    ax.legend(fontsize=8)
    path = out / f"scripted-o{obstructions}.png"
    fig.savefig(path, dpi=80, bbox_inches="tight")
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--obstructions", type=int, choices=VARIANTS, default=10)
    ap.add_argument("--episodes", type=int, default=50)
    ap.add_argument("--out", type=Path, default=Path("results/kinder-cluttered"))
    args = ap.parse_args(argv)
    if args.episodes < 1:
        ap.error("--episodes must be at least 1")
    args.out.mkdir(parents=True, exist_ok=True)
    episodes = run(args.obstructions, args.episodes, args.out)
    print(f"ClutteredRetrieval2D-o{args.obstructions}, scripted: {summary(episodes)}")
    print(f"wrote {plot(episodes, args.obstructions, args.out)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
