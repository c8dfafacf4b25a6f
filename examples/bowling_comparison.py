"""The paper's Fig. 4(b): RANDOM, CONTINUOUS-NN, SYMBOLIC-NN and PRADA bowling games of 2 throws.

The paper's bowling protocol (Section VI-C), which differs from ``groundsym evaluate``'s tower
protocol in three ways, so this script runs it itself from the library's pieces:

- symbols (1 unary + 3 binary) are learned from 80 random throws in *5-pin* worlds (40 games of 2
  throws), while models and games use the full 10-pin rack;
- model traces are n = 25, 50, 100 random *games of T = 2 throws* (not traces of 10 primitives);
- a game scores the pins down after its 2 throws, i.e. the reward of the last scene
  (``BowlingSim.episode_score == "final"``), not the sum of the scene rewards.

Per run r (independent seeds): learn symbols once; then for every n collect n random games,
abstract them, learn NID rules and the reward model, and play ``--games`` games with each method.
``runs x games`` games per method and n (paper: 100). Every finished run is saved in
``OUT/runs/`` at once, and a rerun with the same options resumes from there.

Outputs: ``OUT/fig4b.json`` (every game's score, means and standard errors over games),
``OUT/fig4b.md`` (the table) and ``OUT/fig4b.png`` (grouped bars like the paper's).
``--truth-symbols`` plans with the simulator's own relations instead (a diagnosis that separates
planning from symbol learning).

    nice python examples/bowling_comparison.py --out results/bowling-fig4b --runs 10 --games 10
    nice python examples/bowling_comparison.py --out results/bowling-small --runs 2 --games 10 \\
        --traces 25,50 --evals 4000        # reduced: fits a shared 2-core machine in minutes
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from groundsym.collect import collect_traces
from groundsym.episode import SimEnv, run_episode
from groundsym.fileio import atomic_write_bytes, atomic_write_json, atomic_write_text, read_json
from groundsym.modeldir import learn_symbolic_model, load_model
from groundsym.planner import PlanningModel, make_planner
from groundsym.progress import Progress
from sims.bowling import BowlingSim

METHODS = ("random", "continuous-nn", "symbolic-nn", "prada")
LABELS = {"random": "RANDOM", "continuous-nn": "CONTINUOUS-NN", "symbolic-nn": "SYMBOLIC-NN", "prada": "PRADA"}
TRUTH = ("upright", "sameColumn", "behind")


def run_seeds(seed: int, run: int, traces: list[int]) -> dict[str, Any]:
    """Independent seeds per run (and per n), so runs can be resumed or reordered freely."""
    s = [int(x) for x in np.random.SeedSequence(seed, spawn_key=(run,)).generate_state(3 + 2 * len(traces))]
    return {"symbol_data": s[0], "anneal": s[1], "games": s[2],
            "model_data": dict(zip(traces, s[3::2])), "planners": dict(zip(traces, s[4::2]))}


def learn_symbols(args: argparse.Namespace, seeds: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
    """1 unary + 3 binary symbols from ``--symbol-games`` random games in 5-pin worlds, graded on them."""
    if args.truth_symbols:
        from groundsym.evaluation.truth import TruthSymbols

        return TruthSymbols(TRUTH, dict(BowlingSim.truth_predicates)), {"symbols": "truth"}
    from bowling_symbols import anneal_symbols    # the sibling script (examples/ is on sys.path)

    from groundsym.grounding import match_symbols

    with BowlingSim(pins=args.symbol_pins) as small:
        data = collect_traces(small, args.symbol_games, 2, seeds["symbol_data"], progress=False)
    symbols, result = anneal_symbols(data, unary=args.unary, binary=args.binary, evals=args.evals,
                                     restarts=args.restarts, seed=seeds["anneal"],
                                     transition_weight=args.transition_weight, progress=False)
    return symbols, {"symbols": "learned", "loss": result.terms.to_doc(), "text": repr(symbols),
                     "grounding_on_training_data": [m.to_doc() for m in match_symbols(symbols, data)]}


def play_run(args: argparse.Namespace, run: int, traces: list[int], sim: BowlingSim) -> dict[str, Any]:
    """One run: symbols, then per n a model and ``--games`` games per method; final pins per game."""
    t0 = time.monotonic()
    seeds = run_seeds(args.seed, run, traces)
    symbols, report = learn_symbols(args, seeds)
    starts = [int(x) for x in np.random.SeedSequence(seeds["games"]).generate_state(args.games)]
    scores: dict[str, dict[str, list[float]]] = {}
    report["rules"] = {}
    for n in traces:
        mdata = collect_traces(sim, n, 2, seeds["model_data"][n], progress=False)
        sds = symbols.to_symbolic_dataset(mdata)
        with tempfile.TemporaryDirectory() as tmp:
            learn_symbolic_model(sds, Path(tmp), seed=seeds["planners"][n], argv=[], progress=False, mode="nid")
            m = load_model(tmp)
        report["rules"][str(n)] = len(m.rules.rules)      # NID rules PRADA plans with (besides defaults)
        pm = PlanningModel(dict(sim.primitives), predicates=dict(symbols.predicates), symbols=symbols,
                           rules=m.rules, reward=m.reward, traces=mdata, symbolic_traces=sds, gamma=float(sim.gamma))
        pseeds = np.random.SeedSequence(seeds["planners"][n]).generate_state(len(args.methods) * len(starts))
        for i, method in enumerate(args.methods):
            got = []
            for k, start in enumerate(starts):
                planner = make_planner(method, pm, {}, int(pseeds[i * len(starts) + k]))
                episode = run_episode(SimEnv(sim, symbols), planner, 2, start, method)
                got.append(float(episode.steps[-1].reward))      # pins down after the 2nd throw
            scores.setdefault(str(n), {})[method] = got
    return {"run": run, "scores": scores, "report": report, "seconds": time.monotonic() - t0}


def fingerprint(args: argparse.Namespace) -> str:
    """What decides the numbers; a resumed run must match it."""
    keys = ("seed", "traces", "games", "symbol_games", "symbol_pins", "evals", "restarts", "unary", "binary",
            "truth_symbols", "methods", "transition_weight")
    doc = {k: getattr(args, k) for k in keys}
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=list).encode()).hexdigest()[:16]


def mean_se(xs: list[float]) -> tuple[float, float]:
    a = np.asarray(xs, dtype=float)
    return float(a.mean()), float(a.std(ddof=1) / math.sqrt(len(a))) if len(a) > 1 else float("nan")


def summarise(units: list[dict[str, Any]], traces: list[int], methods: tuple[str, ...]) -> list[dict[str, Any]]:
    rows = []
    for n in traces:
        for method in methods:
            games = [s for u in units for s in u["scores"][str(n)][method]]
            m, se = mean_se(games)
            rows.append({"model_traces": n, "method": method, "mean": m, "stderr": se, "games": len(games)})
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    lines = ["| model traces n | method | pins down after 2 throws (mean ± s.e.) | games |", "|---:|---|---:|---:|"]
    lines += [f"| {r['model_traces']} | {LABELS.get(r['method'], r['method'])} | {r['mean']:.2f} ± {r['stderr']:.2f} | "
              f"{r['games']} |" for r in rows]
    return "\n".join(lines) + "\n"


def plot(rows: list[dict[str, Any]], methods: tuple[str, ...], title: str) -> bytes:
    """Grouped bars with standard-error whiskers: one group per n, one bar per method."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 4), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ns = sorted({r["model_traces"] for r in rows})
    width = 0.8 / len(methods)
    for k, method in enumerate(methods):
        got = {r["model_traces"]: r for r in rows if r["method"] == method}
        xs = [i + (k - (len(methods) - 1) / 2) * width for i in range(len(ns))]
        ax.bar(xs, [got[n]["mean"] for n in ns], width, yerr=[got[n]["stderr"] for n in ns], capsize=3,
               label=LABELS.get(method, method))
    ax.set_xticks(range(len(ns)), [f"n = {n}" for n in ns])
    ax.set_xlabel("model traces (random games of 2 throws)")
    ax.set_ylabel("pins down after 2 throws")
    ax.set_ylim(0, 10.5)
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=len(methods), fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight")
    return buf.getvalue()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="results/bowling-fig4b", help="output folder")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--traces", default="25,50,100", help="model traces n, comma-separated (paper: 25,50,100)")
    ap.add_argument("--runs", type=int, default=10, help="independent runs (each learns its own symbols)")
    ap.add_argument("--games", type=int, default=10, help="games per method, n and run (runs x games: paper 100)")
    ap.add_argument("--symbol-games", type=int, default=40, help="random games for symbols (paper: 40 = 80 throws)")
    ap.add_argument("--symbol-pins", type=int, default=5, help="pins in the symbol-learning worlds (paper: 5)")
    ap.add_argument("--evals", type=int, default=100000, help="symbol-learning budget per run (loss evaluations)")
    ap.add_argument("--restarts", type=int, default=4)
    ap.add_argument("--unary", type=int, default=1)
    ap.add_argument("--binary", type=int, default=3)
    ap.add_argument("--transition-weight", type=float, default=1.0,
                    help="weight of the symbol loss's prediction term (see examples/bowling_symbols.py)")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--truth-symbols", action="store_true",
                    help="diagnosis: plan with the sim's upright/sameColumn/behind instead of learned symbols")
    args = ap.parse_args()
    args.methods = tuple(m for m in args.methods.split(",") if m)
    traces = [int(t) for t in args.traces.split(",")]
    args.traces = traces
    out = Path(args.out)
    (out / "runs").mkdir(parents=True, exist_ok=True)
    key = fingerprint(args)
    bar = Progress(args.runs, "bowling fig4b")
    units = []
    with BowlingSim() as sim:
        for r in range(args.runs):
            path = out / "runs" / f"run{r:03d}.json"
            unit = read_json(path) if path.exists() else None
            if unit is None or unit.get("fingerprint") != key:
                unit = play_run(args, r, traces, sim) | {"fingerprint": key}
                atomic_write_json(path, unit)
            units.append(unit)
            rows = summarise(units, traces, args.methods)
            bar.update(r + 1, ", ".join(f"{r_['method']}@{r_['model_traces']}: {r_['mean']:.2f}" for r_ in rows[:4]))
    bar.close()
    rows = summarise(units, traces, args.methods)
    symbols = "the simulator's true relations" if args.truth_symbols else \
        f"{args.unary} unary + {args.binary} binary learned symbols ({args.evals} evals, " \
        f"prediction weight {args.transition_weight:g})"
    title = f"Bowling (paper Fig. 4(b)), {args.runs} runs x {args.games} games, {symbols}"
    doc = {"rows": rows, "setup": {k: v for k, v in vars(args).items()}, "fingerprint": key,
           "runs": [{"run": u["run"], "report": u["report"], "seconds": u["seconds"]} for u in units],
           "scores": {str(u["run"]): u["scores"] for u in units}}
    atomic_write_json(out / "fig4b.json", doc)
    atomic_write_text(out / "fig4b.md", f"{title}\n\n" + table(rows))
    atomic_write_bytes(out / "fig4b.png", plot(rows, args.methods, title))
    print("\n" + title + "\n\n" + table(rows))
    print(f"Outputs in {out}/: fig4b.json, fig4b.md, fig4b.png, runs/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
