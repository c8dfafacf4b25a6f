"""Canonical forms of small relational states: equal encodings if and only if isomorphic.

The symbol-learning loss groups isomorphic state(-action) pairs into classes (distance 0 to each
other) and caches distances between classes across evaluations, keyed by their encodings. That
is only sound if a state's canonical form is a function of the state alone: never of the batch
it was computed in, nor of what was computed before. Everything here is built that way:

* **Colour refinement** (Weisfeiler-Lehman by 64-bit hashing) runs on each state until *its own*
  partition is stable; a batch only shares the array operations. Isomorphic states stop in the
  same round with the same colours, so ordering objects by colour is the same for both.
* When every colour class consists of interchangeable objects ("twins": swapping any two leaves
  the state unchanged), that order is canonical already (the common case).
* Otherwise **individualisation-refinement** (the method of nauty and bliss): pick the first
  class in colour order that is not all twins, give each of its objects in turn a colour of its
  own, refine, and recurse; the canonical encoding is the smallest leaf. Twins and automorphisms
  found on the way (two leaves with the same encoding) prune siblings, which keeps symmetric
  states (5 mutual pairs, cycles, complete bipartite graphs) to a few dozen leaves instead of
  every order of every class.

Hash collisions could only merge colour classes; they never break exactness, because the search
visits an isomorphism-invariant tree and every leaf is an actual encoding of the state.

The hashing itself is :mod:`.hashing`. The numpy code here is the reference of the compiled
kernels (:mod:`groundsym.compiled.canonical`); :func:`canonical_forms` takes its four steps with
compiled twins as one :class:`CanonicalKernels` object, so this module never imports the
kernels (they build on it).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from .hashing import HASH_PRIMES, mix

__all__ = ["NUMPY_CANONICAL", "CanonicalKernels", "canonical_form", "canonical_forms", "encode_rows", "refine",
           "search_leaves", "twin_groups_of"]


def codes(bits: np.ndarray) -> np.ndarray:
    """Pack the last axis of a 0/1 array into integers (up to 62 bits)."""
    if bits.shape[-1] == 0:
        return np.zeros(bits.shape[:-1], dtype=np.int64)
    return (bits.astype(np.int64) << np.arange(bits.shape[-1], dtype=np.int64)).sum(-1)


def object_codes(unary: np.ndarray, lock: np.ndarray) -> np.ndarray:
    """Per object: its unary bits and its action-argument lock as one integer (the initial colour)."""
    return codes(unary) + (lock.astype(np.int64) << unary.shape[-1])


def _n_classes(col: np.ndarray) -> np.ndarray:
    """Per row: the number of distinct colours."""
    if col.shape[1] == 0:
        return np.zeros(len(col), dtype=np.int64)
    srt = np.sort(col, axis=1)
    return 1 + (srt[:, 1:] != srt[:, :-1]).sum(1)


def initial_colours(ucode: np.ndarray) -> np.ndarray:
    """Colours before refinement: a hash of each object's own code."""
    return mix(ucode.astype(np.uint64) + HASH_PRIMES[0])


def refine(col: np.ndarray, ecode: np.ndarray) -> np.ndarray:
    """Refine colours ``col`` (N, M) by the edge codes ``ecode`` (N, M, M) until each row is stable.

    A row stops in the first round that splits none of its classes and keeps the colours it had
    then, whatever the other rows do: the result for a state depends on that state only.
    """
    col = col.copy()
    n, m = col.shape
    if n == 0 or m < 2:
        return col
    off = ~np.eye(m, dtype=bool)[None]
    active = np.arange(n)
    classes = _n_classes(col)
    for _ in range(m):
        c, e = col[active], ecode[active]
        out_e = e.astype(np.uint64) * HASH_PRIMES[1]
        in_e = e.transpose(0, 2, 1).astype(np.uint64) * HASH_PRIMES[2]
        t = mix(c[:, None, :] * HASH_PRIMES[3] + out_e + mix(in_e + c[:, None, :]))
        nb = np.where(off, t, np.uint64(0)).sum(2, dtype=np.uint64)
        new = mix(c * HASH_PRIMES[4] + nb)
        now = _n_classes(new)
        split = now > classes[active]   # refinement only splits classes
        col[active[split]] = new[split]
        classes[active[split]] = now[split]
        active = active[split & (now < m)]
        if not len(active):
            break
    return col


def colours(ucode: np.ndarray, ecode: np.ndarray) -> np.ndarray:
    """Stable refined colours of a batch of states (each row independent of the others)."""
    return refine(initial_colours(ucode), ecode)


def twins(ucode: np.ndarray, ecode: np.ndarray) -> np.ndarray:
    """(N, M, M): objects i, j interchangeable (the transposition (i j) leaves the state unchanged)."""
    m = ucode.shape[1]
    row = (ecode[:, :, None, :] != ecode[:, None, :, :]).sum(-1)          # over k, including k in {i, j}
    col = (ecode.transpose(0, 2, 1)[:, :, None, :] != ecode.transpose(0, 2, 1)[:, None, :, :]).sum(-1)
    nz = ecode != 0
    # remove the k = i and k = j terms: E[i,i]=E[j,j]=0, so they count E[j,i]!=0 and E[i,j]!=0
    row = row - nz.transpose(0, 2, 1) - nz
    col = col - nz - nz.transpose(0, 2, 1)
    same = (ucode[:, :, None] == ucode[:, None, :]) & (row == 0) & (col == 0) & (ecode == ecode.transpose(0, 2, 1))
    return same | np.eye(m, dtype=bool)[None]


def twin_groups_of(unary: np.ndarray, binary: np.ndarray, lock: np.ndarray) -> np.ndarray:
    """Group id per object of a batch (``unary`` (N, M, K), ``binary`` (N, M, M, L), ``lock``
    (N, M)): objects in one group are interchangeable. The id is the group's first object."""
    n, m = unary.shape[:2]
    if m == 0:
        return np.zeros((n, 0), dtype=np.int64)
    return np.argmax(twins(object_codes(unary, lock), codes(binary)), axis=2)


def encode_rows(unary: np.ndarray, binary: np.ndarray, lock: np.ndarray) -> np.ndarray:
    """The flat uint8 encoding of a batch of states in their given object order: locks, unary
    bits, binary bits. Lexicographic order of these rows is the order canonical forms minimise."""
    n = unary.shape[0]
    return np.concatenate([lock.reshape(n, -1).astype(np.uint8), unary.reshape(n, -1).astype(np.uint8),
                           binary.reshape(n, -1).astype(np.uint8)], axis=1)


def colour_order(col: np.ndarray, lock: np.ndarray) -> np.ndarray:
    """Object order of a batch: action arguments first (by lock), then ascending colour, ties by
    index. Candidates with the same arguments then hold them at the same canonical positions,
    which the loss's enumeration kernel relies on."""
    return np.lexsort((col, -lock.astype(np.int64)), axis=-1)


def needing_search(ucode: np.ndarray, ecode: np.ndarray, col: np.ndarray,
                    perms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows in which two objects of one colour are not interchangeable, with their twin groups.

    Twins are an equivalence relation, so comparing neighbours in colour order is enough; they
    are computed only for rows that have a tie at all (most rows have none, and the twin test
    costs ``M^3`` per row)."""
    rows = np.arange(len(col))[:, None]
    i, j = perms[:, :-1], perms[:, 1:]
    tied = col[rows, i] == col[rows, j]
    cand = np.flatnonzero(tied.any(1))
    if not len(cand):
        return cand, np.zeros((0, col.shape[1]), dtype=np.int64)
    groups = np.argmax(twins(ucode[cand], ecode[cand]), axis=2)
    r = np.arange(len(cand))[:, None]
    bad = (tied[cand] & (groups[r, i[cand]] != groups[r, j[cand]])).any(1)
    return cand[bad], groups[bad]


class CanonicalKernels(Protocol):
    """The four steps of :func:`canonical_forms` that have compiled twins, as one object: the
    caller chooses the kernels once and passes them. :data:`NUMPY_CANONICAL` is the reference;
    ``groundsym.compiled.COMPILED_CANONICAL`` computes the same integers (docs/symbols.md)."""

    def colours(self, ucode: np.ndarray, ecode: np.ndarray) -> np.ndarray:
        """Stable refined colours (N, M) of a batch (:func:`colours`)."""

    def colour_order(self, col: np.ndarray, lock: np.ndarray) -> np.ndarray:
        """(N, M) objects ordered by lock, then colour, then index (:func:`colour_order`)."""

    def needing_search(self, ucode: np.ndarray, ecode: np.ndarray, col: np.ndarray,
                       perms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rows whose colour classes are not all twins, and their twin groups (:func:`needing_search`)."""

    def individualise(self, unary: np.ndarray, binary: np.ndarray, lock: np.ndarray, ecode: np.ndarray,
                      groups: np.ndarray, col: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The canonical encoding and order of one such state, by individualisation-refinement."""


class _NumpyCanonical:
    """The reference steps: this module's numpy code."""

    def colours(self, ucode: np.ndarray, ecode: np.ndarray) -> np.ndarray:
        return colours(ucode, ecode)

    def colour_order(self, col: np.ndarray, lock: np.ndarray) -> np.ndarray:
        return colour_order(col, lock)

    def needing_search(self, ucode: np.ndarray, ecode: np.ndarray, col: np.ndarray,
                       perms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return needing_search(ucode, ecode, col, perms)

    def individualise(self, unary: np.ndarray, binary: np.ndarray, lock: np.ndarray, ecode: np.ndarray,
                      groups: np.ndarray, col: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return _Search(unary, binary, lock, ecode, groups).run(col)


#: The numpy reference of the :class:`CanonicalKernels`.
NUMPY_CANONICAL: CanonicalKernels = _NumpyCanonical()


def canonical_forms(unary: np.ndarray, binary: np.ndarray, lock: np.ndarray,
                    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] | None = None,
                    kernels: CanonicalKernels = NUMPY_CANONICAL) -> tuple[np.ndarray, np.ndarray]:
    """Canonical encodings of a batch of states: equal rows if and only if the states are isomorphic.

    ``unary`` (N, M, K), ``binary`` (N, M, M, L) with zero diagonals, ``lock`` (N, M) small ints
    (action argument masks; objects match only objects with the same lock). Returns ``codes``
    (N, W) uint8 and ``perms`` (N, M): canonical position ``c`` of state ``n`` holds its object
    ``perms[n, c]``. Both are functions of each state alone (see the module docstring). States
    that need the individualisation search are memoised in ``cache`` when given, keyed by the
    state's own encoding (sound, because the result depends on nothing else). ``kernels``
    computes the colours, orders, twin tests and searches: this module's numpy code (the
    reference) or the compiled kernels of :mod:`groundsym.compiled` (the same integers).
    """
    n, m = unary.shape[:2]
    ucode = object_codes(unary, lock)
    ecode = codes(binary)
    col = kernels.colours(ucode, ecode)
    perms = kernels.colour_order(col, lock)
    idx = np.arange(n)[:, None]
    out = encode_rows(unary[idx, perms], binary[idx[:, :, None], perms[:, :, None], perms[:, None, :]],
                      lock[idx, perms])
    if m < 2:
        return out, perms
    for k, groups in zip(*kernels.needing_search(ucode, ecode, col, perms)):
        raw = encode_rows(unary[k:k + 1], binary[k:k + 1], lock[k:k + 1]).tobytes() if cache is not None else b""
        hit = cache.get(raw) if cache is not None else None
        if hit is None:
            hit = kernels.individualise(unary[k], binary[k], lock[k], ecode[k], groups, col[k])
            if cache is not None:
                if len(cache) > 100_000:
                    cache.clear()
                cache[raw] = hit
        out[k], perms[k] = hit
    return out, perms


def canonical_form(unary: np.ndarray, binary: np.ndarray, lock: np.ndarray,
                   kernels: CanonicalKernels = NUMPY_CANONICAL) -> tuple[np.ndarray, np.ndarray]:
    """:func:`canonical_forms` of one state: ``unary`` (M, K), ``binary`` (M, M, L), ``lock`` (M,)."""
    codes_, perms = canonical_forms(unary[None], binary[None], lock[None], kernels=kernels)
    return codes_[0], perms[0]


class _Search:
    """Individualisation-refinement for one state whose colour classes are not all twins."""

    def __init__(self, unary: np.ndarray, binary: np.ndarray, lock: np.ndarray, ecode: np.ndarray,
                 groups: np.ndarray):
        self.unary, self.binary, self.lock = unary, binary, lock
        self.ecode = ecode[None]
        self.groups = groups
        self.best: bytes | None = None
        self.best_perm: np.ndarray | None = None
        self.first_perm: np.ndarray | None = None
        self.first: bytes | None = None
        self.autos: list[np.ndarray] = []   # automorphisms found: object -> object
        self.leaves = 0

    def run(self, col: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self._visit(col, [])
        assert self.best is not None and self.best_perm is not None
        return np.frombuffer(self.best, dtype=np.uint8).copy(), self.best_perm

    def _encode(self, perm: np.ndarray) -> bytes:
        return encode_rows(self.unary[perm][None], self.binary[perm][:, perm][None], self.lock[perm][None]).tobytes()

    def _target(self, col: np.ndarray, perm: np.ndarray) -> np.ndarray | None:
        """The first colour class (in canonical order) holding objects that are not twins."""
        c = col[perm]
        starts = np.flatnonzero(np.r_[True, c[1:] != c[:-1]])
        ends = np.r_[starts[1:], len(c)]
        for s, e in zip(starts, ends):
            if e - s > 1 and len(np.unique(self.groups[perm[s:e]])) > 1:
                return np.sort(perm[s:e])
        return None

    def _leaf(self, perm: np.ndarray) -> None:
        self.leaves += 1
        code = self._encode(perm)
        if self.first is None:
            self.first, self.first_perm = code, perm
        elif code == self.first:
            self._automorphism(perm, self.first_perm)
        if self.best is None or code < self.best:
            self.best, self.best_perm = code, perm
        elif code == self.best and self.best_perm is not self.first_perm:
            self._automorphism(perm, self.best_perm)

    def _automorphism(self, perm: np.ndarray, other: np.ndarray) -> None:
        """Two leaves with equal encodings: object perm[c] -> other[c] preserves the state."""
        gamma = np.empty(len(perm), dtype=np.int64)
        gamma[perm] = other
        if not np.array_equal(gamma, np.arange(len(perm))):
            self.autos.append(gamma)

    def _orbit_roots(self, prefix: list[int]) -> np.ndarray:
        """Orbits of the automorphisms found so far that fix every individualised object."""
        m = len(self.groups)
        parent = np.arange(m)

        def root(x: int) -> int:
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        fixed = np.array(prefix, dtype=np.int64)
        for g in self.autos:
            if len(fixed) and not np.array_equal(g[fixed], fixed):
                continue
            for x in range(m):
                a, b = root(x), root(int(g[x]))
                if a != b:
                    parent[max(a, b)] = min(a, b)
        return np.array([root(x) for x in range(m)])

    def _visit(self, col: np.ndarray, prefix: list[int]) -> None:
        perm = colour_order(col[None], self.lock[None])[0]
        cell = self._target(col, perm)
        if cell is None:
            self._leaf(perm)
            return
        fresh = _individual_colour(col, col[cell[0]])
        visited: list[int] = []
        for v in cell.tolist():
            if any(self.groups[v] == self.groups[w] for w in visited):
                continue        # a twin of a visited object: the transposition maps one subtree onto the other
            if self.autos and visited:
                roots = self._orbit_roots(prefix)
                if any(roots[v] == roots[w] for w in visited):
                    continue    # an automorphism fixing the prefix maps v onto a visited object
            visited.append(v)
            child = col.copy()
            child[v] = fresh
            self._visit(refine(child[None], self.ecode)[0], prefix + [v])


def _individual_colour(col: np.ndarray, old: np.uint64) -> np.uint64:
    """A colour for an object taken out of its class: a function of the class's colour only (so
    every choice of object gets the same one), moved on while it collides with a colour in use."""
    new = mix(np.array([old], dtype=np.uint64) ^ HASH_PRIMES[5])     # arrays: uint64 scalars warn on overflow
    used = set(col.tolist())
    while int(new[0]) in used:
        new = mix(new + np.uint64(1))
    return new[0]


def search_leaves(unary: np.ndarray, binary: np.ndarray, lock: np.ndarray) -> int:
    """How many leaves the individualisation search visits for one state (0 when colour
    refinement alone orders it): the measure of its cost, for tests and benchmarks."""
    ucode, ecode = object_codes(unary[None], lock[None]), codes(binary[None])
    col = colours(ucode, ecode)
    perms = colour_order(col, lock[None])
    rows, groups = needing_search(ucode, ecode, col, perms)
    if unary.shape[0] < 2 or not len(rows):
        return 0
    search = _Search(unary, binary, lock, ecode[0], groups[0])
    search.run(col[0])
    return search.leaves
