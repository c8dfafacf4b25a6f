"""One annealing restart: its state, and the moves that advance it by the Metropolis rule.

A restart's state is everything it needs to continue (generator, population, best), JSON-able,
so a run resumes from a checkpoint to exactly the result of an uninterrupted run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..loss import Loss, LossTerms
from ..symbols import Symbol
from .config import AnnealConfig, Candidate, slots
from .proposals import perturb, random_symbol

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
        cand = [random_symbol(rng, a, n, loss.data, cfg) for a, n in slots(cfg)]
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
    slot_list = slots(cfg)
    rungs = [cfg.ladder ** k for k in range(len(pop))]
    while done < stop:
        temp = temperature(cfg, done, state.budget, n_tr)
        if cfg.ladder > 1 and len(pop) > 1 and rng.random() < cfg.p_exchange:
            exchange(rng, pop, losses, int(rng.integers(len(pop) - 1)), temp, rungs)
        c = int(rng.integers(len(pop)))
        slot = int(rng.integers(len(slot_list)))
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
        arity, name = slot_list[slot]
        if move < cfg.p_swap + cfg.p_reseed:
            fresh = random_symbol(rng, arity, name, loss.data, cfg)
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
            cand[slot] = perturb(rng, cand[slot], cfg)
            terms = loss(cand)
            done += 1
        delta = terms.total - losses[c]
        if delta <= 0 or rng.random() < math.exp(-delta / (temp * rungs[c])):
            pop[c], losses[c] = cand, terms.total
            if terms.total < best_terms.total:
                best, best_terms = cand, terms
    return RestartState(state.index, state.budget, done, rng.bit_generator.state, pop, losses, best, best_terms)


def exchange(rng: np.random.Generator, pop: list[Candidate], losses: list[float], k: int, temp: float,
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
    they go 2-30 nats deeper (docs/symbols-results.md, "Loss or search?").
    """
    best, best_terms = cand, loss(cand)
    for _ in range(cfg.hop_steps):
        trial = list(best)
        trial[slot] = perturb(rng, best[slot], cfg)
        terms = loss(trial)
        if terms.total <= best_terms.total:
            best, best_terms = trial, terms
    return best, best_terms
