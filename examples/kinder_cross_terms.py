"""Is it the search or the loss? The loss terms of every seed's learned symbols on ONE seed's traces.

``examples/kinder_table.py terms`` compares a seed's learned symbols with hand-made ones; this
compares them with what the other seeds learned from their own traces of the same task. When a
seed's own set scores lower on its traces than sets that hold a relation it lacks, a larger search
budget would not find that relation: the loss prefers the set without it (docs/kinder.md, "Why
b3's seed 0 fails"). When it scores higher, the search stopped short.

    python examples/kinder_cross_terms.py --task b3 --seed 0 --out results/kinder
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from groundsym.grounding import match_symbols
from groundsym.loss import Loss, LossConfig, prepare
from groundsym.modeldir import load_model
from groundsym.symbols import SymbolSet
from groundsym.traces import read_traces


def cross_terms(task_dir: Path, seed: int) -> str:
    """A markdown table: per seed folder under ``task_dir``, its learned symbols scored on the
    traces of ``seed``, with each symbol's best-matching true relation on those traces."""
    ds = read_traces(task_dir / f"seed-{seed}" / "traces.json")
    loss = Loss(prepare(ds, LossConfig()), LossConfig())
    lines = [f"traces of seed {seed}", "",
             "| symbols of seed | F1 on these traces | effect | prediction | reward | regulariser | total |",
             "|---|---|---|---|---|---|---|"]
    for folder in sorted(task_dir.glob("seed-*"), key=lambda p: int(p.name.split("-")[1])):
        if not (folder / "model" / "symbols.json").exists():
            continue
        symbols = list(load_model(folder / "model").symbols.symbols)
        t = loss(symbols)
        f1 = ", ".join(f"{m.best_match} {m.f1:.2f}" for m in match_symbols(SymbolSet.for_dataset(symbols, ds), ds))
        lines.append(f"| {folder.name.split('-')[1]} | {f1} | {t.effect:.1f} | {t.transition:.1f} | "
                     f"{t.reward:.1f} | {t.regulariser:.1f} | {t.total:.1f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", required=True, help="a task folder of kinder_table.py's output, e.g. b3")
    ap.add_argument("--seed", type=int, default=0, help="whose traces score the sets")
    ap.add_argument("--out", type=Path, default=Path("results/kinder"), help="kinder_table.py's --out")
    args = ap.parse_args(argv)
    task_dir = args.out / args.task
    if not (task_dir / f"seed-{args.seed}" / "traces.json").is_file():
        print(f"kinder_cross_terms: {task_dir / f'seed-{args.seed}' / 'traces.json'}: no such traces file "
              "(run kinder_table.py symbols first)", file=sys.stderr)
        return 2
    print(cross_terms(task_dir, args.seed))
    return 0


if __name__ == "__main__":
    sys.exit(main())
