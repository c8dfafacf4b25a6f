"""The results folder, which an interrupted evaluation resumes from.

``OUT/config.json`` holds the options' fingerprint, ``OUT/runs/N{N}-run{r}.json`` one finished
unit's record and ``OUT/models/`` its models. Only the driver writes here, atomically, as each unit
finishes (the units themselves may run on other machines, ``groundsym.executors``); a unit counts
as done once its record exists, so the same command resumes with the units left.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping

from ..errors import UserError
from ..fileio import atomic_write_json, atomic_write_text, read_json
from .config import EvalConfig, validate

UNIT_SCHEMA = "groundsym.evaluation-unit/1"


def unit_path(out: Path, n_symbol: int, run: int) -> Path:
    return out / "runs" / f"N{n_symbol}-run{run:03d}.json"


def check_config(out: Path, cfg: EvalConfig) -> None:
    """Resume only an evaluation with the same options; never mix two. The executor is not an
    option here: a folder started on one executor resumes on any other."""
    validate(cfg)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a directory")
    path = out / "config.json"
    if path.exists():
        old = read_json(path)
        if old.get("fingerprint") != cfg.fingerprint():
            raise UserError(f"{path}: {out} holds an evaluation with other options; "
                            f"resume it with the same options or choose another -o")
    else:
        atomic_write_json(path, {"fingerprint": cfg.fingerprint(), "config": cfg.key()})


def save_unit(out: Path, result: Mapping[str, Any]) -> None:
    """Write a finished unit's models, then its record (whose presence means the unit is done); a
    whole run's result (``units``: a record per symbol-data size) writes every record last."""
    for folder, files in result["models"].items():
        for name, text in files.items():
            atomic_write_text(out / "models" / folder / name, text)
    for unit in result.get("units") or [result["unit"]]:
        atomic_write_json(unit_path(out, unit["symbol_data"], unit["run"]), unit)


def finished_units(out: Path, cfg: EvalConfig, runs: int) -> list[dict[str, Any]]:
    """The records of the units finished so far, checked (:func:`check_unit`), in run order."""
    units = []
    for r in range(runs):
        for N in cfg.symbol_data:
            p = unit_path(out, N, r)
            if p.exists():
                units.append(check_unit(read_json(p), p, cfg, N, r))
    return units


def check_unit(u: Any, path: Path, cfg: EvalConfig, n_symbol: int, run: int) -> dict[str, Any]:
    """A finished unit's record as ``aggregate`` reads it; a damaged one is one line naming the field."""
    def fail(field: str, msg: str) -> UserError:
        return UserError(f"{path}: {field}: {msg}")

    def number(v: Any) -> bool:
        return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)

    if not isinstance(u, dict):
        raise fail("document", "expected a JSON object")
    if u.get("config") != cfg.fingerprint():
        raise fail("config", "from an evaluation with other options")
    for key, want in (("symbol_data", n_symbol), ("run", run)):
        if u.get(key) != want or isinstance(u.get(key), bool):
            raise fail(key, f"expected {want} (the file's name), got {u.get(key)!r}")
    entries = u.get("entries")
    if not isinstance(entries, list):
        raise fail("entries", "expected a list")
    for i, e in enumerate(entries):
        if not (isinstance(e, dict) and isinstance(e.get("method"), str) and number(e.get("mean"))
                and isinstance(e.get("model_traces"), int) and not isinstance(e.get("model_traces"), bool)):
            raise fail(f"entries[{i}]", "expected method (text), model_traces (whole number) and mean (a number)")
    report = u.get("report", {})
    grounding = report.get("grounding") if isinstance(report, dict) else None
    if not isinstance(report, dict) or not isinstance(grounding, (list, type(None))):
        raise fail("report", "expected an object with an optional grounding list")
    for i, g in enumerate(grounding or []):
        ok = isinstance(g, dict) and all(isinstance(g.get(k), (str, type(None))) for k in
                                         ("best_match", "negation_match")) \
            and all(g.get(k) is None or number(g.get(k)) for k in ("f1", "negation_f1"))
        if not ok:
            raise fail(f"report.grounding[{i}]", "expected best_match/negation_match names and f1 numbers")
    return u
