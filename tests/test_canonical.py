"""Canonical forms: equal if and only if isomorphic (against the naive enumeration), a function of
each state alone (never of the batch), and bounded on highly symmetric states."""

import tracemalloc

import numpy as np
import pytest

from groundsym.relational import Encoded, naive_state_distance
from groundsym.relational.canonical import canonical_form, canonical_forms, encode_rows, search_leaves


def random_state(rng, m, k, l, density, locked=False):
    """A random state of ``m`` objects, ``k`` unary and ``l`` binary symbols (shared with
    tests/test_compiled.py and benchmarks/bench_canonical.py)."""
    u = (rng.random((m, k)) < density).astype(np.uint8)
    b = (rng.random((m, m, l)) < density).astype(np.uint8)
    b[np.arange(m), np.arange(m)] = 0
    lock = np.zeros(m, dtype=np.int64)
    if locked:  # an action's arguments: the first (lock 1) and maybe a second (lock 2)
        args = rng.choice(m, size=min(m, int(rng.integers(1, 3))), replace=False)
        lock[args] = [1, 2][:len(args)]
    return u, b, lock


def relabel(rng, u, b, lock):
    """The same state with its objects in a random order (an isomorphic state)."""
    p = rng.permutation(len(u))
    return u[p], b[p][:, p], lock[p]


def _symmetric(m, edges, k=1):
    b = np.zeros((m, m, 1), dtype=np.uint8)
    for i, j in edges:
        b[i, j, 0] = b[j, i, 0] = 1
    return np.zeros((m, k), dtype=np.uint8), b, np.zeros(m, dtype=np.int64)


def _directed_cycles(n_cycles, length):
    m = n_cycles * length
    b = np.zeros((m, m, 1), dtype=np.uint8)
    for c in range(n_cycles):
        for i in range(length):
            b[c * length + i, c * length + (i + 1) % length, 0] = 1
    return np.zeros((m, 1), dtype=np.uint8), b, np.zeros(m, dtype=np.int64)


def _cycle(n, off=0):
    return [(off + i, off + (i + 1) % n) for i in range(n)]


SYMMETRIC = {
    "5 mutual pairs": _symmetric(10, [(2 * i, 2 * i + 1) for i in range(5)]),
    "6 mutual pairs": _symmetric(12, [(2 * i, 2 * i + 1) for i in range(6)]),
    "12-cycle": _symmetric(12, _cycle(12)),
    "two 6-cycles": _symmetric(12, _cycle(6) + _cycle(6, 6)),
    "complete bipartite 6 + 6": _symmetric(12, [(i, j) for i in range(6) for j in range(6, 12)]),
    "4 directed 3-cycles": _directed_cycles(4, 3),
    "3 directed 4-cycles": _directed_cycles(3, 4),
    "Petersen graph": _symmetric(10, _cycle(5) + [(5 + i, 5 + (i + 2) % 5) for i in range(5)]
                                 + [(i, i + 5) for i in range(5)]),
}


def _check_form(u, b, lock, code, perm):
    """The form is an actual encoding of the state: the state in the order ``perm``."""
    assert sorted(perm.tolist()) == list(range(len(u)))
    assert np.array_equal(code, encode_rows(u[perm][None], b[perm][:, perm][None], lock[perm][None])[0])


@pytest.mark.parametrize("seed", range(3))
def test_forms_are_equal_exactly_for_isomorphic_states(seed):
    """Against the naive enumeration of all permutations, up to 7 objects: sparse random states
    over few symbols collide often, so both answers occur many times."""
    rng = np.random.default_rng(seed)
    equal = differ = 0
    for _ in range(12):
        m = int(rng.integers(2, 8))
        k, l = int(rng.integers(0, 2)), int(rng.integers(1, 3))
        locked = rng.random() < 0.4
        pool = [random_state(rng, m, k, l, float(rng.uniform(0.05, 0.3)), locked) for _ in range(6)]
        pool += [relabel(rng, *pool[int(rng.integers(len(pool)))]) for _ in range(4)]
        forms = [canonical_form(*s) for s in pool]
        for s, (code, perm) in zip(pool, forms):
            _check_form(*s, code, perm)
        for i in range(len(pool)):
            for j in range(i + 1, len(pool)):
                ei = Encoded(pool[i][0], pool[i][1], np.zeros(0, np.uint8), pool[i][2])
                ej = Encoded(pool[j][0], pool[j][1], np.zeros(0, np.uint8), pool[j][2])
                iso = sorted(ei.lock.tolist()) == sorted(ej.lock.tolist()) and naive_state_distance(ei, ej)[0] == 0
                same = np.array_equal(forms[i][0], forms[j][0])
                assert same == iso
                equal += same
                differ += not same
    assert equal > 40 and differ > 100


def test_forms_do_not_depend_on_the_batch():
    """A state's form and order are the same alone, in any batch and in any position. States that
    need few refinement rounds share batches with states that need many (paths, cycles), which
    is what made the old per-batch round count change colours."""
    rng = np.random.default_rng(4)
    m = 8
    states = [random_state(rng, m, 1, 2, float(rng.uniform(0.02, 0.3)), rng.random() < 0.3) for _ in range(120)]
    path = np.zeros((m, m, 2), dtype=np.uint8)
    path[np.arange(m - 1), np.arange(1, m), 0] = 1
    states += [(np.zeros((m, 1), np.uint8), path, np.zeros(m, np.int64))]
    states += [relabel(rng, *states[int(rng.integers(len(states)))]) for _ in range(60)]
    alone = [canonical_form(*s) for s in states]
    for _ in range(6):
        pick = rng.choice(len(states), size=int(rng.integers(2, 60)), replace=False)
        u = np.stack([states[i][0] for i in pick])
        b = np.stack([states[i][1] for i in pick])
        lock = np.stack([states[i][2] for i in pick])
        cache: dict = {}
        codes, perms = canonical_forms(u, b, lock, cache)
        for row, i in enumerate(pick):
            assert np.array_equal(codes[row], alone[i][0])
            assert np.array_equal(perms[row], alone[i][1])


@pytest.mark.parametrize("name", sorted(SYMMETRIC))
def test_symmetric_states_are_bounded_and_canonical(name):
    """Highly symmetric states that colour refinement cannot split: the search visits a few dozen
    leaves (twins and automorphisms prune it) in little memory, and relabelled copies get the
    same form."""
    u, b, lock = SYMMETRIC[name]
    assert 0 < search_leaves(u, b, lock) <= 64
    tracemalloc.start()
    code, perm = canonical_form(u, b, lock)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 200e6
    _check_form(u, b, lock, code, perm)
    rng = np.random.default_rng(0)
    for _ in range(5):
        assert np.array_equal(canonical_form(*relabel(rng, u, b, lock))[0], code)


def testrandom_states_of_8_to_12_objects_are_bounded_and_invariant():
    rng = np.random.default_rng(9)
    for _ in range(200):
        m = int(rng.integers(8, 13))
        s = random_state(rng, m, int(rng.integers(0, 3)), int(rng.integers(1, 3)),
                          float(rng.uniform(0.01, 0.4)), rng.random() < 0.3)
        assert search_leaves(*s) <= 64
        code, perm = canonical_form(*s)
        _check_form(*s, code, perm)
        assert np.array_equal(canonical_form(*relabel(rng, *s))[0], code)
