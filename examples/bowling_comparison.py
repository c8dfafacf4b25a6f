"""The paper's Fig. 4(b): RANDOM, CONTINUOUS-NN, SYMBOLIC-NN and PRADA bowling 2 throws per game.

For each number of model traces n (paper: 25, 50, 100 random games of T = 2 throws), one
``groundsym evaluate`` run plays ``runs x starts`` games (paper: 100) with each method. Each run
learns its own symbols (1 unary + 3 binary, from ``--symbol-data`` random throws, paper: 80) and
its own models from independent data, as the paper's protocol says. A game's score is the number
of pins down after its 2 throws (the reward of the last scene, see docs/bowling.md), so the table
reports that, with standard errors over games, beside the discounted value evaluate reports.

Outputs: ``OUT/n25/``, ``OUT/n50/``, ``OUT/n100/`` (each evaluate's own results.json, table and
PNG), then ``OUT/fig4b.json``, ``OUT/fig4b.md`` and ``OUT/fig4b.png`` (grouped bars like the paper's).

    nice python examples/bowling_comparison.py --out results/bowling-fig4b --runs 20 --starts 5
    nice python examples/bowling_comparison.py --out results/bowling-fig4b-small --runs 4 --starts 5 \\
        --traces 25,50 --evals 5000          # a reduced version that fits a shared machine
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import time
from pathlib import Path

from groundsym.cli import main as groundsym
from groundsym.fileio import atomic_write_bytes, atomic_write_json, atomic_write_text

METHODS = ("random", "continuous-nn", "symbolic-nn", "prada")
LABELS = {"random": "RANDOM", "continuous-nn": "CONTINUOUS-NN", "symbolic-nn": "SYMBOLIC-NN", "prada": "PRADA"}


def run(argv: list[str]) -> None:
    print(f"\n$ groundsym {' '.join(shlex.quote(a) for a in argv)}", flush=True)
    t0 = time.monotonic()
    status = groundsym(argv)
    if status != 0:
        sys.exit(f"bowling_comparison: step failed with status {status}: groundsym {' '.join(argv)}")
    print(f"  ({time.monotonic() - t0:.1f} s)", flush=True)


def final_scores(folder: Path, method: str) -> list[float] | None:
    """Pins down after the last throw of every game of ``method``, from the episodes evaluate kept.

    Looks for episode documents (``groundsym.episode/1``: a ``steps`` list with rewards) anywhere
    in ``folder``; None when evaluate kept none, and the caller falls back on its summary.
    """
    scores = []
    for path in sorted(folder.rglob("*.json")):
        try:
            doc = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        for ep in _episodes(doc):
            if ep.get("planner") == method and ep.get("steps"):
                scores.append(float(ep["steps"][-1]["reward"]))
    return scores or None


def _episodes(doc: object):
    """Every episode document nested anywhere in ``doc``."""
    if isinstance(doc, dict):
        if doc.get("schema") == "groundsym.episode/1":
            yield doc
            return
        for v in doc.values():
            yield from _episodes(v)
    elif isinstance(doc, list):
        for v in doc:
            yield from _episodes(v)


def mean_se(xs: list[float]) -> tuple[float, float]:
    m = sum(xs) / len(xs)
    var = sum((x - m) ** 2 for x in xs) / (len(xs) - 1) if len(xs) > 1 else 0.0
    return m, math.sqrt(var / len(xs))


def summarise(out: Path, traces: list[int]) -> dict:
    rows = []
    for n in traces:
        folder = out / f"n{n}"
        summary = json.loads((folder / "results.json").read_text())
        by_method = {m["method"]: m for m in summary["methods"]}
        for method in METHODS:
            if method not in by_method:
                continue
            s = by_method[method]
            scores = final_scores(folder, method)
            row = {"model_traces": n, "method": method, "value_mean": s["mean"], "value_stderr": s["stderr"],
                   "games": s["n"]}
            if scores:
                row["pins_mean"], row["pins_stderr"] = mean_se(scores)
                row["games"] = len(scores)
            rows.append(row)
    return {"rows": rows}


def table(doc: dict) -> str:
    lines = ["| model traces n | method | pins down after 2 throws | games | evaluate's value (sum of scene rewards) |",
             "|---|---|---|---|---|"]
    for r in doc["rows"]:
        pins = f"{r['pins_mean']:.2f} ± {r['pins_stderr']:.2f}" if "pins_mean" in r else "(no episodes kept)"
        lines.append(f"| {r['model_traces']} | {LABELS[r['method']]} | {pins} | {r['games']} | "
                     f"{r['value_mean']:.2f} ± {r['value_stderr']:.2f} |")
    return "\n".join(lines) + "\n"


def plot(doc: dict, path: Path) -> None:
    """Grouped bars with standard-error whiskers: one group per n, one bar per method."""
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 4), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ns = sorted({r["model_traces"] for r in doc["rows"]})
    width = 0.8 / len(METHODS)
    for k, method in enumerate(METHODS):
        rows = {r["model_traces"]: r for r in doc["rows"] if r["method"] == method}
        xs = [i + (k - (len(METHODS) - 1) / 2) * width for i, n in enumerate(ns) if n in rows]
        key = "pins" if all("pins_mean" in rows[n] for n in rows) else "value"
        ys = [rows[n][f"{key}_mean"] for n in ns if n in rows]
        es = [rows[n][f"{key}_stderr"] for n in ns if n in rows]
        ax.bar(xs, ys, width, yerr=es, capsize=3, label=LABELS[method])
    ax.set_xticks(range(len(ns)), [f"n = {n}" for n in ns])
    ax.set_ylabel("pins down after 2 throws")
    ax.set_title("Bowling (paper Fig. 4(b)): mean ± standard error")
    ax.legend(loc="lower right", fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight")
    atomic_write_bytes(path, buf.getvalue())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="results/bowling-fig4b", help="output folder")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--traces", default="25,50,100", help="model traces n, comma-separated (paper: 25,50,100)")
    ap.add_argument("--runs", type=int, default=20, help="independent runs per n (each learns its own symbols)")
    ap.add_argument("--starts", type=int, default=5, help="games per run (runs x starts = games; paper: 100)")
    ap.add_argument("--symbol-data", type=int, default=80, help="random throws for symbol learning (paper: 80)")
    ap.add_argument("--evals", type=int, default=20000, help="symbol-learning budget per run (loss evaluations)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--pins", type=int, default=10, help="pins per game (paper: the full rack)")
    ap.add_argument("--summarise-only", action="store_true", help="only rebuild the table and PNG from OUT/")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    traces = [int(t) for t in args.traces.split(",")]
    if not args.summarise_only:
        for n in traces:
            run(["evaluate", "--sim", "bowling", "--sim-opt", f"pins={args.pins}", "--methods", ",".join(METHODS),
                 "--symbol-data", str(args.symbol_data), "--model-traces", str(n), "--steps", "2",
                 "--runs", str(args.runs), "--starts", str(args.starts), "--evals", str(args.evals),
                 "--workers", str(args.workers), "--seed", str(args.seed), "-o", str(out / f"n{n}")])
    doc = summarise(out, traces)
    doc["setup"] = vars(args)
    atomic_write_json(out / "fig4b.json", doc)
    atomic_write_text(out / "fig4b.md", table(doc))
    plot(doc, out / "fig4b.png")
    print("\n" + table(doc))
    print(f"Outputs in {out}/: fig4b.json, fig4b.md, fig4b.png and one evaluate folder per n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
