"""groundsym against SAM, OffLAM and NOLAM on AMLGym's domains (docs/amlgym.md).

For each domain, training size (the first k learning trajectories) and noise level (each
well-typed ground atom flipped with that probability in every state), every learner gets the same
domain signature and trajectory files; its model is scored with ``amlgym.metrics``: syntactic
precision and recall against the reference domain, predictive power (applicability, effects) on
AMLGym's held-out states, and problem solving with Fast Downward (solved and false-plan ratios).
Learning CPU time is ``time.process_time`` around the learner's call in this process (the
interpreter's start-up and imports excluded); ours includes reading the trajectories.

Resumable: each domain's cells go to ``<results>/<domain>.json`` as they finish, and a cell
already there is not run again. ``--tables`` writes docs/amlgym-table.md and the PNGs from
whatever the results hold. Needs the ``amlgym`` extra (``pip install -e '.[amlgym]'``: it pins
up-fast-downward 0.5.2, so it lives in a venv of its own, not the test venv).

    python benchmarks/amlgym_table.py --domains blocksworld ferry --sizes 1 10 --noise 0 0.01
    python benchmarks/amlgym_table.py --tables
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from amlgym_data import (flip_atoms, problem_objects, read_signature, read_trajectory,  # noqa: E402
                         symbolic_dataset, write_trajectory)

from groundsym.fileio import atomic_write_json, atomic_write_text  # noqa: E402
from groundsym.ppddl.ast import Typed  # noqa: E402
from groundsym.ppddl.determinize import determinize  # noqa: E402
from groundsym.ppddl.operators import operator_domain  # noqa: E402
from groundsym.rules.learner import examples_from_dataset  # noqa: E402
from groundsym.rules.successful import SuccessOptions, learn_from_successes  # noqa: E402

DOMAINS6 = ("blocksworld", "ferry", "grippers", "miconic", "satellite", "spanner")
#: AMLGym's 20 domains (its benchmarks README: the IPC learning tracks' domains); the package also
#: ships domain files without learning trajectories (driverlog, grid, hanoi, zenotravel) and
#: visitall, which its README does not list
DOMAINS20 = ("barman", "blocksworld", "childsnack", "depots", "elevators", "ferry", "floortile", "goldminer",
             "grippers", "matchingbw", "miconic", "nomystery", "npuzzle", "parking", "rovers", "satellite",
             "sokoban", "spanner", "tpp", "transport")
LEARNERS = ("groundsym", "SAM", "OffLAM", "NOLAM")
ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "docs" / "results" / "amlgym"


def learn_groundsym(domain_path: str, traj_paths: list[str], objects: list[dict[str, str]]) -> str:
    """Our learner on AMLGym's input: successful-only rules, one typed operator per action,
    determinised most-likely with the noise outcome dropped."""
    sig = read_signature(domain_path)
    runs = [(*read_trajectory(p), objs) for p, objs in zip(traj_paths, objects)]
    ds = symbolic_dataset(sig, runs)
    types = ds.meta["types"]
    rs, _ = learn_from_successes(examples_from_dataset(ds), ds.predicates, tuple(types),
                                 SuccessOptions(negative=sig.negative_preconditions), seed=0,
                                 constants=tuple(sig.constants))
    signatures = {p: tuple(Typed(f"?a{i + 1}", sig.type_predicate(t) if t != "object" else "object")
                           for i, t in enumerate(ts)) for p, ts in sig.predicates.items()}
    params = {a: tuple(f"?{n}" for n, _ in ps) for a, ps in sig.operators.items()}
    declared = {a: tuple(sig.type_predicate(t) if t != "object" else "object" for _, t in ps)
                for a, ps in sig.operators.items()}      # the signature every learner is given
    dom = operator_domain(rs, ds.predicates, name=sig.name, types=types, noise="drop",
                          signatures=signatures, parameters=params, parameter_types=declared,
                          constants={c: sig.type_predicate(t) for c, t in sig.constants.items()})
    plain, _ = determinize(dom, None, "most-likely")
    text = "\n".join(line for line in str(plain).splitlines() if not line.strip().startswith(";"))
    learned = {a.name for a in plain.actions}
    extra = [_unseen(a, ps, sig) for a, ps in sorted(sig.operators.items()) if a not in learned]
    head, *blocks = text.rstrip()[:-1].split("\n  (:action ")
    blocks = ["  (:action " + b for b in blocks] + extra
    # in the reference's order: AMLGym's domain reader takes an operator's text from the first
    # ":action NAME..." in the file, so where one name prefixes another (childsnack's make_sandwich,
    # make_sandwich_no_gluten) it reads the longer one's body for both, in the reference and the
    # learned file alike; in the same order both are misread the same way (as the baselines' are)
    order = {a: k for k, a in enumerate(sig.operators)}
    blocks.sort(key=lambda b: order.get(b.split()[1], len(order)))
    return "\n".join([head, *blocks]) + ")\n"


def _unseen(name: str, params: tuple[tuple[str, str], ...], sig) -> str:
    """An operator the trajectories never show (or never changing anything): SAM's safe choice,
    every well-typed atom over its parameters as precondition and no change, so no plan uses it.
    Its effect re-adds its first precondition (a no-op where it applies): unified-planning drops
    an empty effect when it writes the domain for Fast Downward, whose translator then rejects
    the action, and no problem of the domain is solved (matchingbw's unseen putdown_pos_neg)."""
    import itertools

    def fits(t: str, want: str) -> bool:
        return want == "object" or want in sig.ancestors(t)
    pre = sorted({f"({p} {' '.join(args)})".replace(" )", ")") for p, ts in sig.predicates.items()
                  for args in itertools.product(*([f"?{n}" for n, t in params if fits(t, w)] for w in ts))})
    typed = " ".join(f"?{n} - {sig.type_predicate(t)}" for n, t in params)
    return (f"  (:action {name}\n    :parameters ({typed})\n    :precondition (and {' '.join(pre)})\n"
            f"    :effect (and {pre[0] if pre else ''}))")


def learn_cell(learner: str, domain_path: str, traj_paths: list[str], objects: list[dict[str, str]],
               noise: float) -> tuple[str, float]:
    """The learned domain text and the learning CPU seconds (in a scratch working directory:
    the AMLGym adapters write ``tmp/`` where they run)."""
    from amlgym.algorithms import get_algorithm
    here = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="amlgym-") as tmp:
        os.chdir(tmp)
        try:
            t0 = time.process_time()
            with contextlib.redirect_stdout(io.StringIO()):
                if learner == "groundsym":
                    text = learn_groundsym(domain_path, traj_paths, objects)
                else:
                    agent = get_algorithm(learner, **({"noise": noise} if learner == "NOLAM" else {}))
                    text = agent.learn(domain_path, traj_paths)
            return text, time.process_time() - t0
        finally:
            os.chdir(here)


class _OverBudget(Exception):
    pass


@contextlib.contextmanager
def cpu_budget(seconds: float):
    """Raise :class:`_OverBudget` in this process once it has used ``seconds`` more CPU (process
    time, as a loaded machine's wall clock would mislead): AMLGym's predictive power grounds every
    type-consistent action and asks unified-planning's simulator about each in every test state,
    which in sokoban (65,000 ground actions, about 54 CPU s per state) takes hours whatever the model."""
    import signal

    def stop(*_):
        raise _OverBudget()
    old = signal.signal(signal.SIGPROF, stop)
    signal.setitimer(signal.ITIMER_PROF, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.signal(signal.SIGPROF, old)


def score(learned: str, domain: str, ref_path: str, n_problems: int, timeout: int, budget: float = 300.0) -> dict:
    """``amlgym.metrics`` of one learned domain (text) against the reference; predictive power
    within ``budget`` CPU seconds (else the cell says so in ``partial`` and has no applicability
    or effect figures)."""
    from amlgym.benchmarks import get_problems_path, get_test_states
    from amlgym.metrics import predictive_power, problem_solving, syntactic_precision, syntactic_recall
    from amlgym.modeling.UPEnv import UPEnv
    with tempfile.TemporaryDirectory(prefix="amlgym-score-") as tmp:
        path = str(Path(tmp) / "learned.pddl")
        Path(path).write_text(learned)
        here = os.getcwd()
        os.chdir(tmp)
        try:
            with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
                warnings.simplefilter("ignore")
                out = {"precision": syntactic_precision(path, ref_path), "recall": syntactic_recall(path, ref_path)}
                states = get_test_states(domain)
                probs = {Path(p).name: p for p in get_problems_path(domain, "predictive_power")}
                keys = sorted(states)[:n_problems]
                try:
                    with cpu_budget(budget):
                        pp = predictive_power([UPEnv(path, probs[k]) for k in keys],
                                              [UPEnv(ref_path, probs[k]) for k in keys],
                                              [states[k] for k in keys], show_progress=False)
                    out["applicability"] = pp["applicability"]
                    out["effects"] = pp["predicted_effects"]
                except _OverBudget:
                    out["partial"] = f"predictive power not scored: over {budget:g} CPU s (the scorer's grounding)"
                out["solving"] = problem_solving(path, ref_path, get_problems_path(domain, "solving")[:n_problems],
                                                 timeout=timeout, show_progress=False)
        except Exception as err:        # a model the metrics cannot read counts as failed, with the reason
            out = {**locals().get("out", {}), "error": f"{type(err).__name__}: {err}"[:300]}
        finally:
            os.chdir(here)
    return _plain(out)


def _plain(x):
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (np.floating, np.integer)):
        return float(x)
    return x


def run_domain(domain: str, sizes: list[int], noises: list[float], learners: list[str], n_problems: int,
               timeout: int, seed: int, redo: frozenset[str] = frozenset(), budget: float = 300.0) -> None:
    """Every cell of ``domain`` not in its results file yet (``redo``: these learners' cells
    again, e.g. after a change to the learner)."""
    from amlgym.benchmarks import get_domain_path, get_problems_path, get_trajectories_path
    ref = get_domain_path(domain)
    out_path = RESULTS / f"{domain}.json"
    results = json.loads(out_path.read_text()) if out_path.exists() else {}
    trajs = get_trajectories_path(domain, "learning")
    problems = {int(Path(p).name.split("_")[0]): p for p in get_problems_path(domain, "learning")}
    sig = read_signature(ref)
    objects = [{**sig.constants, **problem_objects(problems[int(Path(t).name.split("_")[0])])} for t in trajs]
    for noise in noises:
        with tempfile.TemporaryDirectory(prefix="amlgym-noisy-") as tmp:
            paths = []
            rng = np.random.default_rng(seed)
            for k, (t, objs) in enumerate(zip(trajs, objects)):
                states, actions = read_trajectory(t)
                p = Path(tmp) / f"{k}_{domain}_traj"
                write_trajectory(p, flip_atoms(states, sig, objs, noise, rng), actions)
                paths.append(str(p))
            for size in sizes:
                for learner in learners:
                    key = f"{learner}|{size}|{noise:g}"
                    if key in results and learner not in redo:
                        continue
                    print(f"{domain} {key} ...", file=sys.stderr, flush=True)
                    try:
                        text, cpu = learn_cell(learner, ref, paths[:size], objects[:size], noise)
                        cell = {"cpu": cpu, **score(text, domain, ref, n_problems, timeout, budget)}
                    except Exception as err:
                        cell = {"error": f"{type(err).__name__}: {err}"[:300]}
                    results = _store(out_path, key, cell)
                    print(f"{domain} {key}: {_summary(cell)}", file=sys.stderr, flush=True)


def _store(path: Path, key: str, cell: dict) -> dict:
    """Add one cell to a domain's results file, under a lock and re-reading the file first, so
    runs of other learners or settings may write the same file at the same time."""
    import fcntl
    with open(path.with_suffix(".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        results = json.loads(path.read_text()) if path.exists() else {}
        results[key] = cell
        atomic_write_json(path, results)
    return results


def _summary(c: dict) -> str:
    if "precision" not in c:
        return c.get("error", "?")
    s = c.get("solving", {})
    return (f"P {c['precision']['mean']:.2f} R {c['recall']['mean']:.2f} "
            f"app P {c.get('applicability', {}).get('mean_precision', float('nan')):.2f} "
            f"solved {s.get('solving_ratio', float('nan')):.2f} false {s.get('false_plans_ratio', float('nan')):.2f} "
            f"cpu {c.get('cpu', float('nan')):.2f}s" + (f" [{c['error'][:60]}]" if "error" in c else ""))


def write_tables(docs: Path = ROOT / "docs") -> None:
    """docs/amlgym-table.md (one row per domain, size, noise, learner) and PNGs of precision and
    recall against training size, from the results files."""
    rows = ["| domain | trajs | noise | learner | synt. P | synt. R | app. P | app. R | eff. P | eff. R | "
            "solved | false plans | CPU s |", "|" + "---|" * 13]
    data = {}
    for f in sorted(RESULTS.glob("*.json")):
        res = json.loads(f.read_text())
        data[f.stem] = res
        for key in sorted(res, key=lambda k: (float(k.split("|")[2]), int(k.split("|")[1]),
                                              LEARNERS.index(k.split("|")[0]))):
            learner, size, noise = key.split("|")
            c = res[key]

            def g(*path: str) -> str:
                x = c
                for p in path:
                    x = x.get(p, {}) if isinstance(x, dict) else {}
                return f"{x:.2f}" if isinstance(x, (int, float)) else "-"
            rows.append(f"| {f.stem} | {size} | {noise} | {learner}{_stale(c)} | {g('precision', 'mean')} | "
                        f"{g('recall', 'mean')} | {g('applicability', 'mean_precision')} | "
                        f"{g('applicability', 'mean_recall')} | {g('effects', 'mean_precision')} | "
                        f"{g('effects', 'mean_recall')} | {g('solving', 'solving_ratio')} | "
                        f"{g('solving', 'false_plans_ratio')} | {g('cpu')} |")
    head = ["# AMLGym table (generated by benchmarks/amlgym_table.py --tables; see docs/amlgym.md)", "",
            "## At the largest training size", "",
            "Each cell: syntactic precision/recall (mean over operators), applicability precision, solved and",
            "false-plan ratios, learning CPU seconds; `x`: the learner or the scoring failed (the reasons are",
            "below); `(at COMMIT)`: a groundsym cell measured by the learner of that commit and not run",
            "again since (docs/amlgym.md, Measured, says what changed after it).", "", *summary(data), "",
            "## Against the targets", "",
            "At the largest training size: each metric of groundsym against OffLAM's on clean traces and",
            "NOLAM's on noisy ones (`short`: the metrics where groundsym is below, ours/theirs); false plans",
            "(target 0); learning CPU against 2x the reference's or 0.5 s.", "", *targets(data), "",
            "## Why cells failed or were scored in part", "",
            *failures(data), "", "## Every cell", ""]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip() or "unknown"
    tail = ["", "## Measured", "",
            f"Tables written from docs/results/amlgym/*.json at commit {commit} by "
            "`python benchmarks/amlgym_table.py --tables`; the cells by `python benchmarks/amlgym_table.py` "
            "(docs/amlgym.md says how, and with which noise and problems), on a shared, loaded machine: "
            "CPU seconds are process time, not wall time."]
    atomic_write_text(docs / "amlgym-table.md", "\n".join(head + rows + tail) + "\n")
    _plot(data, docs / "amlgym-precision-recall.png")


def summary(data: dict) -> list[str]:
    """Per domain and noise level, at the largest size run: each learner's syntactic P/R (mean),
    applicability precision, solved and false-plan ratios and CPU seconds; ``x`` marks a cell
    whose learner or scoring failed (its error is in the results file)."""
    out = ["| domain | noise | trajs | " + " | ".join(LEARNERS) + " |", "|" + "---|" * (3 + len(LEARNERS))]
    for dom, res in sorted(data.items()):
        for nz in sorted({k.split("|")[2] for k in res}, key=float):
            sizes = [int(k.split("|")[1]) for k in res if k.split("|")[2] == nz]
            big = max(sizes)
            cells = []
            for learner in LEARNERS:
                c = res.get(f"{learner}|{big}|{nz}")
                if c is None:
                    cells.append("")
                elif "precision" not in c or "solving" not in c:
                    cells.append("x")
                else:
                    app = c.get("applicability", {}).get("mean_precision")
                    cells.append(f"{c['precision']['mean']:.2f}/{c['recall']['mean']:.2f} "
                                 f"app {'-' if app is None else f'{app:.2f}'} "
                                 f"sol {c['solving']['solving_ratio']:.2f} fp {c['solving']['false_plans_ratio']:.2f} "
                                 f"{c['cpu']:.2f}s{_stale(c)}")
            out.append(f"| {dom} | {nz} | {big} | " + " | ".join(cells) + " |")
    return out


METRICS = (("synt. P", ("precision", "mean")), ("synt. R", ("recall", "mean")),
           ("app. P", ("applicability", "mean_precision")), ("app. R", ("applicability", "mean_recall")),
           ("eff. P", ("effects", "mean_precision")), ("eff. R", ("effects", "mean_recall")),
           ("solved", ("solving", "solving_ratio")))


def _stale(cell: dict) -> str:
    """A mark for a cell measured by an older learner (``code``: its commit), not yet redone."""
    return f" (at {cell['code']})" if "code" in cell else ""


def _metric(cell: dict | None, path: tuple[str, ...]) -> float | None:
    x = cell
    for k in path:
        x = x.get(k) if isinstance(x, dict) else None
    return float(x) if isinstance(x, (int, float)) and x == x else None


def targets(data: dict) -> list[str]:
    """Per domain and noise level at the largest size: the metrics where groundsym falls below
    the reference learner (OffLAM clean, NOLAM noisy; a reference that failed counts as met by a
    scored model), its false-plan ratio and whether its CPU is within 2x the reference's or 0.5 s."""
    rows = ["| domain | noise | reference | short of the reference (ours/theirs) | false plans | CPU s ours / ref | "
            "CPU met |", "|---|---|---|---|---|---|---|"]
    for dom, res in sorted(data.items()):
        for nz in sorted({k.split("|")[2] for k in res}, key=float):
            big = max(int(k.split("|")[1]) for k in res if k.split("|")[2] == nz)
            ours, ref_name = res.get(f"groundsym|{big}|{nz}"), "OffLAM" if float(nz) == 0 else "NOLAM"
            ref = res.get(f"{ref_name}|{big}|{nz}")
            if ours is None or ref is None:
                continue
            short = []
            for name, path in METRICS:
                a, b = _metric(ours, path), _metric(ref, path)
                if a is None and b is not None:
                    short.append(f"{name} -/{b:.2f}")
                elif a is not None and b is not None and a < b - 1e-9:
                    short.append(f"{name} {a:.2f}/{b:.2f}")
            fp = _metric(ours, ("solving", "false_plans_ratio"))
            ca, cb = _metric(ours, ("cpu",)), _metric(ref, ("cpu",))
            met = "yes" if ca is not None and (ca < 0.5 or (cb is not None and ca <= 2 * cb)) else "no"
            what = ", ".join(short) or ("none" if "error" not in ref else f"none ({ref_name} failed)")
            what += _stale(ours)
            rows.append(f"| {dom} | {nz} | {ref_name} | {what} | {'-' if fp is None else f'{fp:.2f}'} | "
                        f"{'-' if ca is None else f'{ca:.2f}'} / {'-' if cb is None else f'{cb:.2f}'} | {met} |")
    return rows


def failures(data: dict) -> list[str]:
    """One row per learner and reason: the cells (domain, trajectories, noise) whose learning or
    scoring raised it, the reason as the results file holds it (shortened)."""
    why: dict[tuple[str, str], list[str]] = {}
    for dom, res in sorted(data.items()):
        for key, c in sorted(res.items()):
            if "error" in c or "partial" in c:
                learner, size, nz = key.split("|")
                reason = " ".join(c.get("error", c.get("partial", "")).split())[:110].replace("|", "/")
                why.setdefault((learner, reason), []).append(f"{dom} {size}/{nz}")
    rows = ["| learner | reason (the learner's or the scorer's exception, or what was not scored) | "
            "cells (domain trajs/noise) |", "|---|---|---|"]
    for (learner, reason), cells in sorted(why.items(), key=lambda kv: (LEARNERS.index(kv[0][0]), kv[0][1])):
        rows.append(f"| {learner} | `{reason}` | {', '.join(cells)} |")
    return rows if len(rows) > 2 else ["No cell failed."]


def _plot(data: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    noises = sorted({k.split("|")[2] for res in data.values() for k in res}, key=float)
    fig, axes = plt.subplots(2, max(1, len(noises)), figsize=(4 * max(1, len(noises)), 6), squeeze=False)
    for j, nz in enumerate(noises):
        for i, metric in enumerate(("precision", "recall")):
            ax = axes[i][j]
            for learner in LEARNERS:
                pts: dict[int, list[float]] = {}
                for res in data.values():
                    for k, c in res.items():
                        ln, size, n = k.split("|")
                        if ln == learner and n == nz and metric in c:
                            pts.setdefault(int(size), []).append(c[metric]["mean"])
                if pts:
                    xs = sorted(pts)
                    style = {"groundsym": ("o", "-"), "SAM": ("s", "--"), "OffLAM": ("^", ":"), "NOLAM": ("v", "-.")}
                    m, ls = style[learner]
                    counts = "/".join(str(len(pts[x])) for x in xs)
                    ax.plot(xs, [np.mean(pts[x]) for x in xs], marker=m, linestyle=ls, alpha=0.8,
                            label=f"{learner} ({counts} domains)")
            ax.set_title(f"syntactic {metric}, noise {nz}\n(mean over the domains scored at each size)", fontsize=9)
            ax.set_xlabel("trajectories")
            ax.set_ylim(0, 1.05)
            ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--domains", nargs="*", default=list(DOMAINS6), help="AMLGym domains (default: the 6 of issue 36)")
    ap.add_argument("--all", action="store_true", help="AMLGym's 20 domains")
    ap.add_argument("--sizes", nargs="*", type=int, default=[1, 5, 10], help="training trajectories (default 1 5 10)")
    ap.add_argument("--noise", nargs="*", type=float, default=[0.0, 0.01, 0.05], help="flip probabilities")
    ap.add_argument("--learners", nargs="*", default=list(LEARNERS), choices=LEARNERS)
    ap.add_argument("--problems", type=int, default=3, help="problems per domain for prediction and solving")
    ap.add_argument("--timeout", type=int, default=20, help="planner seconds per problem")
    ap.add_argument("--seed", type=int, default=0, help="seed of the noise")
    ap.add_argument("--pp-budget", type=float, default=300.0, metavar="S",
                    help="CPU seconds for AMLGym's predictive power per cell (sokoban's takes hours; default 300)")
    ap.add_argument("--redo", nargs="*", default=[], choices=LEARNERS,
                    help="run these learners' cells again though the results hold them")
    ap.add_argument("--tables", action="store_true", help="only write docs/amlgym-table.md and the PNG")
    args = ap.parse_args()
    if any(n < 0 or n >= 0.5 for n in args.noise) or any(s < 1 for s in args.sizes) or args.problems < 1 \
            or not args.pp_budget > 0:
        print("amlgym_table: --noise in [0, 0.5), --sizes and --problems at least 1, --pp-budget above 0",
              file=sys.stderr)
        return 2
    if args.tables:
        write_tables()
        return 0
    try:
        from amlgym.benchmarks import get_trajectories_path
    except ImportError:
        print("amlgym_table: needs the amlgym extra (pip install -e '.[amlgym]', in a venv of its own)",
              file=sys.stderr)
        return 2
    domains = list(DOMAINS20) if args.all else args.domains
    def learnable(d: str) -> bool:
        try:
            return bool(get_trajectories_path(d, "learning"))
        except (ModuleNotFoundError, TypeError):
            return False
    unknown = [d for d in domains if not learnable(d)]
    if unknown:
        print(f"amlgym_table: --domains: no AMLGym learning trajectories for {', '.join(unknown)}", file=sys.stderr)
        return 2
    RESULTS.mkdir(parents=True, exist_ok=True)
    for d in domains:
        run_domain(d, args.sizes, args.noise, args.learners, args.problems, args.timeout, args.seed,
                   frozenset(args.redo), args.pp_budget)
    write_tables()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
