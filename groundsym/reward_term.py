"""The loss's reward term from a linear model over relational counts (``LossConfig.reward_model = "linear"``).

The default reward term predicts each state's reward from its leave-one-out nearest neighbour
(:mod:`groundsym.mixtures`). A nearest neighbour only generalises across *isomorphic* states: a
symbol that splits the states (cube size in the tower) leaves many of them without an exact twin,
so what it says about the reward is rarely seen by the predictor, even when the reward is a simple
function of it (the tower's mean height gains a centimetre for each big cube below another).
This term instead fits the reward as a linear function of the abstraction's relational count
features, the family the learned reward model uses (:mod:`groundsym.reward`: how many objects
are ``u1``, how many pairs ``b1``, how many ``b1`` pairs have a ``u2`` below, chains of three ...),
and charges each state the Gaussian likelihood of its *leave-one-out* residual, computed in closed
form from the ridge hat matrix (Allen 1974, *The relationship between variable selection and data
augmentation and a method for prediction*, Technometrics 16: the PRESS residual
``e_i / (1 - h_ii)``). So a symbol earns reward likelihood where the counts it adds predict
states the model has not fitted, and a symbol the reward does not depend on earns nothing.

Everything is a fixed sequence of numpy reductions on the abstraction (no BLAS call whose
summation order could depend on the thread count), so the term is a function of the abstraction
and the data alone, bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from .reward import _chain_count

#: ridge strength on standardised features, times the number of states: small enough to leave a
#: well-determined fit alone, large enough that collinear counts (``b1`` and its chains when no
#: tower is taller than two) do not make the solve singular.
RIDGE = 1e-3


def count_features(up: np.ndarray, bp: np.ndarray) -> np.ndarray:
    """Relational count features of states ``up`` (T, M, K) and ``bp`` (T, M, M, L) (uint8, a
    binary symbol false on the diagonal), as (T, F) floats.

    Per state: the count of each unary and binary symbol; of objects with two unary symbols; of
    pairs ``(p ?a ?b)`` whose first or second object has a unary symbol; of pairs with two binary
    symbols the same way round or reversed; of compositions ``(p ?a ?b) (q ?b ?c)`` over three
    distinct objects; of ``p``-chains of three atoms over four objects (the family of
    :func:`groundsym.reward.candidate_features` at its defaults); and of pairs joined by a ``p``-path
    of any length, alone and with a unary symbol on either end. The path counts make a relation and
    its transitive closure equally good at predicting a reward that depends on the closure (the
    tower's mean height counts the cubes below each cube): without them the closure (`above`)
    would predict towers taller than the chains better than the relation itself (`on`), whose
    rules are the simpler ones.
    """
    u = up.astype(np.float64)
    b = bp.astype(np.float64)
    t, _, k = u.shape
    n_bin = b.shape[-1]
    iu = np.triu_indices(k, 1)
    cols = [u.sum(axis=1), b.sum(axis=(1, 2)),
            np.einsum("tmi,tmj->tij", u, u)[:, iu[0], iu[1]]]                 # (q ?a) (q' ?a), q < q'
    if n_bin:
        cols += [np.einsum("tabp,tak->tpk", b, u).reshape(t, -1),              # (p ?a ?b) (q ?a)
                 np.einsum("tabp,tbk->tpk", b, u).reshape(t, -1)]              # (p ?a ?b) (q ?b)
        same = np.einsum("tabp,tabq->tpq", b, b)                              # (p ?a ?b) (q ?a ?b)
        rev = np.einsum("tabp,tbaq->tpq", b, b)                               # (p ?a ?b) (q ?b ?a)
        walks = np.einsum("tbp,tbq->tpq", b.sum(axis=1), b.sum(axis=2))       # (p ?a ?b) (q ?b ?c), any c
        ip = np.triu_indices(n_bin, 1)
        iq = np.triu_indices(n_bin, 0)
        cols += [same[:, ip[0], ip[1]], rev[:, iq[0], iq[1]],
                 (walks - rev).reshape(t, -1),                                # ... c = a left out
                 _chain_count(np.moveaxis(b, 3, 1), 3)]                       # exact: counts of 0/1 products
        c = path_closure(b)
        cols += [c.sum(axis=(1, 2)), np.einsum("tabp,tak->tpk", c, u).reshape(t, -1),
                 np.einsum("tabp,tbk->tpk", c, u).reshape(t, -1)]
    return np.concatenate(cols, axis=1)


def path_closure(b: np.ndarray) -> np.ndarray:
    """(T, M, M, L): whether a path of one or more ``p`` atoms leads from ``a`` to ``b`` (``a != b``),
    by repeated squaring of the relation."""
    r = np.moveaxis(b, 3, 1) > 0                                  # (T, L, M, M)
    for _ in range(max(1, int(np.ceil(np.log2(max(b.shape[1], 2)))))):
        r = r | (np.matmul(r.astype(np.float64), r.astype(np.float64)) > 0)
    m = b.shape[1]
    r[..., np.arange(m), np.arange(m)] = False
    return np.moveaxis(r, 1, 3).astype(np.float64)


def loo_residuals(X: np.ndarray, y: np.ndarray, ridge: float = RIDGE) -> np.ndarray:
    """Leave-one-out residuals of a ridge fit with intercept on standardised columns of ``X``
    (PRESS: ``e_i / (1 - h_ii)``). Constant columns are dropped; without any column the model is
    the mean, and its leave-one-out residual is ``(y_i - mean) n / (n - 1)``."""
    n = len(y)
    sd = X.std(axis=0)
    keep = sd > 1e-12
    if not keep.any():
        return (y - y.mean()) * (n / (n - 1))
    Z = (X[:, keep] - X[:, keep].mean(axis=0)) / sd[keep]
    yc = y - y.mean()
    A = np.einsum("ti,tj->ij", Z, Z) + ridge * n * np.eye(Z.shape[1])
    sol = np.linalg.solve(A, np.column_stack([np.einsum("ti,t->i", Z, yc), Z.T]))   # [coef | A^-1 Z']
    h = 1.0 / n + np.einsum("ti,it->t", Z, sol[:, 1:])
    resid = yc - np.einsum("ti,i->t", Z, sol[:, 0])
    return resid / np.maximum(1.0 - h, 1e-9)


def linear_reward_nll(counts: np.ndarray, reward: np.ndarray, sigma: float) -> float:
    """``-sum_t log N(r_t; leave-one-out linear prediction from the counts of s_t, sigma^2)``;
    ``counts``: :func:`count_features` of the states (or the compiled twin's)."""
    if len(reward) < 3:
        return 0.0
    e = loo_residuals(counts, reward)
    s2 = sigma * sigma
    return float(len(e) * 0.5 * math.log(2 * math.pi * s2) + (e * e).sum() / (2 * s2))
