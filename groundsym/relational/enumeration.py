"""Up to :data:`ENUMERATE_MAX` objects: every kept permutation of a query packed into 64-bit words
(the bit-parallel enumeration of the loss's numpy reference), and the naive ``M!`` reference."""

from __future__ import annotations

import itertools

import numpy as np

from .encoding import Encoded, INF


ENUMERATE_MAX = 7  # up to this many objects, a query is compared with all candidates bit-parallel


_ALL_PERMS: dict[int, np.ndarray] = {}


def all_permutations(m: int) -> np.ndarray:
    """(m!, m) every permutation of range(m), in itertools order (memoised)."""
    if m not in _ALL_PERMS:
        _ALL_PERMS[m] = np.array(list(itertools.permutations(range(m))), dtype=np.int64).reshape(-1, m)
    return _ALL_PERMS[m]


_POSITIONS: dict[int, np.ndarray] = {}


def permutation_positions(m: int) -> np.ndarray:
    """(m!, m) inverse of :func:`all_permutations`: where each object lands (memoised)."""
    if m not in _POSITIONS:
        _POSITIONS[m] = np.argsort(all_permutations(m), axis=1)
    return _POSITIONS[m]


def pack_words(bits: np.ndarray) -> np.ndarray:
    """Pack rows of 0/1 into 64-bit words: (N, W) -> (N, ceil(W / 64)) uint64."""
    packed = np.packbits(bits.astype(np.uint8), axis=1)
    pad = (-packed.shape[1]) % 8
    if pad:
        packed = np.concatenate([packed, np.zeros((len(packed), pad), np.uint8)], axis=1)
    return np.ascontiguousarray(packed).view(np.uint64)


_BIT_INDEX: dict[tuple[int, int, int], np.ndarray] = {}


def _bit_index(m: int, k: int, l: int) -> np.ndarray:
    """(m!, W) positions in a flat (unary, binary) bit vector of each permuted state's bits."""
    key = (m, k, l)
    if key not in _BIT_INDEX:
        sig = all_permutations(m)
        u = (sig[:, :, None] * k + np.arange(k)[None, None, :]).reshape(len(sig), -1)
        b = m * k + ((sig[:, :, None, None] * m + sig[:, None, :, None]) * l
                     + np.arange(l)[None, None, None, :]).reshape(len(sig), -1)
        _BIT_INDEX[key] = np.concatenate([u, b], axis=1)
    return _BIT_INDEX[key]


def _flat_bits(e: Encoded) -> np.ndarray:
    return np.concatenate([e.unary.ravel(), e.binary.ravel()])


_BIT_DEST: dict[tuple[int, int, int], tuple[np.ndarray, np.ndarray]] = {}


def _bit_destinations(m: int, k: int, l: int) -> tuple[np.ndarray, np.ndarray]:
    """(n_bits, m!) the word, and its value as that word, at which each bit of a flat state lands
    under each permutation (memoised); the values are those :func:`pack_words` packs."""
    key = (m, k, l)
    if key not in _BIT_DEST:
        idx = _bit_index(m, k, l)                    # permuted position p takes source bit idx[s, p]
        n = idx.shape[1]
        dest = np.argsort(idx, axis=1)               # source bit j lands at dest[s, j]
        unit = pack_words(np.eye(n, dtype=np.uint8))     # the packed pattern of a lone bit at each position
        word = np.argmax(unit != 0, axis=1)
        value = unit[np.arange(n), word]
        _BIT_DEST[key] = (np.ascontiguousarray(word[dest].T), np.ascontiguousarray(value[dest].T))
    return _BIT_DEST[key]


def permuted_words(q: Encoded, which: np.ndarray | None = None) -> np.ndarray:
    """Permutations of ``q`` (all, or the indices ``which``) packed into 64-bit words (for enumeration).

    Built from the bits that are set, each placed where the permutation sends it: states are
    sparse, so this beats gathering every bit of every permuted state.
    """
    m, k, l = q.n_objects, q.unary.shape[1], q.binary.shape[2]
    word, value = _bit_destinations(m, k, l)
    cols = np.arange(word.shape[1]) if which is None else np.asarray(which)
    out = np.zeros((len(cols), -(-word.shape[0] // 64)), dtype=np.uint64)
    bits = np.flatnonzero(_flat_bits(q))
    if len(bits):
        v = value[bits[:, None], cols[None, :]]      # (set bits, permutations)
        if out.shape[1] == 1:
            out[:, 0] = np.bitwise_or.reduce(v, axis=0)
        else:
            w = word[bits[:, None], cols[None, :]]
            for j in range(out.shape[1]):
                out[:, j] = np.bitwise_or.reduce(np.where(w == j, v, np.uint64(0)), axis=0)
    return out


def naive_state_distance(a: Encoded, b: Encoded) -> tuple[float, np.ndarray | None]:
    """Reference: enumerate every permutation (the paper's kernel); exact, ``O(M!)``."""
    if a.label != b.label:
        return INF, None
    m = a.n_objects
    best, best_perm = INF, None
    ea, eb = a.binary.astype(np.int8), b.binary.astype(np.int8)
    const = int(np.sum(a.nullary != b.nullary))
    unary = (a.unary[:, None, :] != b.unary[None, :, :]).sum(-1)
    forbid = a.lock[:, None] != b.lock[None, :]
    rows = np.arange(m)
    gen = itertools.permutations(range(m))
    while True:
        chunk = np.array(list(itertools.islice(gen, 20000)), dtype=np.int64).reshape(-1, m)
        if len(chunk) == 0:
            break
        ok = ~forbid[rows[None], chunk].any(1)
        if not ok.any():
            continue
        chunk = chunk[ok]
        cost = const + unary[rows[None], chunk].sum(1) + \
            np.abs(ea[None] - eb[chunk[:, :, None], chunk[:, None, :]]).sum(axis=(1, 2, 3))
        k = int(np.argmin(cost))
        if cost[k] < best:
            best, best_perm = float(cost[k]), chunk[k].copy()
    return best, best_perm
