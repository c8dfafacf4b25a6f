"""A relational reward model: reward as a linear function of relational count features.

A feature counts the injective groundings of a small conjunction of atoms over variables, e.g.
``#(?a): (u1 ?a)`` ("how many objects are u1"), ``#(?a ?b): (b1 ?a ?b)`` or a chain
``#(?a ?b ?c): (on ?a ?b) (on ?b ?c)``. Counts generalise over object identities and over the
number of objects, and they are sums of *products of distinct atom indicators*, so under the
independent atom marginals PRADA propagates, the expected reward is exact by linearity:
``E[r] = w0 + sum_k w_k sum_groundings prod_i P(atom_i)`` (Lang & Toussaint 2010, PRADA's reward for a general reward model).

Weights are fitted by ridge regression on standardised features, with the ridge strength chosen
by cross-validation over traces; the held-out fit (RMSE, R^2, against predicting the mean) is
measured on traces kept out of fitting, and the final model is refitted on all data.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from itertools import combinations, combinations_with_replacement, permutations
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from .errors import UserError
from .fileio import atomic_write_json, read_json
from .docreader import DocReader
from .identifiers import check_names
from .logic import Atom, is_variable, parse_atom

SCHEMA = "groundsym.reward/1"
LAMBDAS = tuple(float(x) for x in np.logspace(-4, 3, 15))
VARS = ("?a", "?b", "?c", "?d", "?e", "?f", "?g", "?h")


@dataclass(frozen=True, order=True)
class Feature:
    """The number of injective groundings of ``atoms`` (a conjunction over variables)."""

    atoms: tuple[Atom, ...]

    @property
    def variables(self) -> tuple[str, ...]:
        out: list[str] = []
        for a in self.atoms:
            out.extend(x for x in a.args if x not in out)
        return tuple(out)

    def __str__(self) -> str:
        return f"#({' '.join(self.variables)}): " + " ".join(str(a) for a in self.atoms)

    def evaluate(self, arrays: Mapping[str, np.ndarray], n_objects: int) -> np.ndarray:
        """Sum over groundings of the product of atom values; ``arrays[p]`` has shape (..., M^arity)."""
        if 2 <= len(self.atoms) <= 3 and _is_chain(self, self.atoms[0].predicate):
            return _chain_count(arrays[self.atoms[0].predicate], len(self.atoms))
        vs = self.variables
        G = _groundings(len(vs), n_objects)                       # T x k
        col = {v: G[:, i] for i, v in enumerate(vs)}
        prod = None
        for a in self.atoms:
            arr = arrays[a.predicate]
            val = arr[(..., *(col[x] for x in a.args))] if a.args else arr[..., None]
            prod = val if prod is None else prod * val
        return prod.sum(axis=-1)


def _chain_count(P: np.ndarray, n: int) -> np.ndarray:
    """``sum over distinct a, b, c (, d) of P[a,b] P[b,c] (P[c,d])``, by matrix products: walks of
    length ``n`` minus those that visit an object twice (inclusion-exclusion; with a zero
    diagonal consecutive objects differ already). The same number as enumerating the injective
    groundings, at M^3 instead of M^(n+1) products (the tower's PRADA reward evaluates it for 500
    beliefs at every step)."""
    P = P * (1.0 - np.eye(P.shape[-1]))
    P2 = P @ P
    if n == 2:
        return P2.sum(axis=(-2, -1)) - np.trace(P2, axis1=-2, axis2=-1)
    P3 = P2 @ P
    D = (P * np.swapaxes(P, -1, -2)).sum(axis=-1)           # sum_b P[a,b] P[b,a]
    a_is_c = (D * P.sum(axis=-1)).sum(axis=-1)              # P[a,b] P[b,a] P[a,d]
    b_is_d = (P.sum(axis=-2) * D).sum(axis=-1)              # P[a,b] P[b,c] P[c,b]
    a_is_d = np.trace(P3, axis1=-2, axis2=-1)               # P[a,b] P[b,c] P[c,a]
    both = (P * P * np.swapaxes(P, -1, -2)).sum(axis=(-2, -1))   # a = c and b = d
    return P3.sum(axis=(-2, -1)) - a_is_c - b_is_d - a_is_d + both


@lru_cache(maxsize=64)
def _groundings(k: int, m: int) -> np.ndarray:
    rows = list(permutations(range(m), k))
    return np.array(rows, dtype=int).reshape(len(rows), k)


def candidate_features(predicates: Mapping[str, int], max_size: int = 2, chain: int = 3) -> list[Feature]:
    """Counts of single atoms, of pairs of atoms sharing a variable, and of ``on``-like chains."""
    a, b, c, d = VARS[:4]
    nul = [p for p, k in sorted(predicates.items()) if k == 0]
    un = [p for p, k in sorted(predicates.items()) if k == 1]
    bi = [p for p, k in sorted(predicates.items()) if k == 2]
    feats = [Feature((Atom(p),)) for p in nul] + [Feature((Atom(p, (a,)),)) for p in un]
    feats += [Feature((Atom(p, (a, b)),)) for p in bi]
    if max_size >= 2:
        feats += [Feature((Atom(p, (a,)), Atom(q, (a,)))) for p, q in combinations(un, 2)]
        feats += [Feature((Atom(p), Atom(q, (a,)))) for p in nul for q in un]
        for p in bi:
            feats += [Feature((Atom(p, (a, b)), Atom(q, (x,)))) for q in un for x in (a, b)]
        for p, q in combinations_with_replacement(bi, 2):
            if p != q:
                feats.append(Feature((Atom(p, (a, b)), Atom(q, (a, b)))))
            feats.append(Feature((Atom(p, (a, b)), Atom(q, (b, a)))))
        for p in bi:
            feats += [Feature((Atom(p, (a, b)), Atom(q, (b, c)))) for q in bi]
    for n in range(3, min(chain, len(VARS) - 1) + 1):     # chains of n atoms over n + 1 objects
        feats += [Feature(tuple(Atom(p, (VARS[i], VARS[i + 1])) for i in range(n))) for p in bi]
    return feats


def state_arrays(states: Sequence[frozenset], objects: Sequence[str], predicates: Mapping[str, int],
                 values: Sequence[Mapping[Atom, float]] | None = None) -> dict[str, np.ndarray]:
    """Per predicate, a (B, M, ..., M) array of atom values (indicators, or probabilities if given)."""
    m = len(objects)
    pos = {o: i for i, o in enumerate(objects)}
    out = {p: np.zeros((len(states),) + (m,) * k) for p, k in predicates.items()}
    for i, s in enumerate(states):
        items = values[i].items() if values is not None else ((x, 1.0) for x in s)
        for atom, v in items:
            if atom.predicate in out and all(x in pos for x in atom.args):
                out[atom.predicate][(i, *(pos[x] for x in atom.args))] = v
    return out


@dataclass(frozen=True)
class RewardModel:
    """``reward(s) = intercept + sum_k weights[k] * features[k](s)``."""

    features: tuple[Feature, ...]
    weights: tuple[float, ...]
    intercept: float
    predicates: tuple[tuple[str, int], ...]
    fit: dict = field(default_factory=dict, compare=False)

    def __str__(self) -> str:
        terms = [f"{self.intercept:+.4g}"] + [f"{w:+.4g} * {f}" for f, w in zip(self.features, self.weights)]
        return "reward = " + "\n         ".join(terms)

    def _value(self, arrays: Mapping[str, np.ndarray], n_objects: int) -> np.ndarray:
        tot = np.full(next(iter(arrays.values())).shape[:1] if arrays else (1,), self.intercept, dtype=float)
        for f, w in zip(self.features, self.weights):
            tot = tot + w * f.evaluate(arrays, n_objects)
        return tot

    def predict(self, state: frozenset, objects: Sequence[str]) -> float:
        """The reward of one symbolic state (closed world)."""
        return float(self._value(state_arrays([state], objects, dict(self.predicates)), len(objects))[0])

    def expected(self, marginals: Mapping[Atom, float], objects: Sequence[str]) -> float:
        """Expected reward when each atom is true independently with probability ``marginals[atom]``
        (absent atoms: probability 0). Exact: each feature is a sum of products of distinct atoms."""
        arrays = state_arrays([frozenset()], objects, dict(self.predicates), [marginals])
        return float(self._value(arrays, len(objects))[0])

    def expected_arrays(self, arrays: Mapping[str, np.ndarray], n_objects: int) -> np.ndarray:
        """Batched :meth:`expected`: ``arrays[p]`` holds marginals of shape (B, M, ..., M)."""
        return self._value(arrays, n_objects)

    def to_doc(self, provenance: Mapping[str, Any] | None = None) -> dict[str, Any]:
        doc: dict[str, Any] = {"schema": SCHEMA}
        if provenance:
            doc["provenance"] = dict(provenance)
        doc["predicates"] = dict(self.predicates)
        doc["intercept"] = self.intercept
        doc["terms"] = [{"weight": w, "atoms": [str(a) for a in f.atoms], "feature": str(f)}
                        for f, w in zip(self.features, self.weights)]
        doc["fit"] = self.fit
        return doc


def dataset_matrix(ds, features: Sequence[Feature]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Feature matrix X, rewards y and the trace index of every rewarded state of a symbolic dataset."""
    rows, ys, groups = [], [], []
    for t_idx, tr in enumerate(ds.traces):
        states = list(tr.states[:-1])
        rewards = list(tr.rewards)
        if tr.final_reward is not None:
            states.append(tr.states[-1])
            rewards.append(tr.final_reward)
        if not states:
            continue
        arrays = state_arrays(states, tr.objects, ds.predicates)
        X = np.stack([f.evaluate(arrays, len(tr.objects)) for f in features], axis=1) if features else \
            np.zeros((len(states), 0))
        rows.append(X)
        ys.extend(rewards)
        groups.extend([t_idx] * len(states))
    if not rows:
        return np.zeros((0, len(features))), np.zeros(0), np.zeros(0, dtype=int)
    return np.concatenate(rows), np.array(ys, dtype=float), np.array(groups, dtype=int)


def _ridge(X: np.ndarray, y: np.ndarray, lam: float) -> tuple[np.ndarray, float]:
    """Ridge on standardised columns; returns weights and intercept in the original units."""
    mu, sd = X.mean(axis=0), X.std(axis=0)
    sd[sd == 0] = 1.0
    Z = (X - mu) / sd
    ym = y.mean()
    A = Z.T @ Z + lam * len(y) * np.eye(Z.shape[1])
    beta = np.linalg.solve(A, Z.T @ (y - ym)) if Z.shape[1] else np.zeros(0)
    w = beta / sd
    return w, float(ym - mu @ w)


def _folds(groups: np.ndarray, k: int, rng: np.random.Generator) -> list[np.ndarray]:
    """Test masks of k folds that keep each trace whole (states of one trace are correlated)."""
    uniq = np.unique(groups)
    if len(uniq) < 2:
        idx = rng.permutation(len(groups))
        return [np.isin(np.arange(len(groups)), part) for part in np.array_split(idx, min(k, len(groups)))]
    perm = rng.permutation(uniq)
    return [np.isin(groups, part) for part in np.array_split(perm, min(k, len(uniq)))]


def _choose_lambda(X: np.ndarray, y: np.ndarray, groups: np.ndarray, rng: np.random.Generator) -> float:
    folds = [m for m in _folds(groups, 5, rng) if m.any() and (~m).any()]
    if not folds:
        return LAMBDAS[len(LAMBDAS) // 2]
    errs = []
    for lam in LAMBDAS:
        e = 0.0
        for m in folds:
            w, b = _ridge(X[~m], y[~m], lam)
            e += float(((X[m] @ w + b - y[m]) ** 2).sum())
        errs.append(e)
    return LAMBDAS[int(np.argmin(errs))]


def _fit_stats(pred: np.ndarray, y: np.ndarray, base: float) -> dict[str, float]:
    rmse = float(np.sqrt(np.mean((pred - y) ** 2))) if len(y) else 0.0
    brmse = float(np.sqrt(np.mean((base - y) ** 2))) if len(y) else 0.0
    r2 = 1.0 - rmse ** 2 / brmse ** 2 if brmse > 1e-12 else (1.0 if rmse < 1e-9 else 0.0)
    return {"n": int(len(y)), "rmse": rmse, "baseline_rmse": brmse, "r2": r2}


def fit_reward(ds, *, seed: int = 0, holdout: float = 0.2, max_size: int = 2, chain: int = 3,
               tie_chains: bool = True) -> RewardModel:
    """Fit the reward model of a symbolic dataset; report held-out fit on ``holdout`` of the traces.
    ``chain``: the longest chain feature ``(p ?a ?b) (p ?b ?c) ...`` over each binary predicate.

    ``tie_chains``: each binary predicate also gets one *path* column, the sum of its chains of 1 to
    ``chain`` atoms (pairs in a ``p``-path: for ``on``, cube pairs one above the other), fitted with
    one weight that the model then gives each of those chains. A column the data cannot tell from a
    path column (random traces without towers of three: pairs only) is left out, so the path column
    takes its weight, and a chain the data never showed is valued as the data's pattern continued
    (the tower's reward, a mean height, is linear in such pairs) instead of 0."""
    rng = np.random.default_rng(seed)
    preds = dict(sorted(ds.predicates.items()))
    feats = candidate_features(preds, max_size, chain)
    X, y, groups = dataset_matrix(ds, feats)
    if len(y) == 0:
        return RewardModel((), (), 0.0, tuple(preds.items()), {"note": "no rewarded states"})
    members: list[tuple[int, ...]] = [(k,) for k in range(len(feats))]     # the features a column stands for
    if tie_chains:
        for p in (p for p, k in preds.items() if k == 2):
            path = tuple(k for k, f in enumerate(feats) if _is_chain(f, p))
            if len(path) > 1:
                members.append(path)
                X = np.hstack([X, X[:, list(path)].sum(axis=1, keepdims=True)])
    varying = X.std(axis=0) > 1e-12 if len(y) > 1 else np.zeros(X.shape[1], dtype=bool)
    for j in range(len(feats), X.shape[1]):            # a path column replaces columns equal to it
        if varying[j]:
            same = np.abs(X[:, :len(feats)] - X[:, j:j + 1]).max(axis=0) <= 1e-12
            varying[:len(feats)] &= ~same
    cols = np.flatnonzero(varying)
    X = X[:, cols]
    report: dict[str, Any] = {"features_considered": len(feats), "features_used": len(cols),
                              "path_columns": int(sum(len(members[j]) > 1 for j in cols))}
    if np.ptp(y) < 1e-12:
        report["note"] = "constant reward"
        return RewardModel((), (), float(y.mean()), tuple(preds.items()), report)
    test = _folds(groups, max(2, round(1 / holdout)) if holdout > 0 else 2, rng)[0] if holdout > 0 else None
    if test is not None and test.any() and (~test).any():
        lam = _choose_lambda(X[~test], y[~test], groups[~test], rng)
        w, b = _ridge(X[~test], y[~test], lam)
        report["heldout"] = _fit_stats(X[test] @ w + b, y[test], float(y[~test].mean()))
    lam = _choose_lambda(X, y, groups, rng)
    w, b = _ridge(X, y, lam)
    report["train"] = _fit_stats(X @ w + b, y, float(y.mean()))
    report["ridge_lambda"] = lam
    weight = np.zeros(len(feats))
    for j, wj in zip(cols, w):
        weight[list(members[j])] += wj
    keep = np.abs(weight) > 1e-12
    return RewardModel(tuple(f for f, k in zip(feats, keep) if k), tuple(float(x) for x in weight[keep]), b,
                       tuple(preds.items()), report)


def _is_chain(f: Feature, p: str) -> bool:
    """``f`` is a chain ``(p ?a ?b) (p ?b ?c) ...`` of one or more atoms of ``p``."""
    return all(a.predicate == p and a.arity == 2 for a in f.atoms) and \
        all(x.args[1] == y.args[0] for x, y in zip(f.atoms, f.atoms[1:])) and len(set(f.variables)) == len(f.atoms) + 1


def write_reward(path: str | Path, model: RewardModel, provenance: Mapping[str, Any] | None = None) -> None:
    atomic_write_json(path, model.to_doc(provenance))


def doc_to_reward(doc: Any, path: str | Path = "<reward>") -> RewardModel:
    def fail(fieldname: str, msg: str) -> UserError:
        return UserError(f"{path}: {fieldname}: {msg}")

    if not isinstance(doc, dict):
        raise fail("document", "expected a JSON object")
    if doc.get("schema") != SCHEMA:
        raise fail("schema", f"expected {SCHEMA!r}, got {doc.get('schema')!r}")
    preds = doc.get("predicates")
    if not isinstance(preds, dict) or any(isinstance(v, bool) or not isinstance(v, int) or v < 0
                                          for v in preds.values()):
        raise fail("predicates", "expected an object of name: arity")
    check_names(preds, f"{path}: predicates")
    r = DocReader(path)            # numbers at most MAX_MAGNITUDE, as in traces: 1e308 overflows the planners
    b = r.number(doc.get("intercept"), "intercept")
    terms = doc.get("terms")
    if not isinstance(terms, list):
        raise fail("terms", "expected a list")
    feats, weights = [], []
    for i, t in enumerate(terms):
        w = r.number(t.get("weight") if isinstance(t, dict) else None, f"terms[{i}].weight")
        atoms_doc = t.get("atoms")
        if not isinstance(atoms_doc, list) or not atoms_doc:
            raise fail(f"terms[{i}].atoms", "expected a non-empty list of atoms")
        atoms = []
        for j, s in enumerate(atoms_doc):
            try:
                a = parse_atom(s) if isinstance(s, str) else None
            except ValueError as exc:
                raise fail(f"terms[{i}].atoms[{j}]", str(exc)) from None
            if a is None or preds.get(a.predicate) != a.arity or not all(map(is_variable, a.args)):
                raise fail(f"terms[{i}].atoms[{j}]", f"expected a declared predicate over ?variables, got {s!r}")
            atoms.append(a)
        feats.append(Feature(tuple(atoms)))
        weights.append(float(w))
    fit = doc.get("fit", {})
    return RewardModel(tuple(feats), tuple(weights), float(b), tuple(sorted(preds.items())),
                       fit if isinstance(fit, dict) else {})


def read_reward(path: str | Path) -> RewardModel:
    return doc_to_reward(read_json(path), path)
