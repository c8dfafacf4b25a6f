"""The IPPC 2006/2008 table: every problem x {PRADA, FF-Replan all-outcomes, most-likely, LRTDP, RANDOM}.

Each cell runs ``--episodes`` episodes (seeds 0..K-1, each planner built afresh per episode as
``groundsym plan`` does) of at most ``--steps`` primitives and prints one JSON line: successes,
mean steps of the successful episodes, dead ends the planner proved, and seconds per decision
(wall time of the cell over the decisions made). Lines are appended to ``--out`` as cells finish,
so a run cut short keeps the rows it has. Problems run in the order given (default: the tyre
worlds first, then the blocks worlds), planners in the order RANDOM, LRTDP (h_max), LRTDP (h_add),
FF-Replan all-outcomes, most-likely, PRADA. LRTDP keeps its values across the episodes of a cell
(``share=1``, its default), as a planner running the IPPC's rounds of one problem may.

    nice -n 10 .venv/bin/python benchmarks/ippc_table.py --out ippc.jsonl
    .venv/bin/python benchmarks/ippc_table.py --out ippc.jsonl --markdown

(Not named bench_*: make bench would run it, and it takes hours.)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from groundsym.episode import ppddl_model, ppddl_world, run_episode  # noqa: E402
from groundsym.planner import make_planner  # noqa: E402
from groundsym.ppddl.parser import load  # noqa: E402

ORDER = ["ippc2006/tireworld", "ippc2008/triangle-tireworld", "ippc2006/blocksworld", "ippc2006/ex-blocksworld",
         "ippc2008/blocksworld", "ippc2008/ex-blocksworld"]
PLANNERS = [("random", "random", {}), ("lrtdp", "lrtdp", {"seconds": "2"}),
            ("lrtdp-hadd", "lrtdp", {"seconds": "2", "heuristic": "hadd"}),
            ("ffr-all-outcomes", "external", {}), ("ffr-most-likely", "external", {"determinize": "most-likely"}),
            ("prada", "prada", {})]


def load_problem(path: Path):
    return load(path.parent / "domain.pddl", path) if "ippc2006" in str(path) else load(path)


def cell(path: Path, planner: str, opts: dict, episodes: int, steps: int, budget: float | None = None) -> dict:
    """One cell; with ``budget`` (seconds), no episode starts once the cell has spent it, and the
    row says how many episodes ran and that the cell timed out."""
    domain, problem = load_problem(path)
    env, task = ppddl_world(domain, problem)
    model = ppddl_model(domain, problem, task, need_rules=planner == "prada")
    wins, lengths, dead, decisions, ran = 0, [], 0, 0, 0
    t = time.perf_counter()
    for seed in range(episodes):
        if budget is not None and time.perf_counter() - t > budget:
            break
        ran += 1
        ep = run_episode(env, make_planner(planner, model, opts, seed), steps, seed)
        decisions += len(ep.steps) + ep.dead_end
        dead += ep.dead_end
        if ep.success:
            wins += 1
            lengths.append(len(ep.steps))
    spent = time.perf_counter() - t
    return {"successes": wins, "episodes": ran, "timed_out": ran < episodes, "budget": budget, "mean_steps": sum(lengths) / len(lengths) if lengths else None,
            "dead_ends": dead, "seconds_per_decision": spent / max(decisions, 1), "seconds": spent}


def markdown(path: Path, data: Path) -> str:
    """One row per problem; a cell is ``successes/episodes, mean steps, dead ends, s/decision``."""
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    got = {(r["problem"], r["planner"]): r for r in rows}
    head = "| problem | " + " | ".join(p for p, _, _ in PLANNERS) + " |"
    out = [head, "|" + "---|" * (len(PLANNERS) + 1)]
    for folder in ORDER:
        for f in sorted((data / folder).glob("p*.pddl")):
            name = f"{folder}/{f.stem}"
            cells = []
            for label, _, _ in PLANNERS:
                r = got.get((name, label))
                if r is None:
                    cells.append("not measured")
                    continue
                steps = f"{r['mean_steps']:.1f}" if r["mean_steps"] is not None else "-"
                dead = f", {r['dead_ends']} dead" if r["dead_ends"] else ""
                cut = f" (timed out: {r['budget']:.0f} s budget)" if r.get("timed_out") else ""
                cells.append(f"{r['successes']}/{r['episodes']}{cut}, {steps} st{dead}, {r['seconds_per_decision']:.2g} s")
            out.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(ROOT / "tests" / "data" / "ippc"))
    ap.add_argument("--out", required=True, help="JSON lines, appended")
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--only", nargs="*", help="problem folders, e.g. ippc2008/triangle-tireworld")
    ap.add_argument("--cell-seconds", type=float, help="budget per cell: no episode starts after it (the row "
                    "says how many ran)")
    ap.add_argument("--planners", nargs="*", help="column labels to run, e.g. random prada (default: all)")
    ap.add_argument("--markdown", action="store_true", help="print --out as a table (rows not run: not measured)")
    args = ap.parse_args()
    if args.markdown:
        print(markdown(Path(args.out), Path(args.data)))
        return 0
    for folder in args.only or ORDER:
        for path in sorted((Path(args.data) / folder).glob("p*.pddl")):
            for label, planner, opts in PLANNERS:
                if args.planners and label not in args.planners:
                    continue
                row = {"problem": f"{folder}/{path.stem}", "planner": label, "steps": args.steps,
                       **cell(path, planner, opts, args.episodes, args.steps, args.cell_seconds)}
                print(json.dumps(row), flush=True)
                with open(args.out, "a") as f:
                    f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
