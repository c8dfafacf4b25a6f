"""PRADA's settings replayed on a finished `groundsym evaluate` folder's models (docs/planning.md,
"What limits PRADA on the true vocabulary").

A sweep of planner options costs only episodes: each run's rules and reward are read from the
folder's `models/` (written by the evaluation itself), and every setting plays the run's own start
states with the run's own planner seeds, exactly as `groundsym evaluate` would (common random
numbers). So the settings differ only by the planner, and a setting's episodes pair one to one with
the default's; the default setting is replayed too and checked against the folder's recorded values
(a replay that does not reproduce them says so and stops). Each episode is also read for what went
wrong (`tower_prada_diagnosis.step_reading`: failed grasps and releases, repeats), so a setting's
gain can be told apart from luck with physics.

Only folders of `--truth-symbols` evaluations replay here (learned symbols are not kept in the
folder). Episodes are appended to `OUT/episodes.jsonl` as they end, so an interrupted sweep resumes.

    python examples/prada_settings.py FOLDER --out OUT --runs 0-4 \\
        --setting "default=" --setting "samples2000=samples=2000" --setting "h6=horizon=6,samples=2000"
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from groundsym.episode import SimEnv, run_episode  # noqa: E402
from groundsym.errors import UserError  # noqa: E402
from groundsym.evaluation.config import EvalConfig, validate  # noqa: E402
from groundsym.evaluation.protocol import model_name, start_seeds, unit_seeds  # noqa: E402
from groundsym.evaluation.truth import TruthSymbols  # noqa: E402
from groundsym.fileio import atomic_write_json, read_json  # noqa: E402
from groundsym.modeldir import load_model  # noqa: E402
from groundsym.planner import PlanningModel, make_planner  # noqa: E402
from groundsym.registry import make_sim  # noqa: E402
from sims.tower import optimal_episode_value  # noqa: E402
from tower_prada_diagnosis import seed_range, step_reading  # noqa: E402

READ = ("failed_grasps", "failed_releases", "releases", "repeats", "default_rule_steps")


def parse_setting(text: str) -> tuple[str, dict[str, str]]:
    """``label=key=value,key=value`` (``label=`` for the folder's own options) -> (label, options)."""
    label, sep, rest = text.partition("=")
    if not sep or not label:
        raise UserError(f"--setting {text!r}: expected LABEL=KEY=VALUE,... (or LABEL= for the folder's options)")
    opts = {}
    for item in filter(None, rest.split(",")):
        key, sep, value = item.partition("=")
        if not sep:
            raise UserError(f"--setting {text!r}: {item!r} is not KEY=VALUE")
        opts[key] = value
    return label, opts


def folder_config(folder: Path) -> EvalConfig:
    """The evaluation's options as its config.json records them (truth-symbol folders only)."""
    doc = read_json(folder / "config.json")["config"]
    if not doc.get("truth_symbols"):
        raise UserError(f"{folder}/config.json: truth_symbols: empty (only --truth-symbols folders replay)")
    keep = ("sim", "methods", "symbol_data", "model_traces", "seed", "evals", "steps", "starts", "unary",
            "binary", "restarts", "trace_length", "truth_symbols", "rule_data")
    kw = {k: tuple(doc[k]) if isinstance(doc[k], list) else doc[k] for k in keep if k in doc}
    kw["model_data"] = doc.get("model_data", "unit")
    kw["sim_options"] = dict(doc.get("sim_options", {}))
    kw["planner_options"] = {m: dict(o) for m, o in doc.get("planner_options", {}).items()}
    return EvalConfig(**kw)


def replay_run(cfg: EvalConfig, folder: Path, sim, run: int, options: dict[str, str]) -> list[dict]:
    """The run's episodes under ``options`` (merged over the folder's), one record per start state."""
    n_symbol, n = cfg.symbol_data[0], cfg.model_traces[0]
    symbols = TruthSymbols(tuple(cfg.truth_symbols), dict(sim.truth_predicates))
    m = load_model(folder / "models" / model_name(n_symbol, n, run))
    pm = PlanningModel(dict(sim.primitives), predicates=dict(symbols.predicates), symbols=symbols,
                       rules=m.rules, reward=m.reward, gamma=float(sim.gamma))
    method = cfg.methods[0]
    given = {**cfg.planner_options.get(method, {}), **options}
    starts = start_seeds(cfg, run)
    pseeds = np.random.SeedSequence(unit_seeds(cfg, n_symbol, run)["planners"][n]).generate_state(
        len(cfg.methods) * len(starts))
    steps = cfg.steps or int(sim.episode_length)
    out = []
    for k, start in enumerate(starts):
        planner = make_planner(method, pm, given, int(pseeds[k]))
        ep = run_episode(SimEnv(sim, symbols), planner, steps, start, method)
        reading = step_reading(ep, m.rules, tuple(sim.objects))
        out.append({"run": run, "start": k, "value": ep.value, **{key: reading[key] for key in READ},
                    "actions": reading["actions"]})
    return out


def summary(rows: list[dict], optimum: float, reference: list[dict] | None) -> dict:
    """Share of V* (mean over runs +- standard error), per-episode readings, and the paired
    difference to the reference setting (same run and start state)."""
    runs = sorted({r["run"] for r in rows})
    per_run = [np.mean([r["value"] for r in rows if r["run"] == k]) / optimum for k in runs]
    doc = {"runs": len(runs), "episodes": len(rows), "share": float(np.mean(per_run)),
           "stderr": float(np.std(per_run, ddof=1) / np.sqrt(len(runs))) if len(runs) > 1 else 0.0,
           "full_episodes": float(np.mean([r["value"] / optimum >= 0.98 for r in rows])),
           "run_shares": [float(x) for x in per_run]}
    for key in READ:
        doc[key] = float(np.mean([r[key] for r in rows]))
    if reference is not None:
        ref = {(r["run"], r["start"]): r["value"] for r in reference}
        d = [(r["value"] - ref[(r["run"], r["start"])]) / optimum for r in rows if (r["run"], r["start"]) in ref]
        doc["paired_diff"] = float(np.mean(d)) if d else None
        doc["paired_stderr"] = float(np.std(d, ddof=1) / np.sqrt(len(d))) if len(d) > 1 else None
    return doc


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", type=Path, help="a finished `groundsym evaluate --truth-symbols ...` folder")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--runs", default="0-9", help="runs to replay, e.g. 0-4 or 0,3")
    ap.add_argument("--setting", action="append", default=[], help="LABEL=KEY=VALUE,... (repeatable; "
                    "the first is the reference of the paired differences)")
    args = ap.parse_args()
    try:
        cfg = folder_config(args.folder)
        settings = [parse_setting(s) for s in args.setting] or [("default", {})]
        method = cfg.methods[0]
        for label, opts in settings:      # every option checked before the first episode
            validate(EvalConfig(**{**cfg.__dict__, "planner_options": {method: {**cfg.planner_options.get(method, {}), **opts}}}))
        runs = seed_range(args.runs)
        recorded = {r: read_json(args.folder / "runs" / f"N{cfg.symbol_data[0]}-run{r:03d}.json") for r in runs}
    except (UserError, OSError, ValueError, KeyError) as exc:
        print(f"prada_settings: {exc}", file=sys.stderr)
        return 2
    sim = make_sim(cfg.sim, dict(cfg.sim_options))
    optimum = optimal_episode_value({k: v for k, v in cfg.sim_options.items() if k != "noise"})
    args.out.mkdir(parents=True, exist_ok=True)
    log = args.out / "episodes.jsonl"
    done = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    have = {(d["setting"], d["run"]) for d in done}
    total = len(settings) * len(runs)
    for i, (label, opts) in enumerate(settings):
        for j, run in enumerate(runs):
            if (label, run) in have:
                continue
            rows = replay_run(cfg, args.folder, sim, run, opts)
            if not opts:
                want = recorded[run]["entries"][0]["values"]
                if not np.allclose([r["value"] for r in rows], want, rtol=0, atol=1e-12):
                    print(f"{args.folder}: run {run}: the replay does not reproduce the recorded values "
                          f"({[r['value'] for r in rows]} against {want})", file=sys.stderr)
                    return 1
            with log.open("a") as fh:
                for r in rows:
                    fh.write(json.dumps({"setting": label, "options": opts, **r}) + "\n")
            done.extend({"setting": label, "options": opts, **r} for r in rows)
            share = np.mean([r["value"] for r in rows]) / optimum
            print(f"[{i * len(runs) + j + 1}/{total}] {label} run {run}: {share:.1%}", flush=True)
    by = {label: [d for d in done if d["setting"] == label and d["run"] in runs] for label, _ in settings}
    ref = by[settings[0][0]]
    table = {label: {"options": opts, **summary(by[label], optimum, None if label == settings[0][0] else ref)}
             for label, opts in settings}
    atomic_write_json(args.out / "summary.json", {"folder": str(args.folder), "runs": runs, "optimum": optimum,
                                                  "settings": table})
    for label, doc in table.items():
        pd = f"  paired {doc['paired_diff']:+.1%} +- {doc['paired_stderr']:.1%}" if doc.get("paired_diff") is not None else ""
        print(f"{label:24s} {doc['share']:.1%} +- {doc['stderr']:.1%}  failed releases {doc['failed_releases']:.2f}"
              f"  failed grasps {doc['failed_grasps']:.2f}  repeats {doc['repeats']:.2f}{pd}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
