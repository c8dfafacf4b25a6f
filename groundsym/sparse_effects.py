"""A prior that prefers sparse effects in the loss's prediction term (``LossConfig.sparse_effects``).

The prediction term asks whether a transition's successor can be predicted from its nearest
neighbour; it does not ask whether the change could be *stated* by the rules that will be
learned from the abstraction. NID rules (Pasula, Zettlemoyer & Kaelbling 2007, *Learning symbolic
models of stochastic domains*, JAIR 29) state each outcome as a conjunction of literals over the
action's arguments and uniquely referenced objects, and their learner's score charges every
literal of an outcome (the penalty term of its Eq. 4). A relation whose changes grow with the scene
cannot be stated that way: with ``above`` (the transitive closure of ``on``) a release onto a
tower of height h makes h literals true, "above every cube below", which no single NID outcome
says, so the release rules turn noisy and planning on them loses (docs/planning.md, "Vocabulary
with size"). With ``on`` the same release changes one literal.

This term charges ``beta`` nats for every literal of a symbol that a transition changes beyond
the first: a geometric prior ``P(k extra literals) ~ exp(-beta k)`` on how far an effect reaches
beyond one literal per symbol, the description-length cost of listing those literals as the rule
learner will pay for them (Rissanen 1978, *Modeling by shortest data description*, Automatica 14).
The first change of each symbol is free: charging every changed literal (measured first) made
any symbol that changes at all costlier than the effect term's price of seeing no change, and
the search pruned `inhand` (docs/planning.md, "Vocabulary"). Between two relations that predict
equally well it prefers the one whose effects stay local; ``beta = 0`` (the default) leaves the
loss as it was.
"""

from __future__ import annotations

import numpy as np


def changes_per_symbol(u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray) -> np.ndarray:
    """(T, K + L): how many literals of each active symbol each transition changes. ``u`` (S, M, K)
    and ``b`` (S, M, M, L) are the symbols' truth on every scene (uint8, a binary symbol false on
    the diagonal), ``pre``/``post`` the scene indices before and after each transition."""
    unary = (u[pre] != u[post]).sum(axis=1)
    binary = (b[pre] != b[post]).sum(axis=(1, 2))
    return np.concatenate([unary, binary], axis=1).astype(np.int64)


def changed_literals(u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray) -> int:
    """How many literals of the active symbols change over all transitions."""
    return int(changes_per_symbol(u, b, pre, post).sum())


def excess_changes(u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray) -> int:
    """The changed literals beyond the first of each symbol in each transition."""
    return int(np.maximum(changes_per_symbol(u, b, pre, post) - 1, 0).sum())


def sparse_effects_nll(u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray, beta: float) -> float:
    """``beta`` nats per excess changed literal (module docstring); exactly 0.0 when ``beta`` is 0."""
    if beta == 0:
        return 0.0
    return float(beta * excess_changes(u, b, pre, post))
