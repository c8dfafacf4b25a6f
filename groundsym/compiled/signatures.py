"""Nearest classes of ``local:1`` views as linear assignments over object signatures (compiled).

In a ``local:1`` view (:mod:`groundsym.relational.local`) every kept binary literal has an action
argument at one end, and the exact distance pins arguments onto arguments (equal lock values).
So once the arguments are placed, a free object's cost depends on its own match only: the
distance of two views is the Hamming distance of their argument parts plus a *linear*
assignment of free objects to free objects, each priced by the Hamming distance of their
*signatures* (the object's unary bits and its relations to and from each argument, packed in one
word). The generic pair search (:mod:`.pair_search`) treats the same problem as a quadratic
assignment over all M objects; here the work is a merge of two sorted signature lists (equal
signatures cost nothing and, the Hamming distance being a metric, an optimal assignment keeps
them matched: the Kantorovich-Rubinstein duality, Villani, *Optimal Transport*, 2009, Thm 5.10)
and a Hungarian method (Kuhn 1955; the shortest-augmenting-path form of Jonker & Volgenant 1987)
on the few that differ. Candidates are visited in order of the per-bit count bound (each bit's
count difference is paid at least once), cut at the best distance so far.

The first kernel gives each item its canonical order (arguments by lock value, then free objects
by signature, then index) and its class key; the second the nearest classes of the lone ones
with, per hit, the order that attains the distance (``hit_sigma``, canonical positions of the
query onto those of the hit's class), as :class:`groundsym.neighbourhood.Neighbourhood` holds
them. Equal keys are equal views up to an argument-respecting isomorphism and the distances are
the exact view distances (``tests/test_loss_signature.py`` checks both against the exact
machinery); where several orders attain a distance, the one returned is the assignment's, not the
exact search's first minimiser, which is why this is a distance of its own
(``distance=signature``, docs/symbol-search.md).
"""

from __future__ import annotations

import numpy as np

from .base import njit, popcount
from .classes import group_keys, lone_classes
from .pair_search import _hungarian

#: Signature bits at most (the canonical sort packs an object's index below them).
MAX_SIGNATURE_BITS = 56


@njit(cache=True)
def _arguments(lock_row, out):
    """The arguments of one transition (lock != 0) by increasing lock value into ``out``; their count.
    (An insertion sort in place: the lock values of distinct arguments are distinct bit sets, and
    a loss evaluation sorts every transition's arguments, so no array is allocated here.)"""
    a = 0
    for o in range(len(lock_row)):
        v = lock_row[o]
        if v == 0:
            continue
        t = a
        while t > 0 and lock_row[out[t - 1]] > v:
            out[t] = out[t - 1]
            t -= 1
        out[t] = o
        a += 1
    return a


@njit(cache=True)
def argument_literals(u, b, pre, post, lock, n_args):
    """The ``local:1`` views of each transition's two states with every kept relation as a bit of
    one object: (2T, M, K + 2 n_args L) uint8, scene ``t`` the state before transition ``t``,
    ``T + t`` the state after it. Per object: its unary literals, then per argument slot (the
    arguments by increasing lock value, as chosen in the state before) and binary symbol its
    relation *to* that argument, and, for an object that is not an argument, the relation *from*
    it. Every literal ``local:1`` keeps (a binary literal with an argument at one end) is one bit
    here, once; the others are dropped (they are cleared in both states of a view)."""
    n = len(pre)
    m, k = u.shape[1], u.shape[2]
    l = b.shape[3]
    width = k + 2 * n_args * l
    out = np.zeros((2 * n, m, width), dtype=np.uint8)
    slots = np.empty(m, dtype=np.int64)
    for t in range(n):
        a = _arguments(lock[t], slots)
        for half in range(2):
            s = pre[t] if half == 0 else post[t]
            row = t + half * n
            for o in range(m):
                for kk in range(k):
                    out[row, o, kk] = u[s, o, kk]
                free = lock[t, o] == 0
                for i in range(a):
                    x = slots[i]
                    for ll in range(l):
                        out[row, o, k + 2 * (i * l + ll)] = b[s, o, x, ll]
                        if free:
                            out[row, o, k + 2 * (i * l + ll) + 1] = b[s, x, o, ll]
    return out


@njit(cache=True)
def view_keys(u, lock, label, n_args):
    """Per item (``u`` (N, M, B) uint8 bits of :func:`argument_literals`, ``lock`` (N, M),
    ``label`` (N,)): its canonical order (N, M: arguments by lock value, then free objects by
    signature, then index), its free objects' signatures (their B bits packed) in that order (N,
    M; -1 after the free ones) and its class key (N, R): label, the arguments' lock values, the
    arguments' bits, the sorted signatures. ``n_args`` is the most arguments of any item (the
    key's padding)."""
    n, m, w = u.shape
    width = 1 + n_args + n_args * w + m
    keys = np.full((n, width), -1, dtype=np.int64)
    perms = np.empty((n, m), dtype=np.int64)
    sigs = np.full((n, m), -1, dtype=np.int64)
    args = np.empty(m, dtype=np.int64)
    packed = np.empty(m, dtype=np.int64)
    for t in range(n):
        a = _arguments(lock[t], args)
        keys[t, 0] = label[t]
        pos = 1 + n_args
        for i in range(a):
            x = args[i]
            perms[t, i] = x
            keys[t, 1 + i] = lock[t, x]
            for bit in range(w):
                keys[t, pos] = u[t, x, bit]
                pos += 1
        f = 0
        for o in range(m):
            if lock[t, o] != 0:
                continue
            s = 0
            for bit in range(w):
                s |= np.int64(u[t, o, bit]) << bit
            packed[f] = (s << 6) | o
            f += 1
        srt = np.sort(packed[:f])
        base = 1 + n_args + n_args * w
        for i in range(f):
            perms[t, a + i] = srt[i] & 63
            sigs[t, i] = srt[i] >> 6
            keys[t, base + i] = srt[i] >> 6
    return perms, sigs, keys


@njit(cache=True)
def _residuals(sq, sc, nf, rq, rc, common_q, common_c):
    """Merge two sorted signature lists of ``nf`` free objects: the positions matched by equal
    signatures (k-th equal with k-th equal) into ``common_q/_c``, the others into ``rq``/``rc``.
    Returns (number matched, number left on each side)."""
    i = 0
    j = 0
    nc = 0
    nq = 0
    nr = 0
    while i < nf or j < nf:
        if i < nf and j < nf and sq[i] == sc[j]:
            common_q[nc] = i
            common_c[nc] = j
            nc += 1
            i += 1
            j += 1
        elif j >= nf or (i < nf and sq[i] < sc[j]):
            rq[nq] = i
            nq += 1
            i += 1
        else:
            rc[nr] = j
            nr += 1
            j += 1
    return nc, nq


@njit(cache=True)
def nearest_by_signature(keys, sigs, n_free, first, lone, arg_lo, arg_hi, n_bits):
    """The nearest classes of each lone class (``first[c]``: an item of class c; ``lone``: the lone
    classes) among the classes with the same label and lock values (key columns ``< arg_lo``),
    by argument-part Hamming distance (key columns ``arg_lo:arg_hi``) plus the optimal assignment
    of free-object signatures. Returns best (Q,), hit_query, hit_class, hit_sigma (H, M) sorted by
    query, then class: ``hit_sigma`` maps the query's canonical positions onto the hit class's."""
    n_cls = len(first)
    m = sigs.shape[1]
    q_n = len(lone)
    best = np.full(q_n, np.inf)
    cap = 16
    hq = np.empty(cap, dtype=np.int64)
    hc = np.empty(cap, dtype=np.int64)
    hs = np.empty((cap, m), dtype=np.int64)
    h = 0
    dist = np.empty(n_cls, dtype=np.int64)
    lb = np.empty(n_cls, dtype=np.int64)
    rq = np.empty(m, dtype=np.int64)
    rc = np.empty(m, dtype=np.int64)
    cq = np.empty(m, dtype=np.int64)
    cc = np.empty(m, dtype=np.int64)
    cost = np.empty((m, m), dtype=np.int64)
    assign = np.empty(m, dtype=np.int64)
    pot_u = np.empty(m + 1, dtype=np.int64)
    pot_v = np.empty(m + 1, dtype=np.int64)
    way = np.empty(m + 1, dtype=np.int64)
    minv = np.empty(m + 1, dtype=np.int64)
    used = np.empty(m + 1, dtype=np.bool_)
    match = np.empty(m + 1, dtype=np.int64)
    for qi in range(q_n):
        k = lone[qi]
        iq = first[k]
        nf = n_free[iq]
        n_cand = 0
        for c in range(n_cls):
            dist[c] = -1
            if c == k:
                continue
            ic = first[c]
            same = True
            for col in range(arg_lo):
                if keys[iq, col] != keys[ic, col]:
                    same = False
                    break
            if not same:
                continue
            d = 0
            for col in range(arg_lo, arg_hi):
                d += keys[iq, col] != keys[ic, col]
            nc, nr = _residuals(sigs[iq], sigs[ic], nf, rq, rc, cq, cc)
            bound = 0
            for bit in range(n_bits):
                cnt = 0
                for x in range(nr):
                    cnt += (sigs[iq, rq[x]] >> bit) & 1
                    cnt -= (sigs[ic, rc[x]] >> bit) & 1
                bound += abs(cnt)
            lb[c] = d + bound
            dist[c] = -2          # a candidate, not yet searched
            n_cand += 1
        if n_cand == 0:
            continue
        cands = np.empty(n_cand, dtype=np.int64)
        t = 0
        for c in range(n_cls):
            if dist[c] == -2:
                cands[t] = lb[c]
                t += 1
        bound_order = np.argsort(cands, kind="mergesort")
        ids = np.empty(n_cand, dtype=np.int64)
        t = 0
        for c in range(n_cls):
            if dist[c] == -2:
                ids[t] = c
                t += 1
        top = 1 << 60
        for x in range(n_cand):
            c = ids[bound_order[x]]
            if lb[c] > top:
                break
            ic = first[c]
            nc, nr = _residuals(sigs[iq], sigs[ic], nf, rq, rc, cq, cc)
            d = 0
            for col in range(arg_lo, arg_hi):
                d += keys[iq, col] != keys[ic, col]
            if nr > 0:
                for y in range(nr):
                    for z in range(nr):
                        cost[y, z] = popcount(np.uint64(sigs[iq, rq[y]] ^ sigs[ic, rc[z]]))
                d += _hungarian(cost, nr, pot_u, pot_v, match, way, minv, used)
            dist[c] = d
            if d < top:
                top = d
        best[qi] = top
        a = m - nf
        for c in range(n_cls):       # the hits in class order, each with its assignment
            if dist[c] != top:
                continue
            ic = first[c]
            nc, nr = _residuals(sigs[iq], sigs[ic], nf, rq, rc, cq, cc)
            if nr > 0:
                for y in range(nr):
                    for z in range(nr):
                        cost[y, z] = popcount(np.uint64(sigs[iq, rq[y]] ^ sigs[ic, rc[z]]))
                _hungarian(cost, nr, pot_u, pot_v, match, way, minv, used)
                for z in range(1, nr + 1):        # match[j]: the row matched to column j (1-based)
                    assign[match[z] - 1] = z - 1
            if h == cap:
                cap *= 2
                hq2 = np.empty(cap, dtype=np.int64)
                hc2 = np.empty(cap, dtype=np.int64)
                hs2 = np.empty((cap, m), dtype=np.int64)
                hq2[:h] = hq[:h]
                hc2[:h] = hc[:h]
                hs2[:h] = hs[:h]
                hq, hc, hs = hq2, hc2, hs2
            hq[h] = qi
            hc[h] = c
            for p in range(a):
                hs[h, p] = p
            for y in range(nc):
                hs[h, a + cq[y]] = a + cc[y]
            for y in range(nr):
                hs[h, a + rq[y]] = a + rc[assign[y]]
            h += 1
    return best, hq[:h].copy(), hc[:h].copy(), hs[:h].copy()


@njit(cache=True)
def signature_classes(u, lock, label, n_args):
    """One whole pass of ``signature_neighbours`` (:func:`view_keys`, the classes of equal keys by
    ``group_keys``, the lone classes, :func:`nearest_by_signature`): the fields of
    :class:`groundsym.neighbourhood.Neighbourhood` (cls, perms, lone, best, hit query, class,
    sigma). One call instead of four and a numpy grouping of the keys through a byte view, which
    together took a third of the pass at 20 objects. Classes are numbered in the numeric order of
    their keys, each class's first item its smallest (what the mixtures read of a class: its
    members and their order, not its number)."""
    n, m, w = u.shape
    perms, sigs, keys = view_keys(u, lock, label, n_args)
    first, cls = group_keys(keys)
    c_n = len(first)
    lone = lone_classes(cls, c_n)
    n_free = np.empty(n, dtype=np.int64)
    for i in range(n):
        f = m
        for o in range(m):
            f -= lock[i, o] != 0
        n_free[i] = f
    arg_lo = 1 + n_args
    best, hq, hc, hs = nearest_by_signature(keys, sigs, n_free, first, lone, arg_lo, arg_lo + n_args * w, w)
    return cls, perms, lone, best, hq, hc, hs
