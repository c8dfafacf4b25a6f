"""Continuous trace files (``groundsym.traces/1``): read, validate, write atomically.

A trace is a sequence of scenes ``y_0 .. y_T`` and the actions ``a_0 .. a_{T-1}`` between them; the
reward of a step is the reward of that step's scene (``r_t`` in the paper). The file layout is
documented in ``docs/formats.md``. Readers ignore unknown keys and reject missing or malformed ones
with one line naming the file and the field.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from . import __version__
from .errors import UserError
from .fileio import atomic_write_json, read_json
from .docreader import DocReader
from .logic import Atom
from .world import Scene

SCHEMA = "groundsym.traces/1"


@dataclass(eq=False)
class Trace:
    """Scenes ``0..T`` (the last is the final scene) and the ``T`` actions between them."""

    objects: tuple[str, ...]
    scenes: list[Scene]
    actions: list[Atom]

    def __post_init__(self) -> None:
        if len(self.scenes) != len(self.actions) + 1:
            raise ValueError("a trace needs one more scene than actions")

    def __len__(self) -> int:
        return len(self.actions)

    def transitions(self) -> Iterator[tuple[Scene, Atom, Scene]]:
        for t, a in enumerate(self.actions):
            yield self.scenes[t], a, self.scenes[t + 1]


@dataclass(eq=False)
class Dataset:
    """Traces plus metadata (sim, options, seed, feature and primitive names, provenance)."""

    traces: list[Trace]
    feature_names: tuple[str, ...]
    primitives: dict[str, int]
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def n_transitions(self) -> int:
        return sum(len(t) for t in self.traces)

    def transitions(self) -> Iterator[tuple[Scene, Atom, Scene]]:
        for tr in self.traces:
            yield from tr.transitions()


# ----------------------------------------------------------------------------- writing

def _scene_doc(scene: Scene) -> dict[str, Any]:
    doc: dict[str, Any] = {"features": np.asarray(scene.features, dtype=float).tolist()}
    if scene.pair_features is not None:
        doc["pair_features"] = np.asarray(scene.pair_features, dtype=float).tolist()
    doc["truth"] = [str(a) for a in sorted(scene.truth)]
    doc["reward"] = float(scene.reward)
    if scene.unseen:
        doc["unseen"] = list(scene.unseen)
    return doc


def traces_doc(ds: Dataset) -> dict[str, Any]:
    meta = dict(ds.meta)
    meta["feature_names"] = list(ds.feature_names)
    meta["primitives"] = dict(ds.primitives)
    meta.setdefault("version", __version__)
    traces = []
    for tr in ds.traces:
        steps = []
        for t, a in enumerate(tr.actions):
            d = _scene_doc(tr.scenes[t])
            d["action"] = str(a)
            steps.append(d)
        traces.append({"objects": list(tr.objects), "steps": steps, "final": _scene_doc(tr.scenes[-1])})
    return {"schema": SCHEMA, "meta": meta, "traces": traces}


def write_traces(path: str | Path, ds: Dataset) -> None:
    """Write a dataset atomically as ``groundsym.traces/1`` JSON."""
    atomic_write_json(path, traces_doc(ds), indent=None)


# ----------------------------------------------------------------------------- reading

def _read_scene(r: DocReader, doc: Any, field: str, objects: tuple[str, ...], n_feat: int,
                need_reward: bool = True) -> Scene:
    M = len(objects)
    feats = r.matrix(r.get(doc, "features", field, list), f"{field}.features", (M, n_feat))
    pair = None
    if isinstance(doc, dict) and "pair_features" in doc:
        pair = r.matrix(doc["pair_features"], f"{field}.pair_features", (M, M, None))
    truth_doc = doc.get("truth", []) if isinstance(doc, dict) else []
    if not isinstance(truth_doc, list):
        raise r.fail(f"{field}.truth", "expected a list of atoms")
    objs = set(objects)
    truth = frozenset(r.atom(a, f"{field}.truth[{i}]", objs) for i, a in enumerate(truth_doc))
    if need_reward:
        reward = r.number(r.get(doc, "reward", field, (int, float)), f"{field}.reward")
    else:
        reward = r.number(doc["reward"], f"{field}.reward") if "reward" in doc else 0.0
    return Scene(objects, feats, reward, truth, pair, _read_unseen(r, doc, field, objects))


def _read_unseen(r: DocReader, doc: dict, field: str, objects: tuple[str, ...]) -> tuple[str, ...]:
    """The objects a sensor did not see in the scene (optional; none when absent)."""
    unseen = doc.get("unseen", [])
    if not isinstance(unseen, list) or not all(isinstance(o, str) and o in objects for o in unseen):
        raise r.fail(f"{field}.unseen", f"expected a list of the trace's objects ({', '.join(objects)})")
    return tuple(unseen)


def traces_from_doc(doc: Any, path: str | Path = "<traces>") -> Dataset:
    r = DocReader(path)
    if not isinstance(doc, dict):
        raise r.fail("document", "expected a JSON object")
    schema = r.get(doc, "schema", "", str)
    if schema != SCHEMA:
        raise r.fail("schema", f"expected {SCHEMA!r}, got {schema!r}")
    meta = r.get(doc, "meta", "", dict)
    names = r.get(meta, "feature_names", "meta", list)
    if not names or not all(isinstance(n, str) for n in names):
        raise r.fail("meta.feature_names", "expected a non-empty list of names")
    prims = r.arities(meta, "primitives", "meta")
    traces_doc = r.get(doc, "traces", "", list)
    traces: list[Trace] = []
    for i, tdoc in enumerate(traces_doc):
        f = f"traces[{i}]"
        objs = r.get(tdoc, "objects", f, list)
        if not objs or not all(isinstance(o, str) for o in objs) or len(set(objs)) != len(objs):
            raise r.fail(f"{f}.objects", "expected a non-empty list of distinct object names")
        objects = tuple(objs)
        steps = r.get(tdoc, "steps", f, list)
        scenes, actions = [], []
        for t, sdoc in enumerate(steps):
            sf = f"{f}.steps[{t}]"
            scenes.append(_read_scene(r, sdoc, sf, objects, len(names)))
            actions.append(r.atom(r.get(sdoc, "action", sf, str), f"{sf}.action", set(objects), prims))
        final = r.get(tdoc, "final", f, dict)
        scenes.append(_read_scene(r, final, f"{f}.final", objects, len(names), need_reward=False))
        traces.append(Trace(objects, scenes, actions))
    return Dataset(traces, tuple(names), prims,
                   {k: v for k, v in meta.items() if k not in ("feature_names", "primitives")})


def read_traces(path: str | Path) -> Dataset:
    """Read and validate a ``groundsym.traces/1`` file."""
    return traces_from_doc(read_json(path), path)


def file_schema(path: str | Path) -> str:
    """The ``schema`` of a JSON data file (to tell continuous from symbolic traces)."""
    doc = read_json(path)
    if not isinstance(doc, dict) or not isinstance(doc.get("schema"), str):
        raise UserError(f"{path}: schema: missing (expected {SCHEMA!r} or 'groundsym.symbolic-traces/1')")
    return doc["schema"]
