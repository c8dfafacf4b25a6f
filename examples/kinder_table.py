"""KinDER's kinematic-2D tasks: symbols learned from random primitives, graded against the task's
relations, and PRADA solving the tasks counted as KinDER counts (docs/kinder.md).

One command per table; every step is resumable (a finished traces file, model or episode is kept
and skipped when the command runs again):

    python examples/kinder_table.py symbols  --task b1 --seeds 5 --out results/kinder
    python examples/kinder_table.py planning --task b1 --seeds 5 --episodes 50 --out results/kinder
    python examples/kinder_table.py table --out results/kinder      # docs/kinder.md's table
    python examples/kinder_table.py picture --task b1 --out results/kinder   # a solved episode, PNG
    python examples/kinder_table.py terms --task o1 --seeds 5 --out results/kinder  # learned vs hand-made loss

``symbols``: per seed, ``--traces`` x ``--length`` random primitives (500 transitions by default,
the issue's bound), ``groundsym learn``, and each relation the task is written in matched to its
best learned symbol (F1 over every scene of the traces, ``groundsym.grounding.match_symbols``).
``planning``: per seed and episode, PRADA with the learned model (symbols, NID rules, reward) and,
side by side, PRADA with rules and reward learned on the true relations (the hand-written
relations of the task, computed from KinDER's state); success is KinDER's, the task solved within
3,000 environment steps, every step inside a primitive counted. Needs the kinder extra (make kinder).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from groundsym.cli import main as groundsym
from groundsym.collect import collect_traces
from groundsym.commands.plan import episode_seeds, sim_planning_model
from groundsym.fileio import atomic_write_json
from groundsym.grounding import match_symbols, scores, truth_arrays
from groundsym.modeldir import load_model
from groundsym.planner import Observation, make_planner
from groundsym.symbolic_traces import SymbolicDataset, SymbolicTrace, write_symbolic_traces
from groundsym.loss import Loss, LossConfig, prepare
from groundsym.symbols import Symbol, SymbolSet, dataset_arrays
from groundsym.traces import read_traces, write_traces
from sims.kinder2d import ObstructionSim, StickButtonSim
from sims.kinder_cluttered import ClutteredSim

TASKS = {  # name: (sim class, options, --unary, --binary, KinDER id)
    "b1": (StickButtonSim, {"buttons": 1}, 3, 0, "StickButton2D-b1"),
    "b3": (StickButtonSim, {"buttons": 3}, 3, 0, "StickButton2D-b3"),
    "o1": (ObstructionSim, {"obstructions": 1}, 2, 1, "Obstruction2D-o1"),
    "o3": (ObstructionSim, {"obstructions": 3, "reward": "graded"}, 2, 1, "Obstruction2D-o3"),
    "c10": (ClutteredSim, {"obstructions": 10, "reward": "graded"}, 2, 1, "ClutteredRetrieval2D-o10"),
}
LEARN_OPTIONS = {         # extra `groundsym learn` options per task: 12 objects need the fast loss
    "c10": ["--loss", "distance=signature"]}
RELATIONS_TO = {          # unary relations that are about one fixed object: also graded as pairs with it
    "o1": {"blocking": "target_surface"}, "o3": {"blocking": "target_surface"}, "c10": {"blocking": "target_block"}}
BUDGET = 3000            # KinDER's environment steps per episode, every step inside a primitive counted
NO_CAP = 0               # --max-primitives 0: the episode ends only at KinDER's budget (the default)
PRADA = {"samples": "200",      # sampled action sequences per decision (its default horizon, 4)
         "actions": "legal",     # only primitives the world offers (typed arguments: pick(S) of a stick)
         "references": "unique",  # NID's semantics of a rule's references (docs/kinder.md)
         "retries": "1",          # a primitive that changed nothing is not tried a third time there ...
         "retry_memory": "visit"}  # ... until the state changes (the world may have, unseen: docs/kinder.md)
PUBLISHED = {            # success within 3,000 steps, 50 episodes x 5 seeds (the table)
    "b1": {"bilevel planning": 0.99, "diffusion policy": 0.65, "PPO": 0.07, "LLM planning": 0.29},
    "b3": {"bilevel planning": 0.30, "diffusion policy": 0.32, "PPO": 0.00, "LLM planning": 0.01},
}


def seed_dir(out: Path, task: str, seed: int) -> Path:
    return out / task / f"seed-{seed}"


# ----------------------------------------------------------------------------- symbols

def learn_seed(task: str, seed: int, out: Path, traces: int, length: int, evals: int) -> dict:
    cls, opts, unary, binary, _ = TASKS[task]
    d = seed_dir(out, task, seed)
    d.mkdir(parents=True, exist_ok=True)
    data, model, truth_data, truth_model = d / "traces.json", d / "model", d / "truth.json", d / "truth-model"
    if not data.exists():
        sim = cls(**opts)
        t0 = time.process_time()
        write_traces(data, collect_traces(sim, traces, length, seed, progress=False))
        print(f"{task} seed {seed}: collected in {time.process_time() - t0:.0f} CPU s", file=sys.stderr)
    if not (model / "symbols.json").exists():
        groundsym(["learn", str(data), "-o", str(model), "--unary", str(unary), "--binary", str(binary),
                   "--evals", str(evals), "--restarts", "2", "--workers", "1", "--seed", str(seed), "--quiet",
                   *LEARN_OPTIONS.get(task, [])])
    ds = read_traces(data)
    if not (truth_model / "rules.json").exists():
        write_symbolic_traces(truth_data, truth_dataset(ds, cls))
        groundsym(["learn", str(truth_data), "-o", str(truth_model), "--quiet"])
    best: dict[str, float] = {p: 0.0 for p in cls.truth_predicates}
    symbols = load_model(model).symbols
    for m in match_symbols(symbols, ds):
        if m.best_match in best:
            best[m.best_match] = max(best[m.best_match], round(m.f1, 3))
    for relation, f1 in pair_f1(symbols, ds, RELATIONS_TO.get(task, {})).items():
        best[relation] = max(best[relation], round(f1, 3))
    return best


def pair_f1(symbols, ds, relations_to: dict[str, str]) -> dict[str, float]:
    """The best F1 of a learned binary symbol, with the fixed object as either argument, against a
    unary relation about that object: ``blocking(X)`` says X stands over *the* target surface, and
    a learned ``b(S, X)`` (or ``b(X, S)``) with S the surface is that relation written as the pair
    it is. The surface moves from task to task, so no symbol of X's own features can hold it."""
    if not relations_to or not symbols.binary:
        return {}
    feats, pairs = dataset_arrays(ds)
    _, b = symbols.truth_arrays(feats, pairs)
    true_u, _ = truth_arrays(ds)
    objects = ds.traces[0].objects
    out = {}
    for relation, other in relations_to.items():
        j = objects.index(other)
        rest = [i for i in range(len(objects)) if i != j]
        true = true_u.get(relation, np.zeros(feats.shape[:2], bool))[:, rest]
        out[relation] = max(scores(b[:, rows, cols, k], true)[2] for k in range(b.shape[-1])
                            for rows, cols in ((rest, j), (j, rest)))
    return out


def truth_dataset(ds, cls) -> SymbolicDataset:
    """The same traces, abstracted by the task's true relations instead of learned symbols."""
    traces = [SymbolicTrace(tr.objects, [s.truth for s in tr.scenes], list(tr.actions),
                            [s.reward for s in tr.scenes[:-1]], tr.scenes[-1].reward) for tr in ds.traces]
    return SymbolicDataset(traces, dict(cls.truth_predicates), dict(ds.primitives))


# ----------------------------------------------------------------------------- loss terms

WIDE = 1e3                # a width far above every spread: the dimension is ignored


def hand_made_symbols() -> dict[str, list[Symbol]]:
    """Obstruction2D symbols written by hand over x, y, w, h, green (docs/kinder.md): the target
    block (green 0, at table height: not the surface, whose centre is at 5 cm), and X standing over
    Y at table height within 13 cm sideways (``over``: the target on the surface, or the surface
    under an obstruction that blocks it) or within 3 cm (``on``); unused slots never hold."""
    def box(name: str, arity: int, centre: list[float], half: list[float]) -> Symbol:
        return Symbol(name, arity, np.array(centre), np.array(half) / np.sqrt(np.log(2)))
    target = box("u1", 1, [0, 0.17, 0, 0, 0], [WIDE, 0.058, WIDE, WIDE, 0.025])
    off = Symbol("u2", 1, np.full(5, WIDE), np.full(5, 1e-3))
    over = box("b1", 2, [0, 0.117, 0, 0, 0], [0.13, 0.05, WIDE, WIDE, WIDE])
    on = box("b1", 2, [0, 0.117, 0, 0, 0], [0.03, 0.05, WIDE, WIDE, WIDE])
    return {"targetBlock + over": [target, off, over], "targetBlock + on": [target, off, on]}


def loss_terms(task: str, out: Path, seeds: range) -> str:
    """Per seed: the loss terms of the learned symbols and of hand-made ones on the same traces,
    as docs/symbols.md's diagnostics compare them (is it the search or the loss?)."""
    lines = ["| seed | symbols | F1 | effect | prediction | reward | regulariser | total |", "|---|---|---|---|---|---|---|---|"]
    for seed in seeds:
        d = seed_dir(out, task, seed)
        ds = read_traces(d / "traces.json")
        loss = Loss(prepare(ds, LossConfig()), LossConfig())
        sets = {"learned": list(load_model(d / "model").symbols.symbols), **hand_made_symbols()}
        for name, symbols in sets.items():
            t = loss(symbols)
            held = SymbolSet.for_dataset([s for s in symbols if s.centre[0] < WIDE], ds)
            f1 = ", ".join(f"{m.symbol} {m.best_match} {m.f1:.2f}" for m in match_symbols(held, ds))
            lines.append(f"| {seed} | {name} | {f1} | {t.effect:.1f} | {t.transition:.1f} | {t.reward:.1f} | "
                         f"{t.regulariser:.1f} | {t.total:.1f} |")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- planning

def run_episode(sim, planner, abstract, seed: int, frames: list | None = None,
                max_primitives: int = NO_CAP) -> dict:
    """PRADA replanning after every primitive until solved or KinDER's budget of environment steps
    is spent (or ``max_primitives``, when not 0); ``frames`` collects an image of the start and of
    the scene after every primitive. A primitive that takes no environment step (a StickButton2D
    press of a button already pressed) is charged one, so an episode always ends."""
    scene = sim.reset(seed)
    actions, idle = [], 0
    while frames is not None and not frames:
        frames.append(sim.env.render())
    while (not sim.solved() and sim.env_steps + idle < BUDGET
           and (max_primitives == NO_CAP or len(actions) < max_primitives)):
        obs = Observation(scene.objects, tuple(sim.actions()), abstract(scene), scene, len(actions), 10)
        decision = planner.choose(obs)
        before = sim.env_steps
        scene = sim.step(decision.action)
        idle += sim.env_steps == before
        actions.append(str(decision.action))
        if frames is not None:
            frames.append(sim.env.render())
        planner.observe(decision.action, Observation(scene.objects, tuple(sim.actions()), abstract(scene),
                                                      scene, len(actions), 10))
    return {"seed": seed, "success": bool(sim.solved() and sim.env_steps <= BUDGET),
            "env_steps": int(sim.env_steps), "idle_primitives": idle, "actions": actions}


ARMS = ("learned", "true relations", "random")


def plan_seed(task: str, seed: int, out: Path, episodes: int, max_primitives: int, random_episodes: int,
              arms: tuple[str, ...] = ARMS, shard: tuple[int, int] = (0, 1)) -> None:
    """Episodes of each arm, resumed from ``episodes-<arm>.json``. With ``shard`` (K, N), N > 1, this
    process runs the episodes whose index is K modulo N, into ``episodes-<arm>.shard-K-of-N.json``,
    and after each one merges what every shard has finished into ``episodes-<arm>.json`` as far as
    the episodes run without a gap: N processes of a loaded machine share one seed's episodes, and
    the merged file is the one a single process writes (each episode has its own seeds)."""
    cls, opts, *_ = TASKS[task]
    d = seed_dir(out, task, seed)
    sim = cls(**opts)
    models = {"learned": (lambda: load_model(d / "model"), lambda m: m.symbols.abstract_scene),
              "true relations": (lambda: load_model(d / "truth-model"), lambda m: (lambda scene: scene.truth)),
              "random": (lambda: None, lambda m: (lambda scene: frozenset()))}   # our skills without a planner
    k_of, n = shard
    for arm in arms:
        load, abstraction = models[arm]
        model = load()
        path = d / f"episodes-{arm.replace(' ', '-')}.json"
        old = json.loads(path.read_text()) if path.exists() else {"max_primitives": max_primitives, "episodes": []}
        if old.get("max_primitives") != max_primitives:
            raise SystemExit(f"{path}: made with --max-primitives {old.get('max_primitives')}; "
                             f"use that, or another --out")
        head = {"task": task, "seed": seed, "arm": arm, "max_primitives": max_primitives}
        done = merge_shards(path, old["episodes"], head)
        mine_path = path.with_name(f"{path.stem}.shard-{k_of}-of-{n}.json")
        mine = json.loads(mine_path.read_text())["episodes"] if n > 1 and mine_path.exists() else []
        pm = sim_planning_model(model, sim)
        for k, ep_seed in enumerate(episode_seeds(1000 + seed, min(episodes, random_episodes) if model is None
                                                  else episodes)):
            if k < len(done) or (n > 1 and (k % n != k_of or any(e["index"] == k for e in mine))):
                continue
            planner = make_planner("prada", pm, PRADA, ep_seed) if model else make_planner("random", pm, {}, ep_seed)
            t0 = time.process_time()
            record = {**run_episode(sim, planner, abstraction(model), ep_seed, max_primitives=max_primitives),
                      "cpu_s": round(time.process_time() - t0, 2)}
            if n == 1:
                done.append(record)
                atomic_write_json(path, {**head, "episodes": done})
            else:
                mine.append({"index": k, **record})
                atomic_write_json(mine_path, {**head, "episodes": mine})
                done = merge_shards(path, json.loads(path.read_text())["episodes"] if path.exists() else [], head)
            print(f"{task} seed {seed} {arm} episode {k}: {'solved' if record['success'] else 'not solved'} "
                  f"in {record['env_steps']} steps", file=sys.stderr)
    sim.close()


def merge_shards(path: Path, done: list[dict], head: dict) -> list[dict]:
    """``done`` extended by the shards' episodes that follow it without a gap (written back when
    that adds any)."""
    extra = {}
    for p in path.parent.glob(f"{path.stem}.shard-*.json"):
        extra.update({e["index"]: {k: v for k, v in e.items() if k != "index"}
                      for e in json.loads(p.read_text())["episodes"]})
    merged = list(done)
    while len(merged) in extra:
        merged.append(extra[len(merged)])
    if len(merged) > len(done):
        atomic_write_json(path, {**head, "episodes": merged})
    return merged


def picture(task: str, out: Path, seed: int = 0) -> Path:
    """The first solved episode of ``seed`` with the learned model, replayed (same seeds, same run)
    and drawn as a strip: the start, then the scene after each primitive."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cls, opts, *_ = TASKS[task]
    d = seed_dir(out, task, seed)
    record = json.loads((d / "episodes-learned.json").read_text())
    k, ep = next((k, e) for k, e in enumerate(record["episodes"]) if e["success"])
    sim, model = cls(**opts), load_model(d / "model")
    planner = make_planner("prada", sim_planning_model(model, sim), PRADA, ep["seed"])
    frames: list = []
    replay = run_episode(sim, planner, model.symbols.abstract_scene, ep["seed"], frames, record["max_primitives"])
    assert replay["actions"] == ep["actions"], "the replay differs from the recorded episode"
    fig, axes = plt.subplots(1, len(frames), figsize=(3.2 * len(frames), 2.6))
    for ax, img, title in zip(np.atleast_1d(axes), frames, ["start", *ep["actions"]]):
        ax.imshow(img)
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
    fig.suptitle(f"{TASKS[task][4]}: PRADA on the learned model, solved in {ep['env_steps']} env steps")
    path = out / f"{task}-solved.png"
    fig.savefig(path, dpi=80, bbox_inches="tight")
    return path


# ----------------------------------------------------------------------------- table

def success_rates(out: Path, task: str, arm: str) -> list[bool]:
    return [e["success"] for p in sorted(out.glob(f"{task}/seed-*/episodes-{arm}.json"))
            for e in json.loads(p.read_text())["episodes"]]


def success_png(out: Path) -> Path:
    """Bars: PRADA learned, PRADA on the true relations, the published baselines, per task."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ours = {"PRADA learned": "learned", "PRADA true relations": "true-relations", "random primitives": "random"}
    names = [*ours, "bilevel planning", "diffusion policy", "PPO", "LLM planning"]
    tasks = [t for t in TASKS if success_rates(out, t, "learned")]
    fig, ax = plt.subplots(figsize=(8, 3.2))
    width = 0.8 / len(names)
    for i, name in enumerate(names):
        vals = [(np.mean(success_rates(out, t, ours[name]) or [np.nan])) if name in ours
                else PUBLISHED.get(t, {}).get(name, np.nan) for t in tasks]
        ax.bar(np.arange(len(tasks)) + i * width, vals, width, label=name)
    ax.set_xticks(np.arange(len(tasks)) + 0.4 - width / 2, [TASKS[t][4] for t in tasks])
    ax.set_ylabel("success within 3,000 steps")
    ax.set_ylim(0, 1.05)
    ax.legend(fontsize=7, ncol=3, loc="upper center", bbox_to_anchor=(0.5, -0.12))
    path = out / "kinder-success.png"
    fig.savefig(path, dpi=80, bbox_inches="tight")
    return path


def table(out: Path) -> str:
    lines = ["| task | seeds | F1 per relation (mean over seeds) | PRADA learned | PRADA true relations "
             "| random primitives | published |", "|---|---|---|---|---|---|---|"]
    for task, (cls, *_rest, kid) in TASKS.items():
        seeds = sorted(out.glob(f"{task}/seed-*/f1.json"))
        if not seeds:
            continue
        f1 = [json.loads(p.read_text()) for p in seeds]
        means = {r: np.mean([f[r] for f in f1 if r in f]) for r in cls.truth_predicates}
        cells = []
        for arm in ("learned", "true-relations", "random"):
            wins = success_rates(out, task, arm)
            cells.append(f"{np.mean(wins):.2f} ({len(wins)} episodes)" if wins else "-")
        pub = ", ".join(f"{k} {v:.2f}" for k, v in PUBLISHED.get(task, {}).items()) or "-"
        lines.append(f"| {kid} | {len(f1)} | " + ", ".join(f"{r} {v:.2f}" for r, v in means.items())
                     + f" | {' | '.join(cells)} | {pub} |")
    return "\n".join(lines)


def per_seed(out: Path) -> str:
    """Per task and arm: the success of each seed and the median environment steps of a solved episode."""
    lines = []
    for task in TASKS:
        for arm in ("learned", "true-relations", "random"):
            runs = [json.loads(p.read_text())["episodes"] for p in sorted(out.glob(f"{task}/seed-*/episodes-{arm}.json"))]
            if not runs:
                continue
            steps = [e["env_steps"] for r in runs for e in r if e["success"]]
            rates = ", ".join(f"{np.mean([e['success'] for e in r]):.2f} ({len(r)})" for r in runs)
            lines.append(f"- {task} {arm}: per seed {rates}; median env steps of a solved episode "
                         f"{np.median(steps) if steps else float('nan'):.0f}")
    return "\n".join(lines)


def seed_range(text: str) -> range:
    first, _, last = text.partition("-")
    if not (first.isdigit() and (not last or last.isdigit())):
        raise argparse.ArgumentTypeError(f"expected N or A-B, got {text!r}")
    return range(int(first), int(last) + 1) if last else range(int(first))


def arm_list(text: str) -> tuple[str, ...]:
    arms = tuple(a.replace("-", " ") for a in text.split(","))
    bad = [a for a in arms if a not in ARMS]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown arm {bad[0]!r}; expected learned, true-relations, random")
    return arms


def shard_spec(text: str) -> tuple[int, int]:
    k, _, n = text.partition("/")
    if not (k.isdigit() and n.isdigit() and int(k) < int(n)):
        raise argparse.ArgumentTypeError(f"expected K/N with 0 <= K < N, got {text!r}")
    return int(k), int(n)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=("symbols", "planning", "table", "picture", "terms"))
    ap.add_argument("--task", choices=sorted(TASKS), default="b1")
    ap.add_argument("--seeds", type=seed_range, default=range(5),
                    help="N (seeds 0 to N-1) or A-B (seeds A to B): runs of other seeds may go on beside")
    ap.add_argument("--traces", type=int, default=50)
    ap.add_argument("--length", type=int, default=10)
    ap.add_argument("--evals", type=int, default=20000)
    ap.add_argument("--episodes", type=int, default=50)
    ap.add_argument("--max-primitives", type=int, default=NO_CAP,
                    help="primitives per episode at most; 0 (default): none, only KinDER's 3,000 env steps")
    ap.add_argument("--random-episodes", type=int, default=10,
                    help="episodes of the random-primitive arm per seed (the first of the same episode seeds)")
    ap.add_argument("--arms", type=arm_list, default=ARMS,
                    help="planning: the arms to run, of learned,true-relations,random (default: all)")
    ap.add_argument("--shard", type=shard_spec, default=(0, 1),
                    help="planning: K/N runs the episodes whose index is K modulo N (N processes share a seed)")
    ap.add_argument("--out", type=Path, default=Path("results/kinder"))
    args = ap.parse_args(argv)
    if args.what == "table":
        print(table(args.out))
        print(per_seed(args.out))
        print(f"wrote {success_png(args.out)}", file=sys.stderr)
        return 0
    if args.what == "terms":
        print(loss_terms(args.task, args.out, args.seeds))
        return 0
    if args.what == "picture":
        print(f"wrote {picture(args.task, args.out, args.seeds[0])}")
        return 0
    for seed in args.seeds:
        if args.what == "symbols":
            f1 = learn_seed(args.task, seed, args.out, args.traces, args.length, args.evals)
            atomic_write_json(seed_dir(args.out, args.task, seed) / "f1.json", f1)
            print(f"{args.task} seed {seed}: F1 {f1}")
        else:
            plan_seed(args.task, seed, args.out, args.episodes, args.max_primitives, args.random_episodes,
                      args.arms, args.shard)
    return 0


if __name__ == "__main__":
    sys.exit(main())
