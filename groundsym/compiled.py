"""Compiled (numba) kernels of the symbol loss's miss path, each mirroring a numpy reference.

The loss spends its time, on an abstraction it has not seen, in two places: canonical forms of
every state (colour refinement, :mod:`groundsym.canonical`) and the nearest classes of every lone
class (bit-parallel enumeration, ``Loss._nearest_enumerated``). Both are loops over a handful of
objects and a few thousand permutations, which numpy can only vectorise with large temporaries.
The kernels here compute the *same* integers (64-bit hashes that wrap the same way, the same
object orders, distances, first minimising permutations), so the loss is bit for bit the same
with or without them; ``tests/test_compiled.py`` checks that over thousands of annealing
evaluations. The numpy code stays the reference (``Loss(..., kernels="numpy")``).

numba compiles on first use and caches the machine code on disk (``cache=True``: beside this
module, or in ``NUMBA_CACHE_DIR``), so a process pays the compilation once and later processes
load it. Without numba installed, :data:`AVAILABLE` is False and the loss uses numpy.
"""

from __future__ import annotations

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
    h = np.uint64(0xCBF29CE484222325)
    for v in x:
        h = _mix(h ^ np.uint64(v))
    return np.int64(h >> np.uint64(1))


@njit(cache=True)
def canonical_batch(unary, binary, lock, ucode, ecode, memo):
    """canonical.canonical_forms compiled whole, with a per-state memo.

    A state's form and order are functions of the state alone, so they are kept in ``memo`` (a
    numba typed dict: hash of the state's own encoding -> its encoding, form and order, checked
    byte for byte on every hit; a hash collision is computed afresh and not stored). Returns
    (forms (N, R) uint8, perms (N, M) int64).
    """
    n, m = ucode.shape
    k = unary.shape[2]
    l = binary.shape[3]
    r_len = m + m * k + m * m * l
    forms = np.empty((n, r_len), dtype=np.uint8)
    perms = np.empty((n, m), dtype=np.int64)
    ident = np.arange(m)
    for i in range(n):
        raw = _encode_row(unary[i], binary[i], lock[i], ident)
        h = _hash_bytes(raw)
        if h in memo:
            entry = memo[h]
            if _equal(entry[:r_len], raw):
                forms[i] = entry[r_len:2 * r_len]
                for p in range(m):
                    perms[i, p] = entry[2 * r_len + p]
                continue
            store = False
        else:
            store = True
        col = np.empty(m, dtype=np.uint64)
        for x in range(m):
            col[x] = _mix(np.uint64(ucode[i, x]) + P0)
        refine_row(col, ecode[i])
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
                groups = twin_groups_row(ucode[i], ecode[i])
                for c in range(m - 1):
                    if col[perm[c]] == col[perm[c + 1]] and groups[perm[c]] != groups[perm[c + 1]]:
                        need = True
                        break
        if need:
            form, perm = individualise(unary[i], binary[i], lock[i], ecode[i], groups, col)
        else:
            form = _encode_row(unary[i], binary[i], lock[i], perm)
        forms[i] = form
        perms[i] = perm
        if store:
            entry = np.empty(2 * r_len + m, dtype=np.uint8)
            entry[:r_len] = raw
            entry[r_len:2 * r_len] = form
            for p in range(m):
                entry[2 * r_len + p] = np.uint8(perm[p])
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


@njit(cache=True)
def state_words(unary, binary):
    """(C, W) uint64: each state's flat bits (unary M*K, then binary M*M*L), bit j in word j // 64."""
    c, m, k = unary.shape
    l = binary.shape[3]
    nbits = m * k + m * m * l
    w = (nbits + 63) // 64
    out = np.zeros((c, max(w, 1)), dtype=np.uint64)
    for s in range(c):
        for i in range(m):
            for a in range(k):
                if unary[s, i, a]:
                    j = i * k + a
                    out[s, j >> 6] |= np.uint64(1) << np.uint64(j & 63)
            for i2 in range(m):
                for a in range(l):
                    if binary[s, i, i2, a]:
                        j = m * k + (i * m + i2) * l + a
                        out[s, j >> 6] |= np.uint64(1) << np.uint64(j & 63)
    return out


@njit(cache=True)
def _kept_orders(groups, lock):
    """Loss._enumerated_orders as permutations (rows: objects in new position order), in
    itertools (lexicographic) order: the action's arguments first (locks descending) and
    interchangeable objects in increasing order, generated directly by depth-first search."""
    m = len(groups)
    target = -np.sort(-lock)
    cap = 64
    out = np.empty((cap, m), dtype=np.int64)
    n = 0
    seq = np.empty(m, dtype=np.int64)
    nxt = np.zeros(m + 1, dtype=np.int64)     # next object to try at each depth
    used = np.zeros(m, dtype=np.bool_)
    depth = 0
    while depth >= 0:
        if depth == m:
            if n == cap:
                cap *= 2
                grown = np.empty((cap, m), dtype=np.int64)
                grown[:n] = out[:n]
                out = grown
            out[n] = seq
            n += 1
            depth -= 1
            used[seq[depth]] = False
            continue
        placed = False
        o = nxt[depth]
        while o < m:
            ok = not used[o] and lock[o] == target[depth]
            if ok:
                for e in range(o):            # earlier twins of o must already be placed
                    if groups[e] == groups[o] and not used[e]:
                        ok = False
                        break
            if ok:
                seq[depth] = o
                used[o] = True
                nxt[depth] = o + 1
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
    return out[:n]


@njit(cache=True)
def _orders_of(groups, lock, cache):
    """:func:`_kept_orders` as int8, memoised in ``cache`` by the structure (groups, locks)."""
    m = len(groups)
    key = np.int64(0)
    cacheable = True
    for i in range(m):
        if lock[i] >= 16:
            cacheable = False
        key |= np.int64(groups[i]) << np.int64(3 * i)
        key |= np.int64(lock[i] & 15) << np.int64(21 + 4 * i)
    if cacheable and key in cache:
        return cache[key]
    orders = _kept_orders(groups, lock).astype(np.int8)
    if cacheable:
        cache[key] = orders
    return orders


@njit(cache=True)
def _permuted_words(unary, binary, orders, w):
    """(P, W) the query's bits under each order (position p takes object orders[r, p]).

    Only the set bits are placed (states are sparse): per order, each lands where the order
    sends its objects."""
    m, k = unary.shape
    l = binary.shape[2]
    n_set = 0
    for i in range(m):
        for a in range(k):
            n_set += unary[i, a] != 0
        for i2 in range(m):
            for a in range(l):
                n_set += binary[i, i2, a] != 0
    src_i = np.empty(n_set, dtype=np.int64)      # object, second object (-1: unary), column
    src_j = np.empty(n_set, dtype=np.int64)
    col = np.empty(n_set, dtype=np.int64)
    t = 0
    for i in range(m):
        for a in range(k):
            if unary[i, a]:
                src_i[t], src_j[t], col[t] = i, -1, a
                t += 1
        for i2 in range(m):
            for a in range(l):
                if binary[i, i2, a]:
                    src_i[t], src_j[t], col[t] = i, i2, a
                    t += 1
    p = orders.shape[0]
    out = np.zeros((p, w), dtype=np.uint64)
    pos = np.empty(m, dtype=np.int64)
    for r in range(p):
        for q in range(m):
            pos[orders[r, q]] = q
        for t in range(n_set):
            if src_j[t] < 0:
                j = pos[src_i[t]] * k + col[t]
            else:
                j = m * k + (pos[src_i[t]] * m + pos[src_j[t]]) * l + col[t]
            out[r, j >> 6] |= np.uint64(1) << np.uint64(j & 63)
    return out


_SIGMA_BITS = 3          # a sigma entry (a position < 8) packed in 3 bits: enumeration is for M <= 7
_DIST_SHIFT = 32


@njit(cache=True)
def _pack(dist, orders, f, m):
    """One pair's exact distance and sigma (query position -> candidate position) as an int64."""
    v = np.int64(dist) << np.int64(_DIST_SHIFT)
    for p in range(m):
        v |= np.int64(p) << np.int64(_SIGMA_BITS * orders[f, p])
    return v


@njit(cache=True)
def nearest_classes(unary, binary, lock, labels, profile, n_unary, lone, ucode, ecode, ids, memo, order_cache):
    """Loss._nearest_enumerated for every lone class: exact nearest classes, all ties.

    ``unary`` (C, M, K), ``binary`` (C, M, M, L), ``lock`` (C, M): class representatives in
    canonical order; ``profile`` (C, P) as ``loss._profiles``; ``lone`` (Q,) class indices;
    ``ucode``/``ecode`` the representatives' object and edge codes (for their twin groups).
    Candidates are visited in order of the profile bound and skipped once it exceeds the best
    distance; a candidate's permutations stop at one that reaches its bound.

    ``ids`` (C,) names each class by its canonical encoding (the caller interns the encodings)
    and ``memo`` (a numba typed dict) holds the exact distance and first minimising permutation
    of every pair computed before: both are functions of the two encodings alone, so a pair is
    computed once per process however often the two classes meet again.

    Returns ``best`` (Q,) and the hits as parallel arrays (query position, class, sigma (H, M)),
    sorted by query, then class: sigma maps the query's canonical positions onto the class's.
    """
    c_n, m = lock.shape
    q_n = len(lone)
    words = state_words(unary, binary)
    w = words.shape[1]
    best = np.full(q_n, INF)
    n_hits = 0
    hq = np.empty(4 * q_n + 4, dtype=np.int64)
    hv = np.empty(4 * q_n + 4, dtype=np.int64)
    hc = np.empty(4 * q_n + 4, dtype=np.int64)
    bound = np.empty(c_n)
    packed = np.empty(c_n, dtype=np.int64)
    mask = np.int64((1 << _DIST_SHIFT) - 1)
    for qi in range(q_n):
        q = lone[qi]
        for c in range(c_n):
            ok = c != q and labels[c] == labels[q]
            if ok:
                for i in range(m):
                    if lock[c, i] != lock[q, i]:
                        ok = False
                        break
            if not ok:
                bound[c] = INF
                continue
            s = 0.0
            h = 0.0
            for f in range(profile.shape[1]):
                d = abs(profile[q, f] - profile[c, f])
                if f < n_unary:
                    s += d
                else:
                    h += d
            bound[c] = s + 0.5 * h
        order = np.argsort(bound, kind="mergesort")
        if bound[order[0]] == INF:
            continue
        orders = np.empty((0, m), dtype=np.int8)
        qw = np.empty((0, w), dtype=np.uint64)
        have_orders = False
        dist = np.full(c_n, INF)
        b = INF
        base = ids[q] << np.int64(32)
        for oi in range(c_n):
            c = order[oi]
            lo = bound[c]
            if lo == INF or lo > b:
                break
            key = base | ids[c]
            if key in memo:
                v = memo[key]
            else:
                if not have_orders:
                    orders = _orders_of(twin_groups_row(ucode[q], ecode[q]), lock[q], order_cache)
                    qw = _permuted_words(unary[q], binary[q], orders, w)
                    have_orders = True
                dmin = INF
                arg = 0
                for r in range(len(orders)):
                    d = np.uint64(0)
                    for x in range(w):
                        d += _popcount(qw[r, x] ^ words[c, x])
                    fd = float(d)
                    if fd < dmin:
                        dmin = fd
                        arg = r
                        if fd <= lo:
                            break
                v = _pack(dmin, orders, arg, m)
                memo[key] = v
            packed[c] = v
            dv = float(v >> np.int64(_DIST_SHIFT))
            dist[c] = dv
            if dv < b:
                b = dv
        best[qi] = b
        for c in range(c_n):
            if dist[c] == b:
                if n_hits == len(hq):
                    hq = np.concatenate((hq, np.empty_like(hq)))
                    hv = np.concatenate((hv, np.empty_like(hv)))
                    hc = np.concatenate((hc, np.empty_like(hc)))
                hq[n_hits] = qi
                hc[n_hits] = c
                hv[n_hits] = packed[c] & mask
                n_hits += 1
    hs = np.empty((n_hits, m), dtype=np.int64)
    for t in range(n_hits):
        for p in range(m):
            hs[t, p] = (hv[t] >> np.int64(_SIGMA_BITS * p)) & np.int64(7)
    return best, hq[:n_hits], hc[:n_hits], hs


def new_memo():
    """An empty pair memo for :func:`nearest_classes` (int64 -> int64)."""
    return numba.typed.Dict.empty(key_type=numba.types.int64, value_type=numba.types.int64)


def new_order_cache():
    """An empty cache of enumerated orders for :func:`nearest_classes` (int64 -> int8[:, :])."""
    return numba.typed.Dict.empty(key_type=numba.types.int64, value_type=numba.types.int8[:, :])


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
    hit_start = np.zeros(len(lone) + 1, dtype=np.int64)
    for t in range(len(hq)):
        hit_start[hq[t] + 1] += 1
    for q in range(len(lone)):
        hit_start[q + 1] += hit_start[q]
    lone_pos = np.full(len(start) - 1, -1, dtype=np.int64)
    for q in range(len(lone)):
        lone_pos[lone[q]] = q
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
def reward_entries(cls, lone, hq, hc):
    """loss.reward_entries (the numpy reference) compiled: the same entries in the same order."""
    n = len(cls)
    order, start = _class_members(cls)
    lone_pos = np.full(len(start) - 1, -1, dtype=np.int64)
    for q in range(len(lone)):
        lone_pos[lone[q]] = q
    total = 0
    for k in range(len(start) - 1):
        size = start[k + 1] - start[k]
        if size > 1:
            total += size * (size - 1)
    for t in range(len(hq)):
        total += start[hc[t] + 1] - start[hc[t]]
    item = np.empty(total, dtype=np.int64)
    other = np.empty(total, dtype=np.int64)
    e = 0
    for k in range(len(start) - 1):
        g0, g1 = start[k], start[k + 1]
        if g1 - g0 > 1:
            for a in range(g0, g1):
                for a2 in range(g0, g1):
                    if a != a2:
                        item[e] = order[a]
                        other[e] = order[a2]
                        e += 1
    for t in range(len(hq)):
        i = order[start[lone[hq[t]]]]
        c = hc[t]
        for g in range(start[c], start[c + 1]):
            item[e] = i
            other[e] = order[g]
            e += 1
    key = item * (n + 1) + other
    srt = np.argsort(key, kind="mergesort")
    return item[srt], other[srt]


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
                        np.arange(2, dtype=np.int64), new_memo(), new_order_cache())
        cls = np.array([0, 1], dtype=np.int64)
        one = np.zeros(0, dtype=np.int64)
        transition_entries(u, b, np.array([0, 0]), np.array([1, 1]), np.array([[0, 1, 2], [0, 1, 2]]), cls,
                           cls, one, one, np.zeros((0, 3), dtype=np.int64), True)
        reward_entries(cls, cls, one, one)
        from .canonical import canonical_forms    # a directed 4-cycle needs individualisation
        cyc = np.zeros((1, 4, 4, 1), dtype=np.uint8)
        for i in range(4):
            cyc[0, i, (i + 1) % 4, 0] = 1
        canonical_forms(np.zeros((1, 4, 1), dtype=np.uint8), cyc, np.zeros((1, 4), dtype=np.int64), kernels="numba")
        z4 = np.zeros((1, 4), dtype=np.int64)
        canonical_batch(np.zeros((1, 4, 1), dtype=np.uint8), cyc, z4, z4, cyc[..., 0].astype(np.int64), new_state_memo())
    return time.perf_counter() - t0
