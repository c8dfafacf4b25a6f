"""The model directory: everything learned from one dataset, in files a person can read.

``learn_symbolic_model`` writes ``rules.json`` + ``rules.txt`` (NID rules), ``reward.json`` (the
relational reward model) and ``symbolic-traces.json`` (the symbolic training data, which the
symbolic nearest-neighbour planner and ``export-domain`` need); ``groundsym learn`` adds
``symbols.json`` and ``traces.json`` beside them when it learned symbols from continuous data.
``load_model`` reads a directory back as one frozen :class:`Model`; the larger, optional parts
(symbols, traces) load on first use.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from .errors import UserError
from .fileio import atomic_write_json, dumps_json
from .provenance import provenance
from .reward import RewardModel, fit_reward, read_reward, write_reward
from .rules.evaluate import score_ruleset
from .rules.io import read_rules, write_rules, write_rules_text
from .rules.learner import ALPHA, LearnOptions, examples_from_dataset, learn_rules
from .rules.model import P_MIN, RuleSet
from .symbolic_traces import SymbolicDataset, dataset_to_doc, read_symbolic_traces

RULES, RULES_TXT, REWARD, SYMBOLIC = "rules.json", "rules.txt", "reward.json", "symbolic-traces.json"
SYMBOLS, TRACES = "symbols.json", "traces.json"


def learn_symbolic_model(sds: SymbolicDataset, out_dir: Path, *, seed: int, argv: list[str],
                         alpha: float | None = None, p_min: float | None = None,
                         progress: bool = True) -> None:
    """Learn NID rules and a reward model from symbolic traces and write them to ``out_dir``."""
    if sds.n_transitions < 1:
        raise UserError("symbolic traces: traces: no transitions to learn from")
    if alpha is not None and alpha < 0:
        raise UserError(f"--alpha: must be at least 0, got {alpha}")
    if p_min is not None and not 0 < p_min < 1:
        raise UserError(f"--p-min: must be in (0, 1), got {p_min}")
    out_dir = Path(out_dir)
    data_doc = dataset_to_doc(sds)
    data_sha = hashlib.sha256(dumps_json(data_doc, indent=None).encode()).hexdigest()
    opts = LearnOptions(alpha=ALPHA if alpha is None else alpha, p_min=P_MIN if p_min is None else p_min)
    prov = provenance(argv, seed=seed, data_sha256=data_sha)
    rs, report = learn_rules(examples_from_dataset(sds), sds.predicates, opts, seed=seed, progress=progress)
    covers = score_ruleset(rs, sds).covers
    reward = fit_reward(sds, seed=seed)
    options = {"alpha": opts.alpha, "p_min": opts.p_min, "p_min_default": opts.p_min_default,
               "default_clip": list(opts.default_clip), "nochange_prior": opts.nochange_prior,
               "score": report.score,
               "transitions": sds.n_transitions}
    data_doc["meta"] = {**data_doc.get("meta", {}), "provenance": prov}
    atomic_write_json(out_dir / SYMBOLIC, data_doc, indent=None)
    write_rules(out_dir / RULES, rs, predicates=sds.predicates, primitives=sds.primitives, covers=covers,
                options=options, provenance=prov)
    write_rules_text(out_dir / RULES_TXT, rs, covers, title=f"NID rules learned from {sds.n_transitions} "
                     f"transitions (alpha {opts.alpha:g}, seed {seed})")
    write_reward(out_dir / REWARD, reward, prov)


@dataclass(frozen=True, eq=False)
class Model:
    """A loaded model directory. ``symbols``, ``traces`` and ``symbolic_traces`` load lazily."""

    path: Path
    rules: RuleSet
    reward: RewardModel
    meta: dict[str, Any] = field(default_factory=dict)

    def __str__(self) -> str:
        return f"Model({self.path}: {len(self.rules.rules)} rules, {len(self.reward.features)} reward terms)"

    @property
    def predicates(self) -> dict[str, int]:
        return dict(self.meta.get("predicates") or dict(self.reward.predicates))

    @property
    def primitives(self) -> dict[str, int]:
        return dict(self.meta.get("primitives") or {})

    @cached_property
    def symbols(self) -> Any:
        """The learned symbols (``groundsym.symbols``) if the directory has ``symbols.json``, else None."""
        p = self.path / SYMBOLS
        if not p.exists():
            return None
        from .symbols import load_symbols   # the symbol-learning module; only needed when present
        return load_symbols(p)

    @cached_property
    def traces(self) -> Any:
        """The continuous training traces (``traces.json``) if present, else None."""
        p = self.path / TRACES
        if not p.exists():
            return None
        from .traces import read_traces
        return read_traces(p)

    @cached_property
    def symbolic_traces(self) -> SymbolicDataset | None:
        p = self.path / SYMBOLIC
        return read_symbolic_traces(p) if p.exists() else None


def load_model(directory: str | Path) -> Model:
    """Read a model directory; one clear error line if it is not one."""
    d = Path(directory)
    if not d.is_dir():
        raise UserError(f"{d}: not a model directory (expected a directory holding {RULES})")
    if not (d / RULES).exists():
        raise UserError(f"{d}: not a model directory (no {RULES})")
    rules, meta = read_rules(d / RULES)
    reward = read_reward(d / REWARD) if (d / REWARD).exists() else RewardModel((), (), 0.0, ())
    return Model(d, rules, reward, meta)
