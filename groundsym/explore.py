"""Directed exploration: collect -> learn -> collect, choosing primitives the model knows least.

Random primitives spend most of the data on what the model already knows (in the tower cell,
releases with an empty hand and grasps of covered cubes). Lang, Toussaint & Kersting (2012),
*Exploration in relational domains for model-based reinforcement learning* (JMLR 13), count
experience per *rule context*: a state-action pair is as known as the training transitions its
covering NID rule explains, so experience generalises over objects and states the rule's context
does not tell apart; the E^3 / R-max principle then drives the robot to the least-known pairs.
That is what is implemented here (their count-based exploration, without the planning-to-explore
step: with a model whose contexts are over the acting object's neighbourhood the least-known pair
is usually one primitive away):

* round 0 runs ``round_traces`` traces of uniformly random primitives (the same traces, bit for
  bit, as ``collect_traces`` with the same seed);
* after every round, symbols and NID rules are learned on all traces so far (as ``groundsym learn``
  would, with ``evals`` loss evaluations) and kept as a model directory ``round-R`` in the work
  folder, beside the round's traces (``round-R.json``);
* in the next round, each step abstracts the scene with that model's symbols and counts each
  runnable primitive's experience: the transitions, in all data so far and in this round's steps
  before it, covered by the same rule; a primitive no rule covers is counted by its *local
  signature* (the action's name and the atoms about its arguments, other objects anonymous). As in
  E^3 / R-max, a pair is *known* once its count reaches ``known``: the step runs an unknown
  primitive of smallest count (ties drawn uniformly), or, when every primitive is known, a
  uniformly random one. Without the threshold (a first version) the least-known primitive was
  almost always one no rule covers, a release with an empty hand, say, and traces spent their
  steps on such no-ops, one signature after another.

``mode="glib"`` replaces the counting by goal babbling with a planner (``groundsym.glib``); the
rounds, the learning and the resumption are the same.

Every random choice derives from ``seed`` (``collect.trace_seeds``: trace ``i`` keeps its reset
seed and action Generator whatever the mode), learning from ``SeedSequence(seed, round)``, so the
same seed gives the same file. A round's traces and model are written atomically once it ends: an
interrupted run started again with the same options continues after the last finished round.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Hashable

import numpy as np

from .anneal import AnnealConfig, anneal
from .collect import collect_trace, trace_seeds
from .errors import UserError
from .fileio import atomic_write_json
from .glib import GlibModel, GlibOptions, glib_model, glib_trace
from .logic import Atom
from .loss import LossConfig, prepare
from .modeldir import learn_symbolic_model, load_model, model_transaction
from .progress import Progress
from .rules.model import RuleSet
from .sim import Sim, cell_meta
from .symbols import SymbolSet
from .traces import Dataset, Trace, read_traces, write_traces

MODES = ("counts", "glib")


@dataclass(frozen=True)
class ExploreConfig:
    """One exploration run: ``rounds`` x ``round_traces`` traces of ``length`` primitives, a model
    learned after each round with ``evals`` loss evaluations in ``restarts`` restarts over
    ``unary`` + ``binary`` candidate symbols."""

    rounds: int
    round_traces: int
    length: int
    evals: int = 15_000
    restarts: int = 4
    unary: int = 1
    binary: int = 1
    mode: str = "counts"
    known: int = 3
    glib: GlibOptions = GlibOptions()

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise UserError(f"--explore: {self.mode}: unknown mode (known: {', '.join(MODES)})")
        if self.rounds < 1 or self.round_traces < 1 or self.length < 1 or self.known < 1:
            raise UserError("--rounds: need at least one round of at least one trace of one primitive")
        try:
            self.anneal_config()
        except ValueError as exc:
            raise UserError(f"--explore-evals: {exc}") from None

    def anneal_config(self) -> AnnealConfig:
        return AnnealConfig(n_unary=self.unary, n_binary=self.binary, evals=self.evals, restarts=self.restarts)

    def record(self) -> dict[str, Any]:
        """The options as JSON values; GLIB's only in ``glib`` mode (a ``counts`` record is as before)."""
        out = json.loads(json.dumps(asdict(self)))
        if self.mode != "glib":
            del out["glib"]
        return out


@dataclass(frozen=True)
class RoundModel:
    """What the next round explores with: the symbols, the rules, and experience counts."""

    symbols: SymbolSet
    rules: RuleSet
    counts: dict


def local_signature(state: frozenset, action: Atom) -> tuple:
    """The action's name and the atoms about its arguments, arguments by position, others as ``*``."""
    where = {o: i for i, o in enumerate(action.args)}
    sig = {(a.predicate, tuple(f"#{where[x]}" if x in where else "*" for x in a.args))
           for a in state if any(x in where for x in a.args)}
    return (action.predicate, action.arity, tuple(sorted(sig)))


def experience_key(rules: RuleSet, state: frozenset, action: Atom, objects: tuple[str, ...]) -> Hashable:
    """The covering rule's index, or the local signature when no single rule covers."""
    rule, _ = rules.covering(state, action, objects)
    if rule is not None:
        return ("rule", rules.rules.index(rule))
    return ("none",) + local_signature(state, action)


def experience_counts(rules: RuleSet, symbols: SymbolSet, ds: Dataset) -> dict:
    """How many transitions of ``ds`` each experience key covers."""
    counts: dict = {}
    for tr in symbols.to_symbolic_dataset(ds).traces:
        for s, a, _ in tr.transitions():
            key = experience_key(rules, s, a, tr.objects)
            counts[key] = counts.get(key, 0) + 1
    return counts


def least_known(model: RoundModel, state: frozenset, actions: list[Atom], objects: tuple[str, ...],
                rng: np.random.Generator, known: int = 3) -> tuple[Atom, Hashable]:
    """An unknown primitive (count below ``known``) of smallest count, ties uniformly at random;
    when all are known, any primitive uniformly at random. Also its key."""
    keys = [experience_key(model.rules, state, a, objects) for a in actions]
    counts = np.array([model.counts.get(k, 0) for k in keys])
    ties = np.flatnonzero(counts == counts.min()) if counts.min() < known else np.arange(len(actions))
    pick = int(ties[int(rng.integers(len(ties)))])
    return actions[pick], keys[pick]


def explore_trace(sim: Sim, model: RoundModel, length: int, reset_seed: int, rng: np.random.Generator,
                  on_step=None, known: int = 3) -> Trace:
    """One trace from ``reset_seed``: each step the least-known primitive; counts grow as it goes."""
    scenes = [sim.reset(reset_seed)]
    actions = []
    for _ in range(length):
        state = model.symbols.abstract_scene(scenes[-1])
        action, key = least_known(model, state, sim.actions(), tuple(scenes[-1].objects), rng, known)
        model.counts[key] = model.counts.get(key, 0) + 1
        actions.append(action)
        scenes.append(sim.step(action))
        if on_step is not None:
            on_step()
    return Trace(scenes[0].objects, scenes, actions)


def learn_round(ds: Dataset, cfg: ExploreConfig, seed: int, out: Path) -> None:
    """Symbols and rules on all traces so far, written as a model directory at ``out``."""
    loss_cfg = LossConfig()
    result = anneal(prepare(ds, loss_cfg, str(out)), loss_cfg, cfg.anneal_config(), seed, workers=1)
    symbols = SymbolSet.for_dataset(result.symbols, ds)
    with model_transaction(out) as stage:
        symbols.save_symbols(stage / "symbols.json", extra={"loss": result.terms.to_doc(), "seed": seed})
        learn_symbolic_model(symbols.to_symbolic_dataset(ds), stage, seed=seed,
                             argv=["groundsym", "collect", "--explore"], progress=False, mode="nid")


def load_round(out: Path, ds: Dataset, cfg: ExploreConfig, gamma: float = 0.9) -> RoundModel | GlibModel:
    m = load_model(out)
    if cfg.mode == "glib":
        return glib_model(m.symbols, m.rules, ds, cfg.glib, gamma)
    return RoundModel(m.symbols, m.rules, experience_counts(m.rules, m.symbols, ds))


def check_work(work: Path, identity: dict[str, Any]) -> None:
    """A work folder belongs to one run: refuse to continue one made with other options."""
    path = work / "explore.json"
    if path.exists():
        try:
            old = json.loads(path.read_text())
        except (OSError, ValueError):
            raise UserError(f"{path}: not an exploration record (delete the folder to start afresh)") from None
        if old != identity:
            diff = sorted(k for k in set(old) | set(identity) if old.get(k) != identity.get(k))
            raise UserError(f"{path}: made with other options ({', '.join(diff)} differ): "
                            f"use another --work folder or the same options")
    else:
        atomic_write_json(path, identity)


def explore_traces(sim: Sim, cfg: ExploreConfig, seed: int, work: Path, progress: bool = True,
                   meta: dict[str, Any] | None = None) -> Dataset:
    """All rounds (resuming finished ones from ``work``), as one Dataset in trace order."""
    identity = {"sim": sim.name, "options": dict(getattr(sim, "options", {})), "seed": seed, **cfg.record()}
    work.mkdir(parents=True, exist_ok=True)
    check_work(work, identity)
    seeds = trace_seeds(seed, cfg.rounds * cfg.round_traces)
    bar = Progress(cfg.rounds * cfg.round_traces * cfg.length, f"explore {sim.name}", enabled=progress)
    traces: list[Trace] = []
    model: RoundModel | GlibModel | None = None
    for r in range(cfg.rounds):
        path = work / f"round-{r}.json"
        if path.exists():
            traces.extend(read_traces(path).traces)
            bar.update(len(traces) * cfg.length, f"round {r + 1}/{cfg.rounds} (kept)")
        else:
            mine = seeds[r * cfg.round_traces:(r + 1) * cfg.round_traces]
            got = [run_trace(sim, model, cfg, s, rng, lambda: bar.update(bar.done + 1, f"round {r + 1}"))
                   for s, rng in mine]
            done = {"round": r, **({"glib": dict(model.stats)} if isinstance(model, GlibModel) else {})}
            write_traces(path, dataset(sim, got, done))
            traces.extend(got)
        if r + 1 < cfg.rounds:
            so_far = dataset(sim, traces, {})
            out = work / f"round-{r}"
            if not (out / "rules.json").exists():
                bar.update(bar.done, f"round {r + 1}: learning")
                learn_round(so_far, cfg, int(np.random.SeedSequence([seed, r]).generate_state(1)[0]), out)
            model = load_round(out, so_far, cfg, float(getattr(sim, "gamma", 0.9)))
    bar.close()
    info = {"sim": sim.name, "options": dict(getattr(sim, "options", {})), "seed": seed,
            "traces": len(traces), "length": cfg.length, **cell_meta(sim),
            "explore": {k: v for k, v in cfg.record().items() if k != "length"}}
    info.update(meta or {})
    return dataset(sim, traces, info)


def run_trace(sim: Sim, model: RoundModel | GlibModel | None, cfg: ExploreConfig, reset_seed: int,
              rng: np.random.Generator, on_step) -> Trace:
    if model is None:
        return collect_trace(sim, cfg.length, reset_seed, rng, on_step)
    if isinstance(model, GlibModel):
        return glib_trace(sim, model, cfg.glib, cfg.length, reset_seed, rng, on_step)
    return explore_trace(sim, model, cfg.length, reset_seed, rng, on_step, cfg.known)


def dataset(sim: Sim, traces: list[Trace], meta: dict[str, Any]) -> Dataset:
    if getattr(sim, "pair_feature_names", None):
        meta = {**meta, "pair_feature_names": list(sim.pair_feature_names)}
    return Dataset(list(traces), tuple(sim.feature_names), dict(sim.primitives), meta)
