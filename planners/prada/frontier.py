"""The factored frontier (Murphy & Weiss 2001) over a :class:`~planners.prada.grounding.Grounding`.

PRADA keeps only per-atom marginals (Lang & Toussaint 2010): a belief matrix ``B`` holds one
sample per row and one ground atom per column. One step of inference for all samples is which rule
applies (:func:`rule_probabilities`), how likely each action is to manipulate
(:func:`action_weights`), and the marginals after the chosen actions (:func:`transition`).
"""

from __future__ import annotations

import numpy as np

from .contexts import context_probabilities
from .grounding import Grounding
from .segments import AVAILABLE as COMPILED, segment_products

RULE_MIN_PROB = 0.03   # libPRADA prunes a rule whose context probability falls below this


def rule_probabilities(g: Grounding, B: np.ndarray, min_prob: float = RULE_MIN_PROB) -> np.ndarray:
    """P(U = r) for every sample (row of ``B``) and ground rule: context holds, no rival does.
    A context probability below ``min_prob`` counts as 0 (libPRADA's pruning)."""
    if not len(g.rule_group):
        return np.zeros((B.shape[0], 0))
    if g.ctx.shape[1] < 8 and COMPILED:    # (numpy multiplies fewer than 8 factors in order)
        phi = context_probabilities(np.ascontiguousarray(B), g.ctx, g.sign, float(min_prob))
    else:
        lit = B[:, g.ctx]
        lit = np.where(g.sign, lit, 1.0 - lit)
        phi = lit.prod(axis=2)
        phi[phi < min_prob] = 0.0
    if g.family is not None:
        return _unique_reference_probabilities(g, phi)
    return _alone(phi, g.starts, g.rule_group)


def _alone(phi: np.ndarray, starts: np.ndarray, group: np.ndarray) -> np.ndarray:
    """``phi * _none_of_the_others(phi, ...)`` with the logarithms and exponentials taken only
    where ``phi`` > 0: elsewhere the product is 0 whatever the factor (a finite number at most
    1), and ``log(1 - 0)`` is 0, which the segment sums add unchanged. numpy's ``log`` and
    ``exp`` give each element the same bits wherever it sits in an array, so the result is the
    same bit for bit (``tests/test_prada_segments.py``); most contexts of a large grounding are
    pruned to 0 (at 20 objects the logarithms and exponentials of all of them took most of a
    decision)."""
    live = phi > 0
    if live.mean() > 0.5:
        return phi * _none_of_the_others(phi, starts, group)
    z = 1.0 - phi[live]
    zero_live = z <= 1e-12
    logz = np.zeros_like(phi)
    logz[live] = np.log(np.where(zero_live, 1.0, z))
    zero = np.zeros(phi.shape, dtype=np.int64)
    zero[live] = zero_live
    seg_log = np.add.reduceat(logz, starts, axis=1)[:, group]
    seg_zero = np.add.reduceat(zero, starts, axis=1)[:, group]
    out = np.zeros_like(phi)
    out[live] = phi[live] * (np.exp(seg_log[live] - logz[live]) * (seg_zero[live] - zero[live] == 0))
    return out


def _none_of_the_others(p: np.ndarray, starts: np.ndarray, group: np.ndarray) -> np.ndarray:
    """For each column, the product of ``1 - p`` over the other columns of its segment (segments
    begin at ``starts``; ``group`` maps a column to its segment), in log space with zero counts, so
    a certain rival gives exactly 0."""
    z = 1.0 - p
    zero = z <= 1e-12
    logz = np.log(np.where(zero, 1.0, z))
    seg_log = np.add.reduceat(logz, starts, axis=1)[:, group]
    seg_zero = np.add.reduceat(zero.astype(np.int64), starts, axis=1)[:, group]
    return np.exp(seg_log - logz) * (seg_zero - zero == 0)


def _unique_reference_probabilities(g: Grounding, phi: np.ndarray) -> np.ndarray:
    """NID's semantics with references: a rule covers when exactly one binding of its references
    does (a binding holds and its siblings, the other bindings for the same action, do not), and
    it applies when no other rule of the action covers."""
    fam = g.family
    fam_starts = np.flatnonzero(np.r_[True, fam[1:] != fam[:-1]])
    alone = phi * _none_of_the_others(phi, fam_starts, fam)           # this binding and no sibling
    covers = np.add.reduceat(alone, fam_starts, axis=1)                # (N, F): the rule covers
    fam_action = g.rule_group[fam_starts]
    act_starts = np.flatnonzero(np.r_[True, fam_action[1:] != fam_action[:-1]])
    act_of_fam = np.cumsum(np.r_[False, fam_action[1:] != fam_action[:-1]])
    return alone * _none_of_the_others(covers, act_starts, act_of_fam)[:, fam]


def action_weights(g: Grounding, U: np.ndarray) -> np.ndarray:
    """Sampling weight of each ground action: P(a manipulating rule of it applies)."""
    if not U.shape[1]:
        return np.zeros((U.shape[0], 0))
    return np.add.reduceat(U * g.manipulating, g.starts, axis=1)


#: How :func:`transition` multiplies the chosen rules into the atoms (PRADA's ``transition`` option).
TRANSITION_MODES = ("auto", "segments", "tables")


def transition(g: Grounding, B: np.ndarray, U: np.ndarray, chosen: np.ndarray, mode: str = "auto") -> np.ndarray:
    """Marginals after each row's chosen action (``-1`` = none: everything persists).

    The rule tables are sparse (a rule touches a handful of atoms) and only the columns some rule
    touches change: the products cost the tables' non-zeros times the rows, not rules x atoms x
    rows. ``mode``: ``tables`` multiplies the samples' chosen rules into the whole tables (BLAS on
    dense tables, scipy on sparse ones: the code before); ``segments`` walks each sample's own
    action's rules only (:mod:`planners.prada.segments`); ``auto`` walks the segments where the
    tables are sparse (large groundings: the same bits as scipy's product) and keeps BLAS on dense
    ones (whose fused multiply-adds give other last bits in about 0.05% of the marginals)."""
    cols, touched, set_true = g.changing
    dense = isinstance(touched, np.ndarray)
    if mode == "segments" or (mode == "auto" and not dense and COMPILED):
        indptr, indices, tv, sv = g.changing_rows
        off, on = segment_products(U, chosen.astype(np.int64), g.starts.astype(np.int64), len(g.rule_group),
                                   indptr, indices, tv, sv, touched.shape[1])
    else:
        Usel = U * (g.rule_group[None, :] == chosen[:, None])
        off, on = (Usel @ touched, Usel @ set_true) if dense else ((touched.T @ Usel.T).T, (set_true.T @ Usel.T).T)
    if cols is None:
        return g.derive(B * (1.0 - off) + on)
    out = B.copy()
    out[:, cols] = B[:, cols] * (1.0 - off) + on
    return g.derive(out)
