"""One PRADA decision at horizon 4 with 500 samples on a 7-cube tower model, on one core.

Target (issue 5): under 1 second. Prints the decision time, the share spent in factored-frontier
inference (rule probabilities + transitions), in the reward and in sampling, and the speed-up of
the vectorised samples over running the same code one sample at a time (a ratio measured in this
run, so machine noise cancels).

It also times a decision through the command-line path: a child process started with the BLAS
libraries' default threads (none of the ``*_NUM_THREADS`` variables this benchmark sets for itself)
builds the planner with ``make_planner`` and decides through ``groundsym.threads.decide``, the
call the episode loop of ``groundsym plan`` and ``groundsym evaluate`` makes, beside bare
``choose`` calls under the default threads (alternating, so machine noise hits both).

The model: ``--model DIR`` (a learned model directory), or else one built here from 9 random
traces of the tower cell abstracted with its ground-truth ``inhand`` and ``on`` (what a good
learned unary and binary symbol are), with rules and reward learned as ``groundsym learn`` does.

``--before REV``: side by side with PRADA (``planners/prada/``, or ``planners/prada.py`` before the
split) as it was at commit REV (checked out in a temporary git worktree and imported under another name), on the tower model and on IPPC 2008
triangle-tireworld p03 (its true rules): decision times alternate between the two versions in one
run, and the rule tables' memory is reported for each.
"""

from __future__ import annotations

import os

THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
CLI_CHILD = "GROUNDSYM_BENCH_CLI_PATH"      # set in the child that times the CLI's code path
if CLI_CHILD not in os.environ:
    for var in THREAD_VARS:
        os.environ.setdefault(var, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import planners.prada as prada  # noqa: E402
import planners.prada.core as prada_core  # noqa: E402
from groundsym.planner import Observation, PlanningModel  # noqa: E402


def build_model(seed: int, keep: Path | None = None) -> tuple[PlanningModel, frozenset, tuple[str, ...]]:
    from groundsym.collect import collect_traces
    from groundsym.evaluation.truth import TruthSymbols
    from groundsym.modeldir import learn_symbolic_model, load_model
    from groundsym.registry import make_sim

    sim = make_sim("tower", {})
    data = collect_traces(sim, 9, 10, seed, progress=False)
    symbols = TruthSymbols(("inhand", "on"), dict(sim.truth_predicates))
    sds = symbols.to_symbolic_dataset(data)
    with tempfile.TemporaryDirectory() as tmp:
        out = keep if keep is not None else Path(tmp)
        learn_symbolic_model(sds, out, seed=seed, argv=[], progress=False)
        m = load_model(out)
        rules, reward = m.rules, m.reward
    scene = sim.reset(seed + 1)
    sim.close()
    pm = PlanningModel(dict(data.primitives), predicates=symbols.predicates, rules=rules, reward=reward)
    return pm, symbols.abstract_scene(scene), tuple(scene.objects)


def load(model_dir: str | Path) -> tuple[PlanningModel, frozenset, tuple[str, ...]]:
    from groundsym.modeldir import load_model

    m = load_model(model_dir)
    tr = m.symbolic_traces.traces[0]
    pm = PlanningModel(m.primitives, predicates=m.predicates, rules=m.rules, reward=m.reward)
    return pm, tr.states[0], tuple(tr.objects)


def cli_path(model_dir: str, repeats: int) -> int:
    """(In the child, default BLAS threads.) Decisions as the episode loop makes them, beside bare
    ``choose`` calls; both at horizon 4 with 500 samples, alternating."""
    from groundsym.planner import make_planner
    from groundsym.threads import decide
    from threadpoolctl import threadpool_info

    pm, state, objects = load(model_dir)
    obs = Observation(objects, (), state)
    planner = make_planner("prada", pm, {"horizon": "4", "samples": "500"}, 0)
    decide(planner, obs)                                   # grounding and warm-up
    times: dict[str, list[float]] = {"decide": [], "choose": []}
    cpu: dict[str, list[float]] = {"decide": [], "choose": []}
    for _ in range(repeats):
        for label, call in (("decide", lambda: decide(planner, obs)), ("choose", lambda: planner.choose(obs))):
            t, c = time.perf_counter(), time.process_time()
            call()
            times[label].append(time.perf_counter() - t)
            cpu[label].append(time.process_time() - c)
    threads = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    d, c = np.median(times["decide"]), np.median(times["choose"])
    print(f"CLI path (groundsym.threads.decide, BLAS 1 thread): median {d * 1e3:.1f} ms over {repeats} "
          f"(min {min(times['decide']) * 1e3:.1f}; CPU time {np.median(cpu['decide']) * 1e3:.1f} ms); target < 20 ms")
    print(f"same planner, bare choose with the default BLAS threads {threads}: median {c * 1e3:.1f} ms "
          f"(CPU time of all threads {np.median(cpu['choose']) * 1e3:.1f} ms); ratio {c / d:.2f}x; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    return 0


def run_cli_child(model_dir: Path, repeats: int) -> None:
    import subprocess

    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARS}
    env[CLI_CHILD] = "1"
    subprocess.run([sys.executable, __file__, "--cli-path-child", str(model_dir), "--repeats", str(repeats)],
                   env=env, check=True)


class Timer:
    """Wraps module functions to add up the time spent in them."""

    def __init__(self) -> None:
        self.spent: dict[str, float] = {}

    def wrap(self, module, name: str, label: str) -> None:
        fn = getattr(module, name)

        def timed(*a, **k):
            t = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                self.spent[label] = self.spent.get(label, 0.0) + time.perf_counter() - t
        setattr(module, name, timed)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", help="a learned model directory (default: build one from the tower sim)")
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--before", help="a git revision: compare with PRADA at that commit")
    ap.add_argument("--cli-path-child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.cli_path_child:
        return cli_path(args.cli_path_child, args.repeats)
    keep = Path(tempfile.mkdtemp(prefix="bench-prada-")) / "model"
    pm, state, objects = load(args.model) if args.model else build_model(args.seed, keep)
    try:
        return measure(args, pm, state, objects, Path(args.model) if args.model else keep)
    finally:
        import shutil

        shutil.rmtree(keep.parent, ignore_errors=True)


def measure(args: argparse.Namespace, pm: PlanningModel, state: frozenset, objects: tuple[str, ...],
            model_dir: Path) -> int:
    if args.before:
        return side_by_side(args.before, args.repeats, [("tower", pm, state, objects), triangle_p03()])
    obs = Observation(objects, (), state)
    planner = prada.PradaPlanner(pm, {"horizon": "4", "samples": "500"}, seed=0)
    t = time.perf_counter()
    core = planner.core(objects, state)
    ground_s = time.perf_counter() - t
    g = core.g
    print(f"model: {len(pm.rules.rules)} rules, {len(g.objects)} objects -> {g.n_vars} ground atoms, "
          f"{len(g.rule_group)} ground rules, {len(g.actions)} ground actions; grounding once: {ground_s * 1e3:.1f} ms")
    planner.choose(obs)                                     # warm-up
    times = []
    for _ in range(args.repeats):
        t = time.perf_counter()
        planner.choose(obs)
        times.append(time.perf_counter() - t)
    dec = float(np.median(times))
    print(f"one decision, horizon 4, 500 samples: median {dec * 1e3:.1f} ms over {args.repeats} "
          f"(min {min(times) * 1e3:.1f}, max {max(times) * 1e3:.1f}); target < 1000 ms")
    timer = Timer()
    timer.wrap(prada_core, "rule_probabilities", "inference")      # the names PradaCore calls
    timer.wrap(prada_core, "transition", "inference")
    timer.wrap(prada_core, "action_weights", "sampling")
    timer.wrap(prada_core, "sample_rows", "sampling")
    reward = core.reward
    core.reward = lambda B: _timed(timer, "reward", reward, B)
    t = time.perf_counter()
    for _ in range(args.repeats):
        planner.choose(obs)
    total = time.perf_counter() - t
    shares = ", ".join(f"{k} {100 * v / total:.0f}%" for k, v in sorted(timer.spent.items()))
    print(f"time shares: {shares}, other {100 * (1 - sum(timer.spent.values()) / total):.0f}%")
    core.reward = reward
    single = prada.PradaCore(g, reward, 4, 1, core.gamma)
    b0 = g.belief(state)
    rng = np.random.default_rng(0)
    t = time.perf_counter()
    for _ in range(500):
        single.sample(b0, rng)
    loop = time.perf_counter() - t
    t = time.perf_counter()
    core.sample(b0, rng)
    vec = time.perf_counter() - t
    print(f"500 samples one at a time: {loop * 1e3:.0f} ms; vectorised: {vec * 1e3:.1f} ms; ratio {loop / vec:.0f}x")
    sys.stdout.flush()
    run_cli_child(model_dir, max(args.repeats, 20))
    return 0


def triangle_p03() -> tuple:
    from groundsym.episode import ppddl_model, ppddl_world
    from groundsym.ppddl.parser import load as load_ppddl

    domain, problem = load_ppddl(ROOT / "tests/data/ippc/ippc2008/triangle-tireworld/p03.pddl")
    _, task = ppddl_world(domain, problem)
    return "triangle-tireworld p03", ppddl_model(domain, problem, task), task.initial_state, tuple(sorted(task.objects))


def table_bytes(g) -> int:
    """Bytes of the rule tables (dense arrays, or a sparse matrix's data and indices)."""
    def size(m) -> int:
        return m.nbytes if isinstance(m, np.ndarray) else m.data.nbytes + m.indices.nbytes + m.indptr.nbytes
    return size(g.set_true) + size(g.touched)


def side_by_side(rev: str, repeats: int, cases: list) -> int:
    import subprocess

    wt = Path(tempfile.mkdtemp(prefix="groundsym-before-")) / "tree"
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(wt), rev], check=True,
                   capture_output=True)
    try:
        before = import_before(wt)
        print(f"{'case':24s} {'version':8s} {'decision ms (median)':>21s} {'rule tables MB':>15s}")
        for name, pm, state, objects in cases:
            obs = Observation(objects, (), state)
            planners = {v: m.PradaPlanner(pm, {"horizon": "4", "samples": "500"}, seed=0)
                        for v, m in (("before", before), ("after", prada))}
            times: dict[str, list[float]] = {v: [] for v in planners}
            for p in planners.values():
                p.choose(obs)                             # grounding and warm-up
            for _ in range(repeats):                      # alternate, so machine noise hits both
                for v, p in planners.items():
                    t = time.perf_counter()
                    p.choose(obs)
                    times[v].append(time.perf_counter() - t)
            for v, p in planners.items():
                g = p.core(objects, state).g
                print(f"{name:24s} {v:8s} {np.median(times[v]) * 1e3:21.1f} {table_bytes(g) / 1e6:15.2f}")
            print(f"{name:24s} ratio before/after: {np.median(times['before']) / np.median(times['after']):.2f}x")
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(wt)], capture_output=True)
    return 0


def import_before(tree: Path) -> Any:
    """PRADA of another checkout imported as ``prada_before``: the module ``planners/prada.py`` of
    a revision before the split, else the package ``planners/prada/`` (its modules become
    ``prada_before.core`` and so on). It runs on this tree's ``groundsym`` (both versions must share
    one ``Atom`` class), so it must import the names it needs from there: a revision before
    ``groundsym.options`` imports ``PlannerOption`` from ``groundsym.planner`` and is compared by
    running this benchmark in a checkout of its own time."""
    import importlib.util

    single = tree / "planners" / "prada.py"
    if single.exists():
        spec = importlib.util.spec_from_file_location("prada_before", single)
    else:
        package = tree / "planners" / "prada"
        spec = importlib.util.spec_from_file_location("prada_before", package / "__init__.py",
                                                      submodule_search_locations=[str(package)])
    before = importlib.util.module_from_spec(spec)
    sys.modules["prada_before"] = before      # dataclasses look their module up by name
    spec.loader.exec_module(before)
    return before


def _timed(timer: Timer, label: str, fn, *a):
    t = time.perf_counter()
    try:
        return fn(*a)
    finally:
        timer.spent[label] = timer.spent.get(label, 0.0) + time.perf_counter() - t


if __name__ == "__main__":
    sys.exit(main())
