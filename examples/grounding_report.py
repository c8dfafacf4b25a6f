"""The issue's grounding experiment: do the learned symbols mean `inhand` and `on`?

For each seed: record random training traces in the tower cell (16 traces x 10 primitives = 160
transitions; `groundsym collect`), learn symbols (`groundsym learn`), and match each symbol against
the simulator's ground truth on held-out scenes (`groundsym show --against --json`). Prints a table
and writes `report.json` and `report.md` into the output directory. Existing trace files in the
data directory are reused, and so is a model learned with the same seed, data and settings (by the
current code's defaults), so an interrupted report resumes where it stopped.

    .venv/bin/python examples/grounding_report.py --out results/grounding --seeds 1 2 3 4 5 --evals 20000
    # cubes and balls (the paper's second experiment): 2 unary + 1 binary symbols
    .venv/bin/python examples/grounding_report.py --out results/balls --sim-opt "cubes=4 balls=3" --unary 2
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from groundsym.fileio import atomic_write_json, atomic_write_text  # noqa: E402

GROUNDSYM = [sys.executable, "-m", "groundsym.cli"]


def sh(args: list[str], quiet: bool = False) -> str:
    res = subprocess.run(GROUNDSYM + args, cwd=ROOT, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit(f"groundsym {' '.join(args)} failed:\n{res.stderr.strip()}")
    if not quiet and res.stderr.strip():
        print(res.stderr.strip().splitlines()[-1], file=sys.stderr)
    return res.stdout


def learned_already(model: Path, train: Path, seed: int, args: argparse.Namespace) -> bool:
    """Does ``model`` hold symbols learned from ``train`` with this seed and the current settings?"""
    sys.path.insert(0, str(ROOT))
    from groundsym.fileio import file_sha256
    from groundsym.commands.learn import anneal_config, loss_config

    try:
        doc = json.loads((model / "symbols.json").read_text())
    except (OSError, ValueError):
        return False
    want = anneal_config(args)
    prov, cfg = doc.get("provenance", {}), doc.get("config", {})
    return (prov.get("seed") == seed and prov.get("data_sha256") == file_sha256(train)
            and cfg.get("anneal") == want.to_doc() and cfg.get("loss") == loss_config(args.loss).to_doc())


def collect(path: Path, traces: int, seed: int, sim_opt: list[str]) -> None:
    if path.exists():
        return
    opts = [x for o in sim_opt for x in ("--sim-opt", o)]
    sh(["collect", "--sim", "tower", *opts, "--traces", str(traces), "--length", "10", "--seed", str(seed),
        "-o", str(path), "--quiet"])


def summary(rows: list[dict], want: list[str], good: float) -> str:
    """In how many seeds each wanted relation is grounded (a symbol matching it with F1 >= ``good``,
    or a unary symbol whose negation matches it with F1 >= 0.9), and all of them together."""
    from groundsym.grounding import grounded

    hits = {w: 0 for w in want}
    every = 0
    for r in rows:
        got: set[str] = set()
        for m in r["symbols"]:
            got |= set(grounded(m, good))
        ok = {w: any(alt in got for alt in w.split("|")) for w in want}
        for w in want:
            hits[w] += ok[w]
        every += all(ok.values())
    parts = [f"{w} in {hits[w]} of {len(rows)}" for w in want]
    return f"grounded (F1 >= {good}; a negation at >= 0.9): " + ", ".join(parts) + f"; all in {every} of {len(rows)}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--data", type=Path, help="directory for the trace files (default: OUT/data)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--train-traces", type=int, default=16, help="training traces of 10 primitives")
    ap.add_argument("--test-traces", type=int, default=40, help="held-out traces (10 scenes each are scored)")
    ap.add_argument("--evals", type=int, default=100_000)
    ap.add_argument("--restarts", type=int, default=4)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--unary", type=int, default=1)
    ap.add_argument("--binary", type=int, default=1)
    ap.add_argument("--sim-opt", action="append", default=[])
    ap.add_argument("--loss", action="append", default=[], metavar="KEY=VALUE",
                    help="a loss setting for groundsym learn (repeatable), e.g. reg_weight=0.5")
    ap.add_argument("--search", action="append", default=[], metavar="KEY=VALUE",
                    help="a search setting for groundsym learn (repeatable), e.g. looks=subset")
    ap.add_argument("--want", nargs="+", default=["inhand", "on|above"],
                    help="relations every run should ground ('a|b': either); counted per seed")
    ap.add_argument("--good", type=float, default=0.8, help="F1 at which a symbol grounds a relation")
    args = ap.parse_args()
    data = args.data or args.out / "data"
    data.mkdir(parents=True, exist_ok=True)
    test = data / "test.json"
    collect(test, args.test_traces, 200, args.sim_opt)
    rows = []
    for seed in args.seeds:
        train = data / f"train_{seed}.json"
        collect(train, args.train_traces, 100 + seed, args.sim_opt)
        model = args.out / f"model_{seed}"
        cmd = ["learn", str(train), "-o", str(model), "--unary", str(args.unary), "--binary", str(args.binary),
               "--evals", str(args.evals), "--restarts", str(args.restarts), "--seed", str(seed), "--quiet"]
        if args.workers:
            cmd += ["--workers", str(args.workers)]
        cmd += [x for kv in args.loss for x in ("--loss", kv)]
        cmd += [x for kv in args.search for x in ("--search", kv)]
        if not learned_already(model, train, seed, args):
            sh(cmd)
        doc = json.loads(sh(["show", str(model), "--against", str(test), "--json"], quiet=True))
        loss = json.loads((model / "symbols.json").read_text())["loss"]["total"]
        words = sh(["show", str(model)], quiet=True).strip().splitlines()
        rows.append({"seed": seed, "loss": loss, "symbols": doc["symbols"], "words": words})
        for m in doc["symbols"]:
            print(f"seed {seed}: {m['symbol']} ~ {m['best_match']} ({m['argument_order']}) F1 {m['f1']:.3f}",
                  file=sys.stderr)
    report = {"evals": args.evals, "restarts": args.restarts, "loss": args.loss, "search": args.search,
              "unary": args.unary, "binary": args.binary,
              "sim_opt": args.sim_opt, "train_traces": args.train_traces, "test_traces": args.test_traces,
              "runs": rows}
    lines = ["| seed | loss | symbol | best match | order | precision | recall | F1 | negation ~ | F1 |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        for m in r["symbols"]:
            neg = m.get("negation_match")
            lines.append(f"| {r['seed']} | {r['loss']:.1f} | {m['symbol']} | {m['best_match']} | {m['argument_order']} "
                         f"| {m['precision']:.3f} | {m['recall']:.3f} | {m['f1']:.3f} "
                         f"| {neg or ''} | {'' if neg is None else format(m['negation_f1'], '.3f')} |")
    lines += ["", summary(rows, args.want, args.good)]
    report["summary"] = lines[-1]
    atomic_write_json(args.out / "report.json", report)
    text = "\n".join(lines) + "\n"
    atomic_write_text(args.out / "report.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
