"""Permutation-invariant distances between relational states (the paper's Appendix kernel).

``d(s, s') = min over object permutations pi of |s - pi(s')|^2``; for state-action pairs the
permutation must also map the action's arguments onto each other (and the primitive must be the
same, otherwise the distance is infinite). The paper enumerates all ``M!`` permutations; that is kept
here as the reference (:func:`naive_state_distance`, :func:`naive_scene_distance`) and the same exact
minimum is computed fast:

* continuous unary features: a linear assignment (Hungarian, ``linear_sum_assignment``), with the
  action arguments pinned to each other;
* symbolic states with binary relations (a quadratic assignment): branch and bound over partial
  assignments, bounded below by a linear assignment of unary mismatches, exact edge mismatches to
  the objects already placed and half the in/out-degree differences among the rest; the first upper
  bound is that assignment improved by pairwise swaps, and interchangeable objects (same bits, same
  relations) of the second state are tried in one order only.

Public API (used by the nearest-neighbour planners and the symbol-learning loss):

* :func:`scene_distance` -- two continuous scenes, optionally constrained by a pair of actions.
* :func:`state_distance` -- two symbolic states (frozensets of atoms) over given object lists.
* :func:`nearest` -- the nearest candidates of one state(-action) among a list, all ties returned.

Each returns the distance and the permutation as a dict mapping the first (query) state's objects
onto the second's. States with different numbers of objects are padded with empty objects
(symbolic: no atoms true); padded objects do not appear in the mapping.

Encoded symbolic states (:class:`Encoded`, built by :func:`encode_state`) hold the truth values as
arrays: unary ``M x K``, binary ``M x M x L`` (zero diagonal) and nullary bits, plus an action
``label`` and a per-object ``lock`` (bit mask of the action argument positions it fills). Two objects
may be matched only when their locks are equal, which is how an action constraint is imposed.

One concern per module: :mod:`.encoding` (the arrays and shared constants), :mod:`.branch_and_bound`
(the exact symbolic distance), :mod:`.enumeration` (the bit-parallel enumeration up to
:data:`ENUMERATE_MAX` objects, and the naive reference), :mod:`.canonical` (canonical forms:
isomorphic states, equal encodings), :mod:`.hashing` (the 64-bit hashing those refine colours
with), :mod:`.scenes` (continuous scenes) and :mod:`.neighbours` (the public symbolic API). The
compiled kernels of the loss that mirror the enumeration and the canonical forms live in
:mod:`groundsym.compiled`, which builds on this package (never the other way round). Everything
is importable from this package.
"""

from .branch_and_bound import exact_state_distance, first_minimiser, permutation_cost, root_bounds, twin_groups
from .canonical import canonical_forms, twin_groups_of
from .encoding import INF, Encoded, encode_state
from .enumeration import (ENUMERATE_MAX, all_permutations, naive_state_distance, pack_words, permutation_positions,
                          permuted_words)
from .neighbours import Neighbours, count_bound, nearest, state_distance
from .scenes import naive_scene_distance, scene_distance

__all__ = [
    "ENUMERATE_MAX", "INF", "Encoded", "Neighbours", "all_permutations", "canonical_forms", "count_bound",
    "encode_state", "exact_state_distance", "first_minimiser", "naive_scene_distance", "naive_state_distance", "nearest", "pack_words",
    "permutation_cost", "permutation_positions", "permuted_words", "root_bounds", "scene_distance",
    "state_distance", "twin_groups", "twin_groups_of",
]
