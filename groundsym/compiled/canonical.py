"""Canonical forms of states, compiled: the colour refinement, object order, twin test and
individualisation-refinement of :mod:`groundsym.relational.canonical` (their numpy reference),
the same 64-bit hashes wrapping the same way; as :data:`COMPILED_CANONICAL`, the steps
``canonical_forms`` takes. Whole batches with a per-state memo: :mod:`.batch`."""

from __future__ import annotations

import numpy as np

from .base import P0, P1, P2, P3, P4, P5, arrays_equal, mix, njit


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
            col[r, i] = mix(np.uint64(ucode[r, i]) + P0)
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
                nb += mix(c * P3 + np.uint64(ecode[i, j]) * P1 + mix(np.uint64(ecode[j, i]) * P2 + c))
            new[i] = mix(col[i] * P4 + nb)
        now = _n_distinct(new)
        if now <= classes:
            break
        col[:] = new
        classes = now
        if now >= m:
            break


@njit(cache=True)
def colour_order(col, lock):
    """canonical.colour_order: per row, objects by descending lock, then colour, then index."""
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
def order_row(col, lock):
    """:func:`colour_order` of one state: (M,) its objects in canonical order."""
    return colour_order(col.reshape(1, -1), lock.reshape(1, -1))[0]


@njit(cache=True)
def encode_row(unary, binary, lock, perm):
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
    new = mix(old ^ P5)
    while True:
        clash = False
        for c in col:
            if c == new:
                clash = True
                break
        if not clash:
            return new
        new = mix(new + np.uint64(1))


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
            perm = order_row(cols[depth], lock)
            cell = _target(cols[depth], perm, groups)
            if len(cell) == 0:                       # a leaf
                code = encode_row(unary, binary, lock, perm)
                this_is_first = not have_first
                if this_is_first:
                    first, first_perm = code, perm
                    have_first = True
                elif arrays_equal(code, first):
                    autos, n_autos = _add_automorphism(autos, n_autos, perm, first_perm)
                if len(best) == 0 or _less(code, best):
                    best, best_perm = code, perm
                    best_is_first = this_is_first
                elif arrays_equal(code, best) and not best_is_first:
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
    """canonical.needing_search: rows where two objects of one colour are not twins, and the
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
def state_codes(u, b, lock):
    """canonical.object_codes and canonical.codes of a batch: (N, M) object codes, (N, M, M) edge codes."""
    n, m = lock.shape
    ucode = np.empty((n, m), dtype=np.int64)
    ecode = np.empty((n, m, m), dtype=np.int64)
    for i in range(n):
        ucode[i], ecode[i] = state_codes_row(u[i], b[i], lock[i])
    return ucode, ecode


@njit(cache=True)
def state_codes_row(u, b, lock):
    """:func:`state_codes` of one state (any memory layout): (M,) object codes, (M, M) edge codes."""
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


class _CompiledCanonical:
    """The steps of ``relational.canonical.canonical_forms`` compiled (its ``CanonicalKernels``):
    the same colours, orders, twin groups and smallest leaves as the numpy reference."""

    def colours(self, ucode: np.ndarray, ecode: np.ndarray) -> np.ndarray:
        return colours(ucode, ecode)

    def colour_order(self, col: np.ndarray, lock: np.ndarray) -> np.ndarray:
        return colour_order(col, lock.astype(np.int64, copy=False))

    def needing_search(self, ucode: np.ndarray, ecode: np.ndarray, col: np.ndarray,
                       perms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        need, groups = needing_search(ucode, ecode, col, perms)
        return np.flatnonzero(need), groups[need]

    def individualise(self, unary: np.ndarray, binary: np.ndarray, lock: np.ndarray, ecode: np.ndarray,
                      groups: np.ndarray, col: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return individualise(unary, binary, lock.astype(np.int64, copy=False), ecode, groups, col)


#: ``canonical_forms(..., kernels=COMPILED_CANONICAL)``: canonical forms with these kernels.
COMPILED_CANONICAL = _CompiledCanonical()
