"""A rule's outcomes: which ones (InduceOutcomes, Pasula et al. 2007) and how likely (EM; docs/algorithms.md, NID rules).

Given the examples a rule covers, each with its unique binding, the candidate outcomes are the
distinct observed changes written over the rule's variables. Their probabilities maximise the
concave likelihood ``sum_e w_e log(sum_i c[e,i] p_i + p_0 p_min)``; with no overlap between
outcomes this is closed form (counts), otherwise EM for fixed-component mixture weights climbs to
the global optimum without a solver. A greedy search then merges (ADD) or drops (REMOVE) outcomes
while ``log-likelihood - alpha * (number of outcome literals)`` improves.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from ..logic import Literal
from .coverage import Coverage, ExampleTable
from .model import Outcome

PROB_EPS = 1e-6       # outcomes fitted below this probability are dropped (trimming)
NOISE_FLOOR = 1e-6    # the noise outcome keeps at least this mass, so no transition is impossible
MAX_ADD_PAIRS = 400   # ADD moves tried per step when a rule has very many candidate outcomes


def fit_outcome_probs(cover: np.ndarray, p_min: float, weights: np.ndarray | None = None, *,
                      iters: int = 2000, tol: float = 1e-11,
                      noise_floor: float = NOISE_FLOOR) -> tuple[np.ndarray, float]:
    """Maximum-likelihood outcome probabilities.

    ``cover`` is N x K (example e is produced by outcome i); the noise outcome explains every
    example with likelihood ``p_min``. Returns ``(p, p_noise)`` with ``p.sum() + p_noise == 1``.
    Without overlap the optimum is the weighted share of each outcome (the noise outcome takes the
    examples nothing else explains); with overlap, EM from the uniform start.
    """
    C = np.asarray(cover, dtype=bool)
    n, k = C.shape
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    total = w.sum()
    if k == 0 or total <= 0:
        return np.zeros(k), 1.0
    per_row = C.sum(axis=1)
    if per_row.max(initial=0) <= 1:
        p = (w[:, None] * C).sum(axis=0) / total
        noise = float(w[per_row == 0].sum() / total)
    else:
        p, noise = _em(C, w / total, p_min, iters, tol)
    return _floor_noise(p, noise, noise_floor)


def _em(C: np.ndarray, w: np.ndarray, p_min: float, iters: int, tol: float) -> tuple[np.ndarray, float]:
    """EM for the mixture weights of fixed components (the columns of C plus the noise column).
    Examples with the same row of C are merged first (their weights add): same optimum, less work."""
    rows, w = _merge_rows(C, w)
    W = np.concatenate([rows.astype(float), np.full((rows.shape[0], 1), p_min)], axis=1)
    q = np.full(W.shape[1], 1.0 / W.shape[1])
    for it in range(iters):
        q_new = q * ((w / (W @ q)) @ W)
        if it % 10 == 9 and np.abs(q_new - q).max() < tol:
            q = q_new
            break
        q = q_new
    q = q / q.sum()
    return q[:-1], float(q[-1])


def _merge_rows(C: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct rows of a 0/1 matrix and their summed weights."""
    if C.shape[1] <= 62:
        keys = C.astype(np.int64) @ (np.int64(1) << np.arange(C.shape[1], dtype=np.int64))
        uniq, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
        rows = C[first]
    else:
        rows, inverse = np.unique(C, axis=0, return_inverse=True)
    return rows, np.bincount(inverse.reshape(-1), weights=w, minlength=len(rows))


def _floor_noise(p: np.ndarray, noise: float, floor: float) -> tuple[np.ndarray, float]:
    if noise >= floor:
        s = p.sum() + noise
        return p / s, noise / s
    scale = (1.0 - floor) / max(p.sum(), 1e-300)
    return p * scale, floor


def log_likelihood(cover: np.ndarray, p: np.ndarray, noise: float, p_min: float,
                   weights: np.ndarray | None = None) -> float:
    """``sum_e w_e log(sum_i c[e,i] p_i + p_noise p_min)``."""
    C = np.asarray(cover, dtype=float)
    like = (C @ p if C.shape[1] else np.zeros(C.shape[0])) + noise * p_min
    w = np.ones(C.shape[0]) if weights is None else weights
    with np.errstate(divide="ignore"):                 # an impossible example gives -inf, as it should
        return float(w @ np.log(like))


@dataclass(frozen=True)
class OutcomeFit:
    """A rule's fitted outcomes on its covered examples."""

    outcomes: tuple[Outcome, ...]
    probs: tuple[float, ...]
    noise: float
    noise_changes: float
    loglik: float

    @property
    def n_literals(self) -> int:
        return sum(len(o.changes) for o in self.outcomes)


def lifted_changes(table: ExampleTable, cov: Coverage) -> list[Outcome | None]:
    """Each covered example's change written over rule variables; None if it touches an unbound object."""
    out: list[Outcome | None] = []
    cache = table.cache.setdefault("lift", {})
    for row, e_idx in enumerate(cov.index):
        key = (int(e_idx), cov.variables, tuple(cov.binding[row]))
        if key not in cache:
            ex = table.examples[int(e_idx)]
            inverse = {o: v for v, o in cov.names(table, row).items()}
            lits = [Literal(a.substitute(inverse), pos) for atoms, pos in ((ex.adds, True), (ex.dels, False))
                    for a in atoms]
            ok = all(x in inverse for atoms in (ex.adds, ex.dels) for a in atoms for x in a.args)
            cache[key] = Outcome(tuple(lits)) if ok else None
        out.append(cache[key])
    return out


def induce_outcomes(table: ExampleTable, cov: Coverage, alpha: float, p_min: float) -> OutcomeFit:
    """InduceOutcomes (Pasula et al. 2007): observed changes as candidates, then greedy ADD/REMOVE with refitting.

    Outcomes are interned as integers during the search (sets of them are hashed many times)."""
    w = table.weights[cov.index]
    n_changes = table.n_changes[cov.index]
    pool: list[Outcome] = []
    ids: dict[Outcome, int] = {}
    columns: list[np.ndarray] = []

    def intern(o: Outcome) -> int:
        if o not in ids:
            ids[o] = len(pool)
            pool.append(o)
            columns.append(table.outcome_covers(o.changes, cov))
        return ids[o]

    fits: dict[tuple[int, ...], tuple[float, tuple[int, ...], OutcomeFit]] = {}

    def fit(outs: tuple[int, ...]) -> tuple[float, tuple[int, ...], OutcomeFit]:
        if outs not in fits:
            fits[outs] = _trim_and_fit(outs, pool, columns, w, n_changes, alpha, p_min)
        return fits[outs]

    start = tuple(sorted({intern(o) for o in lifted_changes(table, cov) if o is not None}))
    best, best_outs, best_fit = fit(start)
    while True:
        improved = False
        for outs in _neighbours(best_outs, pool, columns, intern):
            sc, kept, f = fit(outs)
            if sc > best + 1e-9:
                best, best_outs, best_fit, improved = sc, kept, f, True
        if not improved:
            return best_fit


def _neighbours(outs: tuple[int, ...], pool: list[Outcome], columns: list[np.ndarray], intern
                ) -> list[tuple[int, ...]]:
    """REMOVE one outcome; ADD (replace two compatible outcomes by their union), where the union
    explains some example (a union that explains nothing is trimmed at once: REMOVE covers it)."""
    cands = [outs[:i] + outs[i + 1:] for i in range(len(outs))]
    for n, (i, j) in enumerate(combinations(range(len(outs)), 2)):
        if n >= MAX_ADD_PAIRS:
            break
        a, b = pool[outs[i]], pool[outs[j]]
        if _contradict(a, b):
            continue
        u = intern(Outcome(a.changes + b.changes))
        rest = tuple(o for k, o in enumerate(outs) if k not in (i, j))
        if u not in rest and columns[u].any():
            cands.append(tuple(sorted(rest + (u,))))
    return cands


def _contradict(a: Outcome, b: Outcome) -> bool:
    neg = {l.negate() for l in b.changes}
    return any(l in neg for l in a.changes)


def _trim_and_fit(outs: tuple[int, ...], pool: list[Outcome], columns: list[np.ndarray], w: np.ndarray,
                  n_changes: np.ndarray, alpha: float, p_min: float
                  ) -> tuple[float, tuple[int, ...], OutcomeFit]:
    """Fit probabilities, drop outcomes that cover nothing or get (almost) no mass, refit; score."""
    outs = tuple(o for o in outs if columns[o].any())
    while True:
        C = np.stack([columns[o] for o in outs], axis=1) if outs else np.zeros((len(w), 0), dtype=bool)
        p, noise = fit_outcome_probs(C, p_min, w)
        keep = p > PROB_EPS
        if keep.all():
            break
        outs = tuple(o for o, k in zip(outs, keep) if k)
    ll = log_likelihood(C, p, noise, p_min, w)
    unexplained = ~C.any(axis=1) if outs else np.ones(len(w), dtype=bool)
    wn = w[unexplained].sum()
    noise_changes = float(w[unexplained] @ n_changes[unexplained] / wn) if wn > 0 else 0.0
    f = OutcomeFit(tuple(pool[o] for o in outs), tuple(float(x) for x in p), float(noise), noise_changes, ll)
    return ll - alpha * f.n_literals, outs, f
