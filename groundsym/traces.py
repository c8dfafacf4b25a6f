"""Continuous trace files (``groundsym.traces/1``): read, validate, write atomically.

A trace is a sequence of scenes ``y_0 .. y_T`` and the actions ``a_0 .. a_{T-1}`` between them; the
reward of a step is the reward of that step's scene (``r_t`` in the paper). The file layout is
documented in ``docs/formats.md``. Readers ignore unknown keys and reject missing or malformed ones
with one line naming the file and the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from . import __version__
from .errors import UserError
from .fileio import atomic_write_json, read_json
from .logic import Atom, parse_atom
from .world import Scene

SCHEMA = "groundsym.traces/1"
MAX_MAGNITUDE = 1e12   # features and rewards beyond this overflow squares and sums in the loss


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


def dataset_to_doc(ds: Dataset) -> dict[str, Any]:
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
    atomic_write_json(path, dataset_to_doc(ds), indent=None)


# ----------------------------------------------------------------------------- reading

class _Reader:
    """Validation helpers that name the file and the field in every error."""

    def __init__(self, path: str | Path):
        self.path = path

    def fail(self, field: str, msg: str) -> UserError:
        return UserError(f"{self.path}: {field}: {msg}")

    def get(self, doc: Any, key: str, field: str, kind: type | tuple[type, ...]) -> Any:
        if not isinstance(doc, dict):
            raise self.fail(field, "expected an object")
        if key not in doc:
            raise self.fail(f"{field}.{key}" if field else key, "missing")
        val = doc[key]
        if not isinstance(val, kind) or isinstance(val, bool) and kind is not bool:
            names = kind.__name__ if isinstance(kind, type) else "/".join(k.__name__ for k in kind)
            raise self.fail(f"{field}.{key}" if field else key, f"expected {names}, got {type(val).__name__}")
        return val

    def matrix(self, val: Any, field: str, shape: tuple[int | None, ...]) -> np.ndarray:
        try:
            arr = np.asarray(val, dtype=float)
        except (TypeError, ValueError):
            raise self.fail(field, "expected an array of numbers") from None
        if arr.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, arr.shape)):
            want = " x ".join("?" if s is None else str(s) for s in shape)
            raise self.fail(field, f"expected shape {want}, got {' x '.join(map(str, arr.shape)) or 'scalar'}")
        if not np.all(np.isfinite(arr)):
            raise self.fail(field, "contains NaN or infinite values")
        if arr.size and np.abs(arr).max() > MAX_MAGNITUDE:
            raise self.fail(field, f"a value of magnitude {np.abs(arr).max():.3g} (at most {MAX_MAGNITUDE:g}: "
                                   f"larger ones overflow the arithmetic)")
        return arr

    def number(self, val: Any, field: str) -> float:
        if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
            raise self.fail(field, f"expected a finite number, got {val!r}")
        if abs(val) > MAX_MAGNITUDE:
            raise self.fail(field, f"{float(val):.3g} is beyond {MAX_MAGNITUDE:g} in magnitude (larger values "
                                   f"overflow the arithmetic)")
        return float(val)

    def atom(self, val: Any, field: str, objects: set[str] | None = None,
             arities: dict[str, int] | None = None) -> Atom:
        if not isinstance(val, str):
            raise self.fail(field, f"expected an atom string, got {type(val).__name__}")
        try:
            atom = parse_atom(val)
        except ValueError as exc:
            raise self.fail(field, str(exc)) from None
        if arities is not None:
            if atom.predicate not in arities:
                raise self.fail(field, f"unknown name {atom.predicate!r} (declared: {', '.join(sorted(arities))})")
            if arities[atom.predicate] != atom.arity:
                raise self.fail(field, f"{atom.predicate} takes {arities[atom.predicate]} arguments, got {atom.arity}")
        if objects is not None:
            for a in atom.args:
                if a not in objects:
                    raise self.fail(field, f"unknown object {a!r} in {val}")
        return atom


def _read_scene(r: _Reader, doc: Any, field: str, objects: tuple[str, ...], n_feat: int,
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


def _read_unseen(r: _Reader, doc: dict, field: str, objects: tuple[str, ...]) -> tuple[str, ...]:
    """The objects a sensor did not see in the scene (optional; none when absent)."""
    unseen = doc.get("unseen", [])
    if not isinstance(unseen, list) or not all(isinstance(o, str) and o in objects for o in unseen):
        raise r.fail(f"{field}.unseen", f"expected a list of the trace's objects ({', '.join(objects)})")
    return tuple(unseen)


def doc_to_dataset(doc: Any, path: str | Path = "<traces>") -> Dataset:
    r = _Reader(path)
    if not isinstance(doc, dict):
        raise r.fail("document", "expected a JSON object")
    schema = r.get(doc, "schema", "", str)
    if schema != SCHEMA:
        raise r.fail("schema", f"expected {SCHEMA!r}, got {schema!r}")
    meta = r.get(doc, "meta", "", dict)
    names = r.get(meta, "feature_names", "meta", list)
    if not names or not all(isinstance(n, str) for n in names):
        raise r.fail("meta.feature_names", "expected a non-empty list of names")
    prims = r.get(meta, "primitives", "meta", dict)
    for k, v in prims.items():
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise r.fail(f"meta.primitives.{k}", "expected a non-negative arity")
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
    return Dataset(traces, tuple(names), {str(k): int(v) for k, v in prims.items()},
                   {k: v for k, v in meta.items() if k not in ("feature_names", "primitives")})


def read_traces(path: str | Path) -> Dataset:
    """Read and validate a ``groundsym.traces/1`` file."""
    return doc_to_dataset(read_json(path), path)


def file_schema(path: str | Path) -> str:
    """The ``schema`` of a JSON data file (to tell continuous from symbolic traces)."""
    doc = read_json(path)
    if not isinstance(doc, dict) or not isinstance(doc.get("schema"), str):
        raise UserError(f"{path}: schema: missing (expected {SCHEMA!r} or 'groundsym.symbolic-traces/1')")
    return doc["schema"]
