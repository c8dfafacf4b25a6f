"""What a perfect planner could earn in the noisy tower cell: a scripted tower builder that reads the
simulator's ground truth (an oracle, for diagnosis only).

The deterministic optimum (sims/tower_optimum.py) assumes that every primitive succeeds. With motor
noise, grasps slip and cubes fall off, so no policy reaches it. This script measures how far a
policy that knows the true state gets, to set the learned planners' share of the optimum against:

* with an empty hand, grasp a clear cube that is not in the target tower, big cubes first;
* with a cube in the hand, open the hand over the top of the target tower;
* the target tower is the highest stack (ties: the one with the most big cubes), or a big cube on
  the table when there is no stack; it is re-read from the truth after every primitive, so the
  policy recovers from failures at once;
* a cube the hand failed to grasp is tried last until a grasp succeeds (the arm cannot reach down
  to a cube beside a tall tower without touching the tower, and then stops; trying the same cube
  again would fail the same way).

    python examples/tower_ceiling.py --episodes 30 [--sim-opt noise=0] [--out results/ceiling]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.logic import Atom  # noqa: E402
from groundsym.options import split_key_values  # noqa: E402
from sims.tower import EPISODE_LENGTH, GAMMA, TowerSim, optimal_episode_value  # noqa: E402


def stacks(truth: frozenset, objects: tuple[str, ...]) -> list[list[str]]:
    """The stacks of the true state, bottom first (objects in the hand belong to none)."""
    below = {a.args[0]: a.args[1] for a in truth if a.predicate == "on"}
    held = {a.args[0] for a in truth if a.predicate == "inhand"}
    above = {y: x for x, y in below.items()}
    out = []
    for o in objects:
        if o in held or o in below:
            continue
        stack = [o]
        while stack[-1] in above and len(stack) <= len(objects):
            stack.append(above[stack[-1]])
        out.append(stack)
    return out


def choose(truth: frozenset, objects: tuple[str, ...], failed: frozenset[str] = frozenset(),
           size_blind: bool = False) -> Atom:
    """The scripted builder's next primitive (module docstring); ``failed``: cubes whose grasp failed;
    ``size_blind``: ignore which cubes are big (cubes in name order, as a planner over inhand/on)."""
    big = set() if size_blind else {a.args[0] for a in truth if a.predicate == "big"}
    balls = {a.args[0] for a in truth if a.predicate == "ball"}
    held = [a.args[0] for a in truth if a.predicate == "inhand"]
    towers = [s for s in stacks(truth, objects) if not set(s) & balls]
    target = max(towers, key=lambda s: (len(s), sum(o in big for o in s), s[0] in big), default=None)
    if held:
        top = target[-1] if target else objects[0]
        return Atom("openHandOver", (top,))
    in_target = set(target or ())
    free = [s[-1] for s in stacks(truth, objects) if s[-1] not in in_target and s[-1] not in balls]
    if not free:                          # everything is one tower: nothing useful to do
        return Atom("openHandOver", (target[-1],))
    free.sort(key=lambda o: (o in failed, o not in big, o))
    return Atom("closeHandAround", (free[0],))


def episode(sim: TowerSim, seed: int, size_blind: bool = False) -> float:
    scene = sim.reset(seed)
    value, failed = 0.0, set()
    for t in range(EPISODE_LENGTH):
        action = choose(scene.truth, sim.objects, frozenset(failed), size_blind)
        scene = sim.step(action)
        if action.predicate == "closeHandAround":
            grasped = Atom("inhand", action.args) in scene.truth
            failed = set() if grasped else failed | {action.args[0]}
        value += GAMMA ** t * scene.reward
    return value


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0, help="first start-state seed (then seed+1, ...)")
    ap.add_argument("--sim-opt", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--out", type=Path, default=None, help="write ceiling.json here")
    ap.add_argument("--size-blind", action="store_true", help="the builder does not know which cubes are big")
    args = ap.parse_args()
    opts = split_key_values(args.sim_opt, "--sim-opt")
    best = optimal_episode_value({k: v for k, v in opts.items() if k != "noise"})
    with TowerSim(**opts) as sim:
        values = []
        for k in range(args.episodes):
            values.append(episode(sim, args.seed + k, args.size_blind))
            print(f"episode {k + 1}/{args.episodes}: V = {values[-1]:.5f} ({values[-1] / best:.1%} of V*)",
                  file=sys.stderr, flush=True)
        noise = sim.options["noise"]
    v = np.array(values)
    se = float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else float("nan")
    print(f"scripted builder with true state, noise {noise} m, {len(v)} episodes: "
          f"V = {v.mean():.5f} +- {se:.5f} (standard error) = {v.mean() / best:.1%} +- {se / best:.1%} "
          f"of the deterministic optimum {best:.5f}")
    if args.out:
        atomic_write_json(args.out / "ceiling.json", {"noise": noise, "options": opts, "values": values,
                                                      "mean": float(v.mean()), "stderr": se, "optimum": best,
                                                      "share_of_optimum": float(v.mean() / best)})
    return 0


if __name__ == "__main__":
    sys.exit(main())
