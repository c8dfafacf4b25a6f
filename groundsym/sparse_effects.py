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

This term charges ``beta`` nats per literal a transition changes, a geometric prior
``P(k changed literals) ~ exp(-beta k)`` on the size of an effect: the description-length cost of
listing the effect's literals, as the rule learner will pay it (Rissanen 1978, *Modeling by shortest
data description*, Automatica 14). Between two relations that predict equally well it prefers the
one with fewer changes; ``beta = 0`` (the default) leaves the loss as it was.
"""

from __future__ import annotations

import numpy as np


def changed_literals(u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray) -> int:
    """How many literals of the active symbols change over all transitions: ``u`` (S, M, K) and
    ``b`` (S, M, M, L) are the symbols' truth on every scene (uint8, a binary symbol false on the
    diagonal), ``pre``/``post`` the scene indices before and after each transition."""
    unary = int(np.count_nonzero(u[pre] != u[post])) if u.size else 0
    binary = int(np.count_nonzero(b[pre] != b[post])) if b.size else 0
    return unary + binary


def sparse_effects_nll(u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray, beta: float) -> float:
    """``beta`` nats per changed literal (module docstring); exactly 0.0 when ``beta`` is 0."""
    if beta == 0:
        return 0.0
    return float(beta * changed_literals(u, b, pre, post))
