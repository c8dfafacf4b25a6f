"""How often a planner lets go of something over a ball, with a model learned on what the camera sees.

Nothing stays on a ball, so a model that knows which objects are balls should rarely release over
one. For each planner, the same episodes (start states from ``episode_seeds(--seed, N)``, as ``groundsym
plan`` draws them) run in the tower cell with the model's symbols; every ``openHandOver(X)`` with an
object in the hand is counted, and those with ``X`` a ball (the simulator's truth, read only here)
apart::

    python examples/perception_releases.py --model MODEL --sim-opt "cubes=4 balls=3 features=pointcloud" \\
        --episodes 30 --planners prada random -o OUT.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.commands.plan import check_model_fits_sim, episode_seeds, sim_planning_model  # noqa: E402
from groundsym.episode import SimEnv, run_episode  # noqa: E402
from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.modeldir import load_model  # noqa: E402
from groundsym.planner import make_planner  # noqa: E402
from groundsym.registry import get_sim_class, make_sim  # noqa: E402
from groundsym.options import split_key_values  # noqa: E402


class CountingEnv(SimEnv):
    """A SimEnv that counts, from the truth of the scene before each primitive, the releases with
    something in the hand, and those over a ball."""

    def __init__(self, sim, symbols):
        super().__init__(sim, symbols)
        self.scene = None
        self.releases = self.over_ball = 0

    def _observe(self, scene, t, steps_left):
        self.scene = scene
        return super()._observe(scene, t, steps_left)

    def step(self, action, t, steps_left):
        truth = self.scene.truth
        if action.predicate == "openHandOver" and any(a.predicate == "inhand" for a in truth):
            self.releases += 1
            self.over_ball += any(a.predicate == "ball" and a.args == action.args for a in truth)
        return super().step(action, t, steps_left)


def run(model_dir: Path, options: dict[str, str], planner: str, planner_opts: dict[str, str], episodes: int,
        seed: int) -> dict:
    model = load_model(model_dir)
    check_model_fits_sim(model, get_sim_class("tower"), str(model_dir), options)
    sim = make_sim("tower", options)
    try:
        pm = sim_planning_model(model, sim)
        env = CountingEnv(sim, pm.symbols)
        values = []
        for k, s in enumerate(episode_seeds(seed, episodes)):
            ep = run_episode(env, make_planner(planner, pm, planner_opts, s), int(sim.episode_length), s, planner)
            values.append(ep.value)
            print(f"{planner} episode {k}: value {ep.value:.4g}, releases {env.releases}, over a ball {env.over_ball}",
                  file=sys.stderr)
    finally:
        sim.close()
    return {"planner": planner, "episodes": episodes, "mean_value": float(np.mean(values)),
            "releases": env.releases, "releases_over_a_ball": env.over_ball}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", type=Path, required=True)
    ap.add_argument("--sim-opt", action="append", default=[])
    ap.add_argument("--planners", nargs="+", default=["prada", "random"])
    ap.add_argument("--planner-opt", action="append", default=[], help="options for prada, e.g. samples=200")
    ap.add_argument("--episodes", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("-o", "--output", type=Path)
    args = ap.parse_args()
    options = split_key_values(args.sim_opt, "--sim-opt")
    rows = []
    for planner in args.planners:
        opts = split_key_values(args.planner_opt, "--planner-opt") if planner == "prada" else {}
        rows.append(run(args.model, options, planner, opts, args.episodes, args.seed))
        r = rows[-1]
        print(f"{planner}: {r['episodes']} episodes, mean value {r['mean_value']:.4g}, releases with something "
              f"in the hand {r['releases']}, over a ball {r['releases_over_a_ball']}")
    if args.output:
        atomic_write_json(args.output, {"command": " ".join(sys.argv), "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
