"""One neighbourhood pass compiled whole (:func:`neighbourhood`; the reference is
``NeighbourhoodEngine.neighbours`` of :mod:`groundsym.neighbourhood`): canonical forms, classes of
equal keys (``neighbourhood.group_rows``), class profiles (``neighbourhood.class_profiles``),
interned class keys, then the nearest classes."""

from __future__ import annotations

import numpy as np

from .base import arrays_equal, insert_sorted, mix, njit, numba
from .batch import canonical_batch
from .canonical import state_codes
from .nearest import nearest_classes


@njit(cache=True)
def _row_less(keys, i, j):
    """Row i of ``keys`` before row j: bytes compared in order (memcmp), then the row index."""
    for c in range(keys.shape[1]):
        if keys[i, c] != keys[j, c]:
            return keys[i, c] < keys[j, c]
    return i < j


@njit(cache=True)
def group_keys(keys):
    """neighbourhood.group_rows compiled: (first row of each group, group id per row), groups numbered in
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
        if t == 0 or not arrays_equal(keys[r], keys[order[t - 1]]):
            g += 1
            first[g] = r
        cls[r] = g
    return first[:g + 1], cls


@njit(cache=True)
def lone_classes(cls, c_n):
    """The classes (of ``c_n``) with exactly one item in ``cls``, in increasing order."""
    sizes = np.zeros(c_n, dtype=np.int64)
    for i in range(len(cls)):
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
    return lone


@njit(cache=True)
def _profiles_of(u, b, rows):
    """neighbourhood.class_profiles compiled: unary counts, then sorted out- and in-degrees per binary symbol
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
                    insert_sorted(out[r, at:at + m], x, d)     # no allocation per row
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
        h = mix(h ^ x[i])
    return np.int64(h >> np.uint64(1))


@njit(cache=True)
def _intern(row, table, store):
    """The id of ``row`` in ``store`` (a typed list of rows), added if new; ``table`` maps a hash
    to an id and is probed linearly past rows that only share the hash."""
    h = _hash_words(row)
    while h in table:
        i = table[h]
        if len(store[i]) == len(row) and arrays_equal(store[i], row):
            return i
        h += 1
    i = len(store)
    store.append(row.copy())
    table[h] = i
    return i


@njit(cache=True)
def neighbourhood(u, b, lock, label, state_memo, table, store, memo, sigmas):
    """NeighbourhoodEngine.neighbours compiled whole (canonical forms, classes, nearest classes of
    lone classes).

    ``u`` (N, M, K), ``b`` (N, M, M, L), ``lock`` (N, M) int64, ``label`` (N,) int64 (< 256).
    ``state_memo`` as :func:`canonical_batch`; ``table``/``store`` intern the classes' keys
    (canonical form and primitive, :func:`_packed_keys`) for the pair ``memo`` of
    :func:`nearest_classes` and its store of orders ``sigmas``. Returns the fields of
    ``neighbourhood.Neighbourhood`` (cls, perms, lone, best, hit query, class, sigma) and the sizes
    of the state memo, the interned keys, the pair memo and its store
    (``len`` of a typed container called from Python compiles on first use, seconds, and costs a
    dispatch every time).
    """
    n, m = lock.shape
    forms, perms = canonical_batch(u, b, lock, state_memo)
    keys = _packed_keys(forms, label, m)
    first, cls = group_keys(keys)
    c_n = len(first)
    lone = lone_classes(cls, c_n)
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
    rucode, recode = state_codes(ru, rb, rl)
    best, hq, hc, hs = nearest_classes(ru, rb, rl, labels, profile, k, lone, rucode, recode, ids, memo, sigmas)
    return cls, perms, lone, best, hq, hc, hs, (len(state_memo), len(store), len(memo), len(sigmas))


def new_intern():
    """An empty interning table and store for :func:`neighbourhood` (hash -> id, id -> key row)."""
    table = numba.typed.Dict.empty(key_type=numba.types.int64, value_type=numba.types.int64)
    store = numba.typed.List.empty_list(numba.types.uint64[::1])
    return table, store
