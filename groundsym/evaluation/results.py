"""An evaluation's results (results.json): per method and setting, the mean over runs of the
per-run means with its standard error, and how often the learned symbols grounded each relation."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..grounding import grounded
from .config import EvalConfig
from .store import finished_units

RESULTS_SCHEMA = "groundsym.results/1"

GOOD_F1 = 0.8   # a relation counts as found in a run when some symbol grounds it with at least this F1
                # (a unary symbol's negation: at least grounding.NEGATION_F1)


def aggregate(out: Path, cfg: EvalConfig, runs: int, optimum: float | None,
              provenance: Mapping[str, Any] | None) -> dict[str, Any]:
    """Mean over runs of the per-run means, with the standard error of that mean."""
    per: dict[tuple[int, int, str], list[float]] = {}
    grounding: dict[int, list[Any]] = {}
    for u in finished_units(out, cfg, runs):
        for e in u["entries"]:
            per.setdefault((u["symbol_data"], e["model_traces"], e["method"]), []).append(float(e["mean"]))
        if u.get("report", {}).get("grounding"):
            grounding.setdefault(u["symbol_data"], []).append(u["report"]["grounding"])
    rows = []
    for N in cfg.symbol_data:
        for n in cfg.model_traces:
            for m in cfg.methods:
                v = np.array(per.get((N, n, m), []))
                if not len(v):
                    continue
                se = float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else float("nan")
                rows.append({"method": m, "symbol_data": N, "model_traces": n, "mean": float(v.mean()),
                             "stderr": se if np.isfinite(se) else None, "n": int(len(v)),
                             "share_of_optimum": float(v.mean() / optimum) if optimum else None})
    meta = {"config": cfg.key(), "runs": runs, "units_done": sum(len(v) for v in per.values()) // max(
        1, len(cfg.methods) * len(cfg.model_traces)), "grounding": _grounding_summary(grounding)}
    if provenance:
        meta["provenance"] = dict(provenance)
    return {"schema": RESULTS_SCHEMA, "methods": rows, "optimum": optimum, "meta": meta}


def _grounding_summary(grounding: Mapping[int, list[Any]]) -> dict[str, Any]:
    """Per symbol-data size: how many runs learned a symbol whose best match is each relation, and
    its mean F1 over those runs (``u1~inhand``: unary symbol u1 matched ``inhand``); and per
    relation, in how many runs some symbol matched it with F1 >= ``GOOD_F1`` (``found``)."""
    out = {}
    for N, reports in grounding.items():
        f1s: dict[str, list[float]] = {}
        found: dict[str, int] = {}
        for rep in reports:
            got: set[str] = set()
            for r in rep:
                f1s.setdefault(f"{r.get('symbol')}~{r.get('best_match')}", []).append(float(r.get("f1", 0.0)))
                got |= set(grounded(r, GOOD_F1))
                for rel in (r.get("best_match"), r.get("negation_match")):
                    if rel is not None:
                        found.setdefault(rel, 0)
            for rel in got:
                found[rel] += 1
        out[str(N)] = {"runs": len(reports),
                       "matches": {k: {"runs": len(v), "mean_f1": float(np.mean(v))} for k, v in sorted(f1s.items())},
                       "found": dict(sorted(found.items()))}
    return out
