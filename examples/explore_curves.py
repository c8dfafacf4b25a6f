"""Random against directed exploration: held-out log-likelihood and PRADA share of V*
against total transitions, in the tower cell.

For every seed, ``--rounds`` rounds of ``--round-traces`` traces of 10 primitives:

* *random*: ``groundsym collect --traces R*k --seed S`` (its first k traces are directed's round 0);
* *directed*: ``groundsym collect --traces R*k --seed S --explore counts --rounds R --work DIR``.

After each round j a model is learned on the first (j+1)*k traces of each (symbols with
``--evals`` loss evaluations, 4 restarts, and NID rules and reward on the same traces, as the
exploration's own round models; directed's are reused), then scored: mean log-likelihood per
transition of 30 held-out random traces (seed 999) abstracted with the model's own symbols, and
PRADA (``retries=1``) from ``--starts`` start states, its episode value as a share of V*.

Everything is kept in ``--out`` (traces, models, one line per scored model in ``curves.jsonl``), so
the command resumes where it stopped; the table and ``explore-curves.png`` are made from whatever
is there.

    python examples/explore_curves.py --seeds 0-9 --rounds 5 --round-traces 5 --starts 6 --out results/explore
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from groundsym.collect import collect_traces  # noqa: E402
from groundsym.episode import SimEnv, run_episode  # noqa: E402
from groundsym.explore import ExploreConfig, dataset, explore_traces, learn_round  # noqa: E402
from groundsym.fileio import atomic_write_bytes  # noqa: E402
from groundsym.glib import GlibOptions  # noqa: E402
from groundsym.modeldir import load_model  # noqa: E402
from groundsym.planner import PlanningModel, make_planner  # noqa: E402
from groundsym.registry import make_sim  # noqa: E402
from groundsym.rules.evaluate import score_ruleset  # noqa: E402
from groundsym.traces import read_traces, write_traces  # noqa: E402
from sims.tower import optimal_episode_value  # noqa: E402
from tower_prada_diagnosis import seed_range  # noqa: E402

LENGTH = 10
MODES = ("random", "directed", "glib")
COLOURS = {"random": "tab:gray", "directed": "tab:red", "glib": "tab:blue"}


def learn_seed(seed: int, j: int) -> int:
    """The seed ``groundsym.explore`` learns round j's model with."""
    return int(np.random.SeedSequence([seed, j]).generate_state(1)[0])


def work_of(mode: str, d: Path) -> Path:
    return d / f"{mode}-work"


def traces_of(sim, mode: str, seed: int, cfg: ExploreConfig, d: Path):
    path = d / f"{mode}.json"
    if not path.exists():
        n = cfg.rounds * cfg.round_traces
        ds = collect_traces(sim, n, LENGTH, seed, progress=False) if mode == "random" else \
            explore_traces(sim, cfg, seed, work_of(mode, d), progress=False)
        write_traces(path, ds)
    return read_traces(path)


def model_dir(sim, mode: str, seed: int, j: int, cfg: ExploreConfig, ds, d: Path) -> Path:
    out = d / f"{mode}-{j}"
    if (out / "rules.json").exists():
        return out
    own = work_of(mode, d) / f"round-{j}"
    if mode != "random" and (own / "rules.json").exists():
        shutil.copytree(own, out)
        return out
    prefix = dataset(sim, ds.traces[:(j + 1) * cfg.round_traces], {})
    learn_round(prefix, cfg, learn_seed(seed, j), out)
    return out


def score(sim, mdir: Path, held, starts: list[int], best: float) -> dict:
    m = load_model(mdir)
    ll = score_ruleset(m.rules, m.symbols.to_symbolic_dataset(held)).mean_log_likelihood
    pm = PlanningModel(dict(sim.primitives), predicates=dict(m.symbols.predicates), symbols=m.symbols,
                       rules=m.rules, reward=m.reward, gamma=float(sim.gamma))
    shares = []
    for start in starts:
        planner = make_planner("prada", pm, {"retries": "1"}, 1000 + start)
        shares.append(run_episode(SimEnv(sim, m.symbols), planner, sim.episode_length, start, "prada").value / best)
    return {"heldout_loglik": ll, "shares": shares, "share": float(np.mean(shares)) if shares else None,
            "symbols": list(m.symbols.predicates)}


def summarise(rows: list[dict], out: Path) -> None:
    print("| transitions | mode | runs | held-out log-lik (mean +- se) | PRADA share of V* (mean +- se) | "
          "mode - random, same seeds and transitions: log-lik, share |")
    print("|---|---|---|---|---|---|")
    curves: dict = {}
    for n in sorted({r["transitions"] for r in rows}):
        for mode in MODES:
            mine = [r for r in rows if r["transitions"] == n and r["mode"] == mode]
            if not mine:
                continue
            stats = []
            for key in ("heldout_loglik", "share"):
                v = np.array([r[key] for r in mine if r[key] is not None], float)
                se = v.std(ddof=1) / np.sqrt(len(v)) if len(v) > 1 else 0.0
                stats.append((v.mean() if len(v) else np.nan, se))
                curves.setdefault((mode, key), []).append((n, *stats[-1]))
            print(f"| {n} | {mode} | {len(mine)} | {stats[0][0]:.4f} +- {stats[0][1]:.4f} | "
                  f"{stats[1][0]:.1%} +- {stats[1][1]:.1%} | {paired(rows, n, mode) if mode != 'random' else ''} |")
    most = max((r["transitions"] for r in rows if r["mode"] == "random"), default=None)
    for mode in ("directed", "glib"):
        for n in sorted({r["transitions"] for r in rows if r["mode"] == mode}):
            if most is not None:
                print(f"{mode} at {n} minus random at {most}, same seeds: {paired(rows, n, mode, most)}")
    atomic_write_bytes(out / "explore-curves.png", curves_png(curves))


def paired(rows: list[dict], n: int, mode: str, against: int | None = None) -> str:
    """Mean and standard error of ``mode`` at ``n`` transitions minus random at ``against`` (default
    ``n``) over the seeds that have both."""
    mine = {r["seed"]: r for r in rows if r["transitions"] == n and r["mode"] == mode}
    base = {r["seed"]: r for r in rows if r["transitions"] == (against or n) and r["mode"] == "random"}
    seeds = sorted(set(mine) & set(base))
    if not seeds:
        return ""
    out = []
    for key, fmt in (("heldout_loglik", "{:+.3f} +- {:.3f}"), ("share", "{:+.1%} +- {:.1%}")):
        d = np.array([mine[s][key] - base[s][key] for s in seeds], float)
        out.append(fmt.format(d.mean(), d.std(ddof=1) / np.sqrt(len(d)) if len(d) > 1 else 0.0) if len(d) else "")
    return ", ".join(out)


def curves_png(curves: dict) -> bytes:
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.8))
    for ax, key, label in zip(axes, ("heldout_loglik", "share"), ("held-out log-likelihood (nats/transition)",
                                                                   "PRADA share of V*")):
        for mode, colour in COLOURS.items():
            pts = np.array(curves.get((mode, key), []), float).reshape(-1, 3)
            if len(pts):
                ax.errorbar(pts[:, 0], pts[:, 1], yerr=pts[:, 2], marker="o", capsize=3, c=colour, label=mode)
        target = np.array(curves.get(("random", key), []), float).reshape(-1, 3)
        if len(target):     # the target: random's figure at its most data, with half as much
            ax.axhline(target[-1, 1], ls="--", c="tab:gray", lw=0.8)
            ax.axvline(target[-1, 0] / 2, ls=":", c="tab:gray", lw=0.8)
        ax.set_xlabel("transitions in all")
        ax.set_ylabel(label)
        ax.legend()
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def tallest(scene) -> int:
    """The tallest tower in the simulator's truth (``on(x, y)``: x stands on y)."""
    below = {a.args[0]: a.args[1] for a in scene.truth if a.predicate == "on"}
    best = 0
    for o in scene.objects:
        h, x = 1, o
        while x in below and h <= len(scene.objects):
            x, h = below[x], h + 1
        best = max(best, h)
    return best


def data_stats(traces) -> tuple[float, int, float]:
    """By the simulator's truth: the share of transitions that change ``inhand`` or ``on``, the
    releases with a cube in hand over a cube that stands on another (the step to a tower of three
    and more, where towers topple), and the mean over traces of the tallest tower reached."""
    changed = over_stack = n = 0
    for tr in traces:
        for (s, a, s2) in tr.transitions():
            n += 1
            changed += any(x.predicate in ("inhand", "on") for x in s.truth ^ s2.truth)
            over_stack += (a.predicate == "openHandOver" and any(x.predicate == "inhand" for x in s.truth)
                           and any(x.predicate == "on" and x.args[0] == a.args[0] for x in s.truth))
    return changed / max(n, 1), over_stack, float(np.mean([max(map(tallest, tr.scenes)) for tr in traces]))


def data_table(out: Path, seeds: list[int], cfgs: dict[str, ExploreConfig]) -> None:
    """What each mode's data holds at each of its sizes (mean over seeds), by the simulator's truth."""
    print("\n| data | seeds | transitions changing inhand/on | releases in hand over a stacked cube | "
          "tallest tower per trace |")
    print("|---|---|---|---|---|")
    for mode, cfg in cfgs.items():
        paths = [out / f"seed{s}" / f"{mode}.json" for s in seeds]
        runs = [read_traces(p).traces for p in paths if p.exists()]
        for j in range(cfg.rounds):
            k = (j + 1) * cfg.round_traces
            v = np.array([data_stats(tr[:k]) for tr in runs]).reshape(-1, 3)
            if len(v):
                print(f"| {mode}, {k * LENGTH} | {len(v)} | {v[:, 0].mean():.0%} | {v[:, 1].mean():.1f} | "
                      f"{v[:, 2].mean():.2f} |")


def configs(args: argparse.Namespace) -> dict[str, ExploreConfig]:
    """Each mode's rounds: random and directed ``--rounds`` x ``--round-traces``, glib its own."""
    modes = [m for m in args.modes.split(",") if m]
    unknown = [m for m in modes if m not in MODES]
    if unknown:
        raise SystemExit(f"--modes: {', '.join(unknown)}: unknown (known: {', '.join(MODES)})")
    out = {}
    for m in modes:
        if m == "glib":
            out[m] = ExploreConfig(args.glib_rounds, args.glib_round_traces, LENGTH, evals=args.evals, mode="glib",
                                   glib=GlibOptions(random_share=args.glib_random_share))
        else:
            out[m] = ExploreConfig(args.rounds, args.round_traces, LENGTH, evals=args.evals)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-9")
    ap.add_argument("--modes", default="random,directed", help="comma-separated: random, directed, glib")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--round-traces", type=int, default=5)
    ap.add_argument("--glib-rounds", type=int, default=4)
    ap.add_argument("--glib-round-traces", type=int, default=3)
    ap.add_argument("--glib-random-share", type=float, default=0.0,
                    help="glib: the share of steps (between pursuits) that run a random primitive instead")
    ap.add_argument("--evals", type=int, default=15_000)
    ap.add_argument("--starts", type=int, default=6)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    cfgs = configs(args)
    args.out.mkdir(parents=True, exist_ok=True)
    sim = make_sim("tower", {})
    best = optimal_episode_value({})
    held_path = args.out / "heldout.json"
    if not held_path.exists():
        write_traces(held_path, collect_traces(sim, 30, LENGTH, 999, progress=False))
    held = read_traces(held_path)
    log = args.out / "curves.jsonl"
    rows = [json.loads(x) for x in log.read_text().splitlines()] if log.exists() else []
    done = {(r["seed"], r["mode"], r["round"]) for r in rows}
    for seed in seed_range(args.seeds):
        d = args.out / f"seed{seed}"
        d.mkdir(exist_ok=True)
        for mode, cfg in cfgs.items():
            ds = traces_of(sim, mode, seed, cfg, d)
            for j in range(cfg.rounds):
                if (seed, mode, j) in done:
                    continue
                mdir = model_dir(sim, mode, seed, j, cfg, ds, d)
                starts = [500 + seed * args.starts + k for k in range(args.starts)]
                row = {"seed": seed, "mode": mode, "round": j, "transitions": (j + 1) * cfg.round_traces * LENGTH,
                       **score(sim, mdir, held, starts, best)}
                with log.open("a") as f:
                    f.write(json.dumps(row) + "\n")
                rows.append(row)
                print(f"seed {seed} {mode} {row['transitions']} transitions: log-lik {row['heldout_loglik']:.4f}, "
                      f"PRADA {row['share'] if row['share'] is not None else float('nan'):.1%}",
                      file=sys.stderr, flush=True)
    sim.close()
    wanted = set(seed_range(args.seeds))
    summarise([r for r in rows if r["seed"] in wanted and r["mode"] in cfgs], args.out)
    data_table(args.out, sorted(wanted), cfgs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
