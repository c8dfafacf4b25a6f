"""The search as a whole: all restarts in rounds on an executor, checkpointed, the best one pruned."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from .. import compiled
from ..executors import ProcessExecutor, RayExecutor
from ..loss import Loss, LossConfig, LossData, LossTerms, active_columns
from ..symbols import Symbol, binary_truth, unary_truth
from .checkpoint import load_checkpoint, save_checkpoint
from .config import AnnealConfig, slot_name
from .restart import RestartState, advance, start_restart

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
    states = load_checkpoint(checkpoint, cfg, loss_cfg, seed, data_sha256) if checkpoint else None
    executor = executor if executor is not None else ProcessExecutor(workers)
    if not executor.in_process and compiled.AVAILABLE:
        compiled.warm_up()    # load the loss kernels once here: forked workers inherit them, and
                              # a Ray worker on this machine finds them in numba's disk cache
    with executor.mapper(_init_worker, (data, loss_cfg, cfg)) as run:
        if states is None:
            states = run(_work, [("start", (r, seed)) for r in range(cfg.restarts)])
        while True:
            save_checkpoint(checkpoint, states, cfg, loss_cfg, seed, data_sha256)
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
    kept = [s.with_name(slot_name(1, i)) for i, s in enumerate(kept_u)]
    kept += [s.with_name(slot_name(2, i)) for i, s in enumerate(kept_b)]
    return kept, pruned
