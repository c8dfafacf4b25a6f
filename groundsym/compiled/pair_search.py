"""The distance of a query class to a candidate class and its first minimising order, compiled: a
branch and bound over the orders the bit-parallel enumeration of
:mod:`groundsym.relational.enumeration` walks, in the same order (:func:`_pair_distance`), with
its lower bounds (:func:`_rest_bound`, and from :data:`STRONG_FROM` objects the linear
assignment of :func:`_assignment_bound`, Kuhn 1955). :mod:`.nearest` calls it for the pairs it
cannot rule out."""

from __future__ import annotations

import numpy as np

from .base import insert_sorted, njit, popcount


ASSIGNMENT_FROM = 3      # the assignment bound is computed at nodes with at least this many objects left
STRONG_FROM = 8          # from this many objects, the dearer bounds (sorted degrees, the assignment)
#: and candidate symmetry breaking: :func:`_pair_distance`'s ``strong`` is True there, None below.
#: None, not False: numba compiles one version per argument type and drops the ``is None``
#: branches from the None version, so a 7-object walk carries none of their code (an 11% faster
#: neighbourhood pass at 7 objects than a runtime flag, measured on replayed annealing passes)


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
    return np.int64(popcount(np.uint64(x)))


@njit(cache=True, inline="always")
def _rest_bound(umq, outq, inq, umc, outc, inc, seq, depth, rq, rc, dq, dc, strong):
    """A lower bound on the mismatches a partial order (positions 0..depth-1 filled by ``seq``)
    has still to add, where ``rq`` are the query's unplaced objects and ``rc`` the free positions:
    per symbol, the unary count difference among the rest, each placed object's out- and
    in-degree difference into the rest, and, for the edges within the rest, their count
    difference or (``strong`` not None) half the L1 difference of the sorted out-degree sequences plus that
    of the in-degree sequences (each mismatched edge changes one out- and one in-degree; sorted is
    the best matching of two sequences), rounded up, which is at least the count difference and
    dearer. The edge sets are disjoint and none is counted yet, so the sum is admissible.
    ``dq``/``dc`` (M,) are scratch."""
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
        if strong is None:
            eq_n = np.int64(0)
            ec_n = np.int64(0)
            for y in range(m):
                if (rq >> np.int64(y)) & np.int64(1):
                    eq_n += _pc(outq[y, a] & rq)
                if (rc >> np.int64(y)) & np.int64(1):
                    ec_n += _pc(outc[y, a] & rc)
            r += abs(eq_n - ec_n)
            continue
        h = np.int64(0)
        for side in range(2):
            nq = 0
            nc = 0
            for y in range(m):
                if (rq >> np.int64(y)) & np.int64(1):
                    insert_sorted(dq, nq, _pc((outq[y, a] if side == 0 else inq[y, a]) & rq))
                    nq += 1
                if (rc >> np.int64(y)) & np.int64(1):
                    insert_sorted(dc, nc, _pc((outc[y, a] if side == 0 else inc[y, a]) & rc))
                    nc += 1
            for t in range(nq):
                h += abs(dq[t] - dc[t])
        r += (h + np.int64(1)) // np.int64(2)
    return r


@njit(cache=True)
def _hungarian(mat, n, hu, hv, hp, way, minv, hused):
    """The minimum of a linear assignment on ``mat[:n, :n]`` (int64 costs), by shortest augmenting
    paths (Kuhn 1955 with potentials, O(n^3)); the other arguments are scratch of length >= n + 1."""
    big = np.int64(1) << np.int64(60)
    for j in range(n + 1):
        hu[j] = 0
        hv[j] = 0
        hp[j] = 0
        way[j] = 0
    for i in range(1, n + 1):
        hp[0] = i
        j0 = 0
        for j in range(n + 1):
            minv[j] = big
            hused[j] = False
        while True:
            hused[j0] = True
            i0 = hp[j0]
            delta = big
            j1 = 0
            for j in range(1, n + 1):
                if not hused[j]:
                    cur = mat[i0 - 1, j - 1] - hu[i0] - hv[j]
                    if cur < minv[j]:
                        minv[j] = cur
                        way[j] = j0
                    if minv[j] < delta:
                        delta = minv[j]
                        j1 = j
            for j in range(n + 1):
                if hused[j]:
                    hu[hp[j]] += delta
                    hv[j] -= delta
                else:
                    minv[j] -= delta
            j0 = j1
            if hp[j0] == 0:
                break
        while True:
            j1 = way[j0]
            hp[j0] = hp[j1]
            j0 = j1
            if j0 == 0:
                break
    return -hv[0]


@njit(cache=True)
def _assignment_bound(uq, eq, uc, ec, outq, inq, outc, inc, seq, depth, rq, rc, mat, xs, ps, hs):
    """A lower bound on what a partial order must still add, tighter than :func:`_rest_bound`:
    the linear assignment of the unplaced objects to the free positions where matching x with p
    costs their unary mismatches, their edge mismatches with every placed pair (exact), and half
    their out- and in-degree differences within the rest (the root bound of
    ``relational.branch_and_bound`` at this node). Every completion pays at least its
    assignment's cost, so the minimum, rounded up, is admissible. Costs are doubled to stay
    integers; ``mat``, ``xs``, ``ps`` and the tuple ``hs`` are scratch."""
    m = outq.shape[0]
    l = outq.shape[1]
    n = 0
    for y in range(m):
        if (rq >> np.int64(y)) & np.int64(1):
            xs[n] = y
            n += 1
    t = 0
    for y in range(m):
        if (rc >> np.int64(y)) & np.int64(1):
            ps[t] = y
            t += 1
    for i in range(n):
        x = xs[i]
        for j in range(n):
            p = ps[j]
            c = _pc(uq[x] ^ uc[p])
            for r in range(depth):
                c += _pc(eq[x, seq[r]] ^ ec[p, r]) + _pc(eq[seq[r], x] ^ ec[r, p])
            c *= 2
            for a in range(l):
                c += abs(_pc(outq[x, a] & rq) - _pc(outc[p, a] & rc)) + abs(_pc(inq[x, a] & rq) - _pc(inc[p, a] & rc))
            mat[i, j] = c
    total = _hungarian(mat, n, hs[0], hs[1], hs[2], hs[3], hs[4], hs[5])
    return (total + np.int64(1)) // np.int64(2)


@njit(cache=True)
def work_arrays(m):
    """Scratch of :func:`_pair_distance` for states of ``m`` objects, allocated once per pass rather
    than ten arrays per pair searched: sorted degrees (2), the assignment's
    matrix, the previous twin positions, the assignment's potentials and paths."""
    return (np.empty(m, dtype=np.int64), np.empty(m, dtype=np.int64), np.empty((m, m), dtype=np.int64),
            np.empty(m, dtype=np.int64), np.empty(m + 1, dtype=np.int64), np.empty(m + 1, dtype=np.int64),
            np.empty(m + 1, dtype=np.int64), np.empty(m + 1, dtype=np.int64), np.empty(m + 1, dtype=np.int64),
            np.empty(m + 1, dtype=np.bool_))


@njit(cache=True)
def _pair_distance(uq, eq, uc, ec, umq, outq, inq, umc, outc, inc, lock_q, target, groups, cgroups, cutoff, lo,
                   seq, used, nxt, cost, sigma, work, strong):
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

    Symmetry breaking on both sides: twins of the query (``groups``) are placed in increasing
    order, as the enumeration keeps them, and twin positions of the candidate (``cgroups``, per
    position its first interchangeable one) receive increasing objects. Neither loses the first
    minimiser: swapping two twins, or the objects at two twin positions, keeps the cost and the
    locks, so an order that breaks either rule has an equal order before it (the earlier of the
    two positions gets the smaller object). With many interchangeable objects (cubes that hold
    no relation) the walk visits the partial matchings of the others, not their M! orders.

    ``strong`` (True or None, see :data:`STRONG_FROM`) adds the dearer bounds and the candidate's
    symmetry breaking; either way the result is the same.

    Returns ``d`` and writes the first minimising order into ``sigma`` (M,): per query object,
    its position in the candidate; ``d`` is -1 when every order exceeds ``cutoff`` (nothing is
    known then beyond "more than cutoff", and ``sigma`` is left as it was).
    """
    m = len(lock_q)
    full = (np.int64(1) << np.int64(m)) - np.int64(1)
    best = np.int64(-1)
    dq, dc, mat, cprev = work[0], work[1], work[2], work[3]   # cprev: per position, the previous twin position
    hs = (work[4], work[5], work[6], work[7], work[8], work[9])
    if strong is not None:
        for p in range(m):
            cprev[p] = -1
            for r in range(p - 1, -1, -1):
                if cgroups[r] == cgroups[p]:
                    cprev[p] = r
                    break
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
                for p in range(m):
                    sigma[seq[p]] = p
                if d <= lo:
                    return best
            depth -= 1
            used[seq[depth]] = False
            rq |= np.int64(1) << np.int64(seq[depth])
            continue
        placed = False
        o = nxt[depth]
        if strong is not None and cprev[depth] >= 0 and o <= seq[cprev[depth]]:
            o = seq[cprev[depth]] + 1            # twin positions take increasing objects
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
                go = c < limit and c + _rest_bound(umq, outq, inq, umc, outc, inc, seq, depth + 1, rq_o, rc, dq, dc,
                                                   strong) < limit
                if strong is not None and go and m - depth - 1 >= ASSIGNMENT_FROM:
                    go = c + _assignment_bound(uq, eq, uc, ec, outq, inq, outc, inc, seq, depth + 1, rq_o, rc,
                                               mat, dq, dc, hs) < limit
                if go:
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
    return best
