"""Grounded relational symbols: predicates with RBF classifiers (paper Section IV-V, Eq. (4)).

A :class:`Symbol` is a predicate name, an arity (1 or 2), an RBF centre ``w_c`` and widths
``w_s`` over the unary feature space ``y_i`` or the pair feature space ``y_ij`` (default
``y_i - y_j``). It holds for an object (pair) when ``g(y) = exp(-sum((y - w_c)^2 / w_s^2)) > 0.5``,
i.e. when ``sum(((y - w_c) / w_s)^2) < ln 2``. Binary symbols are evaluated for ordered pairs of
distinct objects only.

A :class:`SymbolSet` is the abstraction ``phi``: it maps scenes, or a whole dataset at once
(vectorised over every scene), to symbolic states. ``symbols.json`` (schema
``groundsym.symbols/1``, see docs/formats.md) stores a symbol set with the share of data where each
symbol holds, the loss it reached and provenance; :func:`load_symbols` checks it against the
feature names of the traces it is applied to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .errors import UserError
from .fileio import atomic_write_json, read_json
from .identifiers import check_names
from .logic import Atom
from .symbolic_traces import SymbolicDataset, SymbolicTrace
from .docreader import DocReader
from .traces import Dataset
from .world import Scene

SCHEMA = "groundsym.symbols/1"
LN2 = math.log(2.0)


@dataclass(frozen=True, eq=False)
class Symbol:
    """One grounded predicate: ``name(X)`` or ``name(X, Y)`` with its RBF ``centre`` and ``widths``."""

    name: str
    arity: int
    centre: np.ndarray
    widths: np.ndarray

    def __post_init__(self) -> None:
        if self.arity not in (1, 2):
            raise ValueError(f"symbol {self.name}: arity must be 1 or 2, got {self.arity}")
        if self.centre.shape != self.widths.shape or self.centre.ndim != 1:
            raise ValueError(f"symbol {self.name}: centre and widths must be vectors of one length")
        if not np.all(self.widths > 0):
            raise ValueError(f"symbol {self.name}: widths must be positive")

    def activation(self, y: np.ndarray) -> np.ndarray:
        """``g(y)`` of Eq. (4) over the last axis of ``y``."""
        return np.exp(-self.mahalanobis(y))

    def mahalanobis(self, y: np.ndarray) -> np.ndarray:
        """``sum_d ((y_d - c_d) / w_d)^2`` over the last axis, added dimension by dimension in
        order: a fixed sequence of float steps, which the loss's compiled truth kernel repeats
        bit for bit (``np.sum`` may pair the terms differently)."""
        z = (y[..., 0] - self.centre[0]) / self.widths[0]
        out = z * z
        for d in range(1, len(self.centre)):
            z = (y[..., d] - self.centre[d]) / self.widths[d]
            out += z * z
        return out

    def holds(self, y: np.ndarray) -> np.ndarray:
        """Truth ``g(y) > 0.5`` over the last axis of ``y`` (vectorised)."""
        return self.mahalanobis(y) < LN2

    def with_name(self, name: str) -> "Symbol":
        return Symbol(name, self.arity, self.centre, self.widths)

    def __repr__(self) -> str:
        c = ", ".join(f"{v:.3g}" for v in self.centre)
        w = ", ".join(f"{v:.3g}" for v in self.widths)
        args = "X" if self.arity == 1 else "X,Y"
        return f"{self.name}({args}): centre [{c}], widths [{w}]"

    def to_doc(self) -> dict[str, Any]:
        return {"name": self.name, "arity": self.arity, "centre": self.centre.tolist(),
                "widths": self.widths.tolist()}


def pair_feature_names(feature_names: Sequence[str]) -> tuple[str, ...]:
    """Names of the default pair features ``y_i - y_j``: ``dx``, ``dy``, ..."""
    return tuple(f"d{n}" for n in feature_names)


def dataset_pair_names(ds: Dataset, where: str = "traces") -> tuple[str, ...]:
    """The pair feature names of a dataset: ``meta.pair_feature_names`` when a sim gave its own
    pair features (the point-cloud tower: differences of means), else ``d<name>`` per feature."""
    names = ds.meta.get("pair_feature_names")
    if names is None:
        return pair_feature_names(ds.feature_names)
    width = next((s.pairs().shape[-1] for tr in ds.traces for s in tr.scenes[:1]), len(names))
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names) or len(names) != width:
        raise UserError(f"{where}: meta.pair_feature_names: expected a list of {width} names (the width of the "
                        f"scenes' pair_features), got {names!r}")
    return tuple(names)


@dataclass(frozen=True, eq=False)
class SymbolSet:
    """Unary symbols ``u1, u2, ...`` and binary symbols ``b1, b2, ...`` over named feature spaces."""

    symbols: tuple[Symbol, ...]
    feature_names: tuple[str, ...]
    pair_names: tuple[str, ...] = ()
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.pair_names:
            object.__setattr__(self, "pair_names", pair_feature_names(self.feature_names))
        for s in self.symbols:
            want = len(self.feature_names) if s.arity == 1 else len(self.pair_names)
            if s.centre.shape[0] != want:
                raise ValueError(f"symbol {s.name}: {s.centre.shape[0]} dimensions, feature space has {want}")

    @classmethod
    def for_dataset(cls, symbols: Sequence[Symbol], ds: Dataset) -> "SymbolSet":
        """Symbols learned on ``ds``, over its unary and pair feature spaces."""
        return cls(tuple(symbols), tuple(ds.feature_names), dataset_pair_names(ds))

    @property
    def unary(self) -> tuple[Symbol, ...]:
        return tuple(s for s in self.symbols if s.arity == 1)

    @property
    def binary(self) -> tuple[Symbol, ...]:
        return tuple(s for s in self.symbols if s.arity == 2)

    @property
    def predicates(self) -> dict[str, int]:
        """Predicate name -> arity, in the order of the symbols."""
        return {s.name: s.arity for s in self.symbols}

    def __repr__(self) -> str:
        return "SymbolSet(" + "; ".join(repr(s) for s in self.symbols) + ")"

    # -- abstraction
    def truth_arrays(self, features: np.ndarray, pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Truth of every symbol for a batch of scenes at once.

        ``features``: (S, M, n) unary features; ``pairs``: (S, M, M, n') pair features.
        Returns unary truth (S, M, K) and binary truth (S, M, M, L), diagonal false.
        """
        return unary_truth(self.unary, features), binary_truth(self.binary, pairs)

    def abstract_scene(self, scene: Scene) -> frozenset:
        """The symbolic state ``phi(scene)``: the set of true ground atoms."""
        u, b = self.truth_arrays(np.asarray(scene.features, float)[None], scene.pairs()[None])
        return atoms_from_arrays(u[0], b[0], scene.objects, self.unary, self.binary)

    def to_symbolic_dataset(self, ds: Dataset) -> SymbolicDataset:
        """Abstract every scene of a continuous dataset (vectorised per trace)."""
        traces = []
        for tr in ds.traces:
            feats = np.stack([np.asarray(s.features, float) for s in tr.scenes])
            pairs = np.stack([s.pairs() for s in tr.scenes])
            u, b = self.truth_arrays(feats, pairs)
            states = [atoms_from_arrays(u[t], b[t], tr.objects, self.unary, self.binary) for t in range(len(feats))]
            rewards = [float(s.reward) for s in tr.scenes]
            traces.append(SymbolicTrace(tr.objects, states, list(tr.actions), rewards[:-1], rewards[-1]))
        meta = {k: v for k, v in ds.meta.items() if k in ("sim", "options", "seed", "cell_version")}
        return SymbolicDataset(traces, self.predicates, dict(ds.primitives), meta)

    def save_symbols(self, path: str | Path, **kwargs: Any) -> None:
        """Write this set as ``symbols.json`` (see the module function :func:`save_symbols`)."""
        save_symbols(path, self, **kwargs)

    def check_features(self, feature_names: Sequence[str], where: str) -> None:
        """UserError unless ``feature_names`` are the ones the symbols were learned on."""
        if tuple(feature_names) != self.feature_names:
            raise UserError(f"{where}: feature_names {list(feature_names)} do not match the symbols' "
                            f"feature space {list(self.feature_names)}")


def unary_truth(symbols: Sequence[Symbol], features: np.ndarray) -> np.ndarray:
    """(S, M, K) truth of unary symbols; one vectorised pass per symbol."""
    out = np.zeros(features.shape[:-1] + (len(symbols),), dtype=bool)
    for k, s in enumerate(symbols):
        out[..., k] = s.holds(features)
    return out


def binary_truth(symbols: Sequence[Symbol], pairs: np.ndarray) -> np.ndarray:
    """(S, M, M, L) truth of binary symbols; the diagonal (an object with itself) is false."""
    out = np.zeros(pairs.shape[:-1] + (len(symbols),), dtype=bool)
    m = pairs.shape[-2]
    off = ~np.eye(m, dtype=bool)[..., None]
    for k, s in enumerate(symbols):
        out[..., k] = s.holds(pairs)
    return out & off


def atoms_from_arrays(u: np.ndarray, b: np.ndarray, objects: Sequence[str], unary: Sequence[Symbol],
                      binary: Sequence[Symbol]) -> frozenset:
    """Ground atoms of one scene's truth arrays (M x K, M x M x L)."""
    atoms = [Atom(unary[k].name, (objects[i],)) for i, k in zip(*np.nonzero(u))]
    atoms += [Atom(binary[l].name, (objects[i], objects[j])) for i, j, l in zip(*np.nonzero(b))]
    return frozenset(atoms)


def dataset_arrays(ds: Dataset) -> tuple[np.ndarray, np.ndarray]:
    """All scenes of a dataset stacked: features (S, M, n), pairs (S, M, M, n'); same M required."""
    sizes = {len(t.objects) for t in ds.traces}
    if len(sizes) > 1:
        raise UserError(f"traces have different numbers of objects {sorted(sizes)}; symbol learning needs one")
    scenes = [s for t in ds.traces for s in t.scenes]
    return (np.stack([np.asarray(s.features, float) for s in scenes]), np.stack([s.pairs() for s in scenes]))


def share_true(symbol_set: SymbolSet, features: np.ndarray, pairs: np.ndarray) -> dict[str, float]:
    """The share of objects (unary) or ordered pairs of distinct objects (binary) where each holds."""
    u, b = symbol_set.truth_arrays(features, pairs)
    m = features.shape[1]
    out = {s.name: float(u[..., k].mean()) for k, s in enumerate(symbol_set.unary)}
    pairs_per_scene = max(m * (m - 1), 1)
    for l, s in enumerate(symbol_set.binary):
        out[s.name] = float(b[..., l].sum() / (features.shape[0] * pairs_per_scene))
    return out


# ----------------------------------------------------------------------------- symbols.json

def symbols_to_doc(symbol_set: SymbolSet, *, shares: dict[str, float] | None = None,
                   extra: dict[str, Any] | None = None) -> dict[str, Any]:
    syms = []
    for s in symbol_set.symbols:
        d = s.to_doc()
        if shares and s.name in shares:
            d["share"] = shares[s.name]
        syms.append(d)
    doc: dict[str, Any] = {"schema": SCHEMA, "feature_names": list(symbol_set.feature_names),
                           "pair_feature_names": list(symbol_set.pair_names), "symbols": syms}
    doc.update(extra or {})
    return doc


def save_symbols(path: str | Path, symbol_set: SymbolSet, *, shares: dict[str, float] | None = None,
                 extra: dict[str, Any] | None = None) -> None:
    """Write ``symbols.json`` atomically (``extra``: loss, pruned symbols, provenance, ...)."""
    atomic_write_json(path, symbols_to_doc(symbol_set, shares=shares, extra=extra))


def load_symbols(path: str | Path, feature_names: Sequence[str] | None = None) -> SymbolSet:
    """Read and validate ``symbols.json``; with ``feature_names``, check they match the symbols'."""
    doc = read_json(path)
    r = DocReader(path)
    if not isinstance(doc, dict):
        raise r.fail("document", "expected a JSON object")
    schema = r.get(doc, "schema", "", str)
    if schema != SCHEMA:
        raise r.fail("schema", f"expected {SCHEMA!r}, got {schema!r}")
    names = r.get(doc, "feature_names", "", list)
    if not names or not all(isinstance(n, str) for n in names):
        raise r.fail("feature_names", "expected a non-empty list of names")
    pair_names = doc.get("pair_feature_names") or list(pair_feature_names(names))
    if not isinstance(pair_names, list) or not all(isinstance(n, str) for n in pair_names):
        raise r.fail("pair_feature_names", "expected a list of names")
    symbols, seen = [], []
    for k, sdoc in enumerate(r.get(doc, "symbols", "", list)):
        f = f"symbols[{k}]"
        name = r.get(sdoc, "name", f, str)
        if name in seen:
            raise r.fail(f"{f}.name", f"expected a new predicate name, got {name!r}")
        check_names([name], f"{path}: {f}.name", taken=seen)
        seen.append(name)
        arity = r.get(sdoc, "arity", f, int)
        if arity not in (1, 2):
            raise r.fail(f"{f}.arity", f"expected 1 or 2, got {arity}")
        n = len(names) if arity == 1 else len(pair_names)
        centre = r.matrix(r.get(sdoc, "centre", f, list), f"{f}.centre", (n,))
        widths = r.matrix(r.get(sdoc, "widths", f, list), f"{f}.widths", (n,))
        if not np.all(widths > 0):
            raise r.fail(f"{f}.widths", "expected positive numbers")
        symbols.append(Symbol(name, arity, centre, widths))
    meta = {k: v for k, v in doc.items() if k not in ("schema", "feature_names", "pair_feature_names", "symbols")}
    out = SymbolSet(tuple(symbols), tuple(names), tuple(pair_names), meta)
    if feature_names is not None:
        out.check_features(feature_names, str(path))
    return out
