"""A planned episode as a filmstrip: each rendered frame with the step, the primitive chosen there
and the planner's expected value.

Input is what ``groundsym plan -o episode.json --render-dir DIR`` writes: a
``groundsym.episodes/1`` file and ``DIR/frame-000.png`` (the start) .. ``frame-T.png`` (after
the T-th primitive); with several episodes, one ``DIR/episode-KK/`` folder each.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import UserError
from ..fileio import read_json
from .page import PNG_MAGIC, Section, esc, png_uri

EPISODES_SCHEMA = "groundsym.episodes/1"
EPISODE_SCHEMA = "groundsym.episode/1"


@dataclass(frozen=True)
class StepView:
    t: int
    action: str
    expected_value: float | None
    reward: float
    state: tuple[str, ...] | None


@dataclass(frozen=True)
class EpisodeView:
    planner: str
    value: float
    gamma: float
    steps: tuple[StepView, ...]
    final_state: tuple[str, ...] | None


def _fail(path: str, field: str, msg: str) -> UserError:
    return UserError(f"{path}: {field}: {msg}")


def _number(v: Any, path: str, field: str, allow_none: bool = False) -> float | None:
    if v is None and allow_none:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise _fail(path, field, f"expected a finite number{' or null' if allow_none else ''}, got {v!r}")
    return float(v)


def _state(v: Any, path: str, field: str) -> tuple[str, ...] | None:
    if v is None:
        return None
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        raise _fail(path, field, "expected a list of atoms (strings) or null")
    return tuple(v)


def read_episode(path: str | Path, index: int = 0) -> EpisodeView:
    """Episode ``index`` of a ``groundsym plan -o`` file (or a single episode document), checked."""
    p = str(path)
    doc = read_json(path)
    if not isinstance(doc, dict):
        raise _fail(p, "document", "expected a JSON object")
    schema = doc.get("schema")
    if schema == EPISODES_SCHEMA:
        episodes = doc.get("episodes")
        if not isinstance(episodes, list) or not episodes:
            raise _fail(p, "episodes", "expected a non-empty list")
        if index >= len(episodes):
            raise _fail(p, "episodes", f"has {len(episodes)} episode(s), no episode {index} (--episode-index)")
        ep, where = episodes[index], f"episodes[{index}]"
    elif schema == EPISODE_SCHEMA:
        if index:
            raise _fail(p, "schema", f"one episode only, no episode {index} (--episode-index)")
        ep, where = doc, "episode"
    else:
        raise _fail(p, "schema", f"expected {EPISODES_SCHEMA!r} (groundsym plan -o), got {schema!r}")
    if not isinstance(ep, dict):
        raise _fail(p, where, "expected an object")
    steps = ep.get("steps")
    if not isinstance(steps, list):
        raise _fail(p, f"{where}.steps", "expected a list")
    views = []
    for i, s in enumerate(steps):
        f = f"{where}.steps[{i}]"
        if not isinstance(s, dict):
            raise _fail(p, f, "expected an object")
        if not isinstance(s.get("action"), str):
            raise _fail(p, f"{f}.action", f"expected a string, got {s.get('action')!r}")
        views.append(StepView(i, s["action"], _number(s.get("expected_value"), p, f"{f}.expected_value", True),
                              _number(s.get("reward"), p, f"{f}.reward"), _state(s.get("state"), p, f"{f}.state")))
    return EpisodeView(str(ep.get("planner", "?")), _number(ep.get("value"), p, f"{where}.value"),
                       _number(ep.get("gamma"), p, f"{where}.gamma"), tuple(views),
                       _state(ep.get("final_state"), p, f"{where}.final_state"))


def read_frames(directory: str | Path, n_steps: int, index: int = 0) -> list[bytes]:
    """``frame-000.png`` .. ``frame-<n_steps>.png`` from ``directory`` (or its ``episode-KK``
    folder, as ``plan --render-dir`` writes for several episodes)."""
    d = Path(directory)
    if not d.is_dir():
        raise UserError(f"--frames {directory}: not a directory (give plan's --render-dir)")
    if not (d / "frame-000.png").exists() and (d / f"episode-{index:02d}").is_dir():
        d = d / f"episode-{index:02d}"
    frames = []
    for k in range(n_steps + 1):
        f = d / f"frame-{k:03d}.png"
        try:
            data = f.read_bytes()
        except FileNotFoundError:
            raise UserError(f"{f}: missing (the episode has {n_steps} step(s), so frame-000.png .. "
                            f"frame-{n_steps:03d}.png are needed)") from None
        except OSError as exc:
            raise UserError(f"{f}: cannot read ({exc.strerror or exc})") from None
        if not data.startswith(PNG_MAGIC):
            raise UserError(f"{f}: not a PNG image")
        frames.append(data)
    return frames


def _ev(x: float | None) -> str:
    return f"{x:.4g}" if x is not None else "- (the planner estimates none)"


def filmstrip_section(ep: EpisodeView, frames: list[bytes] | None, name: str) -> Section:
    """One figure per frame (or per step without frames), captioned with step and action."""
    figs = []
    for k in range(len(ep.steps) + 1):
        if k < len(ep.steps):
            s = ep.steps[k]
            cap = (f"<b>step {k}</b>: <code>{esc(s.action)}</code><br>expected value "
                   f"{esc(_ev(s.expected_value))}; reward after it {s.reward:.4g}")
            state = s.state
        else:
            cap = f"<b>end</b>: after {len(ep.steps)} step(s); episode value {ep.value:.4g}"
            state = ep.final_state
        pic = (f'<img src="{png_uri(frames[k])}" alt="frame {k}">' if frames is not None
               else f"<pre>{esc(' '.join(state) if state else '(no atom true)')}</pre>")
        figs.append(f"<figure>{pic}<figcaption>{cap}</figcaption></figure>")
    body = (f"<p>An episode of the <code>{esc(ep.planner)}</code> planner from {esc(name)}: "
            f"{len(ep.steps)} step(s), value {ep.value:.4g} (discount {ep.gamma:g}). Each frame shows the "
            "scene where the step's primitive was chosen; the expected value is the planner's estimate "
            "of the discounted reward to come.</p>")
    body += f'<div class="strip">{"".join(figs)}</div>'
    return Section("episode", "Planned episode", body)
