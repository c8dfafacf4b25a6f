"""The local distance: an approximation of the loss's neighbour search for 10-40 objects, as an option.

The exact distance between two abstract states is a quadratic assignment over all their objects
(docs/algorithms.md). Its cost grows steeply with the objects when a binary symbol holds for many
pairs, because few objects are then interchangeable (docs/symbol-search.md). A noisy
indeterministic deictic rule (Pasula, Zettlemoyer & Kaelbling, JAIR 29, 2007) cannot look that
far: its outcomes change its arguments and the objects its deictic references reach from them
through the context's relations. ``local:K`` keeps, per transition, only the binary literals such
a rule could reach in ``K`` relation steps from the action's arguments:

* the *reach* of a transition is its arguments and every object joined to them by at most ``K - 1``
  relation steps (any binary symbol, either direction) in the state before the action;
* a binary literal ``(i, j)`` is kept when ``i`` or ``j`` lies in the reach, i.e. when it lies on a
  walk of at most ``K`` steps from an argument; the others are cleared, in the state before the
  action *and* in the state after it (the same mask, chosen from the state before, so a neighbour
  is never chosen by what is to be predicted);
* every unary literal is kept: a deictic reference may pick an object by a unary literal alone
  (the held cube, ``inhand(X)``), and objects without relations are interchangeable, so they cost
  the search almost nothing.

The prediction term then runs the exact machinery (canonical forms, the exact nearest classes,
the same mixtures) on these masked states, so the kernels stay equal to their numpy reference;
only the states differ. The reward term is not local (a reward is a function of the whole
scene): with this distance it finds its neighbours by profile on the whole states
(:mod:`groundsym.profile_neighbours`). Cleared relations are scored as predicted right. The effect term and the
regulariser do not depend on the distance and are unchanged. What this costs in accuracy is
measured, not proven (docs/symbol-search.md, "The local distance").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The distances the loss offers, by name (``LossConfig.distance``).
DISTANCE_KINDS = ("exact", "local", "auto", "signature")
#: ``local`` without a step count.
DEFAULT_STEPS = 1
#: ``auto`` is exact up to this many objects and ``signature`` above (``local:1`` where the symbols
#: need more signature bits than a word holds; docs/symbol-search.md).
AUTO_EXACT_MAX = 10


@dataclass(frozen=True)
class Distance:
    """A parsed ``LossConfig.distance``: ``exact``, ``local:K`` (K >= 1 relation steps), ``auto`` (exact
    up to :data:`AUTO_EXACT_MAX` objects, ``signature`` above), or
    ``signature`` (the ``local:1`` views matched by signature assignment,
    :mod:`groundsym.signature_neighbours`)."""

    kind: str
    steps: int = DEFAULT_STEPS

    @staticmethod
    def parse(text: str) -> "Distance":
        """``exact``, ``local``, ``local:K``, ``auto`` or ``signature``; ValueError naming the setting otherwise."""
        kind, _, steps = text.partition(":")
        if kind not in DISTANCE_KINDS or (steps and kind != "local"):
            raise ValueError(f"distance must be exact, local[:K], auto or signature, got {text!r}")
        if not steps:
            return Distance(kind)
        if not steps.isdigit() or not 1 <= int(steps) <= 62:
            raise ValueError(f"distance local:K needs K a whole number in 1..62, got {text!r}")
        return Distance(kind, int(steps))

    def steps_for(self, n_objects: int) -> int | None:
        """The relation steps of the local distance at this many objects, or None for the exact one."""
        if self.kind == "exact" or (self.kind == "auto" and n_objects <= AUTO_EXACT_MAX):
            return None
        return self.steps

    def by_signature(self, n_objects: int) -> bool:
        """Whether the neighbours are matched by signature at this many objects: ``signature``,
        and ``auto`` above :data:`AUTO_EXACT_MAX` (it computes ``local:1``'s distance, faster at every
        size from 10 objects, and grounded ``on``/``above`` better than ``local:1`` at 10 cubes:
        docs/symbol-search.md)."""
        return self.kind == "signature" or (self.kind == "auto" and n_objects > AUTO_EXACT_MAX)


def reach(binary: np.ndarray, lock: np.ndarray, steps: int) -> np.ndarray:
    """(T, M) bool: per transition, its arguments (``lock`` != 0) and the objects at most ``steps``
    relation steps from them in ``binary`` (T, M, M, L), edges taken in either direction."""
    adj = binary.any(axis=-1)
    adj = adj | adj.transpose(0, 2, 1)
    out = lock != 0
    for _ in range(steps):
        grown = out | (adj & out[:, :, None]).any(axis=1)
        if np.array_equal(grown, out):
            break
        out = grown
    return out


def kept_pairs(binary: np.ndarray, lock: np.ndarray, steps: int) -> np.ndarray:
    """(T, M, M) bool: the ordered pairs whose binary literals ``local:steps`` keeps (one end in
    the reach of ``steps - 1`` relation steps)."""
    near = reach(binary, lock, steps - 1)
    return near[:, :, None] | near[:, None, :]


def local_view(u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray, lock: np.ndarray,
               steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each transition's states before and after under the ``local:steps`` mask, as new scene
    arrays ``(u', b', pre', post')``: scene ``t`` is transition ``t``'s state before, scene
    ``T + t`` its state after (the mask is chosen per transition, so scenes are no longer shared)."""
    before = b[pre]
    keep = kept_pairs(before, lock, steps)[..., None].astype(b.dtype)
    n = len(pre)
    u_view = np.concatenate([u[pre], u[post]])
    b_view = np.concatenate([before * keep, b[post] * keep])
    return u_view, b_view, np.arange(n), np.arange(n, 2 * n)
