"""Compiled (numba) kernels of the symbol loss's miss path, each mirroring a numpy reference.

The loss spends its time, on an abstraction it has not seen, in two places: canonical forms of
every state (colour refinement, :mod:`groundsym.canonical`) and the nearest classes of every lone
class (bit-parallel enumeration, ``Loss._nearest_enumerated``). Both are loops over a handful of
objects and a few thousand permutations, which numpy can only vectorise with large temporaries.
The kernels here compute the *same* integers (64-bit hashes that wrap the same way, the same
object orders, distances, first minimising permutations), so the loss is bit for bit the same
with or without them (the nearest classes come from a branch and bound over the orders the
reference enumerates, cut only where no order can beat the first minimiser the enumeration
returns); ``tests/test_compiled.py`` checks that over thousands of annealing evaluations. The
numpy code stays the reference (``Loss(..., kernels="numpy")``).

numba compiles on first use and caches the machine code on disk (``cache=True``: beside this
module, or in ``NUMBA_CACHE_DIR``), so a process pays the compilation once and later processes
load it. Without numba installed, :data:`AVAILABLE` is False and the loss uses numpy.
"""

from __future__ import annotations

import math

import numpy as np

try:  # numba is a dependency; the numpy reference keeps the loss usable without it
    import numba
    from numba import njit
    AVAILABLE = True
except ImportError:  # pragma: no cover - exercised only where numba cannot install
    numba = None
    AVAILABLE = False

    def njit(*args, **kwargs):  # type: ignore[no-redef]
        return (lambda f: f) if not (len(args) == 1 and callable(args[0])) else args[0]

from .canonical import _M1, _M2, _P

M1, M2 = np.uint64(_M1), np.uint64(_M2)
P0, P1, P2, P3, P4, P5 = (np.uint64(p) for p in _P[:6])
INF = np.inf
LN2 = math.log(2.0)   # as symbols.LN2


# ----------------------------------------------------------------------------- canonical forms

@njit(cache=True, inline="always")
def _mix(x):
    """canonical._mix on one uint64 (multiplication wraps modulo 2^64, as in numpy)."""
    x = x ^ (x >> np.uint64(33))
    x = x * M1
    x = x ^ (x >> np.uint64(33))
    x = x * M2
    return x ^ (x >> np.uint64(33))


@njit(cache=True)
def _n_distinct(values):
    s = np.sort(values)
    n = 1 if len(s) else 0
    for i in range(1, len(s)):
        if s[i] != s[i - 1]:
            n += 1
    return n


@njit(cache=True)
def colours(ucode, ecode):
    """canonical.colours: (N, M) refined colours, each row refined until its own partition is stable."""
    n, m = ucode.shape
    col = np.empty((n, m), dtype=np.uint64)
    for r in range(n):
        for i in range(m):
            col[r, i] = _mix(np.uint64(ucode[r, i]) + P0)
    if m < 2:
        return col
    for r in range(n):
        refine_row(col[r], ecode[r])
    return col


@njit(cache=True)
def refine_row(col, ecode):
    """canonical.refine on one state, in place: rounds until one splits no class."""
    m = len(col)
    if m < 2:
        return
    new = np.empty(m, dtype=np.uint64)
    classes = _n_distinct(col)
    for _ in range(m):
        for i in range(m):
            nb = np.uint64(0)
            for j in range(m):
                if j == i:
                    continue
                c = col[j]
                nb += _mix(c * P3 + np.uint64(ecode[i, j]) * P1 + _mix(np.uint64(ecode[j, i]) * P2 + c))
            new[i] = _mix(col[i] * P4 + nb)
        now = _n_distinct(new)
        if now <= classes:
            break
        col[:] = new
        classes = now
        if now >= m:
            break


@njit(cache=True)
def colour_order(col, lock):
    """canonical._colour_order: per row, objects by descending lock, then colour, then index."""
    n, m = col.shape
    perms = np.empty((n, m), dtype=np.int64)
    for r in range(n):
        p = perms[r]
        for i in range(m):
            p[i] = i
        for i in range(1, m):       # insertion sort: stable, M is small
            x = p[i]
            j = i - 1
            while j >= 0:
                y = p[j]
                if lock[r, y] > lock[r, x] or (lock[r, y] == lock[r, x] and col[r, y] <= col[r, x]):
                    break
                p[j + 1] = y
                j -= 1
            p[j + 1] = x
    return perms


@njit(cache=True)
def _order_row(col, lock):
    return colour_order(col.reshape(1, -1), lock.reshape(1, -1))[0]


@njit(cache=True)
def _encode_row(unary, binary, lock, perm):
    """canonical.encode_rows of one state in the order ``perm``: locks, unary bits, binary bits."""
    m, k = unary.shape
    l = binary.shape[2]
    out = np.empty(m + m * k + m * m * l, dtype=np.uint8)
    t = 0
    for p in range(m):
        out[t] = np.uint8(lock[perm[p]])
        t += 1
    for p in range(m):
        for a in range(k):
            out[t] = unary[perm[p], a]
            t += 1
    for p in range(m):
        for q in range(m):
            for a in range(l):
                out[t] = binary[perm[p], perm[q], a]
                t += 1
    return out


@njit(cache=True)
def _less(a, b):
    """Lexicographic a < b for equal-length uint8 arrays (bytes order)."""
    for i in range(len(a)):
        if a[i] != b[i]:
            return a[i] < b[i]
    return False


@njit(cache=True)
def _target(col, perm, groups):
    """canonical._Search._target: the first colour class in canonical order holding objects
    that are not twins, as sorted objects (empty when there is none)."""
    m = len(perm)
    s = 0
    while s < m:
        e = s + 1
        while e < m and col[perm[e]] == col[perm[s]]:
            e += 1
        if e - s > 1:
            mixed = False
            for x in range(s + 1, e):
                if groups[perm[x]] != groups[perm[s]]:
                    mixed = True
                    break
            if mixed:
                return np.sort(perm[s:e].copy())
        s = e
    return np.empty(0, dtype=np.int64)


@njit(cache=True)
def _individual_colour(col, old):
    new = _mix(old ^ P5)
    while True:
        clash = False
        for c in col:
            if c == new:
                clash = True
                break
        if not clash:
            return new
        new = _mix(new + np.uint64(1))


@njit(cache=True)
def _orbit_roots(autos, n_autos, prefix, depth, m):
    """canonical._Search._orbit_roots: orbits of the automorphisms found that fix the prefix."""
    parent = np.arange(m)
    for g in range(n_autos):
        fixes = True
        for d in range(depth):
            if autos[g, prefix[d]] != prefix[d]:
                fixes = False
                break
        if not fixes:
            continue
        for x in range(m):
            a = x
            while parent[a] != a:
                a = parent[a]
            b = autos[g, x]
            while parent[b] != b:
                b = parent[b]
            if a != b:
                parent[max(a, b)] = min(a, b)
    roots = np.empty(m, dtype=np.int64)
    for x in range(m):
        a = x
        while parent[a] != a:
            a = parent[a]
        roots[x] = a
    return roots


@njit(cache=True)
def individualise(unary, binary, lock, ecode, groups, col0):
    """canonical._Search compiled (the same tree, visiting order, pruning and smallest leaf):
    individualisation-refinement for one state whose colour classes are not all twins.
    Returns (canonical encoding, canonical order)."""
    m = len(lock)
    size = m + 1
    cols = np.empty((size, m), dtype=np.uint64)
    cells = np.empty((size, m), dtype=np.int64)
    cell_len = np.zeros(size, dtype=np.int64)
    idx = np.zeros(size, dtype=np.int64)
    visited = np.empty((size, m), dtype=np.int64)
    n_visited = np.zeros(size, dtype=np.int64)
    fresh = np.empty(size, dtype=np.uint64)
    prefix = np.empty(size, dtype=np.int64)
    autos = np.empty((8, m), dtype=np.int64)
    n_autos = 0
    have_first = False
    best_is_first = False
    first = np.empty(0, dtype=np.uint8)
    first_perm = np.empty(0, dtype=np.int64)
    best = np.empty(0, dtype=np.uint8)
    best_perm = np.empty(0, dtype=np.int64)
    cols[0] = col0
    depth = 0
    entering = True
    while depth >= 0:
        if entering:
            perm = _order_row(cols[depth], lock)
            cell = _target(cols[depth], perm, groups)
            if len(cell) == 0:                       # a leaf
                code = _encode_row(unary, binary, lock, perm)
                this_is_first = not have_first
                if this_is_first:
                    first, first_perm = code, perm
                    have_first = True
                elif _equal(code, first):
                    autos, n_autos = _add_automorphism(autos, n_autos, perm, first_perm)
                if len(best) == 0 or _less(code, best):
                    best, best_perm = code, perm
                    best_is_first = this_is_first
                elif _equal(code, best) and not best_is_first:
                    autos, n_autos = _add_automorphism(autos, n_autos, perm, best_perm)
                depth -= 1
                entering = False
                continue
            cell_len[depth] = len(cell)
            cells[depth, :len(cell)] = cell
            fresh[depth] = _individual_colour(cols[depth], cols[depth, cell[0]])
            idx[depth] = 0
            n_visited[depth] = 0
            entering = False
        # continue the loop over the target cell at this depth
        descended = False
        while idx[depth] < cell_len[depth]:
            v = cells[depth, idx[depth]]
            idx[depth] += 1
            skip = False
            for w in range(n_visited[depth]):
                if groups[v] == groups[visited[depth, w]]:
                    skip = True
                    break
            if not skip and n_autos > 0 and n_visited[depth] > 0:
                roots = _orbit_roots(autos, n_autos, prefix, depth, m)
                for w in range(n_visited[depth]):
                    if roots[v] == roots[visited[depth, w]]:
                        skip = True
                        break
            if skip:
                continue
            visited[depth, n_visited[depth]] = v
            n_visited[depth] += 1
            prefix[depth] = v
            cols[depth + 1] = cols[depth]
            cols[depth + 1, v] = fresh[depth]
            refine_row(cols[depth + 1], ecode)
            depth += 1
            entering = True
            descended = True
            break
        if not descended:
            depth -= 1
    return best, best_perm


@njit(cache=True)
def _equal(a, b):
    for i in range(len(a)):
        if a[i] != b[i]:
            return False
    return True


@njit(cache=True)
def _add_automorphism(autos, n_autos, perm, other):
    """Two leaves with equal encodings: object perm[c] -> other[c] preserves the state; kept
    unless it is the identity."""
    m = len(perm)
    gamma = np.empty(m, dtype=np.int64)
    for c in range(m):
        gamma[perm[c]] = other[c]
    for x in range(m):
        if gamma[x] != x:
            if n_autos == len(autos):
                grown = np.empty((2 * len(autos), m), dtype=np.int64)
                grown[:n_autos] = autos[:n_autos]
                autos = grown
            autos[n_autos] = gamma
            return autos, n_autos + 1
    return autos, n_autos


@njit(cache=True)
def twin_groups_row(ucode, ecode):
    """canonical.twin_groups_of for one state: per object, its first interchangeable object."""
    m = ucode.shape[0]
    groups = np.empty(m, dtype=np.int64)
    for i in range(m):
        groups[i] = i
        for j in range(i):
            if ucode[i] != ucode[j] or ecode[i, j] != ecode[j, i]:
                continue
            same = True
            for k in range(m):
                if k != i and k != j and (ecode[i, k] != ecode[j, k] or ecode[k, i] != ecode[k, j]):
                    same = False
                    break
            if same:
                groups[i] = j
                break
    return groups


@njit(cache=True)
def needing_search(ucode, ecode, col, perms):
    """canonical._needing_search: rows where two objects of one colour are not twins, and the
    twin groups of every row (filled for rows with a colour tie; others: identity)."""
    n, m = col.shape
    need = np.zeros(n, dtype=np.bool_)
    groups = np.empty((n, m), dtype=np.int64)
    for r in range(n):
        tie = False
        for c in range(m - 1):
            if col[r, perms[r, c]] == col[r, perms[r, c + 1]]:
                tie = True
                break
        if not tie:
            for i in range(m):
                groups[r, i] = i
            continue
        groups[r] = twin_groups_row(ucode[r], ecode[r])
        for c in range(m - 1):
            a, b = perms[r, c], perms[r, c + 1]
            if col[r, a] == col[r, b] and groups[r, a] != groups[r, b]:
                need[r] = True
                break
    return need, groups


@njit(cache=True)
def _hash_bytes(x):
    """A 63-bit hash of a byte row, eight bytes per mixing step (memo keys; hits are checked)."""
    h = np.uint64(0xCBF29CE484222325) ^ np.uint64(len(x))
    n = len(x)
    i = 0
    while i < n:
        v = np.uint64(0)
        for j in range(min(8, n - i)):
            v |= np.uint64(x[i + j]) << np.uint64(8 * j)
        h = _mix(h ^ v)
        i += 8
    return np.int64(h >> np.uint64(1))


@njit(cache=True)
def _pack_state(unary, binary, lock, raw):
    """A small state's own encoding as two 64-bit words, written into ``raw`` (16 bytes), and their hash.

    For M <= 7 objects whose M*K + M*M*L bits fit a word: the bits in one word, the locks (a byte
    each) and the shape (K, L) in the other, so equal words mean equal states of the same shape.
    Cheaper than :func:`_encode_row` and :func:`_hash_bytes` on the memo's hit path."""
    m, k = unary.shape
    l = binary.shape[2]
    bits = np.uint64(0)
    j = np.uint64(0)
    for i in range(m):
        for a in range(k):
            if unary[i, a]:
                bits |= np.uint64(1) << j
            j += np.uint64(1)
    for i in range(m):
        for i2 in range(m):
            for a in range(l):
                if binary[i, i2, a]:
                    bits |= np.uint64(1) << j
                j += np.uint64(1)
    meta = np.uint64(k * 16 + l) << np.uint64(56)
    for i in range(m):
        meta |= np.uint64(lock[i] & 255) << np.uint64(8 * i)
    for t in range(8):
        raw[t] = np.uint8((bits >> np.uint64(8 * t)) & np.uint64(255))
        raw[8 + t] = np.uint8((meta >> np.uint64(8 * t)) & np.uint64(255))
    return np.int64(_mix(bits ^ _mix(meta + P1)) >> np.uint64(1))


@njit(cache=True)
def canonical_batch(unary, binary, lock, memo):
    """canonical.canonical_forms compiled whole, with a per-state memo.

    A state's form and order are functions of the state alone, so they are kept in ``memo`` (a
    numba typed dict: hash of the state's own encoding -> its encoding, form and order, checked
    byte for byte on every hit; a hash collision is computed afresh and not stored). The object
    and edge codes (``canonical.object_codes``/``codes``) are computed for the states the memo
    does not hold only. Returns (forms (N, R) uint8, perms (N, M) int64).
    """
    n, m = lock.shape
    k = unary.shape[2]
    l = binary.shape[3]
    r_len = m + m * k + m * m * l
    forms = np.empty((n, r_len), dtype=np.uint8)
    perms = np.empty((n, m), dtype=np.int64)
    ident = np.arange(m)
    packable = m <= 7 and m * k + m * m * l <= 64 and k < 16 and l < 16
    r_key = 16 if packable else r_len
    raw = np.empty(r_key, dtype=np.uint8)
    for i in range(n):
        if packable:
            h = _pack_state(unary[i], binary[i], lock[i], raw)
        else:
            raw = _encode_row(unary[i], binary[i], lock[i], ident)
            h = _hash_bytes(raw)
        if h in memo:
            entry = memo[h]
            if len(entry) == r_key + r_len + m and _equal(entry[:r_key], raw):
                forms[i] = entry[r_key:r_key + r_len]
                for p in range(m):
                    perms[i, p] = entry[r_key + r_len + p]
                continue
            store = False
        else:
            store = True
        ucode, ecode = _codes_row(unary[i], binary[i], lock[i])
        col = np.empty(m, dtype=np.uint64)
        for x in range(m):
            col[x] = _mix(np.uint64(ucode[x]) + P0)
        refine_row(col, ecode)
        perm = _order_row(col, lock[i])
        need = False
        groups = ident
        if m >= 2:
            tie = False
            for c in range(m - 1):
                if col[perm[c]] == col[perm[c + 1]]:
                    tie = True
                    break
            if tie:
                groups = twin_groups_row(ucode, ecode)
                for c in range(m - 1):
                    if col[perm[c]] == col[perm[c + 1]] and groups[perm[c]] != groups[perm[c + 1]]:
                        need = True
                        break
        if need:
            form, perm = individualise(unary[i], binary[i], lock[i], ecode, groups, col)
        else:
            form = _encode_row(unary[i], binary[i], lock[i], perm)
        forms[i] = form
        perms[i] = perm
        if store:
            entry = np.empty(r_key + r_len + m, dtype=np.uint8)
            entry[:r_key] = raw
            entry[r_key:r_key + r_len] = form
            for p in range(m):
                entry[r_key + r_len + p] = np.uint8(perm[p])
            memo[h] = entry
    return forms, perms


def new_state_memo():
    """An empty per-state memo for :func:`canonical_batch` (int64 -> uint8[:])."""
    return numba.typed.Dict.empty(key_type=numba.types.int64, value_type=numba.types.uint8[:])


# ----------------------------------------------------------------------------- nearest classes

@njit(cache=True, inline="always")
def _popcount(x):
    x = x - ((x >> np.uint64(1)) & np.uint64(0x5555555555555555))
    x = (x & np.uint64(0x3333333333333333)) + ((x >> np.uint64(2)) & np.uint64(0x3333333333333333))
    x = (x + (x >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (x * np.uint64(0x0101010101010101)) >> np.uint64(56)


_SIGMA_BITS = 3          # a sigma entry (a position < 8) packed in 3 bits: enumeration is for M <= 7
_DIST_SHIFT = 32


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
                        v = pdeg[c, p, a, d]        # insertion sort: a handful of values, no allocation
                        t = n_free
                        while t > 0 and psorted[c, a, d, t - 1] > v:
                            psorted[c, a, d, t] = psorted[c, a, d, t - 1]
                            t -= 1
                        psorted[c, a, d, t] = v
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
        s += float(_popcount(pu[q, p] ^ pu[c, p]))
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


@njit(cache=True)
def _object_masks(unary, binary):
    """Per class, object sets as m-bit masks: ``um`` (C, K) the objects holding each unary symbol,
    ``out``/``inn`` (C, M, L) each object's out- and in-neighbours under each binary symbol."""
    c_n, m, k = unary.shape
    l = binary.shape[3]
    um = np.zeros((c_n, k), dtype=np.int64)
    out = np.zeros((c_n, m, l), dtype=np.int64)
    inn = np.zeros((c_n, m, l), dtype=np.int64)
    for c in range(c_n):
        for x in range(m):
            for a in range(k):
                if unary[c, x, a]:
                    um[c, a] |= np.int64(1) << np.int64(x)
            for y in range(m):
                for a in range(l):
                    if binary[c, x, y, a]:
                        out[c, x, a] |= np.int64(1) << np.int64(y)
                        inn[c, y, a] |= np.int64(1) << np.int64(x)
    return um, out, inn


@njit(cache=True, inline="always")
def _pc(x):
    return np.int64(_popcount(np.uint64(x)))


@njit(cache=True, inline="always")
def _rest_bound(umq, outq, inq, umc, outc, inc, seq, depth, rq, rc):
    """A lower bound on the mismatches a partial order (positions 0..depth-1 filled by ``seq``)
    has still to add, where ``rq`` are the query's unplaced objects and ``rc`` the free positions:
    per symbol, the unary count difference among the rest, each placed object's out- and
    in-degree difference into the rest, and the edge count difference within the rest. The edge
    sets are disjoint and none is counted yet, so the sum is admissible."""
    k = umq.shape[0]
    l = outq.shape[1]
    m = outq.shape[0]
    r = np.int64(0)
    for a in range(k):
        r += abs(_pc(umq[a] & rq) - _pc(umc[a] & rc))
    for a in range(l):
        for p in range(depth):
            x = seq[p]
            r += abs(_pc(outq[x, a] & rq) - _pc(outc[p, a] & rc))
            r += abs(_pc(inq[x, a] & rq) - _pc(inc[p, a] & rc))
        eq_n = np.int64(0)
        ec_n = np.int64(0)
        for y in range(m):
            if (rq >> np.int64(y)) & np.int64(1):
                eq_n += _pc(outq[y, a] & rq)
            if (rc >> np.int64(y)) & np.int64(1):
                ec_n += _pc(outc[y, a] & rc)
        r += abs(eq_n - ec_n)
    return r


@njit(cache=True)
def _pair_distance(uq, eq, uc, ec, umq, outq, inq, umc, outc, inc, lock_q, target, groups, cutoff, lo,
                   seq, used, nxt, cost):
    """The distance of a query to a candidate class and its first minimising order, by branch and bound.

    Walks the kept orders of the enumeration (the query's object placed at each position, in
    lexicographic order) depth first, adding each placement's mismatches as it goes: the unary
    bits (``uq``/``uc``: per object a word of its unary bits) and the edges (``eq``/``ec``: per
    pair a word of its binary bits) to the objects already placed, both ways; :func:`_rest_bound`
    bounds what the rest must add. A branch whose bound exceeds ``cutoff`` (before a full order
    is found) or reaches the best full order so far is cut: neither can hold a first minimiser
    the enumeration would return, so the result is the enumeration's (distance, order) whenever
    the distance is at most ``cutoff``. A full order at ``lo`` (a lower bound) ends the walk, as
    the enumeration stops there.

    Returns ``(d, sigma)``, sigma packed :data:`_SIGMA_BITS` bits per query object (its position
    in the candidate); ``d`` is -1 when every order exceeds ``cutoff`` (nothing is known then
    beyond "more than cutoff").
    """
    m = len(lock_q)
    full = (np.int64(1) << np.int64(m)) - np.int64(1)
    best = np.int64(-1)
    best_v = np.int64(0)
    used[:] = False
    depth = 0
    nxt[0] = 0
    cost[0] = 0
    rq = full
    while depth >= 0:
        if depth == m:
            d = cost[m]
            if best < 0 or d < best:
                best = d
                best_v = np.int64(0)
                for p in range(m):
                    best_v |= np.int64(p) << np.int64(_SIGMA_BITS * seq[p])
                if d <= lo:
                    return best, best_v
            depth -= 1
            used[seq[depth]] = False
            rq |= np.int64(1) << np.int64(seq[depth])
            continue
        placed = False
        o = nxt[depth]
        rc = full & ~((np.int64(1) << np.int64(depth + 1)) - np.int64(1))
        while o < m:
            ok = not used[o] and lock_q[o] == target[depth]
            if ok:
                for e in range(o):            # earlier twins of o must already be placed
                    if groups[e] == groups[o] and not used[e]:
                        ok = False
                        break
            if ok:
                c = cost[depth] + _pc(uq[o] ^ uc[depth]) + _pc(eq[o, o] ^ ec[depth, depth])
                for p in range(depth):
                    x = seq[p]
                    c += _pc(eq[o, x] ^ ec[depth, p]) + _pc(eq[x, o] ^ ec[p, depth])
                limit = cutoff + 1 if best < 0 else best     # a branch must stay below this
                seq[depth] = o
                rq_o = rq & ~(np.int64(1) << np.int64(o))
                if c < limit and c + _rest_bound(umq, outq, inq, umc, outc, inc, seq, depth + 1, rq_o, rc) < limit:
                    used[o] = True
                    rq = rq_o
                    nxt[depth] = o + 1
                    cost[depth + 1] = c
                    nxt[depth + 1] = 0
                    depth += 1
                    placed = True
                    break
            o += 1
        if not placed:
            nxt[depth] = 0
            depth -= 1
            if depth >= 0:
                used[seq[depth]] = False
                rq |= np.int64(1) << np.int64(seq[depth])
    return best, best_v


@njit(cache=True, inline="always")
def _heap_before(lo, c, i, j):
    return lo[i] < lo[j] or (lo[i] == lo[j] and c[i] < c[j])


@njit(cache=True)
def _heap_push(lo, c, n, v, x):
    """Push (v, x) on the binary min-heap ``lo``/``c`` of ``n`` entries, ordered by (lo, c)."""
    i = n
    lo[i] = v
    c[i] = x
    while i > 0:
        p = (i - 1) >> 1
        if not _heap_before(lo, c, i, p):
            break
        lo[i], lo[p] = lo[p], lo[i]
        c[i], c[p] = c[p], c[i]
        i = p
    return n + 1


@njit(cache=True)
def _heap_pop(lo, c, n):
    """Remove the top of the heap (read it at index 0 before); returns the new size."""
    n -= 1
    lo[0] = lo[n]
    c[0] = c[n]
    i = 0
    while True:
        a = 2 * i + 1
        if a >= n:
            break
        if a + 1 < n and _heap_before(lo, c, a + 1, a):
            a += 1
        if not _heap_before(lo, c, a, i):
            break
        lo[i], lo[a] = lo[a], lo[i]
        c[i], c[a] = c[a], c[i]
        i = a
    return n


@njit(cache=True)
def nearest_classes(unary, binary, lock, labels, profile, n_unary, lone, ucode, ecode, ids, memo):
    """Loss._nearest_enumerated for every lone class: exact nearest classes, all ties.

    ``unary`` (C, M, K), ``binary`` (C, M, M, L), ``lock`` (C, M): class representatives in
    canonical order; ``profile`` (C, P) as ``loss._profiles``; ``lone`` (Q,) class indices;
    ``ucode``/``ecode`` the representatives' object and edge codes (for their twin groups).
    Candidates are visited in order of their lower bound (the profile bound, raised by
    :func:`_pinned_bound` where the query's arguments are pinned), ties by class, and the visits
    stop at the first bound above the best distance; the pinned part is computed only for the
    candidates that come up before that. A pair's distance is found by branch and bound over the enumeration's orders
    (:func:`_pair_distance`) cut at the query's best distance so far: a candidate that cannot
    tie it needs no exact distance.

    ``ids`` (C,) names each class by its canonical encoding (the caller interns the encodings)
    and ``memo`` (a numba typed dict) holds, per pair computed before, either the exact distance
    and first minimising order or a lower bound (flag :data:`_BOUND`): both are functions of the
    two encodings alone, so what ran before changes the work, never the result.

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
    pinned, pin, pu, pcount, pdeg, psorted = _pinned_tables(unary, binary, lock)
    ubits = np.int64((1 << n_unary) - 1)
    uword = np.empty((c_n, m), dtype=np.int64)
    for c in range(c_n):
        for x in range(m):
            uword[c, x] = ucode[c, x] & ubits
    um, out, inn = _object_masks(unary, binary)
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
                n_heap = _heap_pop(heap_lo, heap_c, n_heap)
            elif nxt_c < n_c:
                c = cand[nxt_c]
                lo = cb[nxt_c]
                nxt_c += 1
                if lo > b:
                    break
                if pinned[q]:
                    lo = max(lo, _pinned_bound(pin, q, c, pu, pcount, pdeg, binary, psorted, m))
                n_heap = _heap_push(heap_lo, heap_c, n_heap, lo, c)
                continue
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
                    groups = twin_groups_row(ucode[q], ecode[q])
                    target = -np.sort(-lock[q])
                    have_groups = True
                cut = np.int64(1 << 30) if b == INF else np.int64(b)
                d, sv = _pair_distance(uword[q], ecode[q], uword[c], ecode[c], um[q], out[q], inn[q], um[c], out[c],
                                       inn[c], lock[q], target, groups,
                                       cut, np.int64(math.ceil(lo)), seq, used, nxt, cost)
                if d < 0:
                    v = ((cut + np.int64(1)) << np.int64(_DIST_SHIFT)) | _BOUND
                else:
                    v = (d << np.int64(_DIST_SHIFT)) | sv
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
            hs[t, p] = (hv[t] >> np.int64(_SIGMA_BITS * p)) & np.int64(7)
    return best, hq[:n_hits], hc[:n_hits], hs


@njit(cache=True)
def _codes(u, b, lock):
    """canonical.object_codes and canonical.codes of a batch: (N, M) object codes, (N, M, M) edge codes."""
    n, m = lock.shape
    ucode = np.empty((n, m), dtype=np.int64)
    ecode = np.empty((n, m, m), dtype=np.int64)
    for i in range(n):
        ucode[i], ecode[i] = _codes_row(u[i], b[i], lock[i])
    return ucode, ecode


@njit(cache=True)
def _codes_row(u, b, lock):
    """:func:`_codes` of one state (any memory layout): (M,) object codes, (M, M) edge codes."""
    m, k = u.shape
    l = b.shape[2]
    ucode = np.empty(m, dtype=np.int64)
    ecode = np.empty((m, m), dtype=np.int64)
    for x in range(m):
        v = np.int64(lock[x]) << np.int64(k)
        for a in range(k):
            v += np.int64(u[x, a]) << np.int64(a)
        ucode[x] = v
        for y in range(m):
            e = np.int64(0)
            for a in range(l):
                e += np.int64(b[x, y, a]) << np.int64(a)
            ecode[x, y] = e
    return ucode, ecode


@njit(cache=True)
def _row_less(keys, i, j):
    """Row i of ``keys`` before row j: bytes compared in order (memcmp), then the row index."""
    for c in range(keys.shape[1]):
        if keys[i, c] != keys[j, c]:
            return keys[i, c] < keys[j, c]
    return i < j


@njit(cache=True)
def group_keys(keys):
    """loss.group_rows compiled: (first row of each group, group id per row), groups numbered in
    sorted (byte) order of the rows, a group's first row its smallest index."""
    n = keys.shape[0]
    order = np.arange(n)
    tmp = np.empty(n, dtype=np.int64)
    width = 1
    while width < n:                       # bottom-up merge sort by (row bytes, index)
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            a, z, t = lo, mid, lo
            while a < mid and z < hi:
                if _row_less(keys, order[z], order[a]):
                    tmp[t] = order[z]
                    z += 1
                else:
                    tmp[t] = order[a]
                    a += 1
                t += 1
            while a < mid:
                tmp[t] = order[a]
                a += 1
                t += 1
            while z < hi:
                tmp[t] = order[z]
                z += 1
                t += 1
        order, tmp = tmp, order
        width *= 2
    cls = np.empty(n, dtype=np.int64)
    first = np.empty(n, dtype=np.int64)
    g = -1
    for t in range(n):
        r = order[t]
        if t == 0 or not _equal(keys[r], keys[order[t - 1]]):
            g += 1
            first[g] = r
        cls[r] = g
    return first[:g + 1], cls


@njit(cache=True)
def _profiles_of(u, b, rows):
    """loss._profiles compiled: unary counts, then sorted out- and in-degrees per binary symbol
    (symbol by symbol, where the reference interleaves the symbols: the profile bound is an L1
    distance, which the order of the columns does not change)."""
    n = len(rows)
    m, k = u.shape[1], u.shape[2]
    l = b.shape[3]
    out = np.zeros((n, k + 2 * m * l), dtype=np.int64)
    for r in range(n):
        s = rows[r]
        for a in range(k):
            for x in range(m):
                out[r, a] += u[s, x, a]
        for a in range(l):
            for side in range(2):           # out-degrees, then in-degrees, each sorted
                at = k + side * m * l + a * m
                for x in range(m):
                    d = 0
                    for y in range(m):
                        d += b[s, x, y, a] if side == 0 else b[s, y, x, a]
                    t = x                   # insertion sort in place: no allocation per row
                    while t > 0 and out[r, at + t - 1] > d:
                        out[r, at + t] = out[r, at + t - 1]
                        t -= 1
                    out[r, at + t] = d
    return out


@njit(cache=True)
def _packed_keys(forms, label, m):
    """Each state's class key (canonical form, then primitive label) packed into 64-bit words that
    compare, as unsigned integers word by word, in the order the key's bytes compare (memcmp).

    The form's first ``m`` bytes (the locks) and the label keep 8 bits each, the 0/1 bytes of the
    truth values take one bit each, most significant first: the same fields at the same places
    in every row, so the first differing field decides both comparisons. Sorting and hashing two
    or three words is what grouping and interning then cost, instead of some 64 bytes. A last word
    holds the shape, so that the interned keys of abstractions with other symbol counts never
    coincide."""
    n, r_len = forms.shape
    n_bits = 8 * m + (r_len - m) + 8
    w = (n_bits + 63) // 64
    out = np.zeros((n, w + 1), dtype=np.uint64)
    for i in range(n):
        out[i, w] = np.uint64(r_len) | (np.uint64(m) << np.uint64(32))   # the shape: keys of other shapes differ
        pos = 0
        for t in range(r_len + 1):
            width = 8 if (t < m or t == r_len) else 1
            v = np.uint64(label[i] & 255) if t == r_len else np.uint64(forms[i, t])
            for bit in range(width - 1, -1, -1):
                if (v >> np.uint64(bit)) & np.uint64(1):
                    out[i, pos >> 6] |= np.uint64(1) << np.uint64(63 - (pos & 63))
                pos += 1
    return out


@njit(cache=True)
def _hash_words(x):
    """A 63-bit hash of a row of 64-bit words (memo keys; hits are checked)."""
    h = np.uint64(0xCBF29CE484222325) ^ np.uint64(len(x))
    for i in range(len(x)):
        h = _mix(h ^ x[i])
    return np.int64(h >> np.uint64(1))


@njit(cache=True)
def _intern(row, table, store):
    """The id of ``row`` in ``store`` (a typed list of rows), added if new; ``table`` maps a hash
    to an id and is probed linearly past rows that only share the hash."""
    h = _hash_words(row)
    while h in table:
        i = table[h]
        if len(store[i]) == len(row) and _equal(store[i], row):
            return i
        h += 1
    i = len(store)
    store.append(row.copy())
    table[h] = i
    return i


@njit(cache=True)
def neighbourhood(u, b, lock, label, state_memo, table, store, memo):
    """Loss.neighbours compiled whole (canonical forms, classes, nearest classes of lone classes).

    ``u`` (N, M, K), ``b`` (N, M, M, L), ``lock`` (N, M) int64, ``label`` (N,) int64 (< 256).
    ``state_memo`` as :func:`canonical_batch`; ``table``/``store`` intern the classes' keys
    (canonical form and primitive, :func:`_packed_keys`) for the pair ``memo`` of
    :func:`nearest_classes`. Returns the fields of ``loss.Neighbourhood`` (cls, perms, lone, best,
    hit query, class, sigma) and the sizes of the state memo, the interned keys and the pair memo
    (``len`` of a typed container called from Python compiles on first use, seconds, and costs a
    dispatch every time).
    """
    n, m = lock.shape
    forms, perms = canonical_batch(u, b, lock, state_memo)
    keys = _packed_keys(forms, label, m)
    first, cls = group_keys(keys)
    c_n = len(first)
    sizes = np.zeros(c_n, dtype=np.int64)
    for i in range(n):
        sizes[cls[i]] += 1
    n_lone = 0
    for c in range(c_n):
        n_lone += sizes[c] == 1
    lone = np.empty(n_lone, dtype=np.int64)
    t = 0
    for c in range(c_n):
        if sizes[c] == 1:
            lone[t] = c
            t += 1
    k = u.shape[2]
    l = b.shape[3]
    ru = np.empty((c_n, m, k), dtype=np.uint8)
    rb = np.empty((c_n, m, m, l), dtype=np.uint8)
    rl = np.empty((c_n, m), dtype=np.int64)
    labels = np.empty(c_n, dtype=np.int64)
    ids = np.empty(c_n, dtype=np.int64)
    for c in range(c_n):
        f = first[c]
        for x in range(m):
            px = perms[f, x]
            ru[c, x] = u[f, px]
            rl[c, x] = lock[f, px]
            for y in range(m):
                rb[c, x, y] = b[f, px, perms[f, y]]
        labels[c] = label[f]
        ids[c] = _intern(keys[f], table, store)
    profile = _profiles_of(u, b, first)
    rucode, recode = _codes(ru, rb, rl)
    best, hq, hc, hs = nearest_classes(ru, rb, rl, labels, profile, k, lone, rucode, recode, ids, memo)
    return cls, perms, lone, best, hq, hc, hs, (len(state_memo), len(store), len(memo))


def new_intern():
    """An empty interning table and store for :func:`neighbourhood` (hash -> id, id -> key row)."""
    table = numba.typed.Dict.empty(key_type=numba.types.int64, value_type=numba.types.int64)
    store = numba.typed.List.empty_list(numba.types.uint64[::1])
    return table, store


@njit(cache=True)
def rbf_holds(space, centre, widths):
    """Symbol.holds over the rows of ``space`` (P, n): the same float steps, dimension by dimension."""
    out = np.empty(space.shape[0], dtype=np.bool_)
    n = len(centre)
    for r in range(space.shape[0]):
        z = (space[r, 0] - centre[0]) / widths[0]
        acc = z * z
        for d in range(1, n):
            z = (space[r, d] - centre[d]) / widths[d]
            acc += z * z
        out[r] = acc < LN2
    return out


def new_memo():
    """An empty pair memo for :func:`nearest_classes` (int64 -> int64)."""
    return numba.typed.Dict.empty(key_type=numba.types.int64, value_type=numba.types.int64)


# ----------------------------------------------------------------------------- mixture entries

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
    """loss.transition_entries (the numpy reference) compiled: the same entries in the same order."""
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
    """loss.reward_entries (the numpy reference) compiled: the same entries in the same order,
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
    """First half of loss.mixture_ll: per item the largest log-probability, per entry its distance to it."""
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
    """:func:`transition_entries` and the float steps of loss.mixture_ll before the exponential:
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
    """Second half of loss.mixture_ll: per item the weighted sum of ``e`` and of the weights,
    accumulated in entry order (as ``np.add.at`` does)."""
    acc = np.zeros(n)
    cnt = np.zeros(n)
    for t in range(len(item)):
        acc[item[t]] += weight[t] * e[t]
        cnt[item[t]] += weight[t]
    return acc, cnt


def warm_up() -> float:
    """Compile (or load from the disk cache) every kernel on a tiny input; returns the seconds spent.

    Called once per process before timing-sensitive work, so that compilation is reported apart.
    """
    import time
    t0 = time.perf_counter()
    if AVAILABLE:
        u = np.zeros((2, 3, 1), dtype=np.uint8)
        b = np.zeros((2, 3, 3, 1), dtype=np.uint8)
        b[0, 0, 1, 0] = 1
        lock = np.zeros((2, 3), dtype=np.int64)
        ucode = np.zeros((2, 3), dtype=np.int64)
        ecode = b[..., 0].astype(np.int64)
        col = colours(ucode, ecode)
        perms = colour_order(col, lock)
        needing_search(ucode, ecode, col, perms)
        prof = np.zeros((2, 7), dtype=np.int64)
        nearest_classes(u, b, lock, np.zeros(2, dtype=np.int64), prof, 1, np.array([0, 1]), ucode, ecode,
                        np.arange(2, dtype=np.int64), new_memo())
        cls = np.array([0, 1], dtype=np.int64)
        one = np.zeros(0, dtype=np.int64)
        transition_entries(u, b, np.array([0, 0]), np.array([1, 1]), np.array([[0, 1, 2], [0, 1, 2]]), cls,
                           cls, one, one, np.zeros((0, 3), dtype=np.int64), True)
        reward_entries(cls, cls, one, one)
        item, weight, diff, top = transition_mixture(u, b, np.array([0, 0]), np.array([1, 1]),
                                                     np.array([[0, 1, 2], [0, 1, 2]]), cls, cls, one, one,
                                                     np.zeros((0, 3), dtype=np.int64), True, -3.0, -0.05, 6)
        mixture_sums(item, np.exp(diff), weight, 2)
        reward_mixture(cls, cls, one, one, np.zeros(2), -1.0, 2.0)
        rbf_holds(np.zeros((3, 2)), np.zeros(2), np.ones(2))
        neighbourhood(u, b, lock, np.zeros(2, dtype=np.int64), new_state_memo(), *new_intern(), new_memo())
        from .canonical import canonical_forms    # a directed 4-cycle needs individualisation
        cyc = np.zeros((1, 4, 4, 1), dtype=np.uint8)
        for i in range(4):
            cyc[0, i, (i + 1) % 4, 0] = 1
        canonical_forms(np.zeros((1, 4, 1), dtype=np.uint8), cyc, np.zeros((1, 4), dtype=np.int64), kernels="numba")
        z4 = np.zeros((1, 4), dtype=np.int64)
        canonical_batch(np.zeros((1, 4, 1), dtype=np.uint8), cyc, z4, new_state_memo())
    return time.perf_counter() - t0
