"""What the primitives did in tower traces, by kind of object, from the simulator's ground truth.

A symbol earns its place in the loss only through the transitions where it changes a prediction.
``ball`` matters where a cube is released over a ball (it falls off) or a ball over anything; this
script counts those outcomes per traces file, so a learned result can be read against how often
the data shows the difference (diagnosis only: it reads the truth, which learning never does).

    python examples/tower_outcomes.py results/balls/data/train_1.json [more traces files]

Prints, per file, the grasps (of cubes and balls: succeeded / tried) and the releases with an object
in the hand (held kind over target kind: on the target afterwards / tried), the same for a clear
target alone (nothing on it; a pick-and-place's two halves, as docs/tower.md measures them), and
how many releases were over a ball (where ``ball`` changes the prediction).
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.errors import UserError  # noqa: E402
from groundsym.traces import Dataset, read_traces  # noqa: E402


KIND = {True: "ball", False: "cube"}   # is a ball -> the word


def outcomes(ds: Dataset) -> Counter:
    """(event, success) -> count: "grab ball", "cube over ball", ... as the truth atoms tell."""
    counts: Counter = Counter()
    for tr in ds.traces:
        for t, action in enumerate(tr.actions):
            pre, post = tr.scenes[t], tr.scenes[t + 1]
            balls = {a.args[0] for a in pre.truth if a.predicate == "ball"}
            held = [a.args[0] for a in pre.truth if a.predicate == "inhand"]
            target = action.args[0]
            clear = any(a.predicate == "clear" and a.args == (target,) for a in pre.truth)
            if action.predicate == "openHandOver" and held:
                stacked = any(a.predicate == "on" and a.args == (held[0], target) for a in post.truth)
                counts[(f"{KIND[held[0] in balls]} over {KIND[target in balls]}", stacked)] += 1
                if clear and held[0] != target:
                    counts[(f"{KIND[held[0] in balls]} over clear {KIND[target in balls]}", stacked)] += 1
            elif action.predicate == "closeHandAround" and not held:
                grasped = any(a.predicate == "inhand" and a.args[0] == target for a in post.truth)
                counts[(f"grab {KIND[target in balls]}", grasped)] += 1
                if clear:
                    counts[(f"grab clear {KIND[target in balls]}", grasped)] += 1
    return counts


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("traces", type=Path, nargs="+")
    args = ap.parse_args()
    for path in args.traces:
        try:
            counts = outcomes(read_traces(path))
        except UserError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        events = sorted({e for e, _ in counts})
        cells = [f"{e} {counts[(e, True)]}/{counts[(e, True)] + counts[(e, False)]}" for e in events]
        over_ball = sum(n for (e, _), n in counts.items() if e.endswith("over ball"))
        print(f"{path}: " + ", ".join(cells) + f"; releases over a ball: {over_ball}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
