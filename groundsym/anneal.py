"""Simulated annealing over a population of candidate symbol sets (paper Section VI).

Each restart anneals a small population of candidate symbol sets. A step picks a candidate and
either perturbs one of its symbols (centre moved by a fraction of its widths, widths scaled in log
space), re-seeds it (a centre drawn from the data, with random or with its old widths), or swaps one whole symbol with
another candidate (the paper's operator that speeds convergence). Moves are accepted by the
Metropolis rule under a geometric temperature schedule, given per transition so it scales with
the data; candidate k of the population runs at ``ladder**k`` times that temperature, and
neighbouring candidates trade states by replica exchange (``ladder=1``: one temperature, no
trades). Late re-seeds can be basin hops that settle the new symbol before they are judged
(``hop_steps``). Restarts are independent (own seed from the run's seed) and run in parallel
worker processes, in rounds of ``chunk`` evaluations; the best over all restarts wins. Everything a
restart needs to continue is a JSON-able state, so a run can be checkpointed after every round
and resumed to the same result, and the result never depends on the number of workers.

At the end, symbols that are never or always true on the training data are pruned and the rest
renamed ``u1, u2, ...`` / ``b1, b2, ...``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from . import compiled
from .errors import UserError
from .executors import ProcessExecutor, RayExecutor
from .fileio import atomic_write_json, read_json
from .loss import Loss, LossConfig, LossData, LossTerms, active_columns
from .symbols import Symbol, binary_truth, unary_truth

CHECKPOINT_SCHEMA = "groundsym.anneal-checkpoint/1"


LOOKS = ("independent", "subset")   # how a new symbol chooses the dimensions it ignores


@dataclass(frozen=True)
class AnnealConfig:
    """Search settings; ``evals`` is the total budget over all restarts (the paper used ~1e5)."""

    n_unary: int = 1
    n_binary: int = 1
    evals: int = 100_000
    restarts: int = 4
    population: int = 4
    t_start: float = 0.05        # initial temperature, nats per transition
    t_end: float = 0.0005        # final temperature, nats per transition
    p_reseed: float = 0.3        # 0.1 found inhand+on in 2 of 5 grounding seeds at 2e4 evals, 0.3 in 5
    p_swap: float = 0.1
    step: float = 0.3            # perturbation: centre moves ~ step x width, log-widths ~ step
    width_range: tuple[float, float] = (0.05, 2.0)  # shape of new widths, x the data's spread
    share_range: tuple[float, float] = (0.005, 0.3)  # a new symbol holds for this share of the data
    p_moved: float = 0.5         # share of new centres drawn from objects a primitive moved (pairs: involved)
    p_ignore: float = 0.25       # a new symbol ignores each feature dimension with this probability
    looks: str = "independent"   # or "subset": how many dimensions a new symbol looks at is uniform
    chunk: int = 500             # evaluations per restart between checkpoints
    hop_steps: int = 0           # >0: late re-seeds are basin hops, the new symbol settled this many steps
    hop_after: float = 0.5       # share of a restart's budget after which re-seeds hop (with hop_steps > 0)
    ladder: float = 3.0          # candidate k runs at ladder**k x the temperature (replica exchange;
                                 # 1: one temperature): at 88e004a cubes and balls 2 -> 5 of 10, the tower
                                 # 7 -> 8 (later runs: docs/symbols.md)
    p_exchange: float = 0.1      # with ladder > 1: per move, chance to offer neighbours' states a trade

    def __post_init__(self) -> None:
        if self.n_unary < 0 or self.n_binary < 0 or self.n_unary + self.n_binary == 0:
            raise ValueError("need at least one symbol to learn")
        if self.restarts < 1 or self.population < 1 or self.evals < self.restarts:
            raise ValueError("need at least one restart, one candidate and one evaluation per restart")
        if not 0 <= self.p_ignore < 1:
            raise ValueError(f"p_ignore must be in [0, 1), got {self.p_ignore}")
        if self.looks not in LOOKS:
            raise ValueError(f"looks must be one of {', '.join(LOOKS)}, got {self.looks!r}")
        for name in ("p_reseed", "p_swap", "p_moved"):
            if not 0 <= getattr(self, name) <= 1:
                raise ValueError(f"{name} must be in [0, 1], got {getattr(self, name)}")
        for name in ("t_start", "t_end", "step"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"{name} must be a finite number above 0, got {getattr(self, name)}")
        for name in ("width_range", "share_range"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                raise ValueError(f"{name} must be two finite numbers 0 < lo <= hi, got {lo},{hi}")
        if self.share_range[1] > 1:
            raise ValueError(f"share_range is a share of the data, at most 1, got {self.share_range[1]}")
        if self.chunk < 1:
            raise ValueError(f"chunk must be at least 1, got {self.chunk}")
        if self.hop_steps < 0:
            raise ValueError(f"hop_steps must be 0 (no hops) or more, got {self.hop_steps}")
        if not 0 <= self.hop_after <= 1:
            raise ValueError(f"hop_after must be in [0, 1], got {self.hop_after}")
        if not (math.isfinite(self.ladder) and self.ladder >= 1):
            raise ValueError(f"ladder must be a finite number of at least 1, got {self.ladder}")
        if not 0 <= self.p_exchange <= 1:
            raise ValueError(f"p_exchange must be in [0, 1], got {self.p_exchange}")

    def budget(self, restart: int) -> int:
        base, extra = divmod(self.evals, self.restarts)
        return base + (1 if restart < extra else 0)

    def to_doc(self) -> dict[str, Any]:
        d = asdict(self)
        d["width_range"] = list(self.width_range)
        d["share_range"] = list(self.share_range)
        return d


# ----------------------------------------------------------------------------- candidates

Candidate = list[Symbol]


def _slot_name(arity: int, k: int) -> str:
    return f"{'u' if arity == 1 else 'b'}{k + 1}"


def _slots(cfg: AnnealConfig) -> list[tuple[int, str]]:
    return [(1, _slot_name(1, k)) for k in range(cfg.n_unary)] + [(2, _slot_name(2, k)) for k in range(cfg.n_binary)]


_POINTS: dict[int, tuple] = {}


def _points(data: LossData) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where new symbols centre (memoised for the last data): the object and distinct-pair feature
    vectors of all scenes; the objects a primitive moved (by more than the ``change_tol`` the data
    was prepared with, as a share of a feature's spread), before and after the move; and the
    ordered pairs of distinct objects a primitive *involved* (its arguments and the objects it
    moved), in the scene after it.

    Why those pairs: a relation that a primitive brings about holds between the objects it acted
    on and moved (``openHandOver(X)`` puts the held object on ``X``), and such pairs are rare among
    all pairs (``on`` holds for 1-2% of the tower's pairs, for 60-74% of these). Drawn from all
    pairs, or from every pair with a moved object, 0.03% to 0.13% of the binary proposals matched
    ``on`` or ``above`` (F1 >= 0.8); from these, 0.6% to 1.8% (``examples/proposal_rates.py``,
    docs/symbols.md).
    """
    hit = _POINTS.get(id(data))
    if hit is None or hit[0] is not data:
        m = data.features.shape[1]
        off = ~np.eye(m, dtype=bool)
        unary = data.features.reshape(-1, data.features.shape[-1])
        pairs = data.pairs[:, off].reshape(-1, data.pairs.shape[-1])
        moved = (np.abs(data.features[data.post] - data.features[data.pre]) / data.unary_scale).max(-1) \
            > data.change_tol                                                      # (T, M)
        scenes = np.concatenate([data.pre, data.post])
        mu = data.features[scenes][np.concatenate([moved, moved])]
        involved = moved | (data.lock != 0)                                        # (T, M)
        pair_inv = involved[:, :, None] & involved[:, None, :] & off[None]
        pi = data.pairs[data.post][pair_inv]
        _POINTS.clear()
        hit = _POINTS[id(data)] = (data, unary, pairs, mu if len(mu) else unary, pi if len(pi) else pairs)
    return hit[1], hit[2], hit[3], hit[4]


IGNORE_WIDTH = 100.0  # an ignored dimension's width, x the data's spread (the loss caps its cost)


def _ignored_dimensions(rng: np.random.Generator, n: int, cfg: AnnealConfig) -> np.ndarray:
    """Which of ``n`` dimensions a new symbol ignores: each with probability ``p_ignore``
    (``looks="independent"``, never all), or all but a random subset whose size is uniform in 1..n
    (``looks="subset"``: symbols of one dimension, such as size or height alone, as often as any)."""
    if cfg.looks == "subset":
        ignore = np.ones(n, dtype=bool)
        ignore[rng.choice(n, int(rng.integers(1, n + 1)), replace=False)] = False
        return ignore
    ignore = rng.random(n) < cfg.p_ignore
    if ignore.all():
        ignore[int(rng.integers(n))] = False
    return ignore


def _random_symbol(rng: np.random.Generator, arity: int, name: str, data: LossData, cfg: AnnealConfig) -> Symbol:
    """A centre drawn from the data (an object or an ordered pair of distinct objects; half of the
    time an object that a primitive moved, before or after the move, or a pair of objects that a
    primitive involved, after it, since symbols should reflect what primitives change:
    :func:`_points`) and random widths. Some dimensions are ignored (a width far beyond the
    data's spread; which ones: :func:`_ignored_dimensions`): symbols such as ``ball`` (by size, at
    any position) or "in the same stack" (any height difference) say nothing about some
    dimensions, and random widths almost never find that. The widths of the other dimensions are
    then scaled so that the symbol holds for a random share of the data (0.5% to 30%, log-uniform;
    :func:`share_radius`).

    Without the scaling most proposals are never or almost always true (random widths over several
    dimensions rarely fit the data), and a search wastes its re-seeds on them.
    """
    unary, pairs, moved_u, moved_p = _points(data)
    pts = unary if arity == 1 else pairs
    pool = pts if rng.random() >= cfg.p_moved else (moved_u if arity == 1 else moved_p)
    centre = pool[int(rng.integers(len(pool)))]
    scale = data.unary_scale if arity == 1 else data.pair_scale
    lo, hi = np.log(cfg.width_range)
    widths = scale * np.exp(rng.uniform(lo, hi, len(scale)))
    ignore = _ignored_dimensions(rng, len(scale), cfg)
    widths[ignore] = IGNORE_WIDTH * scale[ignore]
    share = float(np.exp(rng.uniform(np.log(cfg.share_range[0]), np.log(cfg.share_range[1]))))
    used = ~ignore             # the share is set by the dimensions the symbol looks at
    dist = np.sqrt((((pts[:, used] - centre[used]) / widths[used]) ** 2).sum(-1))
    radius = share_radius(dist, share)
    if radius > 0:
        widths[used] = widths[used] * radius / np.sqrt(np.log(2.0))
    return Symbol(name, arity, np.array(centre, dtype=float), widths)


def share_radius(dist: np.ndarray, share: float) -> float:
    """A radius that holds about ``share`` of the points at distances ``dist``, midway between the
    nearest point left out and the farthest one kept.

    Midway, not at a point: features such as size take a few values only, so many points lie at
    exactly the same distance (every ball at distance 0 of a ball's size); a radius on a point
    would leave them on the boundary, and a radius of 0 would make a symbol true nowhere.
    """
    k = min(max(int(np.ceil(share * len(dist))) - 1, 0), len(dist) - 1)
    inner = float(np.partition(dist, k)[k])
    outer = dist[dist > inner]
    return (inner + float(outer.min())) / 2 if len(outer) else inner * 1.0001


def _perturb(rng: np.random.Generator, s: Symbol, cfg: AnnealConfig) -> Symbol:
    n = len(s.centre)
    dims = rng.random(n) < max(0.5, 1.0 / n)
    if not dims.any():
        dims[int(rng.integers(n))] = True
    centre = s.centre + dims * rng.normal(0, cfg.step, n) * s.widths
    widths = s.widths * np.exp(dims * rng.normal(0, cfg.step, n))
    return Symbol(s.name, s.arity, centre, widths)


# ----------------------------------------------------------------------------- one restart

@dataclass
class RestartState:
    """All a restart needs to continue: JSON-able (see :meth:`to_doc`)."""

    index: int
    budget: int
    done: int
    rng_state: dict
    population: list[Candidate]
    losses: list[float]
    best: Candidate
    best_terms: LossTerms

    @property
    def finished(self) -> bool:
        return self.done >= self.budget

    def to_doc(self) -> dict[str, Any]:
        return {"index": self.index, "budget": self.budget, "done": self.done, "rng_state": self.rng_state,
                "population": [[s.to_doc() for s in c] for c in self.population], "losses": self.losses,
                "best": [s.to_doc() for s in self.best], "best_terms": self.best_terms.to_doc()}

    @staticmethod
    def from_doc(doc: dict[str, Any]) -> "RestartState":
        def cand(c):
            return [Symbol(s["name"], int(s["arity"]), np.array(s["centre"], float), np.array(s["widths"], float))
                    for s in c]
        t = doc["best_terms"]
        return RestartState(int(doc["index"]), int(doc["budget"]), int(doc["done"]), doc["rng_state"],
                            [cand(c) for c in doc["population"]], [float(x) for x in doc["losses"]],
                            cand(doc["best"]),
                            LossTerms(t["effect"], t["transition"], t["reward"], t["regulariser"]))


def start_restart(index: int, seed: int, loss: Loss, cfg: AnnealConfig) -> RestartState:
    """A fresh restart: its own generator (spawned from the run's seed), a random population."""
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(cfg.restarts)[index])
    pop, losses = [], []
    best, best_terms = None, None
    for _ in range(cfg.population):
        cand = [_random_symbol(rng, a, n, loss.data, cfg) for a, n in _slots(cfg)]
        terms = loss(cand)
        pop.append(cand)
        losses.append(terms.total)
        if best_terms is None or terms.total < best_terms.total:
            best, best_terms = cand, terms
    return RestartState(index, cfg.budget(index), cfg.population, rng.bit_generator.state, pop, losses,
                        best, best_terms)


def temperature(cfg: AnnealConfig, done: int, budget: int, n_transitions: int) -> float:
    frac = min(done / max(budget, 1), 1.0)
    return n_transitions * cfg.t_start * (cfg.t_end / cfg.t_start) ** frac


def advance(state: RestartState, loss: Loss, cfg: AnnealConfig, n_evals: int) -> RestartState:
    """Run up to ``n_evals`` more evaluations of one restart (deterministic given the state)."""
    rng = np.random.default_rng()
    rng.bit_generator.state = state.rng_state
    pop = [list(c) for c in state.population]
    losses = list(state.losses)
    best, best_terms = state.best, state.best_terms
    done, stop = state.done, min(state.budget, state.done + n_evals)
    n_tr = loss.data.n_transitions
    slots = _slots(cfg)
    rungs = [cfg.ladder ** k for k in range(len(pop))]
    while done < stop:
        temp = temperature(cfg, done, state.budget, n_tr)
        if cfg.ladder > 1 and len(pop) > 1 and rng.random() < cfg.p_exchange:
            _exchange(rng, pop, losses, int(rng.integers(len(pop) - 1)), temp, rungs)
        c = int(rng.integers(len(pop)))
        slot = int(rng.integers(len(slots)))
        move = rng.random()
        # a swap costs two evaluations; it may end a round one past ``stop`` (the next round starts
        # there), so the moves drawn never depend on where rounds end (``chunk``)
        if move < cfg.p_swap and len(pop) > 1 and done + 2 <= state.budget:
            other = int((c + 1 + rng.integers(len(pop) - 1)) % len(pop))
            a, b = list(pop[c]), list(pop[other])
            a[slot], b[slot] = pop[other][slot], pop[c][slot]
            ta, tb = loss(a), loss(b)
            done += 2
            if rungs[c] == rungs[other]:     # one temperature: the plain sum (ladder=1 is the search before it)
                delta = (ta.total + tb.total - losses[c] - losses[other]) / rungs[c]
            else:
                delta = (ta.total - losses[c]) / rungs[c] + (tb.total - losses[other]) / rungs[other]
            if delta <= 0 or rng.random() < math.exp(-delta / temp):
                pop[c], pop[other], losses[c], losses[other] = a, b, ta.total, tb.total
                for cand, t in ((a, ta), (b, tb)):
                    if t.total < best_terms.total:
                        best, best_terms = cand, t
            continue
        cand = list(pop[c])
        arity, name = slots[slot]
        if move < cfg.p_swap + cfg.p_reseed:
            fresh = _random_symbol(rng, arity, name, loss.data, cfg)
            if rng.random() < 0.5:  # a new centre from the data, the widths kept
                fresh = Symbol(name, arity, fresh.centre, cand[slot].widths)
            cand[slot] = fresh
            if hops(cfg, done, state.budget):
                cand, terms = settle(rng, loss, cand, slot, cfg)
                done += 1 + cfg.hop_steps
            else:
                terms = loss(cand)
                done += 1
        else:
            cand[slot] = _perturb(rng, cand[slot], cfg)
            terms = loss(cand)
            done += 1
        delta = terms.total - losses[c]
        if delta <= 0 or rng.random() < math.exp(-delta / (temp * rungs[c])):
            pop[c], losses[c] = cand, terms.total
            if terms.total < best_terms.total:
                best, best_terms = cand, terms
    return RestartState(state.index, state.budget, done, rng.bit_generator.state, pop, losses, best, best_terms)


def _exchange(rng: np.random.Generator, pop: list[Candidate], losses: list[float], k: int, temp: float,
              rungs: list[float]) -> None:
    """Replica exchange: candidates ``k`` and ``k + 1`` (at ``temp`` x ``rungs[k]`` and the next,
    warmer rung) trade their states by the Metropolis rule of parallel tempering. It costs no
    evaluation (both losses are known).

    Why: the warm rungs keep symbols that pay off only together, e.g. ``ball`` with ``above`` on
    cubes and balls (alone, each is worth nothing: ``inhand`` + ``ball`` scores like ``inhand``),
    long enough for the partner to turn up, and the trade brings the pair down to the cold rung,
    where one annealing chain would long have dropped it."""
    a = (losses[k] - losses[k + 1]) * (1.0 / (temp * rungs[k]) - 1.0 / (temp * rungs[k + 1]))
    if a >= 0 or rng.random() < math.exp(a):
        pop[k], pop[k + 1] = pop[k + 1], pop[k]
        losses[k], losses[k + 1] = losses[k + 1], losses[k]


def hops(cfg: AnnealConfig, done: int, budget: int) -> bool:
    """Is a re-seed at ``done`` evaluations a basin hop? Late in a restart (after ``hop_after`` of
    its budget) when ``hop_steps`` is set, and only while the whole hop fits the budget (like a swap,
    so the moves drawn never depend on where rounds end)."""
    return cfg.hop_steps > 0 and done >= cfg.hop_after * budget and done + 1 + cfg.hop_steps <= budget


def settle(rng: np.random.Generator, loss: Loss, cand: Candidate, slot: int,
           cfg: AnnealConfig) -> tuple[Candidate, LossTerms]:
    """A basin hop's second half: ``hop_steps`` greedy perturbations of the re-seeded ``slot`` alone
    (the others stay), so the hop is judged by the depth of the basin it lands in, not by its raw
    first point. Costs ``1 + hop_steps`` evaluations.

    Why: late in a restart the temperature is low and a raw re-seed, however good its basin, is
    almost always worse than the well-tuned symbol it replaces, so it is rejected. Narrow basins
    (``ball``: one dimension, a tight interval) lose to wide ones (``ontable``) that way, though
    they go 2-30 nats deeper (docs/symbols.md, "Loss or search?").
    """
    best, best_terms = cand, loss(cand)
    for _ in range(cfg.hop_steps):
        trial = list(best)
        trial[slot] = _perturb(rng, best[slot], cfg)
        terms = loss(trial)
        if terms.total <= best_terms.total:
            best, best_terms = trial, terms
    return best, best_terms


# ----------------------------------------------------------------------------- parallel rounds

_WORKER: dict[str, Any] = {}


def _init_worker(data: LossData, loss_cfg: LossConfig, cfg: AnnealConfig) -> None:
    _WORKER["loss"] = Loss(data, loss_cfg)
    _WORKER["cfg"] = cfg


def _work(job: tuple[str, Any]) -> RestartState:
    kind, arg = job
    loss, cfg = _WORKER["loss"], _WORKER["cfg"]
    if kind == "start":
        index, seed = arg
        return start_restart(index, seed, loss, cfg)
    return advance(arg, loss, cfg, cfg.chunk)


@dataclass(frozen=True)
class AnnealResult:
    symbols: list[Symbol]           # after pruning and renaming
    terms: LossTerms                # loss of the best candidate (pruned symbols never count)
    candidate: list[Symbol]         # the best candidate before pruning
    pruned: list[Symbol]
    restarts: list[dict[str, Any]]  # per restart: best loss and its terms
    evaluations: int


def anneal(data: LossData, loss_cfg: LossConfig, cfg: AnnealConfig, seed: int, *, workers: int = 1,
           checkpoint: Path | None = None, data_sha256: str = "",
           report: Callable[[int, int, LossTerms | None], None] | None = None,
           executor: ProcessExecutor | RayExecutor | None = None) -> AnnealResult:
    """Run all restarts and return the best symbols.

    Each round's restarts run on ``executor`` (``groundsym.executors``: local worker processes or
    Ray tasks; default: ``workers`` local processes), with the same result wherever they run.

    ``report(done, total, best_terms)`` is called after every round (for progress output). With
    ``checkpoint``, the states are written after every round and an existing file (same data,
    seed and settings) is resumed; an interrupt stops the workers at once and leaves the last
    round's checkpoint.
    """
    total = cfg.evals
    states = _resume(checkpoint, cfg, loss_cfg, seed, data_sha256) if checkpoint else None
    executor = executor if executor is not None else ProcessExecutor(workers)
    if not executor.in_process and compiled.AVAILABLE:
        compiled.warm_up()    # load the loss kernels once here: forked workers inherit them, and
                              # a Ray worker on this machine finds them in numba's disk cache
    with executor.mapper(_init_worker, (data, loss_cfg, cfg)) as run:
        if states is None:
            states = run(_work, [("start", (r, seed)) for r in range(cfg.restarts)])
        while True:
            _save(checkpoint, states, cfg, loss_cfg, seed, data_sha256)
            if report:
                report(sum(s.done for s in states), total, min((s.best_terms for s in states), key=lambda t: t.total))
            todo = [s for s in states if not s.finished]
            if not todo:
                break
            for new in run(_work, [("advance", s) for s in todo]):
                states[new.index] = new
    return _result(states, data)


def _result(states: list[RestartState], data: LossData) -> AnnealResult:
    win = min(states, key=lambda s: (s.best_terms.total, s.index))
    kept, pruned = prune(win.best, data)
    per = [{"restart": s.index, "evaluations": s.done, **s.best_terms.to_doc()} for s in states]
    return AnnealResult(kept, win.best_terms, win.best, pruned, per, sum(s.done for s in states))


def prune(candidate: list[Symbol], data: LossData) -> tuple[list[Symbol], list[Symbol]]:
    """Drop symbols never or always true on the data; rename the rest u1.., b1.. in order."""
    unary = [s for s in candidate if s.arity == 1]
    binary = [s for s in candidate if s.arity == 2]
    ku, kb = active_columns(unary_truth(unary, data.features), binary_truth(binary, data.pairs))
    kept_u = [s for s, k in zip(unary, ku) if k]
    kept_b = [s for s, k in zip(binary, kb) if k]
    pruned = [s for s, k in zip(unary, ku) if not k] + [s for s, k in zip(binary, kb) if not k]
    kept = [s.with_name(_slot_name(1, i)) for i, s in enumerate(kept_u)]
    kept += [s.with_name(_slot_name(2, i)) for i, s in enumerate(kept_b)]
    return kept, pruned


# ----------------------------------------------------------------------------- checkpoints

def _header(cfg: AnnealConfig, loss_cfg: LossConfig, seed: int, data_sha256: str) -> dict[str, Any]:
    return {"schema": CHECKPOINT_SCHEMA, "seed": seed, "data_sha256": data_sha256,
            "anneal": cfg.to_doc(), "loss": loss_cfg.to_doc()}


def _save(path: Path | None, states: list[RestartState], cfg: AnnealConfig, loss_cfg: LossConfig,
          seed: int, data_sha256: str) -> None:
    if path is None:
        return
    doc = _header(cfg, loss_cfg, seed, data_sha256)
    doc["restarts"] = [s.to_doc() for s in states]
    atomic_write_json(path, doc, indent=None)


def _resume(path: Path, cfg: AnnealConfig, loss_cfg: LossConfig, seed: int,
            data_sha256: str) -> list[RestartState] | None:
    if not path.exists():
        return None
    doc = read_json(path)
    want = _header(cfg, loss_cfg, seed, data_sha256)
    if not isinstance(doc, dict):
        raise UserError(f"{path}: not a checkpoint (expected a JSON object)")
    for key, val in want.items():
        if _normalise(doc.get(key)) != _normalise(val):
            raise UserError(f"{path}: {key}: the checkpoint was made with other data or settings "
                            f"({doc.get(key)!r} != {val!r}); delete it or choose another --checkpoint")
    try:
        states = [RestartState.from_doc(d) for d in doc["restarts"]]
    except (KeyError, TypeError, ValueError) as exc:
        raise UserError(f"{path}: restarts: malformed checkpoint ({exc})") from None
    if sorted(s.index for s in states) != list(range(cfg.restarts)):
        raise UserError(f"{path}: restarts: expected {cfg.restarts} restarts")
    return sorted(states, key=lambda s: s.index)


def _normalise(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _normalise(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_normalise(x) for x in v]
    return v


__all__ = ["AnnealConfig", "AnnealResult", "RestartState", "anneal", "advance", "start_restart", "prune",
           "temperature"]
