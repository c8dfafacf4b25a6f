"""The best episode value of the tower cell in the deterministic world (noise off).

Prints the optimum found by exhaustive search over tower-building sequences (sims/tower_optimum.py),
the same divided by the largest cube size (to set beside the paper's 2.963), the optimal plan, and
the value the arm actually earns running that plan in the noise-free pybullet cell.

    python examples/tower_optimum.py [--sim-opt cubes=7 --sim-opt big=3 ...] [--seed S]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.logic import Atom  # noqa: E402
from groundsym.options import split_key_values  # noqa: E402
from sims.tower import EPISODE_LENGTH, GAMMA, TowerSim, resolve_options  # noqa: E402
from sims.tower_optimum import best_plan, ground_plan  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sim-opt", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--seed", type=int, default=0, help="start state for the physical replay")
    args = ap.parse_args()
    given = split_key_values(args.sim_opt, "--sim-opt")
    given.pop("noise", None)
    opts = resolve_options(given)
    plan = best_plan(opts, GAMMA, EPISODE_LENGTH)
    largest = opts["big_size"] if opts["big"] else opts["small_size"]
    print(f"tower cell: {opts['cubes']} cubes ({opts['big']} of {opts['big_size']} m, the rest "
          f"{opts['small_size']} m), {opts['balls']} balls, T = {EPISODE_LENGTH}, gamma = {GAMMA}")
    print(f"optimal episode value V* = {plan.value:.6f} m")
    print(f"V* / largest cube size ({largest} m) = {plan.value / largest:.4f}   (paper: 2.963)")
    with TowerSim(**given, noise=0) as sim:
        sim.reset(args.seed)
        sizes = {o: size for o, (shape, size) in zip(sim.objects, sim.kinds) if shape == "cube"}
        value = 0.0
        print(f"\n{'t':>2}  {'primitive':<24} {'r_t (search)':>12} {'r_t (pybullet)':>14}")
        for t, (prim, obj) in enumerate(ground_plan(plan, sizes)):
            r = sim.step(Atom(prim, (obj,))).reward
            value += GAMMA ** t * r
            print(f"{t + 1:>2}  {f'{prim}({obj})':<24} {plan.rewards[t]:>12.5f} {r:>14.5f}")
    print(f"\nreplayed by the arm in pybullet (noise off, seed {args.seed}): V = {value:.6f} m "
          f"({value / plan.value:.2%} of V*)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
