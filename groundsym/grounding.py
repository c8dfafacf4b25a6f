"""How well learned symbols match the simulator's ground truth (evaluation only, never learning).

For each learned symbol, every ground-truth relation of the same arity found in the traces is
scored over all their scenes: unary symbols over (scene, object), binary ones over (scene, ordered
pair of distinct objects), in both argument orders, since a binary symbol may learn a relation with
its arguments swapped ("under" for "on"). The best match by F1 is reported with its precision and
recall, and, for a unary symbol whose negation matches some relation better (it learned "not in
the hand"), that relation too. A unary symbol grounds a relation when it matches it, or when its
negation matches it with F1 >= :data:`NEGATION_F1` (:func:`grounded`): "not in the hand" is as
good a symbol for planning as "in the hand", since the rules and the reward can use either.
:func:`suggested_names` turns the matches into names for ``groundsym rename`` (``show --against``
and the report print them).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Mapping

import numpy as np

from .errors import UserError
from .symbols import Symbol, SymbolSet, dataset_arrays
from .traces import Dataset


@dataclass(frozen=True)
class Match:
    """The ground-truth relation a learned symbol matches best."""

    symbol: str
    arity: int
    best_match: str | None
    argument_order: str          # "same" or "swapped" ("same" for unary symbols)
    precision: float
    recall: float
    f1: float
    # unary symbols: the relation the symbol's negation matches best, when that beats ``f1`` (a
    # symbol may learn "not in the hand"); None otherwise
    negation_of: str | None = None
    negation_f1: float | None = None

    def __str__(self) -> str:
        if self.best_match is None:
            return f"{self.symbol}/{self.arity}: no ground-truth relation of arity {self.arity}"
        order = " (arguments swapped)" if self.argument_order == "swapped" else ""
        text = (f"{self.symbol}/{self.arity} ~ {self.best_match}{order}: precision {self.precision:.3f}, "
                f"recall {self.recall:.3f}, F1 {self.f1:.3f}")
        if self.negation_of is not None:
            text += f"; its negation ~ {self.negation_of}: F1 {self.negation_f1:.3f}"
        return text

    def to_doc(self) -> dict[str, Any]:
        return {"symbol": self.symbol, "arity": self.arity, "best_match": self.best_match,
                "argument_order": self.argument_order, "precision": self.precision, "recall": self.recall,
                "f1": self.f1, "negation_match": self.negation_of, "negation_f1": self.negation_f1}


NEGATION_F1 = 0.9   # a unary symbol whose negation matches a relation this well grounds that relation


def grounded(doc: Mapping[str, Any], good: float) -> dict[str, float]:
    """The relations one symbol's match document (:meth:`Match.to_doc`) grounds, with the F1 of
    each: its best match when ``f1 >= good``, and the relation its negation matches when
    ``negation_f1 >= max(good, NEGATION_F1)``."""
    out: dict[str, float] = {}
    if doc.get("best_match") is not None and float(doc.get("f1") or 0.0) >= good:
        out[doc["best_match"]] = float(doc["f1"])
    neg, f = doc.get("negation_match"), doc.get("negation_f1")
    if neg is not None and f is not None and float(f) >= max(good, NEGATION_F1):
        out[neg] = max(out.get(neg, 0.0), float(f))
    return out


def suggested_names(matches: list[Match], good: float = 0.5) -> dict[str, str]:
    """Symbol -> the relation it matches (same argument order, F1 >= ``good``), or ``not-<relation>``
    when its negation matches better; a relation two symbols match goes to the better one."""
    best: dict[str, tuple[float, str]] = {}
    for m in matches:
        options = []
        if m.best_match and m.argument_order == "same" and m.f1 >= good:
            options.append((m.f1, m.best_match))
        if m.negation_of and (m.negation_f1 or 0) >= max(good, m.f1):
            options.append((m.negation_f1, f"not-{m.negation_of}"))
        if options:
            f1, name = max(options)
            if name != m.symbol and (name not in best or best[name][0] < f1):
                best[name] = (f1, m.symbol)
    return {sym: name for name, (_, sym) in sorted(best.items(), key=lambda kv: kv[1][1])}


def truth_arrays(ds: Dataset) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Ground truth of every scene as arrays: unary name -> (S, M), binary name -> (S, M, M)."""
    scenes = [(tr.objects, s) for tr in ds.traces for s in tr.scenes]
    arity: dict[str, int] = {}
    for _, s in scenes:
        for a in s.truth:
            arity.setdefault(a.predicate, a.arity)
    m = max(len(o) for o, _ in scenes)
    unary = {p: np.zeros((len(scenes), m), bool) for p, n in arity.items() if n == 1}
    binary = {p: np.zeros((len(scenes), m, m), bool) for p, n in arity.items() if n == 2}
    for k, (objects, s) in enumerate(scenes):
        index = {o: i for i, o in enumerate(objects)}
        for a in s.truth:
            if a.arity == 1 and a.predicate in unary:
                unary[a.predicate][k, index[a.args[0]]] = True
            elif a.arity == 2 and a.predicate in binary and a.args[0] != a.args[1]:
                binary[a.predicate][k, index[a.args[0]], index[a.args[1]]] = True
    return unary, binary


def scores(pred: np.ndarray, true: np.ndarray) -> tuple[float, float, float]:
    """Precision, recall and F1 of boolean arrays (0 where undefined)."""
    tp = float(np.sum(pred & true))
    p = tp / max(float(pred.sum()), 1.0)
    r = tp / max(float(true.sum()), 1.0)
    return p, r, (2 * p * r / (p + r) if p + r > 0 else 0.0)


def match_symbols(symbols: SymbolSet, ds: Dataset) -> list[Match]:
    """The best ground-truth match of every symbol over all scenes of ``ds``."""
    sizes = {len(t.objects) for t in ds.traces}
    if len(sizes) != 1:
        raise UserError("grounding: traces with different numbers of objects are not supported")
    if not any(s.truth for t in ds.traces for s in t.scenes):
        raise UserError("grounding: the traces carry no ground-truth atoms (steps[].truth)")
    feats, pairs = dataset_arrays(ds)
    u, b = symbols.truth_arrays(feats, pairs)
    true_u, true_b = truth_arrays(ds)
    off = _off_diagonal(feats.shape[1])
    out = []
    for k, s in enumerate(symbols.unary):
        cands = [(scores(u[..., k], t), name, "same") for name, t in sorted(true_u.items())]
        match = _best(s.name, 1, cands)
        negated = _best(s.name, 1, [(scores(~u[..., k], t), name, "same") for name, t in sorted(true_u.items())])
        if negated.best_match is not None and negated.f1 > match.f1:
            match = replace(match, negation_of=negated.best_match, negation_f1=negated.f1)
        out.append(match)
    for k, s in enumerate(symbols.binary):
        pred = b[..., k] & off
        cands = []
        for name, t in sorted(true_b.items()):
            cands.append((scores(pred, t & off), name, "same"))
            cands.append((scores(pred, t.transpose(0, 2, 1) & off), name, "swapped"))
        out.append(_best(s.name, 2, cands))
    return out


def _off_diagonal(m: int) -> np.ndarray:
    """(1, M, M) mask of ordered pairs of distinct objects (binary symbols never hold for X, X)."""
    return ~np.eye(m, dtype=bool)[None]


def _best(symbol: str, arity: int, cands: list) -> Match:
    if not cands:
        return Match(symbol, arity, None, "same", 0.0, 0.0, 0.0)
    (p, r, f), name, order = max(cands, key=lambda c: (c[0][2], c[2] == "same"))
    return Match(symbol, arity, name, order, p, r, f)


def fit_relation_symbol(name: str, relation: str, ds: Dataset, swapped: bool = False,
                        scales: tuple[float, ...] = (1.0, 1.25, 1.5, 2.0, 3.0, 4.0)) -> Symbol | None:
    """The simulator's relation ``relation`` written as an RBF symbol: the yardstick a learned symbol
    is measured against (evaluation only; it reads the ground truth).

    The centre is the middle of the positive examples' bounding box and the widths are that box's
    half-extents (at least 1 mm, or 1e-3 of the feature's spread), scaled by the factor from
    ``scales`` that gives the best F1 on ``ds``. ``swapped`` fits the relation with its arguments
    exchanged ("under" for "on"). None when the relation never holds in ``ds``.
    """
    true_u, true_b = truth_arrays(ds)
    feats, pairs = dataset_arrays(ds)
    off = _off_diagonal(feats.shape[1])
    if relation in true_u:
        arity, truth, space = 1, true_u[relation], feats
    elif relation in true_b:
        arity, space = 2, pairs
        truth = (true_b[relation].transpose(0, 2, 1) if swapped else true_b[relation]) & off
    else:
        raise UserError(f"grounding: {relation}: not a ground-truth relation of the traces "
                        f"(known: {', '.join(sorted([*true_u, *true_b]))})")
    pos = space[truth]
    if not len(pos):
        return None
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    spread = space.reshape(-1, space.shape[-1]).std(axis=0)
    half = np.maximum((hi - lo) / 2, np.maximum(1e-3, 1e-3 * spread))
    centre = (lo + hi) / 2
    best = None
    for k in scales:
        sym = Symbol(name, arity, centre, half * k)
        pred = sym.holds(space) & off if arity == 2 else sym.holds(space)
        f1 = scores(pred, truth)[2]
        if best is None or f1 > best[0]:
            best = (f1, sym)
    return best[1]
