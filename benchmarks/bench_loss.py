"""Loss evaluations per CPU second at the paper's size: 7 objects, 160 transitions, 1 unary + 1 binary
symbol, one core.

Two workloads, each on a fresh :class:`~groundsym.loss.Loss` (empty caches), timed in CPU seconds
of this process (the machine is shared):

* ``annealing``: one simulated-annealing restart from a fixed seed (perturbs, re-seeds, swaps),
  which is what ``learn`` pays per core; the default search (a ladder of temperatures since commit
  88e004a), or with ``--one-temperature`` the search of the code before it (``ladder=1``), which is
  what a ``--before`` commit older than that runs: use it to compare the kernels alone;
* ``random``: independent random symbol sets (centres from the data, random widths), the worst
  case for caches.

Each is timed with the compiled kernels (the default) and with the numpy reference they mirror;
the compilation (or loading numba's on-disk cache) is timed apart, once per process. With
``--before REV`` the same workloads also run on the code of commit REV (checked out in a
temporary git worktree) and on this code, each round in two fresh processes, alternating, and
the ratio of the medians is printed: a ratio in one run, on the same data, is what a loaded
machine can measure.

    .venv/bin/python benchmarks/bench_loss.py --traces tower16.json --evals 3000 --before 1648be7
    # tower16.json: groundsym collect --sim tower --traces 16 --seed 0 -o tower16.json

``--curve`` measures how the rate grows with the number of objects: one annealing
restart per cell on the kinematic fixture world (``tests/test_loss.py``: 10-step traces, seed 1,
the table grown with the cubes above 10), for each number of objects, transitions (160: 16
traces; 1,000: 100) and symbol count (1+1, 2+1), each cell the median of ``--processes`` fresh
processes (empty memos, numba's machine code loaded from its disk cache). A cell stops at
``--evals`` evaluations or ``--max-cpu`` CPU seconds, whichever comes first, and reports the
evaluations it did per CPU second. It prints the table and writes a PNG of the curve.

    .venv/bin/python benchmarks/bench_loss.py --curve --sizes 7,10,14,20 --evals 1000 --processes 5 --png curve.png
    .venv/bin/python benchmarks/bench_loss.py --curve --distances exact,local:1 --max-cpu 30 --png curve.png
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Sequence

import numpy as np

ROOT = Path(os.environ.get("GROUNDSYM_BENCH_ROOT") or Path(__file__).resolve().parents[1])
sys.path.insert(0, str(ROOT))

from groundsym import anneal  # noqa: E402
from groundsym.anneal import AnnealConfig, advance, start_restart  # noqa: E402
from groundsym.loss import Loss, LossConfig, prepare  # noqa: E402
from groundsym.fileio import atomic_write_json  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402

# --before runs this script on older code, where the proposal was the private anneal._random_symbol
random_symbol = getattr(anneal, "random_symbol", None) or getattr(anneal, "_random_symbol")


def cpu_rate(fn, n: int) -> float:
    """Evaluations per CPU second of this process (robust to other load on a shared machine)."""
    t0 = time.process_time()
    fn()
    return n / (time.process_time() - t0)


def _loss(data, kernels: str | None) -> Loss:
    return Loss(data) if kernels is None else Loss(data, kernels=kernels)


def benchmark_dataset(traces: Path | None):
    """The benchmark's data: the traces file, or 16 traces of the 7-object kinematic fixture world."""
    if traces is not None:
        return read_traces(traces)
    sys.path.insert(0, str(ROOT / "tests"))
    from test_loss import kinematic_tower
    return kinematic_tower(16, seed=1)


def workloads(traces: Path | None, evals: int, kernels: str | None, one_temperature: bool = False) -> dict[str, float]:
    """Both workloads on one kind of kernels; returns the rates and the compile time."""
    out: dict[str, float] = {}
    import groundsym
    here = Path(groundsym.__file__).resolve().parent
    out["compile_s"] = 0.0
    if ((here / "compiled.py").exists() or (here / "compiled").is_dir()) and kernels != "numpy":  # (older code: none)
        from groundsym import compiled
        out["compile_s"] = compiled.warm_up()
    data = prepare(benchmark_dataset(traces))
    search = {"ladder": 1.0} if one_temperature and "ladder" in AnnealConfig.__dataclass_fields__ else {}
    cfg = AnnealConfig(evals=evals * 4, restarts=4, **search)
    loss = _loss(data, kernels)
    state = start_restart(0, 0, loss, cfg)
    out["annealing"] = cpu_rate(lambda: advance(state, loss, cfg, evals), evals)
    out["abstractions"] = len(loss._abstraction_cache)
    rng = np.random.default_rng(0)
    n_random = max(evals // 10, 50)
    sets = [[random_symbol(rng, 1, "u1", data, cfg), random_symbol(rng, 2, "b1", data, cfg)] for _ in range(n_random)]
    fresh = _loss(data, kernels)
    out["random"] = cpu_rate(lambda: [fresh(c) for c in sets], n_random)
    out["transitions"], out["objects"] = data.n_transitions, data.features.shape[1]
    return out


def run_elsewhere(root: Path, traces: Path | None, evals: int, one_temperature: bool) -> dict[str, float]:
    """The workloads on the code at ``root`` (another checkout), in a subprocess."""
    env = dict(os.environ, GROUNDSYM_BENCH_ROOT=str(root), PYTHONPATH=str(root))
    cmd = [sys.executable, str(Path(__file__).resolve()), "--evals", str(evals), "--json-only"]
    cmd += ["--one-temperature"] if one_temperature else []
    if traces:
        cmd += ["--traces", str(traces.resolve())]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def curve_cell(objects: int, transitions: int, n_unary: int, n_binary: int, evals: int, max_cpu: float,
               distance: str = "exact") -> dict:
    """One cell of the curve in this process: a fresh loss (with this ``distance``), one annealing
    restart, in rounds of 5 evaluations until ``evals`` or ``max_cpu`` CPU seconds."""
    from groundsym import compiled
    compiled.warm_up()
    sys.path.insert(0, str(ROOT / "tests"))
    from test_loss import kinematic_tower
    data = prepare(kinematic_tower(max(transitions // 10, 1), seed=1, n_cubes=objects))
    cfg = AnnealConfig(n_unary=n_unary, n_binary=n_binary, evals=evals * 4, restarts=4)
    loss = Loss(data, LossConfig(distance=distance))
    spent = _time_terms(loss)
    state = start_restart(0, 0, loss, cfg)
    t0 = time.process_time()
    while state.done < evals and time.process_time() - t0 < max_cpu:
        state = advance(state, loss, cfg, 5)
    cpu = time.process_time() - t0
    return {"objects": objects, "transitions": data.n_transitions, "symbols": f"{n_unary}+{n_binary}",
            "distance": distance, "evals": loss.evaluations, "cpu_s": cpu, "rate": loss.evaluations / cpu,
            **{f"{term}_share": t / cpu for term, t in spent.items()}}


def _time_terms(loss: Loss) -> dict[str, float]:
    """CPU seconds of the loss's prediction term (its neighbours and mixtures) and of its reward
    term (the reward's neighbours, exact or by profile, and its mixture), added up while ``loss``
    runs: the reward term is reported apart (a new reward model is to replace it)."""
    import groundsym.loss as loss_module
    spent = {"prediction": 0.0, "reward": 0.0}

    def timed(fn, term):
        def run(*a, **k):
            t = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                spent[term] += time.process_time() - t
        return run
    loss._transition_ll = timed(loss._transition_ll, "prediction")
    loss._transition_ll_backoff = timed(loss._transition_ll_backoff, "prediction")
    loss._reward_nll = timed(loss._reward_nll, "reward")
    loss_module.profile_neighbours = timed(loss_module.profile_neighbours, "reward")
    loss_module.linear_reward_nll = timed(loss_module.linear_reward_nll, "reward")
    loss.backend.count_features = timed(loss.backend.count_features, "reward")
    backend_neighbours = loss.backend.neighbours
    loss.backend.neighbours = lambda u, b, lock, label: (      # the exact reward pass: no locks
        timed(backend_neighbours, "reward" if not lock.any() else "prediction_pass")(u, b, lock, label))
    spent["prediction_pass"] = 0.0
    return spent


def curve(sizes: list[int], transitions: list[int], evals: int, max_cpu: float, processes: int,
          png: Path, distances: Sequence[str] = ("exact",),
          symbols: Sequence[tuple[int, int]] = ((1, 1), (2, 1)), exact_sizes: Sequence[int] | None = None) -> list[dict]:
    """Every cell of the curve, each the median rate of ``processes`` fresh processes; the plot is
    redrawn and the rows written beside it (``.json``) after each cell, so a stopped run leaves the
    cells it measured."""
    rows = []
    for t in transitions:
        for u, b in symbols:
            for dist, m in ((dist, m) for dist in distances for m in sizes
                            if dist != "exact" or exact_sizes is None or m in exact_sizes):
                runs = []
                for _ in range(processes):
                    cmd = [sys.executable, str(Path(__file__).resolve()), "--cell", f"{m},{t},{u},{b}",
                           "--evals", str(evals), "--max-cpu", str(max_cpu), "--distances", dist]
                    res = subprocess.run(cmd, capture_output=True, text=True, check=True, env=dict(os.environ))
                    runs.append(json.loads(res.stdout.strip().splitlines()[-1]))
                row = dict(runs[0], rate=float(np.median([r["rate"] for r in runs])),
                           evals=int(np.median([r["evals"] for r in runs])), processes=len(runs))
                rows.append(row)
                print(f"{row['objects']:>3} objects  {row['transitions']:>5} transitions  {row['symbols']}  "
                      f"{dist:>8}  {row['rate']:>8.1f} evals per CPU s  (median of {len(runs)}; {row['evals']} evals "
                      f"each, {np.median([r['cpu_s'] for r in runs]):.1f} CPU s)", flush=True)
                plot_curve(rows, png)
                atomic_write_json(png.with_suffix(".json"), rows)
    return rows


def plot_curve(rows: list[dict], png: Path) -> None:
    """Evaluations per CPU second against objects, one line per (transitions, symbols); written atomically."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    def key_of(r: dict) -> tuple:
        return r["transitions"], r["symbols"], r.get("distance", "exact")

    for key in sorted({key_of(r) for r in rows}):
        pts = sorted((r["objects"], r["rate"]) for r in rows if key_of(r) == key)
        ax.plot(*zip(*pts), marker="o", ls="-" if key[2] == "exact" else "--",
                label=f"{key[0]} transitions, {key[1]} symbols, {key[2]}")
    ax.axhline(1000, color="grey", ls=":", lw=1)
    ax.axhline(300, color="grey", ls=":", lw=1)
    ax.set(xlabel="objects", ylabel="loss evaluations per CPU second", yscale="log",
           title="Symbol loss speed (one annealing restart, compiled kernels)")
    ax.legend(fontsize=8)
    tmp = png.with_name(png.name + ".tmp.png")
    fig.savefig(tmp, dpi=110, bbox_inches="tight")
    plt.close(fig)
    os.replace(tmp, png)


def report(label: str, r: dict[str, float]) -> None:
    print(f"{label}: annealing {r['annealing']:.0f} evals per CPU second (1e5: {1e5 / r['annealing'] / 60:.1f} CPU min; "
          f"{r['abstractions']} distinct abstractions), random sets {r['random']:.0f} per CPU second"
          + (f"; compile/load {r['compile_s']:.1f} s" if r.get("compile_s") else ""))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--traces", type=Path, help="continuous traces (default: 16 fixture traces, 7 objects)")
    ap.add_argument("--evals", type=int, default=3000, help="evaluations of the annealing workload")
    ap.add_argument("--before", metavar="REV", help="also the code of this git revision, alternating, and the ratio")
    ap.add_argument("--rounds", type=int, default=2, help="alternations with --before (medians are reported)")
    ap.add_argument("--one-temperature", action="store_true",
                    help="anneal with ladder=1 (the search before commit 88e004a): compares kernels with older code")
    ap.add_argument("--curve", action="store_true", help="the rate against the number of objects")
    ap.add_argument("--sizes", default="7,10,14,20,30,40", help="--curve: numbers of objects, comma-separated")
    ap.add_argument("--transitions", default="160,1000", help="--curve: numbers of transitions, comma-separated")
    ap.add_argument("--distances", default="exact", help="--curve: the loss's distance settings, comma-separated "
                    "(exact, local:K, auto, signature)")
    ap.add_argument("--exact-sizes", help="--curve: the sizes the exact distance is measured at (default: --sizes); "
                    "one search block at 30 objects can take minutes")
    ap.add_argument("--symbols", default="1+1,2+1", help="--curve: unary+binary symbol counts, comma-separated")
    ap.add_argument("--processes", type=int, default=5, help="--curve: fresh processes per cell (median)")
    ap.add_argument("--max-cpu", type=float, default=120.0, help="--curve: CPU seconds at most per cell and process")
    ap.add_argument("--png", type=Path, default=Path("loss-speed.png"), help="--curve: where the plot goes")
    ap.add_argument("--cell", help=argparse.SUPPRESS)
    ap.add_argument("--json-only", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    one = args.one_temperature
    if args.cell:
        m, t, u, b = (int(x) for x in args.cell.split(","))
        print(json.dumps(curve_cell(m, t, u, b, args.evals, args.max_cpu, args.distances)))
        return 0
    if args.curve:
        try:
            sizes = [int(x) for x in args.sizes.split(",")]
            transitions = [int(x) for x in args.transitions.split(",")]
            symbols = [tuple(int(n) for n in x.split("+")) for x in args.symbols.split(",")]
            distances = args.distances.split(",")
            exact_sizes = [int(x) for x in args.exact_sizes.split(",")] if args.exact_sizes else None
            for d in distances:
                LossConfig(distance=d)
            if any(len(x) != 2 for x in symbols):
                raise ValueError("--symbols: U+B pairs")
        except ValueError as exc:
            print(f"bench_loss.py: --sizes/--transitions/--symbols/--distances: {exc}", file=sys.stderr)
            return 2
        if min(sizes) < 2 or max(sizes) > 62 or min(transitions) < 10 or args.processes < 1 or args.evals < 1:
            print("bench_loss.py: --sizes in 2..62, --transitions >= 10, --processes and --evals >= 1", file=sys.stderr)
            return 2
        curve(sizes, transitions, args.evals, args.max_cpu, args.processes, args.png, distances, symbols, exact_sizes)
        print(f"plot: {args.png}")
        return 0
    if args.json_only:
        print(json.dumps(workloads(args.traces, args.evals, None, one)))
        return 0
    now = workloads(args.traces, args.evals, None, one)
    print(f"data: {now['transitions']} transitions, {now['objects']} objects"
          f"{' from ' + str(args.traces) if args.traces else ' (kinematic fixture world)'}; 1 unary + 1 binary")
    report("compiled kernels", now)
    ref = workloads(args.traces, args.evals, "numpy", one)
    report("numpy reference", ref)
    print(f"compiled / reference: annealing {now['annealing'] / ref['annealing']:.2f}x, random {now['random'] / ref['random']:.2f}x")
    if args.before:
        wt = Path(tempfile.mkdtemp(prefix="groundsym-before-")) / "tree"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(wt), args.before],
                       check=True, capture_output=True)
        try:
            after, before = [], []
            for k in range(args.rounds):     # both in fresh processes, alternating: the same conditions
                before.append(run_elsewhere(wt, args.traces, args.evals, one))
                after.append(run_elsewhere(ROOT, args.traces, args.evals, one))
            med = {w: (float(np.median([r[w] for r in after])), float(np.median([r[w] for r in before])))
                   for w in ("annealing", "random")}
            report(f"this code (median of {len(after)})", {**now, **{w: a for w, (a, _) in med.items()}})
            report(f"code at {args.before} (median of {len(before)})", {**before[0], **{w: b for w, (_, b) in med.items()}})
            print(f"now / {args.before}: annealing {med['annealing'][0] / med['annealing'][1]:.2f}x, "
                  f"random {med['random'][0] / med['random'][1]:.2f}x (medians of {len(after)} and {len(before)} runs)")
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(wt)], capture_output=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
