"""Checkpoints of a search: every restart's state after each round, refused when the data, seed or
settings differ from the run that made them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import UserError
from ..fileio import atomic_write_json, read_json
from ..loss import LossConfig
from .config import AnnealConfig
from .restart import RestartState

CHECKPOINT_SCHEMA = "groundsym.anneal-checkpoint/1"


def checkpoint_header(cfg: AnnealConfig, loss_cfg: LossConfig, seed: int, data_sha256: str) -> dict[str, Any]:
    return {"schema": CHECKPOINT_SCHEMA, "seed": seed, "data_sha256": data_sha256,
            "anneal": cfg.to_doc(), "loss": loss_cfg.to_doc()}


def save_checkpoint(path: Path | None, states: list[RestartState], cfg: AnnealConfig, loss_cfg: LossConfig,
          seed: int, data_sha256: str) -> None:
    if path is None:
        return
    doc = checkpoint_header(cfg, loss_cfg, seed, data_sha256)
    doc["restarts"] = [s.to_doc() for s in states]
    atomic_write_json(path, doc, indent=None)


def load_checkpoint(path: Path, cfg: AnnealConfig, loss_cfg: LossConfig, seed: int,
            data_sha256: str) -> list[RestartState] | None:
    if not path.exists():
        return None
    doc = read_json(path)
    want = checkpoint_header(cfg, loss_cfg, seed, data_sha256)
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
