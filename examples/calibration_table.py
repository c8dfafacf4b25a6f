"""Calibration of learned outcome probabilities: ECE and reliability diagrams.

Two settings, each scored on held-out transitions with ``groundsym.rules.calibration`` (what
``groundsym score`` reports):

* ``blocks``: the reference blocks world with inapplicable actions, as docs/rules.md "Little data":
  200 training transitions per seed (10 random walks of 20 steps, a quarter of the steps an
  inapplicable action), 2,000 held-out transitions from seed 99; also the true model.
* ``tower``: the tower cell as docs/planning.md: symbols learned on 160 random transitions (16
  traces of 10, 15,000 loss evaluations, 4 restarts), rules from 9 fresh model traces, held out 30
  traces (300 transitions, seed 999) abstracted with the learned symbols; and the same model traces
  and held-out traces abstracted with the true ``inhand``, ``on`` (and ``big``) instead.

Each run's model and scores are kept in ``--out`` (``runs.jsonl``), so an interrupted run resumes.
The table is the mean ECE over runs (+- standard error) and the ECE of all runs' predictions pooled;
``--out`` gets one pooled reliability diagram per row.

    python examples/calibration_table.py --setting blocks --seeds 1-13 --out results/calib
    python examples/calibration_table.py --setting tower --seeds 1-5 --out results/calib
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from groundsym.cli import main as cli  # noqa: E402
from groundsym.evaluation.truth import TruthSymbols  # noqa: E402
from groundsym.modeldir import learn_symbolic_model, load_model  # noqa: E402
from groundsym.ppddl.parser import load  # noqa: E402
from groundsym.ppddl.simulate import Task, simulate_traces  # noqa: E402
from groundsym.ppddl.to_rules import domain_to_rules  # noqa: E402
from groundsym.rules.calibration import calibration, pooled_calibration, write_reliability_png  # noqa: E402
from groundsym.rules.evaluate import score_ruleset  # noqa: E402
from groundsym.rules.learner import examples_from_dataset, learn_rules, LearnOptions  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402
from tower_prada_diagnosis import seed_range  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BLOCKS = ROOT / "domains" / "reference" / "blocksworld"
TRUTH_ROWS = {"truth inhand,on": ("inhand", "on"), "truth inhand,on,big": ("inhand", "on", "big")}


def row(name: str, seed: int, rs, test) -> dict:
    cal = calibration(rs, test)
    return {"row": name, "seed": seed, "mean_log_likelihood": score_ruleset(rs, test).mean_log_likelihood,
            "rules": len(rs.rules), **cal.to_doc()}


def blocks_pairs(seed: int, options: LearnOptions) -> dict[str, tuple]:
    """Each row's (rules, held-out data) for one seed (recomputed: it takes about a second)."""
    domain, problem = load(BLOCKS / "domain.ppddl", BLOCKS / "p01.ppddl")
    task = Task(domain, problem)
    test = simulate_traces(task, 100, 20, np.random.default_rng(99), inapplicable=0.25)
    train = simulate_traces(task, 10, 20, np.random.default_rng(seed), inapplicable=0.25)
    rs, _ = learn_rules(examples_from_dataset(train), train.predicates, options, seed=seed, progress=False)
    return {"learned rules": (rs, test), "true model": (domain_to_rules(domain), test)}


def run_cli(*argv: str) -> None:
    if cli(list(argv)) != 0:
        raise SystemExit(f"failed: groundsym {' '.join(argv)}")


def collected(path: Path, traces: int, seed: int) -> Path:
    if not path.exists():
        run_cli("collect", "--sim", "tower", "--traces", str(traces), "--length", "10", "--seed", str(seed),
                "-o", str(path), "--quiet")
    return path


def tower_pairs(seed: int, out: Path, evals: int, model_traces: int, all_data: bool = False,
                options: LearnOptions | None = None) -> dict[str, tuple]:
    """One run: symbols on 160 random transitions (kept in ``run{seed}``, whatever the model data),
    rules on ``model_traces`` fresh traces abstracted with them (``all_data``: and on the symbol
    data too), and with the true relations; each row's (rules, held-out data abstracted the same way)."""
    base = out / "tower" / f"run{seed}"
    work = base if model_traces == 9 and not all_data else \
        out / "tower" / f"run{seed}-m{model_traces}{'-all' if all_data else ''}"
    base.mkdir(parents=True, exist_ok=True)
    work.mkdir(parents=True, exist_ok=True)
    held = collected(out / "tower" / "heldout.json", 30, 999)
    collected(base / "symbols.json", 16, 100 + seed)
    mdata = collected((base if model_traces == 9 else work) / "model-data.json", model_traces, 200 + seed if model_traces == 9 else 5000 + 100 * seed + model_traces)
    if not (base / "model" / "rules.json").exists():
        run_cli("learn", str(base / "symbols.json"), "--model-data", str(base / "model-data.json"), "-o",
                str(base / "model"), "--evals", str(evals), "--restarts", "4", "--workers", "1",
                "--seed", str(seed), "--quiet")
    symbols = load_model(base / "model").symbols
    model_ds, held_ds = read_traces(mdata), read_traces(held)
    if all_data:
        model_ds.traces[:0] = read_traces(base / "symbols.json").traces
    rows = {"learned symbols": (symbols, work / "model")}
    rows.update({name: (TruthSymbols(names, {"inhand": 1, "on": 2, "big": 1}),
                        work / name.replace(" ", "-").replace(",", "-")) for name, names in TRUTH_ROWS.items()})
    out_pairs = {}
    for name, (sym, mdir) in rows.items():
        if options is not None:       # another learner configuration: rules in memory, no model directory
            sds = sym.to_symbolic_dataset(model_ds)
            rs, _ = learn_rules(examples_from_dataset(sds), sds.predicates, options, seed=seed, progress=False)
            out_pairs[name] = (rs, sym.to_symbolic_dataset(held_ds))
            continue
        if not (mdir / "rules.json").exists():
            learn_symbolic_model(sym.to_symbolic_dataset(model_ds), mdir, seed=seed, argv=["groundsym", "learn"],
                                 progress=False, mode="nid")
        out_pairs[name] = (load_model(mdir).rules, sym.to_symbolic_dataset(held_ds))
    return out_pairs


def summarise(pairs: dict[str, list], rows: list[dict], setting: str, out: Path) -> None:
    print(f"| {setting}: row | runs | ECE mean +- se | its floor (mean) | pooled ECE (floor) | "
          f"noise predicted / unexplained | default-covered share | held-out log-lik |")
    print("|---|---|---|---|---|---|---|---|")
    for name, mine_pairs in pairs.items():
        mine = [r for r in rows if r["row"] == name and r["predictions"] > 0]
        skipped = sum(1 for r in rows if r["row"] == name and r["predictions"] == 0)
        if skipped:     # a run whose rules predict nothing (a failed symbol search) has no ECE, not an ECE of 0
            print(f"({name}: {skipped} run(s) without outcome predictions left out)")
        if not mine:
            continue
        e = np.array([r["ece"] for r in mine])
        se = e.std(ddof=1) / np.sqrt(len(e)) if len(e) > 1 else 0.0
        cal = pooled_calibration(mine_pairs)
        share = cal.default_covered / max(cal.covered + cal.default_covered, 1)
        ll = np.mean([r["mean_log_likelihood"] for r in mine])
        floor = np.mean([r["floor"] for r in mine])
        print(f"| {name} | {len(mine)} | {e.mean():.4f} +- {se:.4f} | {floor:.4f} | {cal.ece:.4f} ({cal.floor:.4f}) | "
              f"{cal.noise_predicted:.3f} / {cal.noise_observed:.3f} | {share:.3f} | {ll:.4f} |")
        write_reliability_png(out / f"reliability-{setting}-{name.replace(' ', '-').replace(',', '-')}.png", cal,
                              f"{setting}: {name}, {len(mine)} runs pooled")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--setting", choices=("blocks", "tower"), required=True)
    ap.add_argument("--seeds", default="1-13")
    ap.add_argument("--evals", type=int, default=15_000, help="tower: loss evaluations per symbol search")
    ap.add_argument("--learn-opt", default="", help="rule learner options KEY=VALUE,... (LearnOptions fields)")
    ap.add_argument("--model-traces", type=int, default=9, help="tower: traces of 10 primitives for the rules")
    ap.add_argument("--rules-on-all", action="store_true",
                    help="tower: learn the rules on the symbol data and the model traces together")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    tag = args.setting + (f"-{args.learn_opt}" if args.learn_opt else "") + \
        (f"-m{args.model_traces}" if args.setting == "tower" and args.model_traces != 9 else "") + \
        ("-all" if args.setting == "tower" and args.rules_on_all else "")
    log = args.out / f"runs-{tag}.jsonl"
    done = [json.loads(x) for x in log.read_text().splitlines()] if log.exists() else []
    seen = {r["seed"] for r in done}
    opts = LearnOptions(**{k: type(getattr(LearnOptions(), k))(v) for k, v in
                           (kv.split("=") for kv in args.learn_opt.split(",") if kv)})
    pairs: dict[str, list] = {}
    for s in seed_range(args.seeds):
        got = blocks_pairs(s, opts) if args.setting == "blocks" else \
            tower_pairs(s, args.out, args.evals, args.model_traces, args.rules_on_all,
                        opts if args.learn_opt else None)
        for name, pair in got.items():
            pairs.setdefault(name, []).append(pair)
        if s in seen:
            continue
        rows = [row(name, s, rs, test) for name, (rs, test) in got.items()]
        with log.open("a") as f:
            f.writelines(json.dumps(r) + "\n" for r in rows)
        done.extend(rows)
        print(f"seed {s}: " + ", ".join(f"{r['row']} ECE {r['ece']:.4f} (floor {r['floor']:.4f})" for r in rows),
              file=sys.stderr, flush=True)
    summarise(pairs, [r for r in done if r["seed"] in set(seed_range(args.seeds))], tag, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
