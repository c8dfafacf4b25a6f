"""The two predictive terms' mixtures in numpy, the reference of :mod:`groundsym.compiled.mixtures`:
which transitions predict each transition's successor or reward (entries sorted by item, then
partner), and the log of each item's weighted mean likelihood over its entries.

The loss's prediction term is ``-sum_t log P(s_t+1 | s_t, a_t)`` and its reward term
``-sum_t log P(r_t | s_t)``, each a mixture over the leave-one-out nearest neighbours of
:mod:`groundsym.neighbourhood` (ties form an equal mixture; docs/symbols.md). The entries come
in one fixed order and accumulate in it, so the sums are the same, bit for bit, whichever
kernels produced them.
"""

from __future__ import annotations

import numpy as np

from .neighbourhood import Neighbourhood, group_rows


def _sorted_entries(columns: list[list[int]], n: int) -> tuple[np.ndarray, ...]:
    """Entry columns (item, partner, values...) as arrays, sorted by item, then partner."""
    arrays = [np.array(c, dtype=np.int64) for c in columns]
    order = np.argsort(arrays[0] * (n + 1) + arrays[1], kind="stable")
    return tuple(a[order] for a in arrays)


def transition_entries(u: np.ndarray, b: np.ndarray, pre: np.ndarray, post: np.ndarray, nb: Neighbourhood,
                       changes: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What predicts each transition's successor: entries ``(item, mispredicted literals, weight)``,
    sorted by item, then the predicting transition (the reference of ``compiled.transition_entries``).

    A member of a class with others is predicted by each other member through the identity (one
    entry per distinct successor pattern, weighted by how many others have it); a lone item by
    every member of its nearest classes, through the hit's permutation (with ``changes``: the
    literals the neighbour's primitive changed take its values, the others keep the item's own);
    a lone item without a comparable neighbour is predicted to change nothing.
    """
    n, m = nb.perms.shape
    idx = np.arange(n)[:, None]
    perms = nb.perms
    succ_u = u[post][idx, perms]                                   # successors, canonical order
    succ_b = b[post][idx[:, :, None], perms[:, :, None], perms[:, None, :]]
    flat = np.concatenate([succ_u.reshape(n, -1), succ_b.reshape(n, -1)], axis=1)
    item: list[int] = []
    partner: list[int] = []
    mis: list[int] = []
    weight: list[int] = []
    hits, members = nb.hits, nb.members
    for k, group in enumerate(members):
        if len(group) > 1:
            first, pattern = group_rows(flat[group])
            counts = np.bincount(pattern, minlength=len(first))
            for a, i in enumerate(group.tolist()):
                for q in range(len(first)):
                    w = int(counts[q]) - int(pattern[a] == q)   # the other members with pattern q
                    if w > 0:
                        item.append(i)
                        partner.append(int(group[first[q]]))
                        mis.append(int((flat[i] != flat[group[first[q]]]).sum()))
                        weight.append(w)
            continue
        i = int(group[0])
        if not hits[k][1]:             # no comparable neighbour: predict no change
            item.append(i)
            partner.append(i)
            mis.append(int((u[pre[i]] != u[post[i]]).sum() + (b[pre[i]] != b[post[i]]).sum()))
            weight.append(1)
            continue
        own, now = perms[i], pre[i]
        for c, sigma in hits[k][1]:
            for j in members[c].tolist():
                obj = perms[j][sigma]                      # neighbour objects in the item's canonical order
                pred_u = u[post[j]][obj]
                pred_b = b[post[j]][obj[:, None], obj[None, :]]
                if changes:  # the literals the neighbour's primitive changed take its values; the rest stay
                    was_u, was_b = u[pre[j]][obj], b[pre[j]][obj[:, None], obj[None, :]]
                    pred_u = np.where(was_u != pred_u, pred_u, u[now][own])
                    pred_b = np.where(was_b != pred_b, pred_b, b[now][own[:, None], own[None, :]])
                item.append(i)
                partner.append(j)
                mis.append(int((pred_u != succ_u[i]).sum() + (pred_b != succ_b[i]).sum()))
                weight.append(1)
    item_a, _, mis_a, weight_a = _sorted_entries([item, partner, mis, weight], n)
    return item_a, mis_a, weight_a


def reward_entries(nb: Neighbourhood) -> tuple[np.ndarray, np.ndarray]:
    """Who predicts each transition's reward: entries ``(item, neighbour)`` sorted by item, then
    neighbour (the reference of ``compiled.reward_entries``): the other members of its class,
    or, for a lone item, every member of its nearest classes."""
    item: list[int] = []
    other: list[int] = []
    members = nb.members
    hits = nb.hits
    for k, group in enumerate(members):
        if len(group) > 1:
            for i in group.tolist():
                for j in group.tolist():
                    if i != j:
                        item.append(i)
                        other.append(j)
            continue
        for c, _ in hits[k][1]:
            for j in members[c].tolist():
                item.append(int(group[0]))
                other.append(j)
    return _sorted_entries([item, other], len(nb.cls))


def mixture_ll(item: np.ndarray, lp: np.ndarray, weight: np.ndarray, n: int) -> np.ndarray:
    """Per item ``0..n-1``: ``log(sum_e weight_e exp(lp_e) / sum_e weight_e)`` over its entries.

    Entries come sorted by item and accumulate in that order (``np.add.at`` is sequential), so
    the result is a function of the entries alone, whichever kernels produced them. An item
    without entries gets 0.
    """
    top = np.full(n, -np.inf)
    np.maximum.at(top, item, lp)
    acc = np.zeros(n)
    np.add.at(acc, item, weight * np.exp(lp - top[item]))
    cnt = np.zeros(n)
    np.add.at(cnt, item, weight)
    return mixture_finish(top, acc, cnt)


def mixture_finish(top: np.ndarray, acc: np.ndarray, cnt: np.ndarray) -> np.ndarray:
    """The last step of :func:`mixture_ll` (shared with the compiled path): ``top + log(acc / cnt)``
    per item, 0 for an item without entries."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ll = top + np.log(acc) - np.log(cnt)
    ll[cnt == 0] = 0.0
    return ll
