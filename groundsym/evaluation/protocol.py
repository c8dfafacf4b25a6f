"""The paper's evaluation protocol (Section VI-B), behind ``groundsym evaluate``.

One *unit* is one run at one symbol-data size N. It collects N random transitions (traces of
10 primitives) and learns symbols on them; then, for every model-trace count n, it collects n
fresh random traces, abstracts them with those symbols, learns NID rules and the reward model,
and runs every method from K start states (all objects on the table) for T primitives, recording
each episode's value ``sum_t gamma^(t-1) r_t``. A method's figure for the run is the mean over its
K episodes; the table reports the mean over runs with its standard error.

Seeds come from ``numpy.random.SeedSequence(seed, spawn_key=...)`` per unit and per run, never
from a shared stream, so a unit's result does not depend on which worker runs it or on what ran
before: the same seed gives the same table for any number of workers. Start states depend on the
run only, so every method and setting of a run starts from the same K scenes (common random
numbers). A unit returns its record and its models as values; the driver alone writes them
(``results/runs/``, ``results/models/``, :mod:`groundsym.evaluation.store`), atomically, as each
unit finishes, so units can run on other machines (``groundsym.executors``) and an interrupted
evaluation resumes from those files.

With ``model_data="run"`` (``--model-data-scope run``) the job is a whole run instead: its sizes share
the run's model traces, and the methods that read no symbols play once per run and model-trace
count (:func:`run_run`); the symbols are those of the per-unit protocol, bit for bit.
"""

from __future__ import annotations

import importlib
import json
import math
import tempfile
import time
from contextlib import closing
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .. import compiled
from ..anneal import anneal
from ..collect import collect_traces
from ..episode import SimEnv, run_episode
from ..executors import ProcessExecutor, RayExecutor
from ..figures import bar_chart
from ..fileio import atomic_write_bytes, atomic_write_json, atomic_write_text
from ..grounding import match_symbols
from ..loss import prepare
from ..modeldir import learn_symbolic_model, load_model
from ..planner import PlanningModel, make_planner
from ..progress import Progress
from ..registry import get_planner_class, get_sim_class, make_sim
from ..symbols import SymbolSet
from .config import EvalConfig, check_truth_symbols
from .results import aggregate
from .store import UNIT_SCHEMA, check_config, save_unit, unit_path
from .tables import markdown_table
from .truth import TruthSymbols

# ----------------------------------------------------------------------------- symbols


def learn_symbols(ds: Any, cfg: EvalConfig, seed: int, sim: Any) -> tuple[Any, dict[str, Any]]:
    """Symbols for one unit: learned by annealing on ``ds`` (or the truth oracle), and a report."""
    if cfg.truth_symbols:
        check_truth_symbols(cfg.truth_symbols, sim.truth_predicates)
        return TruthSymbols(tuple(cfg.truth_symbols), dict(sim.truth_predicates)), {"symbols": "truth"}
    loss_cfg = cfg.loss
    data = prepare(ds, loss_cfg, "symbol data")
    result = anneal(data, loss_cfg, cfg.anneal_config(), seed, workers=1)
    symbols = SymbolSet.for_dataset(result.symbols, ds)
    return symbols, {"symbols": "learned", "loss": result.terms.to_doc(), "evaluations": result.evaluations,
                     "pruned": len(result.pruned)}


def grounding_f1(symbols: Any, ds: Any) -> dict[str, Any]:
    """How each learned symbol matches the sim's truth on ``ds`` (held-out model data; best relation,
    either argument order): the check that the annealing budget was enough."""
    if not getattr(symbols, "symbols", ()):
        return {"grounding": []}
    return {"grounding": [m.to_doc() for m in match_symbols(symbols, ds)]}


# ----------------------------------------------------------------------------- one unit

_SIM_CACHE: dict[str, Any] = {}


def _sim(cfg: EvalConfig) -> Any:
    """One simulation per worker process, reused by all its units (pybullet setup is slow)."""
    key = json.dumps([cfg.sim, dict(cfg.sim_options)], sort_keys=True)
    if key not in _SIM_CACHE:
        _SIM_CACHE[key] = make_sim(cfg.sim, dict(cfg.sim_options))
    return _SIM_CACHE[key]


def start_seeds(cfg: EvalConfig, run: int) -> list[int]:
    """The K start states of a run: the same for every method and setting of that run."""
    return [int(x) for x in np.random.SeedSequence(cfg.seed, spawn_key=(0, run)).generate_state(cfg.starts)]


def unit_seeds(cfg: EvalConfig, n_symbol: int, run: int) -> dict[str, Any]:
    ss = np.random.SeedSequence(cfg.seed, spawn_key=(1, n_symbol, run))
    s = [int(x) for x in ss.generate_state(2 + 2 * len(cfg.model_traces))]
    seeds = {"symbol_data": s[0], "anneal": s[1],
             "model_data": dict(zip(cfg.model_traces, s[2::2])), "planners": dict(zip(cfg.model_traces, s[3::2]))}
    if cfg.model_data == "run":          # the symbols' seeds stay the unit's; the model's become the run's
        seeds.update(run_model_seeds(cfg, run))
    return seeds


def run_model_seeds(cfg: EvalConfig, run: int) -> dict[str, dict[int, int]]:
    """With ``model_data="run"``: the model traces' and the planners' seeds of a run, per model-trace
    count, the same for every symbol-data size of the run (common random numbers across sizes)."""
    s = [int(x) for x in np.random.SeedSequence(cfg.seed, spawn_key=(2, run)).generate_state(2 * len(cfg.model_traces))]
    return {"model_data": dict(zip(cfg.model_traces, s[0::2])), "planners": dict(zip(cfg.model_traces, s[1::2]))}


def symbol_free(cfg: EvalConfig, method: str) -> bool:
    """Does ``method`` play the same episodes whatever a run's symbols (it reads the continuous model
    traces at most), so that with per-run model data its episodes can be shared by the run's sizes?
    Not with ``rule_data="all"``: its traces then include the size's own symbol data."""
    needs = frozenset(getattr(get_planner_class(method), "NEEDS", frozenset()))
    return cfg.model_data == "run" and cfg.rule_data == "model" and needs <= {"traces"}


def model_name(n_symbol: int, n_model: int, run: int) -> str:
    return f"model-N{n_symbol}-n{n_model}-run{run:03d}"


@dataclass(frozen=True)
class SharedModelData:
    """What a run's symbol-data sizes share with ``model_data="run"``: the model traces per count,
    and the finished entries of the symbol-free methods per (count, method)."""

    traces: Mapping[int, Any]
    entries: Mapping[tuple[int, str], dict[str, Any]]


def run_unit(cfg: EvalConfig, n_symbol: int, run: int) -> dict[str, Any]:
    """Learn symbols on N transitions, then models and episodes for every model-trace count.

    Returns ``{"unit": record, "models": {folder: {file: text}}}``, values only: the unit may run
    on another machine, so its models are learned in a private scratch folder (removed at once)
    and handed back to the driver, which writes them (:func:`groundsym.evaluation.store.save_unit`)."""
    with tempfile.TemporaryDirectory(prefix="groundsym-unit-") as scratch:
        return _run_unit(cfg, n_symbol, run, Path(scratch))


def run_run(cfg: EvalConfig, run: int) -> dict[str, Any]:
    """With ``model_data="run"``, one job per run: its model traces collected once, the symbol-free
    methods played once per count, then every symbol-data size as :func:`run_unit` would, reusing
    both. Returns ``{"units": [record per size], "models": {...}}``; the shared part's time is
    counted in the first size's record."""
    t0, c0 = time.monotonic(), time.process_time()
    sim = _sim(cfg)
    seeds = run_model_seeds(cfg, run)
    traces = {n: collect_traces(sim, n, cfg.trace_length, seeds["model_data"][n], progress=False)
              for n in cfg.model_traces}
    entries = {}
    for n in cfg.model_traces:
        pm = PlanningModel(dict(sim.primitives), traces=traces[n], gamma=float(sim.gamma))
        for method in cfg.methods:
            if symbol_free(cfg, method):
                entries[(n, method)] = _entry(cfg, sim, None, pm, n, method, seeds["planners"][n], run)
    shared = SharedModelData(traces, entries)
    shared_wall, shared_cpu = time.monotonic() - t0, time.process_time() - c0
    units, models = [], {}
    with tempfile.TemporaryDirectory(prefix="groundsym-unit-") as scratch:
        for k, n_symbol in enumerate(cfg.symbol_data):
            result = _run_unit(cfg, n_symbol, run, Path(scratch), shared)
            if k == 0:      # the run's shared part, also on its own: what sharing saves the other sizes
                result["unit"]["seconds"] += shared_wall
                result["unit"]["cpu_seconds"] += shared_cpu
                result["unit"]["shared_cpu_seconds"] = shared_cpu
            units.append(result["unit"])
            models.update(result["models"])
    return {"units": units, "models": models}


def _entry(cfg: EvalConfig, sim: Any, symbols: Any, pm: PlanningModel, n: int, method: str, planner_seed: int,
           run: int) -> dict[str, Any]:
    """One method's episodes from the run's start states, with its planner seeds."""
    starts = start_seeds(cfg, run)
    steps = cfg.steps or int(sim.episode_length)
    i = cfg.methods.index(method)
    pseeds = np.random.SeedSequence(planner_seed).generate_state(len(cfg.methods) * len(starts))
    values = []
    for k, start in enumerate(starts):
        planner = make_planner(method, pm, cfg.planner_options.get(method, {}), int(pseeds[i * len(starts) + k]))
        values.append(run_episode(SimEnv(sim, symbols), planner, steps, start, method).value)
    return {"model_traces": n, "method": method, "values": values, "mean": float(np.mean(values))}


def _run_unit(cfg: EvalConfig, n_symbol: int, run: int, scratch: Path,
              shared: SharedModelData | None = None) -> dict[str, Any]:
    t0, c0 = time.monotonic(), time.process_time()
    models: dict[str, dict[str, str]] = {}
    sim = _sim(cfg)
    seeds = unit_seeds(cfg, n_symbol, run)
    n_traces = max(1, math.ceil(n_symbol / cfg.trace_length))
    sym_data = None if cfg.truth_symbols and cfg.rule_data == "model" else \
        collect_traces(sim, n_traces, cfg.trace_length, seeds["symbol_data"], progress=False)
    symbols, report = learn_symbols(sym_data, cfg, seeds["anneal"], sim)
    entries = []
    for n in cfg.model_traces:
        mdata = shared.traces[n] if shared else \
            collect_traces(sim, n, cfg.trace_length, seeds["model_data"][n], progress=False)
        if not cfg.truth_symbols and "grounding" not in report:
            report.update(grounding_f1(symbols, mdata))     # graded on the fresh traces only
        if cfg.rule_data == "all":
            mdata = replace(mdata, traces=sym_data.traces + mdata.traces)
        sds = symbols.to_symbolic_dataset(mdata)
        mdir = scratch / model_name(n_symbol, n, run)
        learn_symbolic_model(sds, mdir, seed=seeds["planners"][n], argv=[], progress=False, mode="nid")
        m = load_model(mdir)
        models[mdir.name] = {f.name: f.read_text() for f in sorted(mdir.iterdir()) if f.is_file()}
        pm = PlanningModel(dict(sim.primitives), predicates=dict(symbols.predicates), symbols=symbols,
                           rules=m.rules, reward=m.reward, traces=mdata, symbolic_traces=sds, gamma=float(sim.gamma))
        for method in cfg.methods:
            played = shared.entries.get((n, method)) if shared else None
            entries.append(dict(played) if played else _entry(cfg, sim, symbols, pm, n, method, seeds["planners"][n], run))
    unit = {"schema": UNIT_SCHEMA, "config": cfg.fingerprint(), "symbol_data": n_symbol, "run": run,
            "entries": entries, "report": report, "seconds": time.monotonic() - t0,
            "cpu_seconds": time.process_time() - c0}
    return {"unit": unit, "models": models}


# ----------------------------------------------------------------------------- the whole evaluation

def evaluate(cfg: EvalConfig, runs: int, out: str | Path, workers: int = 1, progress: bool = True,
             optimum: float | None = None, provenance: Mapping[str, Any] | None = None,
             executor: ProcessExecutor | RayExecutor | None = None) -> dict[str, Any]:
    """Run (or resume) every unit, then write results.json, results.md and results.png.

    Units run on ``executor`` (``groundsym.executors``; default: ``workers`` local processes) and
    come back as values; this process writes each one as it finishes."""
    out = Path(out)
    check_config(out, cfg)
    todo = [(N, r) for r in range(runs) for N in cfg.symbol_data if not unit_path(out, N, r).exists()]
    total = runs * len(cfg.symbol_data)
    if cfg.model_data == "run":       # one job per run with a unit left (a run stopped half-saved runs again)
        fn, jobs = run_run, [(cfg, r) for r in sorted({r for _, r in todo})]
    else:
        fn, jobs = run_unit, [(cfg, N, r) for N, r in todo]
    executor = executor or ProcessExecutor(workers)
    if todo and not cfg.truth_symbols and not executor.in_process:
        warm_up_kernels()     # load numba's kernels once here: forked workers inherit them, and a
                              # Ray worker on this machine finds them in numba's disk cache
    bar = Progress(len(jobs), "evaluate", enabled=progress)    # the ETA counts this call's jobs only
    done = total - len(todo)
    bar.update(0, f"{done} of {total} unit(s) resumed from {out / 'runs'}; running on {executor.description}",
               force=True)
    # closing: an interrupt while a unit is saved stops the units still running at once
    with closing(executor.as_completed(fn, jobs)) as finished:
        for k, result in enumerate(finished, 1):
            save_unit(out, result)
            done = sum(unit_path(out, N, r).exists() for r in range(runs) for N in cfg.symbol_data)
            bar.update(k, f"{done}/{total} units done | {_status(out, cfg, runs)}", force=True)   # a line per job
    bar.close()
    results = aggregate(out, cfg, runs, optimum, provenance)
    write_outputs(out, results)
    return results


def warm_up_kernels() -> None:
    if compiled.AVAILABLE:
        compiled.warm_up()


def _status(out: Path, cfg: EvalConfig, runs: int) -> str:
    rows = aggregate(out, cfg, runs, None, None)["methods"]
    return ", ".join(f"{r['method']}@{r['symbol_data']}/{r['model_traces']}: {r['mean']:.3g}" for r in rows[:6])


def write_outputs(out: Path, results: Mapping[str, Any]) -> None:
    """results.md and results.png, then results.json last: a folder with results.json holds the whole
    evaluation, even when a stop lands between the files (drawing the chart takes a second)."""
    atomic_write_text(out / "results.md", markdown_table(results))
    if results["methods"]:
        atomic_write_bytes(out / "results.png", bar_chart(results))
    atomic_write_json(out / "results.json", results)


def optimum_of(sim_name: str, options: Mapping[str, str]) -> float | None:
    """The sim module's ``optimal_episode_value(options)`` if it has one (the tower does)."""
    mod = importlib.import_module(get_sim_class(sim_name).__module__)
    fn = getattr(mod, "optimal_episode_value", None)
    return float(fn(dict(options))) if fn is not None else None
