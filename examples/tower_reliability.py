"""How reliable the tower cell's primitives are against motor noise: the curve the default noise is
chosen from (docs/tower.md, "Motor noise").

For each noise level (standard deviation per axis of the offset added to a primitive's target):

* pick-and-place attempts: from a fresh start state, grasp a random cube ``a`` (success: ``inhand(a)``),
  then open the hand over another random cube ``b`` (success: ``on(a, b)``); every failure is put
  down to what the controller met (a fingertip on the target's top, an arm link touching another
  object, no IK solution) or, for a release, to the cube not staying on ``b`` (fell off);
* the scripted builder of ``examples/tower_ceiling.py`` (reads the true state): its episode value
  as a share of the deterministic optimum V*;
* optionally (``--random-traces``), random traces as ``groundsym collect`` makes them: the share of
  primitives that end with every object settled, arm collisions, and the least distance between
  the arm (or the held object) and any object during transits.

    python examples/tower_reliability.py --attempts 200 --episodes 30 --random-traces 100 --out results/reliability
    python examples/tower_reliability.py --plot results/reliability      # table and PNG again
    python examples/tower_reliability.py --levels 7.5 --sim-opt "cubes=20 workspace=wide" --out results/r20

Writes ``reliability.json`` (after each level, so an interrupted run keeps what it measured),
prints a Markdown table and draws ``reliability.png``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from groundsym.collect import trace_seeds  # noqa: E402
from groundsym.errors import UserError  # noqa: E402
from groundsym.fileio import atomic_write_bytes, atomic_write_json, read_json  # noqa: E402
from groundsym.logic import Atom  # noqa: E402
from groundsym.options import split_key_values  # noqa: E402
from sims.tower import TowerSim, optimal_episode_value  # noqa: E402
from tower_ceiling import episode  # noqa: E402

LEVELS_MM = (0.0, 2.5, 5.0, 7.5, 10.0)
CAUSES = ("top_contacts", "arm_collisions", "ik_failures")
CAUSE_NAMES = {"top_contacts": "fingertip on top", "arm_collisions": "arm collision", "ik_failures": "IK",
               "fell_off": "fell off", "missed": "closed without a grasp"}


def cause(before: dict[str, int], after: dict[str, int], otherwise: str) -> str:
    """What the controller met during one primitive, else ``otherwise``."""
    for key in CAUSES:
        if after.get(key, 0) > before.get(key, 0):
            return key
    return otherwise


def pick_and_place(sim: TowerSim, attempts: int) -> dict[str, Any]:
    """``attempts`` pick-and-places from seeds 0, 1, ...; counts of successes and failure causes."""
    out: dict[str, Any] = {"attempts": attempts, "grasped": 0, "stacked": 0, "side_brushes": 0,
                           "side_brushes_grasped": 0, "grasp_failures": {}, "release_failures": {}}
    for seed in range(attempts):
        sim.reset(seed)
        cubes = [o for o, (shape, _) in zip(sim.objects, sim.kinds) if shape == "cube"]
        a, b = (str(x) for x in np.random.default_rng(seed + 100).choice(cubes, 2, replace=False))
        e0 = sim.events
        grasped = Atom("inhand", (a,)) in sim.step(Atom("closeHandAround", (a,))).truth
        e1 = sim.events
        brushed = e1.get("side_contacts", 0) > e0.get("side_contacts", 0)
        out["side_brushes"] += brushed
        out["side_brushes_grasped"] += brushed and grasped
        if not grasped:
            why = cause(e0, e1, "missed")
            out["grasp_failures"][why] = out["grasp_failures"].get(why, 0) + 1
            continue
        out["grasped"] += 1
        stacked = Atom("on", (a, b)) in sim.step(Atom("openHandOver", (b,))).truth
        out["stacked"] += stacked
        if not stacked:
            why = cause(e1, sim.events, "fell_off")
            out["release_failures"][why] = out["release_failures"].get(why, 0) + 1
    return out


def builder(sim: TowerSim, episodes: int, best: float) -> dict[str, Any]:
    values = [episode(sim, seed) for seed in range(episodes)]
    v = np.array(values)
    return {"episodes": episodes, "values": values, "share": float(v.mean() / best),
            "stderr": float(v.std(ddof=1) / np.sqrt(len(v)) / best) if len(v) > 1 else 0.0}


def random_traces(sim: TowerSim, traces: int, length: int = 10) -> dict[str, Any]:
    """Random traces as ``groundsym collect`` makes them (seed 21), with the transit clearance watched."""
    e0 = sim.events
    sim.world.clearance = np.inf
    for reset_seed, rng in trace_seeds(21, traces):
        sim.reset(reset_seed)
        choices = sim.actions()
        for _ in range(length):
            sim.step(choices[int(rng.integers(len(choices)))])
    e1 = sim.events
    counts = {k: e1.get(k, 0) - e0.get(k, 0) for k in set(e1) | set(e0)}
    clearance = float(sim.world.clearance)
    sim.world.clearance = None
    return {"primitives": counts.get("primitives", 0), "events": counts,
            "settled_share": 1 - counts.get("unsettled", 0) / max(counts.get("primitives", 0), 1),
            "min_transit_clearance": clearance}


def table(results: list[dict[str, Any]]) -> str:
    rows = ["| noise (mm) | grasp | stack (given a grasp) | pick-and-place | builder (% of V*) | "
            "grasp failures | release failures | side brushes (grasped) |", "|---|---|---|---|---|---|---|---|"]
    for r in results:
        p = r["pick_and_place"]
        fails = ", ".join(f"{CAUSE_NAMES[k]} {v}" for k, v in sorted(p["grasp_failures"].items())) or "none"
        rel = ", ".join(f"{CAUSE_NAMES[k]} {v}" for k, v in sorted(p["release_failures"].items())) or "none"
        b = r.get("builder")
        bcell = f"{b['share']:.1%} ± {b['stderr']:.1%} ({b['episodes']} ep.)" if b else "-"
        rows.append(f"| {r['noise'] * 1000:g} | {p['grasped']}/{p['attempts']} ({p['grasped'] / p['attempts']:.1%}) "
                    f"| {p['stacked']}/{p['grasped']} ({p['stacked'] / max(p['grasped'], 1):.1%}) "
                    f"| {p['stacked']}/{p['attempts']} ({p['stacked'] / p['attempts']:.1%}) | {bcell} | {fails} "
                    f"| {rel} | {p['side_brushes']} ({p['side_brushes_grasped']}) |")
    return "\n".join(rows) + "\n"


def plot(results: list[dict[str, Any]], path: Path) -> None:
    import io

    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    mm = [r["noise"] * 1000 for r in results]
    p = [r["pick_and_place"] for r in results]
    fig = Figure(figsize=(6.4, 4.0), dpi=100)
    ax = fig.add_subplot()
    ax.plot(mm, [x["grasped"] / x["attempts"] for x in p], "o-", label="grasp")
    ax.plot(mm, [x["stacked"] / max(x["grasped"], 1) for x in p], "s-", label="stack, given a grasp")
    ax.plot(mm, [x["stacked"] / x["attempts"] for x in p], "^-", label="pick-and-place")
    built = [r for r in results if "builder" in r]
    if built:
        ax.errorbar([r["noise"] * 1000 for r in built], [r["builder"]["share"] for r in built],
                    [r["builder"]["stderr"] for r in built], fmt="d-", capsize=3, label="scripted builder, share of V*")
    ax.axhline(0.9, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("motor noise: std per axis (mm)")
    ax.set_ylabel("success rate / share of V*")
    ax.set_ylim(0, 1.02)
    ax.set_title("tower cell: primitive reliability against motor noise")
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    atomic_write_bytes(path, buf.getvalue())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--attempts", type=int, default=200, help="pick-and-place attempts per level")
    ap.add_argument("--episodes", type=int, default=30, help="scripted-builder episodes per level (0: none)")
    ap.add_argument("--levels", default=",".join(f"{x:g}" for x in LEVELS_MM), help="noise levels in mm")
    ap.add_argument("--random-traces", type=int, default=0, metavar="N",
                    help="also N random traces of 10 primitives at the default noise (settling, clearance)")
    ap.add_argument("--sim-opt", action="append", default=[], metavar="KEY=VALUE",
                    help="cell options besides the noise (e.g. \"cubes=20 workspace=wide\", docs/tower.md)")
    ap.add_argument("--out", type=Path, default=Path("results/reliability"))
    ap.add_argument("--plot", type=Path, default=None, metavar="DIR", help="only redraw from DIR/reliability.json")
    args = ap.parse_args()
    if args.plot:
        doc = read_json(args.plot / "reliability.json")
        print(table(doc["levels"]), end="")
        plot(doc["levels"], args.plot / "reliability.png")
        return 0
    try:
        given = split_key_values(args.sim_opt, "--sim-opt")
        given.pop("noise", None)                              # the levels set it
        best = optimal_episode_value(given)                   # checks the options before any physics
    except UserError as exc:
        print(f"tower_reliability: {exc}", file=sys.stderr)
        return 2
    doc: dict[str, Any] = {"levels": [], "optimum": best, "sim_options": given}
    for level in (float(x) / 1000 for x in args.levels.split(",") if x.strip()):
        with TowerSim(**given, noise=level) as sim:
            row: dict[str, Any] = {"noise": level, "pick_and_place": pick_and_place(sim, args.attempts)}
            if args.episodes:
                row["builder"] = builder(sim, args.episodes, best)
        doc["levels"].append(row)
        atomic_write_json(args.out / "reliability.json", doc)
        print(f"noise {level * 1000:g} mm done", file=sys.stderr, flush=True)
    if args.random_traces:
        with TowerSim(**given) as sim:
            doc["random_traces"] = random_traces(sim, args.random_traces)
        atomic_write_json(args.out / "reliability.json", doc)
        print(f"random traces at noise {sim.options['noise']}: {doc['random_traces']}")
    print(table(doc["levels"]), end="")
    plot(doc["levels"], args.out / "reliability.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
