"""Continuous traces from recorded arrays, for data that comes without a simulator.

A robot's logs or another toolkit's episodes hold, per step, each object's features, the
primitive that was run with its object arguments, and a reward. :func:`dataset_from_arrays` turns
them into the :class:`~groundsym.traces.Dataset` that ``groundsym collect`` would have written, and
:func:`write_recorded_traces` into a ``groundsym.traces/1`` file that ``learn`` reads (the data
``Delta = {<y_t, a_t, r_t>}`` of Jetchev, Lang & Toussaint, Section IV). Nothing here needs a
simulator: ``meta.sim`` names none, so ``learn`` learns, and commands that need a world to run
(``plan --sim``) are given one separately.

Every check happens before anything is written, and each failure is one line naming the source and
the field, like a malformed traces file (docs/reliability.md): a wrong shape, a NaN, an object name
an action uses that the episode does not list, a primitive with two arities. docs/byo.md shows the
layout with an example.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from .docreader import DocReader
from .identifiers import check_names
from .logic import Atom
from .traces import Dataset, Trace, write_traces
from .world import Scene

ActionLike = str | tuple[str, Sequence[str]]


@dataclass(frozen=True)
class RecordedEpisode:
    """One recorded episode of T primitives.

    ``features`` is (T+1) x M x n: row t holds the M objects' features before primitive t, and the
    last row the scene after the last one. ``actions`` has T entries, each ``"(pick o1)"`` or
    ``("pick", ["o1"])``. ``rewards`` has T+1 entries, the reward of each scene (``r_t`` is the reward
    of the scene primitive t led to, as in a traces file). ``truth`` optionally lists, per scene, the
    atoms known to hold, used only to grade learned symbols (``show --against``).
    """

    objects: Sequence[str]
    features: Any
    actions: Sequence[ActionLike]
    rewards: Any
    truth: Sequence[Sequence[str]] | None = None
    pair_features: Any = None          # optional (T+1) x M x M x n' (default y_i - y_j)


@dataclass(frozen=True)
class _Context:
    reader: DocReader
    n_features: int
    primitives: dict[str, int]


def dataset_from_arrays(episodes: Sequence[RecordedEpisode], feature_names: Sequence[str],
                        primitives: Mapping[str, int] | None = None, meta: Mapping[str, Any] | None = None,
                        source: str | Path = "<recorded>") -> Dataset:
    """The episodes as a checked Dataset; ``primitives`` (name -> arity) is inferred from the
    actions when not given. Errors are :class:`~groundsym.errors.UserError` lines that begin with
    ``source`` and name the field, e.g. ``log.npz: episodes[2].features: contains NaN ...``."""
    r = DocReader(source)
    names = _feature_names(r, feature_names)
    if isinstance(episodes, (str, bytes)) or not isinstance(episodes, Sequence) or not episodes:
        raise r.fail("episodes", "expected a non-empty list of recorded episodes")
    prims = _primitives(r, episodes, primitives)
    ctx = _Context(r, len(names), prims)
    traces = [_trace(ctx, ep, f"episodes[{i}]") for i, ep in enumerate(episodes)]
    info = {"sim": None, "recorded": True, **dict(meta or {})}
    return Dataset(traces, names, prims, info)


def write_recorded_traces(path: str | Path, episodes: Sequence[RecordedEpisode], feature_names: Sequence[str],
                          primitives: Mapping[str, int] | None = None,
                          meta: Mapping[str, Any] | None = None) -> Dataset:
    """Check the episodes, then write them atomically as a ``groundsym.traces/1`` file at ``path``."""
    ds = dataset_from_arrays(episodes, feature_names, primitives, meta, source=path)
    write_traces(path, ds)
    return ds


# ----------------------------------------------------------------------------- checks

def _feature_names(r: DocReader, feature_names: Sequence[str]) -> tuple[str, ...]:
    if isinstance(feature_names, str) or not feature_names or \
            not all(isinstance(n, str) and n for n in feature_names):
        raise r.fail("feature_names", "expected a non-empty list of names")
    if len(set(feature_names)) != len(feature_names):
        raise r.fail("feature_names", "names must be distinct")
    return tuple(feature_names)


def _parse_action(r: DocReader, action: Any, where: str) -> Atom:
    if isinstance(action, str):
        return r.atom(action, where)
    if isinstance(action, (tuple, list)) and len(action) == 2 and isinstance(action[0], str) and \
            isinstance(action[1], (list, tuple)) and all(isinstance(a, str) for a in action[1]):
        return r.atom("(" + " ".join((action[0], *action[1])) + ")", where)
    raise r.fail(where, f"expected \"(name obj ...)\" or (name, [obj, ...]), got {action!r}")


def _primitives(r: DocReader, episodes: Sequence[RecordedEpisode],
                given: Mapping[str, int] | None) -> dict[str, int]:
    if given is not None:
        return r.arities({"primitives": dict(given)}, "primitives")
    found: dict[str, int] = {}
    for i, ep in enumerate(episodes):
        for t, action in enumerate(_actions_of(r, ep, f"episodes[{i}]")):
            where = f"episodes[{i}].actions[{t}]"
            atom = _parse_action(r, action, where)
            if found.setdefault(atom.predicate, atom.arity) != atom.arity:
                raise r.fail(where, f"{atom.predicate} takes {found[atom.predicate]} arguments elsewhere, "
                                    f"{atom.arity} here")
    check_names(found, f"{r.path}: primitives")
    return found


def _actions_of(r: DocReader, ep: Any, where: str) -> Sequence[Any]:
    if not isinstance(ep, RecordedEpisode):
        raise r.fail(where, f"expected a RecordedEpisode, got {type(ep).__name__}")
    if isinstance(ep.actions, str) or not isinstance(ep.actions, Sequence):
        raise r.fail(f"{where}.actions", "expected a list of actions")
    return ep.actions


def _objects(r: DocReader, objects: Any, where: str) -> tuple[str, ...]:
    if isinstance(objects, str) or not isinstance(objects, Sequence) or not objects or \
            not all(isinstance(o, str) for o in objects):
        raise r.fail(where, "expected a non-empty list of object names")
    if len(set(objects)) != len(objects):
        raise r.fail(where, "object names must be distinct")
    check_names(objects, f"{r.path}: {where}")
    return tuple(objects)


def _trace(ctx: _Context, ep: RecordedEpisode, where: str) -> Trace:
    r = ctx.reader
    actions_in = _actions_of(r, ep, where)
    objects = _objects(r, ep.objects, f"{where}.objects")
    T, M = len(actions_in), len(objects)
    if T < 1:
        raise r.fail(f"{where}.actions", "expected at least one action")
    feats = r.matrix(ep.features, f"{where}.features", (T + 1, M, ctx.n_features))
    rewards = r.matrix(ep.rewards, f"{where}.rewards", (T + 1,))
    pairs = None if ep.pair_features is None else \
        r.matrix(ep.pair_features, f"{where}.pair_features", (T + 1, M, M, None))
    truth = _truth(r, ep.truth, T, set(objects), where)
    actions = [r.atom(str(_parse_action(r, a, f"{where}.actions[{t}]")), f"{where}.actions[{t}]",
                      set(objects), ctx.primitives) for t, a in enumerate(actions_in)]
    scenes = [Scene(objects, feats[t], float(rewards[t]), truth[t],
                    None if pairs is None else pairs[t]) for t in range(T + 1)]
    return Trace(objects, scenes, actions)


def _truth(r: DocReader, truth: Any, T: int, objects: set[str], where: str) -> list[frozenset]:
    if truth is None:
        return [frozenset()] * (T + 1)
    if isinstance(truth, str) or not isinstance(truth, Sequence) or len(truth) != T + 1:
        raise r.fail(f"{where}.truth", f"expected one list of atoms per scene ({T + 1})")
    out = []
    for t, atoms in enumerate(truth):
        if isinstance(atoms, str) or not isinstance(atoms, (Sequence, set, frozenset)):
            raise r.fail(f"{where}.truth[{t}]", "expected a list of atoms")
        out.append(frozenset(r.atom(str(a), f"{where}.truth[{t}]", objects) for a in atoms))
    return out


__all__ = ["RecordedEpisode", "dataset_from_arrays", "write_recorded_traces"]
