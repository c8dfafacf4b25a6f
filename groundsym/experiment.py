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
(``results/runs/``, ``results/models/``), atomically, as each unit finishes, so units can run on
other machines (``groundsym.executors``) and an interrupted evaluation resumes from those files.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from .errors import UserError
from .fileio import atomic_write_bytes, atomic_write_json, atomic_write_text, read_json
from .grounding import grounded
from .sim import cell_identity
from .progress import Progress

RESULTS_SCHEMA = "groundsym.results/1"
UNIT_SCHEMA = "groundsym.evaluation-unit/1"


@dataclass(frozen=True)
class EvalConfig:
    """Everything that decides the numbers (not ``runs``, which only says how many, nor ``workers``)."""

    sim: str
    methods: tuple[str, ...]
    symbol_data: tuple[int, ...]
    model_traces: tuple[int, ...]
    seed: int = 0
    evals: int = 100_000
    steps: int | None = None
    starts: int = 3
    unary: int = 1
    binary: int = 1
    restarts: int = 4
    trace_length: int = 10
    sim_options: Mapping[str, str] = field(default_factory=dict)
    planner_options: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    truth_symbols: tuple[str, ...] = ()

    def key(self) -> dict[str, Any]:
        """The options, plus the annealer's and the loss's settings that they imply (so results from
        code with other search or loss defaults are never mixed into one evaluation)."""
        from .loss import LossConfig

        d = asdict(self)
        d["sim_options"] = dict(sorted(self.sim_options.items()))
        d["sim_cell"] = cell_identity(self.sim, self.sim_options)   # defaults and cell version too
        d["planner_options"] = {k: dict(sorted(v.items())) for k, v in sorted(self.planner_options.items())}
        learned = not self.truth_symbols
        d["anneal"] = self.anneal_config().to_doc() if learned else None
        d["loss"] = LossConfig().to_doc() if learned else None
        return d

    def anneal_config(self):
        """The symbol search of every unit; settings it cannot take are a user error."""
        from .anneal import AnnealConfig

        try:
            return AnnealConfig(n_unary=self.unary, n_binary=self.binary, evals=self.evals, restarts=self.restarts)
        except ValueError as exc:
            raise UserError(f"--unary/--binary/--evals/--restarts: {exc}") from None

    def fingerprint(self) -> str:
        return hashlib.sha256(json.dumps(self.key(), sort_keys=True).encode()).hexdigest()[:16]


# ----------------------------------------------------------------------------- symbols

@dataclass(frozen=True)
class TruthSymbols:
    """The simulator's ground-truth relations as the abstraction (an oracle, for diagnosis only:
    it separates planning from symbol learning)."""

    names: tuple[str, ...]
    arities: Mapping[str, int]

    @property
    def predicates(self) -> dict[str, int]:
        return {p: self.arities[p] for p in self.names}

    def abstract_scene(self, scene: Any) -> frozenset:
        return frozenset(a for a in scene.truth if a.predicate in self.names)

    def to_symbolic_dataset(self, ds: Any) -> Any:
        from .symbolic_traces import SymbolicDataset, SymbolicTrace

        traces = []
        for tr in ds.traces:
            states = [self.abstract_scene(s) for s in tr.scenes]
            rewards = [float(s.reward) for s in tr.scenes]
            traces.append(SymbolicTrace(tr.objects, states, list(tr.actions), rewards[:-1], rewards[-1]))
        return SymbolicDataset(traces, self.predicates, dict(ds.primitives), {"truth_symbols": list(self.names)})


def learn_symbols(ds: Any, cfg: EvalConfig, seed: int, sim: Any) -> tuple[Any, dict[str, Any]]:
    """Symbols for one unit: learned by annealing on ``ds`` (or the truth oracle), and a report."""
    if cfg.truth_symbols:
        unknown = [p for p in cfg.truth_symbols if p not in sim.truth_predicates]
        if unknown:
            raise UserError(f"--truth-symbols: {', '.join(unknown)} not among the sim's relations "
                            f"({', '.join(sorted(sim.truth_predicates))})")
        return TruthSymbols(tuple(cfg.truth_symbols), dict(sim.truth_predicates)), {"symbols": "truth"}
    from .anneal import anneal
    from .loss import LossConfig, prepare
    from .symbols import SymbolSet

    loss_cfg = LossConfig()
    data = prepare(ds, loss_cfg, "symbol data")
    result = anneal(data, loss_cfg, cfg.anneal_config(), seed, workers=1)
    symbols = SymbolSet.for_dataset(result.symbols, ds)
    return symbols, {"symbols": "learned", "loss": result.terms.to_doc(), "evaluations": result.evaluations,
                     "pruned": len(result.pruned)}


def grounding_f1(symbols: Any, ds: Any) -> dict[str, Any]:
    """How each learned symbol matches the sim's truth on ``ds`` (held-out model data; best relation,
    either argument order): the check that the annealing budget was enough."""
    from .grounding import match_symbols

    if not getattr(symbols, "symbols", ()):
        return {"grounding": []}
    return {"grounding": [m.to_doc() for m in match_symbols(symbols, ds)]}


# ----------------------------------------------------------------------------- one unit

_SIM_CACHE: dict[str, Any] = {}


def _sim(cfg: EvalConfig) -> Any:
    """One simulation per worker process, reused by all its units (pybullet setup is slow)."""
    from .registry import make_sim

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
    return {"symbol_data": s[0], "anneal": s[1],
            "model_data": dict(zip(cfg.model_traces, s[2::2])), "planners": dict(zip(cfg.model_traces, s[3::2]))}


def model_name(n_symbol: int, n_model: int, run: int) -> str:
    return f"model-N{n_symbol}-n{n_model}-run{run:03d}"


def run_unit(cfg: EvalConfig, n_symbol: int, run: int) -> dict[str, Any]:
    """Learn symbols on N transitions, then models and episodes for every model-trace count.

    Returns ``{"unit": record, "models": {folder: {file: text}}}``, values only: the unit may run
    on another machine, so its models are learned in a private scratch folder (removed at once)
    and handed back to the driver, which writes them (:func:`save_unit`)."""
    with tempfile.TemporaryDirectory(prefix="groundsym-unit-") as scratch:
        return _run_unit(cfg, n_symbol, run, Path(scratch))


def _run_unit(cfg: EvalConfig, n_symbol: int, run: int, scratch: Path) -> dict[str, Any]:
    from .collect import collect_traces
    from .episode import SimEnv, run_episode
    from .modeldir import learn_symbolic_model, load_model
    from .planner import PlanningModel, make_planner

    t0 = time.monotonic()
    models: dict[str, dict[str, str]] = {}
    sim = _sim(cfg)
    seeds = unit_seeds(cfg, n_symbol, run)
    n_traces = max(1, math.ceil(n_symbol / cfg.trace_length))
    sym_data = None if cfg.truth_symbols else \
        collect_traces(sim, n_traces, cfg.trace_length, seeds["symbol_data"], progress=False)
    symbols, report = learn_symbols(sym_data, cfg, seeds["anneal"], sim)
    steps = cfg.steps or int(sim.episode_length)
    starts = start_seeds(cfg, run)
    entries = []
    for n in cfg.model_traces:
        mdata = collect_traces(sim, n, cfg.trace_length, seeds["model_data"][n], progress=False)
        if not cfg.truth_symbols and "grounding" not in report:
            report.update(grounding_f1(symbols, mdata))
        sds = symbols.to_symbolic_dataset(mdata)
        mdir = scratch / model_name(n_symbol, n, run)
        learn_symbolic_model(sds, mdir, seed=seeds["planners"][n], argv=[], progress=False)
        m = load_model(mdir)
        models[mdir.name] = {f.name: f.read_text() for f in sorted(mdir.iterdir()) if f.is_file()}
        pm = PlanningModel(dict(sim.primitives), predicates=dict(symbols.predicates), symbols=symbols,
                           rules=m.rules, reward=m.reward, traces=mdata, symbolic_traces=sds, gamma=float(sim.gamma))
        pseeds = np.random.SeedSequence(seeds["planners"][n]).generate_state(len(cfg.methods) * len(starts))
        for i, method in enumerate(cfg.methods):
            values = []
            for k, start in enumerate(starts):
                planner = make_planner(method, pm, cfg.planner_options.get(method, {}),
                                       int(pseeds[i * len(starts) + k]))
                values.append(run_episode(SimEnv(sim, symbols), planner, steps, start, method).value)
            entries.append({"model_traces": n, "method": method, "values": values, "mean": float(np.mean(values))})
    unit = {"schema": UNIT_SCHEMA, "config": cfg.fingerprint(), "symbol_data": n_symbol, "run": run,
            "entries": entries, "report": report, "seconds": time.monotonic() - t0}
    return {"unit": unit, "models": models}


# ----------------------------------------------------------------------------- the whole evaluation

def unit_path(out: Path, n_symbol: int, run: int) -> Path:
    return out / "runs" / f"N{n_symbol}-run{run:03d}.json"


def validate(cfg: EvalConfig) -> None:
    """Every option a unit will use, checked before the results folder is touched: a refused
    command must leave no config.json behind that would then refuse the corrected one."""
    from .options import parse_options
    from .registry import get_planner_class, get_sim_class

    sim_cls = get_sim_class(cfg.sim)
    parse_options("--sim-opt", "sim", cfg.sim, sim_cls.OPTIONS, dict(cfg.sim_options))
    truth = dict(getattr(sim_cls, "truth_predicates", {}) or {})
    unknown = [p for p in cfg.truth_symbols if p not in truth]
    if unknown:
        raise UserError(f"--truth-symbols: {', '.join(unknown)} not among the sim's relations "
                        f"({', '.join(sorted(truth))})")
    for method in cfg.methods:
        given = dict(cfg.planner_options.get(method, {}))
        parse_options("--planner-opt", "planner", method, getattr(get_planner_class(method), "OPTIONS", ()), given)
    for method in cfg.planner_options:
        if method not in cfg.methods:
            raise UserError(f"--planner-opt {method}:...: {method} is not among --methods")
    if not cfg.truth_symbols:
        cfg.anneal_config()


def check_config(out: Path, cfg: EvalConfig) -> None:
    """Resume only an evaluation with the same options; never mix two. The executor is not an
    option here: a folder started on one executor resumes on any other."""
    validate(cfg)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a directory")
    path = out / "config.json"
    if path.exists():
        old = read_json(path)
        if old.get("fingerprint") != cfg.fingerprint():
            raise UserError(f"{path}: {out} holds an evaluation with other options; "
                            f"resume it with the same options or choose another -o")
    else:
        atomic_write_json(path, {"fingerprint": cfg.fingerprint(), "config": cfg.key()})


_check_config = check_config


def evaluate(cfg: EvalConfig, runs: int, out: str | Path, workers: int = 1, progress: bool = True,
             optimum: float | None = None, provenance: Mapping[str, Any] | None = None,
             executor: Any = None) -> dict[str, Any]:
    """Run (or resume) every unit, then write results.json, results.md and results.png.

    Units run on ``executor`` (``groundsym.executors``; default: ``workers`` local processes) and
    come back as values; this process writes each one as it finishes."""
    from .executors import ProcessExecutor

    out = Path(out)
    check_config(out, cfg)
    todo = [(N, r) for r in range(runs) for N in cfg.symbol_data if not unit_path(out, N, r).exists()]
    total = runs * len(cfg.symbol_data)
    executor = executor or ProcessExecutor(workers)
    if todo and not cfg.truth_symbols and not (isinstance(executor, ProcessExecutor) and executor.workers <= 1):
        warm_up_kernels()     # fill numba's disk cache once here: this machine's workers load it, none compiles
    bar = Progress(len(todo), "evaluate", enabled=progress)    # the ETA counts this call's units only
    done = total - len(todo)
    bar.update(0, f"{done} of {total} unit(s) resumed from {out / 'runs'}; running on {executor.description}",
               force=True)
    for k, result in enumerate(executor.as_completed(run_unit, [(cfg, N, r) for N, r in todo]), 1):
        save_unit(out, result)
        done += 1
        bar.update(k, f"{done}/{total} units done | {_status(out, cfg, runs)}", force=True)   # a line per unit
    bar.close()
    results = aggregate(out, cfg, runs, optimum, provenance)
    write_outputs(out, results)
    return results


def warm_up_kernels() -> None:
    from . import compiled

    if compiled.AVAILABLE:
        compiled.warm_up()


def save_unit(out: Path, result: Mapping[str, Any]) -> None:
    """Write a finished unit's models, then its record (whose presence means the unit is done)."""
    for folder, files in result["models"].items():
        for name, text in files.items():
            atomic_write_text(out / "models" / folder / name, text)
    unit = result["unit"]
    atomic_write_json(unit_path(out, unit["symbol_data"], unit["run"]), unit)


def _units(out: Path, cfg: EvalConfig, runs: int) -> list[dict[str, Any]]:
    units = []
    for r in range(runs):
        for N in cfg.symbol_data:
            p = unit_path(out, N, r)
            if p.exists():
                units.append(check_unit(read_json(p), p, cfg, N, r))
    return units


def check_unit(u: Any, path: Path, cfg: EvalConfig, n_symbol: int, run: int) -> dict[str, Any]:
    """A finished unit's record as ``aggregate`` reads it; a damaged one is one line naming the field."""
    def fail(field: str, msg: str) -> UserError:
        return UserError(f"{path}: {field}: {msg}")

    def number(v: Any) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)

    if not isinstance(u, dict):
        raise fail("document", "expected a JSON object")
    if u.get("config") != cfg.fingerprint():
        raise fail("config", "from an evaluation with other options")
    for key, want in (("symbol_data", n_symbol), ("run", run)):
        if u.get(key) != want or isinstance(u.get(key), bool):
            raise fail(key, f"expected {want} (the file's name), got {u.get(key)!r}")
    entries = u.get("entries")
    if not isinstance(entries, list):
        raise fail("entries", "expected a list")
    for i, e in enumerate(entries):
        if not (isinstance(e, dict) and isinstance(e.get("method"), str) and number(e.get("mean"))
                and isinstance(e.get("model_traces"), int) and not isinstance(e.get("model_traces"), bool)):
            raise fail(f"entries[{i}]", "expected method (text), model_traces (whole number) and mean (a number)")
    report = u.get("report", {})
    grounding = report.get("grounding") if isinstance(report, dict) else None
    if not isinstance(report, dict) or not isinstance(grounding, (list, type(None))):
        raise fail("report", "expected an object with an optional grounding list")
    for i, g in enumerate(grounding or []):
        ok = isinstance(g, dict) and all(isinstance(g.get(k), (str, type(None))) for k in
                                         ("best_match", "negation_match")) \
            and all(g.get(k) is None or number(g.get(k)) for k in ("f1", "negation_f1"))
        if not ok:
            raise fail(f"report.grounding[{i}]", "expected best_match/negation_match names and f1 numbers")
    return u


def _status(out: Path, cfg: EvalConfig, runs: int) -> str:
    rows = aggregate(out, cfg, runs, None, None)["methods"]
    return ", ".join(f"{r['method']}@{r['symbol_data']}/{r['model_traces']}: {r['mean']:.3g}" for r in rows[:6])


def aggregate(out: Path, cfg: EvalConfig, runs: int, optimum: float | None,
              provenance: Mapping[str, Any] | None) -> dict[str, Any]:
    """Mean over runs of the per-run means, with the standard error of that mean."""
    per: dict[tuple[int, int, str], list[float]] = {}
    grounding: dict[int, list[Any]] = {}
    for u in _units(out, cfg, runs):
        for e in u["entries"]:
            per.setdefault((u["symbol_data"], e["model_traces"], e["method"]), []).append(float(e["mean"]))
        if u.get("report", {}).get("grounding"):
            grounding.setdefault(u["symbol_data"], []).append(u["report"]["grounding"])
    rows = []
    for N in cfg.symbol_data:
        for n in cfg.model_traces:
            for m in cfg.methods:
                v = np.array(per.get((N, n, m), []))
                if not len(v):
                    continue
                se = float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else float("nan")
                rows.append({"method": m, "symbol_data": N, "model_traces": n, "mean": float(v.mean()),
                             "stderr": se if np.isfinite(se) else None, "n": int(len(v)),
                             "share_of_optimum": float(v.mean() / optimum) if optimum else None})
    meta = {"config": cfg.key(), "runs": runs, "units_done": sum(len(v) for v in per.values()) // max(
        1, len(cfg.methods) * len(cfg.model_traces)), "grounding": _grounding_summary(grounding)}
    if provenance:
        meta["provenance"] = dict(provenance)
    return {"schema": RESULTS_SCHEMA, "methods": rows, "optimum": optimum, "meta": meta}


GOOD_F1 = 0.8   # a relation counts as found in a run when some symbol grounds it with at least this F1
                # (a unary symbol's negation: at least grounding.NEGATION_F1)


def _grounding_summary(grounding: Mapping[int, list[Any]]) -> dict[str, Any]:
    """Per symbol-data size: how many runs learned a symbol whose best match is each relation, and
    its mean F1 over those runs (``u1~inhand``: unary symbol u1 matched ``inhand``); and per
    relation, in how many runs some symbol matched it with F1 >= ``GOOD_F1`` (``found``)."""
    out = {}
    for N, reports in grounding.items():
        f1s: dict[str, list[float]] = {}
        found: dict[str, int] = {}
        for rep in reports:
            got: set[str] = set()
            for r in rep:
                f1s.setdefault(f"{r.get('symbol')}~{r.get('best_match')}", []).append(float(r.get("f1", 0.0)))
                got |= set(grounded(r, GOOD_F1))
                for rel in (r.get("best_match"), r.get("negation_match")):
                    if rel is not None:
                        found.setdefault(rel, 0)
            for rel in got:
                found[rel] += 1
        out[str(N)] = {"runs": len(reports),
                       "matches": {k: {"runs": len(v), "mean_f1": float(np.mean(v))} for k, v in sorted(f1s.items())},
                       "found": dict(sorted(found.items()))}
    return out


def grounding_table(results: Mapping[str, Any]) -> str:
    """Markdown: per symbol-data size, the runs in which each relation was learned (F1 >= GOOD_F1)."""
    summary = results.get("meta", {}).get("grounding") or {}
    if not summary:
        return ""
    rels = sorted({rel for v in summary.values() for rel in v.get("found", {})})
    lines = ["", f"Grounding of the learned symbols on each run's held-out model data: runs in which some "
             f"symbol matches the relation with F1 >= {GOOD_F1}", "",
             "| symbol data | runs | " + " | ".join(rels) + " |", "|---:|---:|" + "---:|" * len(rels)]
    for N in sorted(summary, key=int):
        v = summary[N]
        lines.append(f"| {N} | {v['runs']} | " + " | ".join(str(v.get("found", {}).get(r, 0)) for r in rels) + " |")
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- outputs

def markdown_table(results: Mapping[str, Any]) -> str:
    opt = results.get("optimum")
    lines = [f"Deterministic optimum: {opt:.4g}" if opt else "Deterministic optimum: not known for this sim", "",
             "| symbol data | model traces | method | mean value | stderr | runs | share of optimum |",
             "|---:|---:|---|---:|---:|---:|---:|"]
    for r in results["methods"]:
        se = f"{r['stderr']:.3g}" if r["stderr"] is not None else "-"
        share = f"{100 * r['share_of_optimum']:.1f}%" if r["share_of_optimum"] is not None else "-"
        lines.append(f"| {r['symbol_data']} | {r['model_traces']} | {r['method']} | {r['mean']:.4g} | {se} | "
                     f"{r['n']} | {share} |")
    return "\n".join(lines) + "\n" + grounding_table(results)


def bar_chart(results: Mapping[str, Any]) -> bytes:
    """One panel per model-trace count, bars per method over symbol-data sizes (like Fig. 2)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = results["methods"]
    cfg = results["meta"]["config"]
    methods, Ns, ns = cfg["methods"], cfg["symbol_data"], cfg["model_traces"]
    fig, axes = plt.subplots(1, len(ns), figsize=(4.5 * len(ns), 3.6), squeeze=False, sharey=True)
    width = 0.8 / max(len(methods), 1)
    for ax, n in zip(axes[0], ns):
        for i, m in enumerate(methods):
            got = {r["symbol_data"]: r for r in rows if r["method"] == m and r["model_traces"] == n}
            xs = [j + (i - (len(methods) - 1) / 2) * width for j, N in enumerate(Ns) if N in got]
            ys = [got[N]["mean"] for N in Ns if N in got]
            es = [got[N]["stderr"] or 0.0 for N in Ns if N in got]
            ax.bar(xs, ys, width, yerr=es, capsize=2, label=m)
        if results.get("optimum"):
            ax.axhline(results["optimum"], color="k", ls="--", lw=1, label="optimum")
        ax.set_xticks(range(len(Ns)), [str(N) for N in Ns])
        ax.set_xlabel("data for symbol learning")
        ax.set_title(f"{cfg['sim']}: {n} model trace(s)")
    axes[0][0].set_ylabel("episode value")
    axes[0][-1].legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def write_outputs(out: Path, results: Mapping[str, Any]) -> None:
    atomic_write_json(out / "results.json", results)
    atomic_write_text(out / "results.md", markdown_table(results))
    if results["methods"]:
        atomic_write_bytes(out / "results.png", bar_chart(results))


def optimum_of(sim_name: str, options: Mapping[str, str]) -> float | None:
    """The sim module's ``optimal_episode_value(options)`` if it has one (the tower does)."""
    import importlib

    from .registry import get_sim_class

    mod = importlib.import_module(get_sim_class(sim_name).__module__)
    fn = getattr(mod, "optimal_episode_value", None)
    return float(fn(dict(options))) if fn is not None else None


def parse_list(text: str, flag: str) -> tuple[int, ...]:
    try:
        vals = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise UserError(f"{flag} {text}: expected whole numbers separated by commas") from None
    if not vals or any(v < 1 for v in vals):
        raise UserError(f"{flag} {text}: expected positive whole numbers")
    return vals


def methods_list(text: str, known: Sequence[str]) -> tuple[str, ...]:
    ms = tuple(m.strip() for m in text.split(",") if m.strip())
    for m in ms:
        if m.split(":", 1)[0] not in known:
            raise UserError(f"--methods {m}: unknown planner (available: {', '.join(known)})")
    if not ms:
        raise UserError("--methods: name at least one planner")
    return ms
