"""Canonical forms of a whole batch of states in one compiled call (:func:`canonical_batch`, the
reference is ``relational.canonical.canonical_forms``), with a memo of the states seen before:
learned abstract states repeat a lot across the loss's evaluations."""

from __future__ import annotations

import numpy as np

from .base import P0, P1, arrays_equal, mix, njit, numba
from .canonical import encode_row, individualise, order_row, refine_row, state_codes_row, twin_groups_row


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
        h = mix(h ^ v)
        i += 8
    return np.int64(h >> np.uint64(1))


@njit(cache=True)
def _pack_state(unary, binary, lock, raw):
    """A small state's own encoding as two 64-bit words, written into ``raw`` (16 bytes), and their hash.

    For M <= 7 objects whose M*K + M*M*L bits fit a word: the bits in one word, the locks (a byte
    each) and the shape (K, L) in the other, so equal words mean equal states of the same shape.
    Cheaper than :func:`encode_row` and :func:`_hash_bytes` on the memo's hit path."""
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
    return np.int64(mix(bits ^ mix(meta + P1)) >> np.uint64(1))


@njit(cache=True)
def canonical_batch(unary, binary, lock, memo):
    """relational.canonical.canonical_forms compiled whole, with a per-state memo.

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
            raw = encode_row(unary[i], binary[i], lock[i], ident)
            h = _hash_bytes(raw)
        if h in memo:
            entry = memo[h]
            if len(entry) == r_key + r_len + m and arrays_equal(entry[:r_key], raw):
                forms[i] = entry[r_key:r_key + r_len]
                for p in range(m):
                    perms[i, p] = entry[r_key + r_len + p]
                continue
            store = False
        else:
            store = True
        ucode, ecode = state_codes_row(unary[i], binary[i], lock[i])
        col = np.empty(m, dtype=np.uint64)
        for x in range(m):
            col[x] = mix(np.uint64(ucode[x]) + P0)
        refine_row(col, ecode)
        perm = order_row(col, lock[i])
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
            form = encode_row(unary[i], binary[i], lock[i], perm)
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
