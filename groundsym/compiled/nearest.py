"""The nearest classes of every lone class, compiled: ``NeighbourhoodEngine.nearest_enumerated``
(:mod:`groundsym.neighbourhood`) and the bit-parallel enumeration of
:mod:`groundsym.relational.enumeration` (their numpy reference), as a branch and bound over the
same orders in the same order (:func:`.pair_search._pair_distance`), cut where no order can beat the first
minimiser the enumeration returns; candidates visited in order of a lower bound
(:func:`nearest_classes`, through :mod:`.heap`), pairs memoised across calls."""

from __future__ import annotations

import math

import numpy as np

from .base import INF, insert_sorted, njit, numba, popcount
from .canonical import state_codes, twin_groups_row
from .heap import heap_pop, heap_push
from .pair_search import STRONG_FROM, _object_masks, _pair_distance, work_arrays


_DIST_SHIFT = 32         # pair memo value: the distance above this bit, flags and a store offset below

MAX_OBJECTS = 62         # object sets are int64 bit masks (:mod:`.pair_search`)


@njit(cache=True)
def _pinned_tables(unary, binary, lock):
    """What :func:`_pinned_bound` needs per class, in canonical order.

    The action's arguments sit at the front of the canonical order (descending locks, distinct
    values), and every kept order sends them to the same front positions: they are *pinned*. A
    class qualifies when that holds (``pinned``); ``pin`` (C, M) marks its pinned positions,
    ``pu`` (C, M) their unary bits as a word, ``pcount`` (C, K) unary counts over the free
    positions, ``pdeg`` (C, M, L, 2) out- and in-degrees without the edges between two pinned
    objects and ``psorted`` (C, L, 2, M) the free positions' degrees sorted (the first M - pins entries used).
    """
    c_n, m, k = unary.shape
    l = binary.shape[3]
    pinned = np.zeros(c_n, dtype=np.bool_)
    pin = np.zeros((c_n, m), dtype=np.bool_)
    pu = np.zeros((c_n, m), dtype=np.uint64)
    pcount = np.zeros((c_n, k), dtype=np.int64)
    pdeg = np.zeros((c_n, m, l, 2), dtype=np.int64)
    psorted = np.zeros((c_n, l, 2, m), dtype=np.int64)
    for c in range(c_n):
        ok = k <= 64
        n_pin = 0
        for p in range(m):
            if lock[c, p] != 0:
                if p != n_pin or (p > 0 and lock[c, p - 1] <= lock[c, p]):
                    ok = False              # arguments not at the front in strictly descending order
                pin[c, p] = True
                n_pin += 1
        if not ok or n_pin == 0:
            continue
        pinned[c] = True
        for p in range(m):
            for a in range(k):
                if pin[c, p]:
                    if unary[c, p, a]:
                        pu[c, p] |= np.uint64(1) << np.uint64(a)
                else:
                    pcount[c, a] += unary[c, p, a]
            for y in range(m):
                if pin[c, p] and pin[c, y]:
                    continue
                for a in range(l):
                    pdeg[c, p, a, 0] += binary[c, p, y, a]
                    pdeg[c, y, a, 1] += binary[c, p, y, a]
        for a in range(l):
            for d in range(2):
                n_free = 0
                for p in range(m):
                    if not pin[c, p]:
                        insert_sorted(psorted[c, a, d], n_free, pdeg[c, p, a, d])
                        n_free += 1
    return pinned, pin, pu, pcount, pdeg, psorted


@njit(cache=True)
def _pinned_bound(pin, q, c, pu, pcount, pdeg, binary, psorted, m):
    """A lower bound on the distance of compatible classes q and c with pinned arguments.

    Unary: the pinned objects' own mismatches plus per-symbol count differences of the free
    ones. Binary: the edges between pinned objects exactly, and every other mismatched edge
    changes one out-degree and one in-degree, so half the summed degree differences (pinned
    objects against their fixed partners, free ones sorted: the best 1-D matching) is admissible.
    """
    k = pcount.shape[1]
    l = pdeg.shape[2]
    s = 0.0
    for a in range(k):
        s += abs(pcount[q, a] - pcount[c, a])
    n_free = 0
    h = 0.0
    for p in range(m):
        if not pin[q, p]:
            n_free += 1
            continue
        s += float(popcount(pu[q, p] ^ pu[c, p]))
        for y in range(m):
            if pin[q, y]:
                for a in range(l):
                    s += binary[q, p, y, a] != binary[c, p, y, a]
        for a in range(l):
            h += abs(pdeg[q, p, a, 0] - pdeg[c, p, a, 0]) + abs(pdeg[q, p, a, 1] - pdeg[c, p, a, 1])
    for a in range(l):
        for d in range(2):
            for t in range(n_free):
                h += abs(psorted[q, a, d, t] - psorted[c, a, d, t])
    return s + 0.5 * h


_BOUND = np.int64(1) << np.int64(31)     # pair memo flag: the entry is a lower bound, not the distance
_NO_ORDER = np.int64(1) << np.int64(30)  # pair memo flag: the exact distance, its first order not yet found
_INLINE_BITS = 3                         # up to _INLINE_MAX objects an order is packed in the memo value,
_INLINE_MAX = 7                          # 3 bits per object (21 bits, below the flags), not in the store
_TWO_PHASE_FROM = STRONG_FROM            # from this many objects, distances first in degree order


@njit(cache=True)
def _degree_orders(unary, binary, lock):
    """Per class, its positions relabelled for the distance search: the arguments first (as they
    are), then the others by decreasing number of true literals, stable. The most constrained
    positions placed first make a quadratic assignment's branch and bound cut early; the order
    does not change the distance, only the work. Returns the relabelled unary, binary and locks."""
    c_n, m, k = unary.shape
    l = binary.shape[3]
    ru = np.empty_like(unary)
    rb = np.empty_like(binary)
    rl = np.empty_like(lock)
    score = np.empty(m, dtype=np.int64)
    order = np.empty(m, dtype=np.int64)
    for c in range(c_n):
        n = 0
        for x in range(m):
            s = np.int64(0)
            for a in range(k):
                s += unary[c, x, a]
            for y in range(m):
                for a in range(l):
                    s += binary[c, x, y, a] + binary[c, y, x, a]
            score[x] = s
            if lock[c, x] != 0:
                order[n] = x
                n += 1
        first_free = n
        for x in range(m):
            if lock[c, x] == 0:
                t = n
                while t > first_free and score[order[t - 1]] < score[x]:
                    order[t] = order[t - 1]
                    t -= 1
                order[t] = x
                n += 1
        for x in range(m):
            ru[c, x] = unary[c, order[x]]
            rl[c, x] = lock[c, order[x]]
            for y in range(m):
                rb[c, x, y] = binary[c, order[x], order[y]]
    return ru, rb, rl


@njit(cache=True)
def _candidate_groups(c, have, cgroups, dgroups, ucode, ecode, ducode, decode, two_phase):
    """Fill class c's twin groups, in canonical order (``cgroups``) and in the degree order of
    phase 1 (``dgroups``), the first time a pass needs them."""
    if not have[c]:
        cgroups[c] = twin_groups_row(ucode[c], ecode[c])
        if two_phase:           # otherwise dgroups is cgroups
            dgroups[c] = twin_groups_row(ducode[c], decode[c])
        have[c] = True


@njit(cache=True)
def nearest_classes(unary, binary, lock, labels, profile, n_unary, lone, ucode, ecode, ids, memo, sigmas):
    """NeighbourhoodEngine.nearest_enumerated for every lone class: exact nearest classes, all ties.

    ``unary`` (C, M, K), ``binary`` (C, M, M, L), ``lock`` (C, M): class representatives in
    canonical order; ``profile`` (C, P) as ``neighbourhood.class_profiles``; ``lone`` (Q,) class
    indices; ``ucode``/``ecode`` the representatives' object and edge codes (for their twin groups).
    Candidates are visited in order of their lower bound (the profile bound, raised by
    :func:`_pinned_bound` where the query's arguments are pinned), ties by class, and the visits
    stop at the first bound above the best distance; the pinned part is computed only for the
    candidates that come up before that. A pair's distance is found by branch and bound over the
    enumeration's orders
    (:func:`_pair_distance`) cut at the query's best distance so far: a candidate that cannot
    tie it needs no exact distance.

    ``ids`` (C,) names each class by its canonical encoding (the caller interns the encodings)
    and ``memo`` (a numba typed dict) holds, per pair computed before, either the exact distance
    and first minimising order or a lower bound (flag :data:`_BOUND`): both are functions of the
    two encodings alone, so what ran before changes the work, never the result. An exact entry
    holds the distance and the offset of its order in ``sigmas`` (a numba typed list of uint8, M
    entries per pair: one byte per object, so any M up to :data:`MAX_OBJECTS`; the caller starts
    both afresh before the offsets reach the flag bits, 30 bits); up to :data:`_INLINE_MAX` objects
    the order is packed in the entry itself, 3 bits per object (no store traffic at the paper's size).

    Returns ``best`` (Q,) and the hits as parallel arrays (query position, class, sigma (H, M)),
    sorted by query, then class: sigma maps the query's canonical positions onto the class's.
    """
    c_n, m = lock.shape
    q_n = len(lone)
    best = np.full(q_n, INF)
    n_hits = 0
    hq = np.empty(4 * q_n + 4, dtype=np.int64)
    hv = np.empty(4 * q_n + 4, dtype=np.int64)
    hc = np.empty(4 * q_n + 4, dtype=np.int64)
    packed = np.empty(c_n, dtype=np.int64)
    sigma_mask = _BOUND - np.int64(1)
    sig = np.zeros(m, dtype=np.int64)
    cgroups = np.empty((c_n, m), dtype=np.int64)      # twin groups of each candidate, when first needed
    have_cgroups = np.zeros(c_n, dtype=np.bool_)
    pinned, pin, pu, pcount, pdeg, psorted = _pinned_tables(unary, binary, lock)
    ubits = np.int64((1 << n_unary) - 1)
    uword = np.empty((c_n, m), dtype=np.int64)
    for c in range(c_n):
        for x in range(m):
            uword[c, x] = ucode[c, x] & ubits
    um, out, inn = _object_masks(unary, binary)
    # from _TWO_PHASE_FROM objects, a pair's distance is searched with the candidate's positions in
    # degree order (phase 1, :func:`_degree_orders`), and the first minimising order in the
    # enumeration's order only for the pairs that end up tied at a query's nearest distance
    # (phase 2, cut at that distance): far candidates never pay for the lexicographic walk
    two_phase = m >= _TWO_PHASE_FROM
    inline_orders = m <= _INLINE_MAX
    if two_phase:
        du, db, dl = _degree_orders(unary, binary, lock)
        ducode, decode = state_codes(du, db, dl)
        dum, dout, dinn = _object_masks(du, db)
    else:
        dl, ducode, decode, dum, dout, dinn = lock, ucode, ecode, um, out, inn
    if two_phase:
        duword = np.empty((c_n, m), dtype=np.int64)
        for c in range(c_n):
            for x in range(m):
                duword[c, x] = ducode[c, x] & ubits
        dgroups = np.empty((c_n, m), dtype=np.int64)
    else:                       # one order: the degree-order views are the canonical ones
        duword, dgroups = uword, cgroups
    work = work_arrays(m)
    seq = np.empty(m, dtype=np.int64)
    used = np.zeros(m, dtype=np.bool_)
    nxt = np.zeros(m + 1, dtype=np.int64)
    cost = np.zeros(m + 1, dtype=np.int64)
    # compatible classes (same primitive, arguments at the same positions) form groups; a query
    # looks at its own group only, in increasing class order
    grp = np.empty(c_n, dtype=np.int64)
    for c in range(c_n):
        grp[c] = -1
        for c2 in range(c):
            if grp[c2] == c2 and labels[c2] == labels[c]:
                same = True
                for i in range(m):
                    if lock[c2, i] != lock[c, i]:
                        same = False
                        break
                if same:
                    grp[c] = c2
                    break
        if grp[c] < 0:
            grp[c] = c
    cand = np.empty(c_n, dtype=np.int64)
    cb = np.empty(c_n)
    heap_lo = np.empty(c_n)
    heap_c = np.empty(c_n, dtype=np.int64)
    dist = np.full(c_n, INF)
    for qi in range(q_n):
        q = lone[qi]
        n_c = 0
        for c in range(c_n):
            if c == q or grp[c] != grp[q]:
                continue
            s = 0.0
            h = 0.0
            for f in range(profile.shape[1]):
                d = abs(profile[q, f] - profile[c, f])
                if f < n_unary:
                    s += d
                else:
                    h += d
            lo = s + 0.5 * h                 # insertion by (bound, class): classes come in order
            t = n_c
            while t > 0 and cb[t - 1] > lo:
                cb[t] = cb[t - 1]
                cand[t] = cand[t - 1]
                t -= 1
            cb[t] = lo
            cand[t] = c
            n_c += 1
        if n_c == 0:
            continue
        groups = np.empty(0, dtype=np.int64)
        target = np.empty(0, dtype=np.int64)
        have_groups = False
        b = INF
        base = ids[q] << np.int64(32)
        # Visit candidates in order of (bound, class), the bound with the pinned arguments' part
        # where the query has them. That part is dearer and mostly not needed: candidates leave
        # ``cand`` in order of the profile part alone and get the pinned part on the way into a
        # heap, and the heap's top is visited once no candidate left in ``cand`` can come before
        # it (a full bound is never below the profile part). The order is the sorted order of
        # the full bounds; the visits stop at the first bound above the best distance.
        nxt_c = 0
        n_heap = 0
        while True:
            if n_heap > 0 and (nxt_c == n_c or heap_lo[0] < cb[nxt_c]
                               or (heap_lo[0] == cb[nxt_c] and heap_c[0] < cand[nxt_c])):
                c = heap_c[0]
                lo = heap_lo[0]
                n_heap = heap_pop(heap_lo, heap_c, n_heap)
            elif nxt_c < n_c:
                c = cand[nxt_c]
                lo = cb[nxt_c]
                nxt_c += 1
                if lo > b:
                    break
                if pinned[q]:
                    lo = max(lo, _pinned_bound(pin, q, c, pu, pcount, pdeg, binary, psorted, m))
                    n_heap = heap_push(heap_lo, heap_c, n_heap, lo, c)
                    continue
                # no pinned part: the profile bound is the whole bound, and the heap stays empty
            else:
                break
            if lo > b:
                break
            key = base | ids[c]
            v = memo.get(key, np.int64(-1))
            if v >= 0 and (v & _BOUND) != 0 and float(v >> np.int64(_DIST_SHIFT)) > b:
                dist[c] = float(v >> np.int64(_DIST_SHIFT))     # known to exceed the best: no tie
                continue
            if v < 0 or (v & _BOUND) != 0:
                if not have_groups:
                    groups, target = twin_groups_row(ucode[q], ecode[q]), -np.sort(-lock[q])
                    have_groups = True
                cut = np.int64(1 << 30) if b == INF else np.int64(b)
                if two_phase:
                    _candidate_groups(c, have_cgroups, cgroups, dgroups, ucode, ecode, ducode, decode, two_phase)
                    d = _pair_distance(uword[q], ecode[q], duword[c], decode[c], um[q], out[q], inn[q], dum[c],
                                       dout[c], dinn[c], lock[q], dl[c], groups, dgroups[c],
                                       cut, np.int64(math.ceil(lo)), seq, used, nxt, cost, sig, work, True)
                else:
                    d = _pair_distance(uword[q], ecode[q], uword[c], ecode[c], um[q], out[q], inn[q], um[c],
                                       out[c], inn[c], lock[q], target, groups, groups,
                                       cut, np.int64(math.ceil(lo)), seq, used, nxt, cost, sig, work, None)
                if d < 0:
                    v = ((cut + np.int64(1)) << np.int64(_DIST_SHIFT)) | _BOUND
                elif two_phase:
                    v = (d << np.int64(_DIST_SHIFT)) | _NO_ORDER
                elif inline_orders:
                    v = d << np.int64(_DIST_SHIFT)
                    for p in range(m):
                        v |= sig[p] << np.int64(_INLINE_BITS * p)
                else:
                    v = (d << np.int64(_DIST_SHIFT)) | np.int64(len(sigmas))
                    for p in range(m):
                        sigmas.append(np.uint8(sig[p]))
                memo[key] = v
            packed[c] = v
            dv = float(v >> np.int64(_DIST_SHIFT))
            dist[c] = dv
            if dv < b:
                b = dv
        best[qi] = b
        for c in range(c_n):                 # hits in class order (``cand`` is in bound order)
            if dist[c] == INF:
                continue
            if dist[c] == b:
                if (packed[c] & _NO_ORDER) != 0:       # phase 2: the first minimising order
                    if not have_groups:
                        groups, target = twin_groups_row(ucode[q], ecode[q]), -np.sort(-lock[q])
                        have_groups = True
                    _candidate_groups(c, have_cgroups, cgroups, dgroups, ucode, ecode, ducode, decode, two_phase)
                    d = np.int64(b)
                    _pair_distance(uword[q], ecode[q], uword[c], ecode[c], um[q], out[q], inn[q], um[c], out[c],
                                   inn[c], lock[q], target, groups, cgroups[c], d, d, seq, used, nxt, cost, sig, work, True)
                    packed[c] = (d << np.int64(_DIST_SHIFT)) | np.int64(len(sigmas))
                    for p in range(m):
                        sigmas.append(np.uint8(sig[p]))
                    memo[base | ids[c]] = packed[c]
                if n_hits == len(hq):
                    hq = np.concatenate((hq, np.empty_like(hq)))
                    hv = np.concatenate((hv, np.empty_like(hv)))
                    hc = np.concatenate((hc, np.empty_like(hc)))
                hq[n_hits] = qi
                hc[n_hits] = c
                hv[n_hits] = packed[c] & sigma_mask
                n_hits += 1
            dist[c] = INF
    hs = np.empty((n_hits, m), dtype=np.int64)
    for t in range(n_hits):
        for p in range(m):
            if inline_orders:
                hs[t, p] = (hv[t] >> np.int64(_INLINE_BITS * p)) & np.int64(7)
            else:
                hs[t, p] = sigmas[hv[t] + p]
    return best, hq[:n_hits], hc[:n_hits], hs


def new_memo():
    """An empty pair memo for :func:`nearest_classes`: the memo (int64 -> int64) and the store
    of its orders (uint8)."""
    return (numba.typed.Dict.empty(key_type=numba.types.int64, value_type=numba.types.int64),
            numba.typed.List.empty_list(numba.types.uint8))
