"""The model directory: everything learned from one dataset, in files a person can read.

``learn_symbolic_model`` writes ``rules.json`` + ``rules.txt`` (NID rules), ``reward.json`` (the
relational reward model) and ``symbolic-traces.json`` (the symbolic training data, which the
symbolic nearest-neighbour planner and ``export-domain`` need); ``groundsym learn`` adds
``symbols.json`` and ``traces.json`` beside them when it learned symbols from continuous data.
``load_model`` reads a directory back as one frozen :class:`Model`; the larger, optional parts
(symbols, traces) load on first use.

A directory is replaced whole (:func:`model_transaction`): the new model is built in a hidden sibling
folder, then swapped in with two renames, so the path always holds a complete model, old or new. A
crash between the renames leaves a named backup (``.NAME.backup``) that the next command touching the
directory puts back (:func:`recover`). ``manifest.json`` records the SHA-256 of every part, and
loading refuses a directory whose parts do not belong together.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from . import staging
from .errors import UserError
from .fileio import atomic_write_json, current_umask, dumps_json, file_sha256, read_json
from .provenance import provenance
from .reward import RewardModel, fit_reward, read_reward, write_reward
from .rules.evaluate import score_ruleset
from .rules.io import read_rules, write_rules, write_rules_text
from .rules.learner import ALPHA, LearnOptions, examples_from_dataset, learn_rules
from .rules.language import Language
from .rules.successful import SuccessOptions, has_failures, learn_from_successes
from .rules.model import P_MIN, RuleSet
from .symbolic_traces import SymbolicDataset, object_types, read_symbolic_traces, symbolic_traces_doc

RULES, RULES_TXT, REWARD, SYMBOLIC = "rules.json", "rules.txt", "reward.json", "symbolic-traces.json"
SYMBOLS, TRACES = "symbols.json", "traces.json"
MANIFEST, MANIFEST_SCHEMA = "manifest.json", "groundsym.model/1"
PARTS = (RULES, RULES_TXT, REWARD, SYMBOLIC, SYMBOLS, TRACES)


RULE_MODES = ("auto", "nid", "successful-only")


def learn_symbolic_model(sds: SymbolicDataset, out_dir: Path, *, seed: int, argv: list[str],
                         alpha: float | None = None, p_min: float | None = None,
                         progress: bool = True, mode: str = "auto", language: Language | None = None) -> None:
    """Learn NID rules and a reward model from symbolic traces and write them to ``out_dir``.

    ``mode``: ``nid`` learns contexts from the failures in the data (random primitives, the
    paper's setting); ``successful-only`` learns the most specific contexts the examples support
    (plans, demonstrations: docs/rules.md, Successful-only traces); ``auto`` takes the second
    where no action leaves its state unchanged. Callers that collect random primitives pass
    ``nid``: a small sample in which every primitive happened to change something is still not a
    plan. ``language``: the constants and negated literals successful-only contexts may use
    (:func:`groundsym.rules.successful.trace_language`; default: all negated literals, no constants)."""
    if mode not in RULE_MODES:
        raise UserError(f"rule learning mode: expected one of {', '.join(RULE_MODES)}, got {mode!r}")
    if sds.n_transitions < 1:
        raise UserError("symbolic traces: traces: no transitions to learn from")
    if alpha is not None and alpha < 0:
        raise UserError(f"--alpha: must be at least 0, got {alpha}")
    if p_min is not None and not 0 < p_min < 1:
        raise UserError(f"--p-min: must be in (0, 1), got {p_min}")
    out_dir = Path(out_dir)
    data_doc = symbolic_traces_doc(sds)
    data_sha = hashlib.sha256(dumps_json(data_doc, indent=None).encode()).hexdigest()
    opts = LearnOptions(alpha=ALPHA if alpha is None else alpha, p_min=P_MIN if p_min is None else p_min)
    prov = provenance(argv, seed=seed, data_sha256=data_sha)
    examples = examples_from_dataset(sds)
    extra: dict[str, Any] = {}
    if mode == "nid" or (mode == "auto" and has_failures(examples)):
        rs, report = learn_rules(examples, sds.predicates, opts, seed=seed, progress=progress)
    else:       # plans, demonstrations: no failure to learn contexts from (docs/rules.md, Successful-only traces)
        lang = language or Language()
        rs, report = learn_from_successes(examples, sds.predicates, tuple(object_types(sds)),
                                          SuccessOptions(alpha=opts.alpha, p_min=opts.p_min, negative=lang.negative),
                                          seed=seed, constants=lang.constants)
        extra = {"mode": "successful-only", "constants": list(lang.constants), "negative_preconditions": lang.negative,
                 "threshold": next(iter(report.per_action.values()), {}).get("threshold", 1.0)}
    covers = score_ruleset(rs, sds).covers
    reward = fit_reward(sds, seed=seed)
    options = {"alpha": opts.alpha, "p_min": opts.p_min, "p_min_default": opts.p_min_default,
               "default_clip": list(opts.default_clip), "nochange_prior": opts.nochange_prior,
               "score": report.score,
               "transitions": sds.n_transitions, **extra}
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
    """Read a model directory; one clear error line if it is not one or its parts do not match."""
    d = Path(directory)
    recover(d)
    if not d.is_dir():
        raise UserError(f"{d}: not a model directory (expected a directory holding {RULES})")
    if not (d / RULES).exists():
        raise UserError(f"{d}: not a model directory (no {RULES})")
    check_manifest(d)
    rules, meta = read_rules(d / RULES)
    reward = read_reward(d / REWARD) if (d / REWARD).exists() else RewardModel((), (), 0.0, ())
    model = Model(d, rules, reward, meta)
    check_vocabulary(model)
    return model


# ------------------------------------------------------------------------------ consistency
def write_manifest(d: Path) -> None:
    """Record the SHA-256 of every part present, so a part from another model is noticed on load."""
    files = {name: file_sha256(d / name) for name in PARTS if (d / name).is_file()}
    atomic_write_json(d / MANIFEST, {"schema": MANIFEST_SCHEMA, "files": files})


def check_manifest(d: Path) -> None:
    """Every part the manifest lists is present and unchanged; no part it does not list is present.
    A directory without a manifest (written by an older version, or by hand) is not checked."""
    path = d / MANIFEST
    if not path.exists():
        return
    doc = read_json(path)
    files = doc.get("files") if isinstance(doc, dict) and doc.get("schema") == MANIFEST_SCHEMA else None
    if not isinstance(files, dict) or not all(isinstance(v, str) for v in files.values()):
        raise UserError(f"{path}: files: expected the schema {MANIFEST_SCHEMA!r} with an object of name: sha256")
    for name in PARTS:
        p = d / name
        if name not in files:
            if p.exists():
                raise UserError(f"{p}: not part of this model (the manifest does not list it); "
                                f"remove it or re-run learn")
            continue
        if not p.is_file():
            raise UserError(f"{p}: missing (the model's manifest lists it); re-run learn")
        if file_sha256(p) != files[name]:
            raise UserError(f"{p}: changed since the model was written, or from another model "
                            f"(its SHA-256 does not match {MANIFEST}); re-run learn")


def check_vocabulary(model: Model) -> None:
    """Rules, reward and symbols speak of the same predicates with the same arities."""
    d = model.path
    preds = model.meta.get("predicates")
    if not isinstance(preds, dict):
        return
    for name, arity in model.reward.predicates:
        if preds.get(name) != arity:
            raise UserError(f"{d / REWARD}: predicates.{name}: not a predicate of {d / RULES} "
                            f"with arity {arity} (the two files are from different models)")
    if (d / SYMBOLS).is_file():
        doc = read_json(d / SYMBOLS)
        symbols = doc.get("symbols") if isinstance(doc, dict) else None
        if not isinstance(symbols, list):
            raise UserError(f"{d / SYMBOLS}: symbols: expected a list")
        for sym in symbols:
            name, arity = (sym.get("name"), sym.get("arity")) if isinstance(sym, dict) else (None, None)
            if preds.get(name) != arity:
                raise UserError(f"{d / SYMBOLS}: symbols: {name!r} (arity {arity}) is not a predicate of "
                                f"{d / RULES} (the two files are from different models)")


# ------------------------------------------------------------------------------ replacing a model whole
def _backup(d: Path) -> Path:
    d = Path(os.path.abspath(d))   # ``-o .`` has no name of its own
    return d.with_name(f".{d.name}.backup")


def recover(d: Path) -> None:
    """Finish or undo a swap a crash interrupted: with no model at ``d`` but a backup, the backup
    (the old model) goes back; with both, the swap had finished and the backup goes."""
    backup = _backup(Path(d))
    if not backup.is_dir():
        return
    if os.path.lexists(d):
        shutil.rmtree(backup, ignore_errors=True)
    else:
        os.rename(backup, d)


def check_model_output(d: Path) -> None:
    """``-o DIR`` may be new, empty or a model directory; anything else is refused before any work
    (replacing a folder of other files would lose them)."""
    recover(d)
    if os.path.islink(d):
        raise UserError(f"{d}: is a symbolic link; give the model directory itself")
    if not os.path.lexists(d):
        for anc in d.parents:
            if anc.exists():
                if not anc.is_dir():
                    raise UserError(f"{d}: cannot write ({anc} is a file, not a directory)")
                if not os.access(anc, os.W_OK | os.X_OK):
                    raise UserError(f"{d}: cannot write (no permission in {anc})")
                break
        return
    if not d.is_dir():
        raise UserError(f"{d}: exists and is not a directory")
    entries = sorted(os.listdir(d))
    if entries and RULES not in entries and SYMBOLS not in entries:
        raise UserError(f"{d}: a folder that holds no model ({entries[0]}, ...); refusing to replace it, "
                        f"choose another -o")
    for e in entries:
        if (d / e).is_dir() and not (d / e).is_symlink():
            raise UserError(f"{d}: holds a folder {e!r} that is not part of a model; refusing to replace it")
    if not os.access(d.parent, os.W_OK | os.X_OK):
        raise UserError(f"{d}: cannot replace (no permission in {d.parent})")


@contextmanager
def model_transaction(d: str | Path) -> Iterator[Path]:
    """Build a model in a sibling staging folder (yielded), then put it at ``d`` in place of the old.

    On an exception or Ctrl-C the staging folder goes and ``d`` is untouched. Files at ``d`` that
    are not model parts (a checkpoint, say) are carried over into the new directory. The folder's
    name records its owner (``groundsym.staging``), so one a hard kill left behind is removed by the
    next transaction on ``d`` once its owner is dead.
    """
    d = Path(os.path.abspath(d))
    check_model_output(d)
    try:
        d.parent.mkdir(parents=True, exist_ok=True)
        staging.remove_stale(d)    # left by writers killed outright (kill -9); a live one's stays
        stage = staging.make(d)
        os.chmod(stage, 0o777 & ~current_umask())   # mkdtemp makes 0700; give the folder the user's usual mode
    except OSError as exc:
        raise UserError(f"{d}: cannot write ({exc.strerror or exc})") from None
    try:
        yield stage
        if d.is_dir():
            _carry_over(d, stage)
        write_manifest(stage)
        try:
            _swap(stage, d)
        except OSError as exc:   # e.g. another command put a directory at d between the renames
            recover(d)
            raise UserError(f"{d}: cannot put the new model in place ({exc.strerror or exc}); "
                            f"the old one is kept") from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _carry_over(old: Path, new: Path) -> None:
    for name in os.listdir(old):
        if name in PARTS or name == MANIFEST or os.path.lexists(new / name):
            continue
        try:
            os.link(old / name, new / name, follow_symlinks=False)
        except OSError:
            shutil.copy2(old / name, new / name, follow_symlinks=False)


def _swap(stage: Path, d: Path) -> None:
    """Two renames; between them only the backup holds the old model (see :func:`recover`)."""
    backup = _backup(d)
    if os.path.lexists(d):
        os.rename(d, backup)
    os.rename(stage, d)
    shutil.rmtree(backup, ignore_errors=True)
