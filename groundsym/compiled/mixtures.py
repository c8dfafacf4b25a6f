"""The two predictive terms' mixtures, compiled: which transitions predict which and with how
many mispredicted literals or which reward (``transition_entries`` and ``reward_entries`` of
:mod:`groundsym.mixtures`, their numpy reference), and the float steps of its ``mixture_ll``
around numpy's exponential."""

from __future__ import annotations

import numpy as np

from .base import njit


@njit(cache=True)
def _class_members(cls):
    """Counting sort of items by class: (order, start) with class k's members order[start[k]:start[k+1]]."""
    n_cls = 0
    for c in cls:
        n_cls = max(n_cls, c + 1)
    start = np.zeros(n_cls + 1, dtype=np.int64)
    for c in cls:
        start[c + 1] += 1
    for k in range(n_cls):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    order = np.empty(len(cls), dtype=np.int64)
    for i in range(len(cls)):
        order[fill[cls[i]]] = i
        fill[cls[i]] += 1
    return order, start


@njit(cache=True)
def _sorted(item, partner, cols, n):
    key = item * (n + 1) + partner
    order = np.argsort(key, kind="mergesort")
    return item[order], partner[order], cols[order]


@njit(cache=True)
def _successor_mismatch(u, b, post, perms, i, j):
    """Literals in which item i's and item j's successors differ, both in canonical order."""
    m, k = u.shape[1], u.shape[2]
    l = b.shape[3]
    mis = 0
    si, sj = post[i], post[j]
    for p in range(m):
        oi, oj = perms[i, p], perms[j, p]
        for a in range(k):
            mis += u[si, oi, a] != u[sj, oj, a]
        for q in range(m):
            qi, qj = perms[i, q], perms[j, q]
            for a in range(l):
                mis += b[si, oi, qi, a] != b[sj, oj, qj, a]
    return mis


@njit(cache=True)
def transition_entries(u, b, pre, post, perms, cls, lone, hq, hc, hs, changes):
    """mixtures.transition_entries (the numpy reference) compiled: the same entries in the same order."""
    n, m = perms.shape
    k_u = u.shape[2]
    l_b = b.shape[3]
    order, start = _class_members(cls)
    cap = 4 * n + 16
    item = np.empty(cap, dtype=np.int64)
    partner = np.empty(cap, dtype=np.int64)
    vals = np.empty((cap, 2), dtype=np.int64)       # mispredicted literals, weight
    e = 0
    hit_start, lone_pos = _hit_ranges(len(lone), hq, len(start) - 1, lone)
    obj = np.empty(m, dtype=np.int64)
    for k in range(len(start) - 1):
        g0, g1 = start[k], start[k + 1]
        size = g1 - g0
        need = 0
        if size > 1:
            pat = np.empty(size, dtype=np.int64)      # index (in the group) of the first equal successor
            for a in range(size):
                pat[a] = a
                for a2 in range(a):
                    if pat[a2] == a2 and _successor_mismatch(u, b, post, perms, order[g0 + a], order[g0 + a2]) == 0:
                        pat[a] = a2
                        break
            cnt = np.zeros(size, dtype=np.int64)
            for a in range(size):
                cnt[pat[a]] += 1
            for a in range(size):
                for q in range(size):
                    if cnt[q] > 0:
                        need += 1
        else:
            q = lone_pos[k]
            need = 1
            for t in range(hit_start[q], hit_start[q + 1]):
                need += start[hc[t] + 1] - start[hc[t]]
        while e + need > cap:
            cap *= 2
            item = np.concatenate((item, np.empty(cap - len(item), dtype=np.int64)))
            partner = np.concatenate((partner, np.empty(cap - len(partner), dtype=np.int64)))
            grown = np.empty((cap, 2), dtype=np.int64)
            grown[:e] = vals[:e]
            vals = grown
        if size > 1:
            for a in range(size):
                i = order[g0 + a]
                for q in range(size):
                    w = cnt[q] - (1 if pat[a] == q else 0)
                    if cnt[q] > 0 and w > 0:
                        j = order[g0 + q]
                        item[e] = i
                        partner[e] = j
                        vals[e, 0] = _successor_mismatch(u, b, post, perms, i, j)
                        vals[e, 1] = w
                        e += 1
            continue
        i = order[g0]
        q = lone_pos[k]
        if hit_start[q] == hit_start[q + 1]:       # no comparable neighbour: predict no change
            mis = 0
            for x in range(m):
                for a in range(k_u):
                    mis += u[pre[i], x, a] != u[post[i], x, a]
                for y in range(m):
                    for a in range(l_b):
                        mis += b[pre[i], x, y, a] != b[post[i], x, y, a]
            item[e] = i
            partner[e] = i
            vals[e, 0] = mis
            vals[e, 1] = 1
            e += 1
            continue
        now = pre[i]
        nxt = post[i]
        for t in range(hit_start[q], hit_start[q + 1]):
            c = hc[t]
            for g in range(start[c], start[c + 1]):
                j = order[g]
                for p in range(m):
                    obj[p] = perms[j, hs[t, p]]
                mis = 0
                for p in range(m):
                    op, own_p = obj[p], perms[i, p]
                    for a in range(k_u):
                        pred = u[post[j], op, a]
                        if changes and u[pre[j], op, a] == pred:
                            pred = u[now, own_p, a]
                        mis += pred != u[nxt, own_p, a]
                    for r in range(m):
                        orr, own_r = obj[r], perms[i, r]
                        for a in range(l_b):
                            pred = b[post[j], op, orr, a]
                            if changes and b[pre[j], op, orr, a] == pred:
                                pred = b[now, own_p, own_r, a]
                            mis += pred != b[nxt, own_p, own_r, a]
                item[e] = i
                partner[e] = j
                vals[e, 0] = mis
                vals[e, 1] = 1
                e += 1
    it, _, vs = _sorted(item[:e], partner[:e], vals[:e], n)
    return it, vs[:, 0].copy(), vs[:, 1].copy()


@njit(cache=True)
def _hit_partners(q, lone, hit_start, hc, order, start, buf):
    """The members of lone query q's nearest classes, in increasing item order, into ``buf``."""
    n = 0
    for t in range(hit_start[q], hit_start[q + 1]):
        c = hc[t]
        for g in range(start[c], start[c + 1]):
            buf[n] = order[g]
            n += 1
    buf[:n] = np.sort(buf[:n])
    return n


@njit(cache=True)
def _hit_ranges(n_lone, hq, n_cls, lone):
    """Where each lone query's hits start in (hq, hc), and each class's position in ``lone``."""
    hit_start = np.zeros(n_lone + 1, dtype=np.int64)
    for t in range(len(hq)):
        hit_start[hq[t] + 1] += 1
    for q in range(n_lone):
        hit_start[q + 1] += hit_start[q]
    lone_pos = np.full(n_cls, -1, dtype=np.int64)
    for q in range(n_lone):
        lone_pos[lone[q]] = q
    return hit_start, lone_pos


@njit(cache=True)
def reward_entries(cls, lone, hq, hc):
    """mixtures.reward_entries (the numpy reference) compiled: the same entries in the same order,
    written item by item (partners in increasing order) instead of sorted afterwards."""
    n = len(cls)
    order, start = _class_members(cls)
    hit_start, lone_pos = _hit_ranges(len(lone), hq, len(start) - 1, lone)
    total = 0
    for k in range(len(start) - 1):
        size = start[k + 1] - start[k]
        if size > 1:
            total += size * (size - 1)
    for t in range(len(hq)):
        total += start[hc[t] + 1] - start[hc[t]]
    item = np.empty(total, dtype=np.int64)
    other = np.empty(total, dtype=np.int64)
    buf = np.empty(n, dtype=np.int64)
    e = 0
    for i in range(n):
        k = cls[i]
        if start[k + 1] - start[k] > 1:
            for g in range(start[k], start[k + 1]):
                if order[g] != i:
                    item[e] = i
                    other[e] = order[g]
                    e += 1
        else:
            for t in range(_hit_partners(lone_pos[k], lone, hit_start, hc, order, start, buf)):
                item[e] = i
                other[e] = buf[t]
                e += 1
    return item, other


@njit(cache=True)
def _top_and_diff(item, lp, n):
    """First half of mixtures.mixture_ll: per item the largest log-probability, per entry its distance to it."""
    top = np.full(n, -np.inf)
    for t in range(len(item)):
        if lp[t] > top[item[t]]:
            top[item[t]] = lp[t]
    diff = np.empty(len(item))
    for t in range(len(item)):
        diff[t] = lp[t] - top[item[t]]
    return top, diff


@njit(cache=True)
def transition_mixture(u, b, pre, post, perms, cls, lone, hq, hc, hs, changes, log_eps, log_ok, n_lit):
    """:func:`transition_entries` and the float steps of mixtures.mixture_ll before the exponential:
    (item, weight, lp - top per entry, top per item). The caller takes ``np.exp`` (numpy's, as the
    reference does) and finishes with :func:`mixture_sums`."""
    item, mis, weight = transition_entries(u, b, pre, post, perms, cls, lone, hq, hc, hs, changes)
    lp = np.empty(len(item))
    for t in range(len(item)):
        lp[t] = mis[t] * log_eps + (n_lit - mis[t]) * log_ok
    top, diff = _top_and_diff(item, lp, len(cls))
    return item, weight.astype(np.float64), diff, top


@njit(cache=True)
def reward_mixture(cls, lone, hq, hc, reward, c0, two_s2):
    """:func:`reward_entries` with the reward term's log-densities ``c0 - (r_i - r_j)^2 / two_s2``,
    as :func:`transition_mixture` returns them (the weights are all 1)."""
    item, other = reward_entries(cls, lone, hq, hc)
    lp = np.empty(len(item))
    for t in range(len(item)):
        d = reward[item[t]] - reward[other[t]]
        lp[t] = c0 - d * d / two_s2
    top, diff = _top_and_diff(item, lp, len(cls))
    return item, diff, top


@njit(cache=True)
def mixture_sums(item, e, weight, n):
    """Second half of mixtures.mixture_ll: per item the weighted sum of ``e`` and of the weights,
    accumulated in entry order (as ``np.add.at`` does)."""
    acc = np.zeros(n)
    cnt = np.zeros(n)
    for t in range(len(item)):
        acc[item[t]] += weight[t] * e[t]
        cnt[item[t]] += weight[t]
    return acc, cnt
