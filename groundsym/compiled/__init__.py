"""Compiled (numba) kernels of the symbol loss's miss path, each mirroring a numpy reference.

The loss spends its time, on an abstraction it has not seen, in two places: canonical forms of
every state (colour refinement, :mod:`groundsym.relational.canonical`) and the nearest classes of
every lone class (bit-parallel enumeration, ``NeighbourhoodEngine.nearest_enumerated`` of
:mod:`groundsym.neighbourhood`). Both are loops over a handful of objects and a few thousand
permutations, which numpy can only vectorise with large temporaries. The kernels here compute
the *same* integers (64-bit hashes that wrap the same way, the same object orders, distances,
first minimising permutations), so the loss is bit for bit the same with or without them (the
nearest classes come from a branch and bound over the orders the reference enumerates, cut only
where no order can beat the first minimiser the enumeration returns); ``tests/test_compiled.py``
checks that over thousands of annealing evaluations. The numpy code stays the reference
(``Loss(..., kernels="numpy")``); :mod:`groundsym.backends` chooses between the two, once per loss.

This package builds on :mod:`groundsym.relational` (the hash constants, the canonical forms'
steps) and nothing above it. One module per concern, each named after what it mirrors:

- :mod:`.canonical`: colour refinement, orders, twins, individualisation (reference:
  :mod:`groundsym.relational.canonical`; :data:`COMPILED_CANONICAL` is its steps as one object);
- :mod:`.batch`: canonical forms of a whole batch with a per-state memo (reference:
  ``relational.canonical.canonical_forms``);
- :mod:`.nearest`: the nearest classes of lone classes (reference:
  ``NeighbourhoodEngine.nearest_enumerated`` and :mod:`groundsym.relational.enumeration`), with
  :mod:`.heap` ordering their candidates and :mod:`.pair_search` the distance of one pair;
- :mod:`.classes`: one whole neighbourhood pass, classes and their profiles (reference:
  ``NeighbourhoodEngine.neighbours``, ``neighbourhood.group_rows``, ``neighbourhood.class_profiles``);
- :mod:`.mixtures`: the transition and reward terms' entries and mixtures (reference:
  ``mixtures.transition_entries``, ``mixtures.reward_entries``, ``mixtures.mixture_ll`` of
  :mod:`groundsym.mixtures`);
- :mod:`.profiles`: the reward term's neighbours by profile (reference:
  ``profile_neighbours_reference`` of :mod:`groundsym.profile_neighbours`);
- :mod:`.truth`: symbols' truth on the data (reference: ``Symbol.holds``);
- :mod:`.counts`: the linear reward term's relational counts (reference: ``count_features`` of
  :mod:`groundsym.reward_term`);
- :mod:`.base`: numba itself and what the others share.

numba compiles on first use and caches the machine code on disk (``cache=True``: beside these
modules, or in ``NUMBA_CACHE_DIR``), so a process pays the compilation once and later processes
load it. Without numba installed, :data:`AVAILABLE` is False and the loss uses numpy.
"""

from __future__ import annotations

import numpy as np

from ..relational.canonical import canonical_forms
from .base import AVAILABLE
from .batch import canonical_batch, new_state_memo
from .canonical import (COMPILED_CANONICAL, colour_order, colours, individualise, needing_search, refine_row,
                        twin_groups_row)
from .classes import group_keys, neighbourhood, new_intern
from .counts import count_features
from .mixtures import mixture_sums, reward_entries, reward_mixture, transition_entries, transition_mixture
from .nearest import MAX_OBJECTS, nearest_classes, new_memo
from .profiles import profile_nearest
from .signatures import argument_literals, nearest_by_signature, signature_classes, view_keys
from .truth import rbf_holds, rbf_holds_columns, scaled_distances_columns

__all__ = [
    "AVAILABLE", "COMPILED_CANONICAL", "MAX_OBJECTS", "argument_literals", "canonical_batch", "colour_order", "colours",
    "count_features", "group_keys", "individualise",
    "mixture_sums", "nearest_by_signature", "nearest_classes", "needing_search", "neighbourhood", "new_intern", "new_memo",
    "new_state_memo", "profile_nearest", "rbf_holds", "rbf_holds_columns", "refine_row", "scaled_distances_columns", "reward_entries", "signature_classes",
    "reward_mixture", "transition_entries", "transition_mixture", "twin_groups_row", "view_keys", "warm_up",
]


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
                        np.arange(2, dtype=np.int64), *new_memo())
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
        rbf_holds_columns(np.zeros((2, 3)), np.zeros(2), np.ones(2))
        scaled_distances_columns(np.zeros((2, 3)), np.zeros(2), np.ones(2), np.ones(2, dtype=np.bool_))
        count_features(u, b)
        profile_nearest(u, b, np.arange(2, dtype=np.int64))
        neighbourhood(u, b, lock, np.zeros(2, dtype=np.int64), new_state_memo(), *new_intern(), *new_memo())
        cyc = np.zeros((1, 4, 4, 1), dtype=np.uint8)     # a directed 4-cycle needs individualisation
        for i in range(4):
            cyc[0, i, (i + 1) % 4, 0] = 1
        canonical_forms(np.zeros((1, 4, 1), dtype=np.uint8), cyc, np.zeros((1, 4), dtype=np.int64),
                        kernels=COMPILED_CANONICAL)
        lock1 = np.array([[1, 0, 0], [1, 0, 0]], dtype=np.int64)
        bits = argument_literals(u, b, np.array([0, 1]), np.array([1, 0]), lock1, 1)
        perms1, sigs, keys = view_keys(bits[:2], lock1, np.zeros(2, dtype=np.int64), 1)
        nearest_by_signature(keys, sigs, np.array([2, 2]), np.array([0, 1]), np.array([0, 1]), 2, 2 + bits.shape[2],
                             bits.shape[2])
        signature_classes(bits[:2], lock1, np.zeros(2, dtype=np.int64), 1)
        z4 = np.zeros((1, 4), dtype=np.int64)
        canonical_batch(np.zeros((1, 4, 1), dtype=np.uint8), cyc, z4, new_state_memo())
    return time.perf_counter() - t0
