"""An evaluation's options: what decides its numbers, their fingerprint, and their checks.

The fingerprint keeps one results folder to one evaluation: a folder resumes only with options of
the same fingerprint (:func:`groundsym.evaluation.store.check_config`).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any, Mapping, Sequence

from ..anneal import AnnealConfig
from ..errors import UserError
from ..loss import LossConfig
from ..options import parse_options
from ..registry import get_planner_class, get_sim_class
from ..sim import cell_identity

# ``model``: the n fresh model traces only (the paper's protocol); ``all``: the unit's symbol data too.
# Rules fitted on 2-5 examples each are overconfident; on all data a run already holds they are
# calibrated and more likely on held-out data (docs/rules.md, "Calibration").
RULE_DATA = ("model", "all")
# ``unit``: every unit (run x symbol-data size) collects its own model traces; ``run``: the sizes of a
# run share them, and the methods that read no symbols (RANDOM, CONTINUOUS-NN) play once per run and
# model-trace count instead of once per size (docs/planning.md, "What a unit costs").
MODEL_DATA = ("unit", "run")


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
    rule_data: str = "model"       # what rules and reward learn from: RULE_DATA (docs/planning.md)
    loss: LossConfig = LossConfig()  # the symbol-learning loss (`--loss`, as `groundsym learn` takes it)
    model_data: str = "unit"       # who collects the model traces: MODEL_DATA

    def key(self) -> dict[str, Any]:
        """The options, plus the annealer's and the loss's settings that they imply (so results from
        code with other search or loss defaults are never mixed into one evaluation)."""
        d = asdict(self)
        if self.rule_data == "model":       # the paper's protocol: folders from before the option resume
            del d["rule_data"]
        if self.model_data == "unit":       # likewise for folders from before per-run model data
            del d["model_data"]
        d["sim_options"] = dict(sorted(self.sim_options.items()))
        d["sim_cell"] = cell_identity(self.sim, self.sim_options)   # defaults and cell version too
        d["planner_options"] = {k: dict(sorted(v.items())) for k, v in sorted(self.planner_options.items())}
        learned = not self.truth_symbols
        d["anneal"] = self.anneal_config().to_doc() if learned else None
        d["loss"] = self.loss.to_doc() if learned else None
        return d

    def anneal_config(self) -> AnnealConfig:
        """The symbol search of every unit; settings it cannot take are a user error."""
        try:
            return AnnealConfig(n_unary=self.unary, n_binary=self.binary, evals=self.evals, restarts=self.restarts)
        except ValueError as exc:
            raise UserError(f"--unary/--binary/--evals/--restarts: {exc}") from None

    def fingerprint(self) -> str:
        return hashlib.sha256(json.dumps(self.key(), sort_keys=True).encode()).hexdigest()[:16]


def check_truth_symbols(names: Sequence[str], truth: Mapping[str, int]) -> None:
    """``--truth-symbols`` must name relations the simulation knows."""
    unknown = [p for p in names if p not in truth]
    if unknown:
        raise UserError(f"--truth-symbols: {', '.join(unknown)} not among the sim's relations "
                        f"({', '.join(sorted(truth))})")


def validate(cfg: EvalConfig) -> None:
    """Every option a unit will use, checked before the results folder is touched: a refused
    command must leave no config.json behind that would then refuse the corrected one."""
    sim_cls = get_sim_class(cfg.sim)
    parse_options("--sim-opt", "sim", cfg.sim, sim_cls.OPTIONS, dict(cfg.sim_options))
    check_truth_symbols(cfg.truth_symbols, getattr(sim_cls, "truth_predicates", {}) or {})
    for method in cfg.methods:
        given = dict(cfg.planner_options.get(method, {}))
        parse_options("--planner-opt", "planner", method, getattr(get_planner_class(method), "OPTIONS", ()), given)
    for method in cfg.planner_options:
        if method not in cfg.methods:
            raise UserError(f"--planner-opt {method}:...: {method} is not among --methods")
    if cfg.rule_data not in RULE_DATA:
        raise UserError(f"--rule-data {cfg.rule_data}: expected one of {', '.join(RULE_DATA)}")
    if cfg.model_data not in MODEL_DATA:
        raise UserError(f"--model-data-scope {cfg.model_data}: expected one of {', '.join(MODEL_DATA)}")
    if not cfg.truth_symbols:
        cfg.anneal_config()
