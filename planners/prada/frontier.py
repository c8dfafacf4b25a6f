"""The factored frontier (Murphy & Weiss 2001) over a :class:`~planners.prada.grounding.Grounding`.

PRADA keeps only per-atom marginals (Lang & Toussaint 2010): a belief matrix ``B`` holds one
sample per row and one ground atom per column. One step of inference for all samples is which rule
applies (:func:`rule_probabilities`), how likely each action is to manipulate
(:func:`action_weights`), and the marginals after the chosen actions (:func:`transition`).
"""

from __future__ import annotations

import numpy as np

from .grounding import Grounding

RULE_MIN_PROB = 0.03   # libPRADA prunes a rule whose context probability falls below this


def rule_probabilities(g: Grounding, B: np.ndarray, min_prob: float = RULE_MIN_PROB) -> np.ndarray:
    """P(U = r) for every sample (row of ``B``) and ground rule: context holds, no rival does.
    A context probability below ``min_prob`` counts as 0 (libPRADA's pruning)."""
    if not len(g.rule_group):
        return np.zeros((B.shape[0], 0))
    lit = B[:, g.ctx]
    lit = np.where(g.sign, lit, 1.0 - lit)
    phi = lit.prod(axis=2)
    phi[phi < min_prob] = 0.0
    z = 1.0 - phi
    zero = z <= 1e-12
    logz = np.log(np.where(zero, 1.0, z))
    seg_log = np.add.reduceat(logz, g.starts, axis=1)[:, g.rule_group]
    seg_zero = np.add.reduceat(zero.astype(np.int64), g.starts, axis=1)[:, g.rule_group]
    others_zero = seg_zero - zero
    return phi * np.exp(seg_log - logz) * (others_zero == 0)


def action_weights(g: Grounding, U: np.ndarray) -> np.ndarray:
    """Sampling weight of each ground action: P(a manipulating rule of it applies)."""
    if not U.shape[1]:
        return np.zeros((U.shape[0], 0))
    return np.add.reduceat(U * g.manipulating, g.starts, axis=1)


def transition(g: Grounding, B: np.ndarray, U: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """Marginals after each row's chosen action (``-1`` = none: everything persists).

    The rule tables are sparse (a rule touches a handful of atoms) and only the columns some rule
    touches change: the products cost the tables' non-zeros times the rows, not rules x atoms x rows."""
    Usel = U * (g.rule_group[None, :] == chosen[:, None])
    cols, touched, set_true = g.changing
    if isinstance(touched, np.ndarray):
        off, on = Usel @ touched, Usel @ set_true
    else:
        off, on = (touched.T @ Usel.T).T, (set_true.T @ Usel.T).T
    if cols is None:
        return g.derive(B * (1.0 - off) + on)
    out = B.copy()
    out[:, cols] = B[:, cols] * (1.0 - off) + on
    return g.derive(out)
