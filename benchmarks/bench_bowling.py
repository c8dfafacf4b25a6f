"""Bowling throws per second on one core, and what the early exit and the coarse time step buy.

Plays random games (2 random throws each, as ``groundsym collect`` does) in the full rack and in
the 5-pin worlds, and prints throws per CPU second (the process's own time, so other jobs on a
shared machine do not count), physics steps per throw and simulated seconds per
throw. Ratios in the same run: the default sim against the same games with the early exit off
(every throw runs to ``max_time``), and against a time step of 1/480 s. The last line says how
often the 1/240 s step gives the same pins down as 1/480 s on the same games (noise off), so the
coarse step's accuracy is measured, not assumed.

Usage: ``python benchmarks/bench_bowling.py [--games N] [--core K]``;
``--simple-play N`` instead measures what simple and random play score over N games (the table in
docs/bowling.md, "What random and simple play score").
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from groundsym.logic import Atom
from sims.bowling import BowlingSim


def play(sim: BowlingSim, games: int, seed: int, early_exit: bool = True) -> tuple[float, int, list[float]]:
    """Random games; returns (CPU seconds of this process, physics steps, pins down per game).

    CPU time, not wall time: on a shared machine wall time counts other people's jobs too.
    """
    sim.alley.early_exit = early_exit
    rng = np.random.default_rng(seed)
    steps0 = sim.alley.steps_run
    scores = []
    t0 = time.process_time()
    for g in range(games):
        sim.reset(seed + g)
        scene = None
        for _ in range(sim.episode_length):
            acts = sim.actions()
            scene = sim.step(acts[rng.integers(len(acts))])
        scores.append(scene.reward)
    return time.process_time() - t0, sim.alley.steps_run - steps0, scores


def report(label: str, cpu: float, steps: int, throws: int, timestep: float) -> float:
    rate = throws / cpu
    print(f"{label:<34} {rate:7.1f} throws/CPU s  {steps / throws:6.0f} steps/throw  "
          f"{steps * timestep / throws:5.2f} s simulated/throw")
    return rate


def column_throw(sim: BowlingSim, scene) -> Atom:
    """``throwRightOfCenter`` at the standing pin with the most standing pins in its column."""
    standing = [o for o in scene.objects if Atom("upright", (o,)) in scene.truth] or list(scene.objects)
    same = {o: sum(Atom("sameColumn", (o, p)) in scene.truth for p in standing) for o in standing}
    return Atom("throwRightOfCenter", (max(standing, key=lambda o: (same[o], o)),))


def simple_play(games: int) -> None:
    """Pins down by simple and random play, ``games`` games each (seeds 0, 1, ...)."""
    def head(sim: BowlingSim) -> str:
        return sim.objects[sim.spots.index(1)]

    plays = {
        "one throwAtCenter at the head pin": (10, lambda sim, s, t: Atom("throwAtCenter", (head(sim),)), 1),
        "one throwRightOfCenter at the head pin": (10, lambda sim, s, t: Atom("throwRightOfCenter", (head(sim),)), 1),
        "throwRightOfCenter at the head pin, then the fullest column":
            (10, lambda sim, s, t: Atom("throwRightOfCenter", (head(sim),)) if t == 0 else column_throw(sim, s), 2),
    }
    for label, (pins, choose, throws) in plays.items():
        with BowlingSim(pins=pins) as sim:
            scores = []
            for g in range(games):
                scene = sim.reset(g)
                for t in range(throws):
                    scene = sim.step(choose(sim, scene, t))
                scores.append(scene.reward)
        s = np.array(scores, dtype=float)
        print(f"{label}: {s.mean():.2f} (sd {s.std(ddof=1):.2f}, standard error {s.std(ddof=1) / np.sqrt(len(s)):.2f}), "
              f"strikes {int(np.sum(s == pins))}/{len(s)}")
    for pins in (10, 5):
        with BowlingSim(pins=pins) as sim:
            _, _, scores = play(sim, games, seed=1000)
        print(f"two random throws, {pins} pins: {np.mean(scores):.2f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--games", type=int, default=40, help="games of 2 throws per setting (default 40)")
    ap.add_argument("--core", type=int, default=0, help="CPU core to pin the process to (default 0)")
    ap.add_argument("--simple-play", type=int, default=0, metavar="N", help="measure simple play over N games instead")
    args = ap.parse_args()
    if args.simple_play:
        simple_play(args.simple_play)
        return 0
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {args.core})
    g, throws = args.games, 2 * args.games
    print(f"bowling: {g} random games of 2 throws per setting, one core (pinned to core {args.core})")

    rates = {}
    for pins in (10, 5):
        with BowlingSim(pins=pins) as sim:
            cpu, steps, _ = play(sim, g, seed=1000)
            rates[pins] = report(f"pins={pins}, default (1/240 s, early exit)", cpu, steps, throws, sim.alley.timestep)
    with BowlingSim() as sim:
        cpu, steps, _ = play(sim, max(g // 4, 2), seed=1000, early_exit=False)
        slow = report("pins=10, early exit off", cpu, steps, 2 * max(g // 4, 2), sim.alley.timestep)
    print(f"ratio early exit on/off: {rates[10] / slow:.1f}x faster")

    with BowlingSim(noise=0, speed_noise=0) as coarse, BowlingSim(noise=0, speed_noise=0, timestep=1 / 480) as fine:
        wc, sc, pins_c = play(coarse, g, seed=2000)
        wf, sf, pins_f = play(fine, g, seed=2000)
    rc = report("pins=10, noise off, 1/240 s", wc, sc, throws, 1 / 240)
    rf = report("pins=10, noise off, 1/480 s", wf, sf, throws, 1 / 480)
    diff = np.abs(np.array(pins_c) - np.array(pins_f))
    print(f"ratio 1/240 s over 1/480 s: {rc / rf:.1f}x faster; same pins down in {np.mean(diff == 0):.0%} of "
          f"games, mean |difference| {diff.mean():.2f} pins (mean score {np.mean(pins_c):.2f} vs {np.mean(pins_f):.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
