"""The fast exact distances agree with the naive enumeration of all permutations (the reference)."""

import itertools

import numpy as np
import pytest

from groundsym.logic import Atom
from groundsym.relational import (INF, Encoded, encode_state, exact_state_distance, naive_scene_distance,
                                  naive_state_distance, nearest, permutation_cost, scene_distance,
                                  state_distance)
from groundsym.world import Scene


def _random_encoded(rng, m, k, l, density, lock_at=None, label=0):
    u = (rng.random((m, k)) < density).astype(np.uint8)
    b = (rng.random((m, m, l)) < density).astype(np.uint8)
    b[np.arange(m), np.arange(m)] = 0
    lock = np.zeros(m, dtype=np.int64)
    if lock_at is not None:
        lock[lock_at] = 1
    return Encoded(u, b, (rng.random(1) < 0.5).astype(np.uint8), lock, label)


@pytest.mark.parametrize("seed,sizes,pairs", [
    (0, (1, 7), 40), (1, (1, 7), 40), (2, (1, 7), 40), (3, (1, 7), 40), (4, (7, 8), 12),
    pytest.param(5, (8, 11), 12, marks=pytest.mark.slow)])
def test_exact_symbolic_distance_matches_enumeration(seed, sizes, pairs):
    """Branch and bound against every permutation, up to 7 objects in the fast run (the paper's
    size) and 8 to 10 in the slow one (branch and bound serves the loss beyond 7)."""
    rng = np.random.default_rng(seed)
    for _ in range(pairs):
        m, k, l = int(rng.integers(*sizes)), int(rng.integers(0, 3)), int(rng.integers(1, 3))
        density = float(rng.uniform(0.05, 0.5))
        locked = rng.random() < 0.5
        a = _random_encoded(rng, m, k, l, density, int(rng.integers(m)) if locked else None)
        b = _random_encoded(rng, m, k, l, density, int(rng.integers(m)) if locked else None)
        fast, perm = exact_state_distance(a, b)
        ref, _ = naive_state_distance(a, b)
        assert fast == ref
        assert permutation_cost(a, b, perm) == fast  # the returned permutation attains it
        assert perm[a.lock != 0].tolist() == np.flatnonzero(b.lock).tolist() or not locked


def test_threshold_search_only_proves_a_lower_bound():
    """Stopped at a threshold, the search returns a value between the threshold and the distance."""
    rng = np.random.default_rng(7)
    stopped = 0
    for _ in range(60):
        m = int(rng.integers(3, 7))
        a = _random_encoded(rng, m, 1, 2, float(rng.uniform(0.1, 0.6)))
        b = _random_encoded(rng, m, 1, 2, float(rng.uniform(0.1, 0.6)))
        exact, _ = exact_state_distance(a, b)
        for threshold in (exact - 2.5, exact - 0.5, exact, exact + 0.5):
            bound, perm = exact_state_distance(a, b, threshold=threshold)
            if perm is None:
                stopped += 1
                assert threshold <= bound <= exact
            else:
                assert bound == exact < threshold
    assert stopped > 60


def test_different_primitives_never_match():
    rng = np.random.default_rng(1)
    a = _random_encoded(rng, 4, 1, 1, 0.3, 0, label=0)
    b = _random_encoded(rng, 4, 1, 1, 0.3, 0, label=1)
    assert exact_state_distance(a, b)[0] == INF


def test_state_distance_on_atoms_hand_computed():
    on = lambda x, y: Atom("on", (x, y))  # noqa: E731
    s1 = frozenset({on("a", "b"), Atom("inhand", ("c",))})
    s2 = frozenset({on("y", "z"), Atom("inhand", ("x",))})
    d, mapping = state_distance(s1, ("a", "b", "c"), s2, ("x", "y", "z"))
    assert d == 0 and mapping == {"a": "y", "b": "z", "c": "x"}
    # constrained: grasping a must map onto grasping z; then the best has 4 mismatched atoms
    d, mapping = state_distance(s1, ("a", "b", "c"), s2, ("x", "y", "z"),
                                Atom("grab", ("a",)), Atom("grab", ("z",)))
    assert mapping["a"] == "z"
    ref = min(_atom_hamming(s1, s2, dict(zip("abc", p))) for p in itertools.permutations("xyz") if p[0] == "z")
    assert d == ref
    assert state_distance(s1, "abc", s2, "xyz", Atom("grab", ("a",)), Atom("drop", ("z",)))[0] == INF


def _atom_hamming(s1, s2, mapping):
    return len({a.substitute(mapping) for a in s1} ^ set(s2))


def test_state_distance_pads_fewer_objects():
    s1 = frozenset({Atom("on", ("a", "b"))})
    s2 = frozenset({Atom("on", ("x", "y")), Atom("on", ("y", "z"))})
    d, mapping = state_distance(s1, ("a", "b"), s2, ("x", "y", "z"))
    assert d == 1 and set(mapping) == {"a", "b"}


def test_scene_distance_matches_enumeration_with_pins():
    rng = np.random.default_rng(3)
    objs = tuple(f"o{i}" for i in range(6))
    for _ in range(20):
        a = Scene(objs, rng.normal(size=(6, 4)))
        b = Scene(objs, rng.normal(size=(6, 4)))
        act_a, act_b = Atom("grab", (objs[rng.integers(6)],)), Atom("grab", (objs[rng.integers(6)],))
        for pair in ((None, None), (act_a, act_b)):
            d, m = scene_distance(a, b, *pair)
            ref, _ = naive_scene_distance(a, b, *pair)
            assert d == pytest.approx(ref, abs=1e-12)
            perm = [objs.index(m[o]) for o in objs]
            assert sum(((a.features[i] - b.features[j]) ** 2).sum() for i, j in enumerate(perm)) == pytest.approx(d)
            if pair[0] is not None:
                assert m[act_a.args[0]] == act_b.args[0]


def test_nearest_returns_all_ties_and_is_exact():
    rng = np.random.default_rng(5)
    objs = ("a", "b", "c", "d", "e")
    preds = {"u": 1, "r": 2}

    def random_state():
        atoms = {Atom("u", (o,)) for o in objs if rng.random() < 0.3}
        atoms |= {Atom("r", (x, y)) for x in objs for y in objs if x != y and rng.random() < 0.15}
        return frozenset(atoms)

    for _ in range(5):
        query = random_state()
        cands = [(random_state(), objs) for _ in range(25)]
        cands.append((frozenset(a.substitute(dict(zip(objs, "edcba"))) for a in query), objs))  # an isomorph
        acts = [Atom("grab", (objs[rng.integers(5)],)) for _ in cands]
        qa = Atom("grab", ("a",))
        acts[-1] = Atom("grab", ("e",))
        res = nearest(query, objs, cands, qa, acts, preds)
        ref = [state_distance(query, objs, s, o, qa, acts[k], preds)[0] for k, (s, o) in enumerate(cands)]
        assert res.distance == 0 == min(ref)
        assert list(res.indices) == [k for k, d in enumerate(ref) if d == 0]
        res = nearest(query, objs, cands[:-1], qa, acts[:-1], preds)
        assert res.distance == min(ref[:-1])
        assert list(res.indices) == [k for k, d in enumerate(ref[:-1]) if d == res.distance]
        for k, m in zip(res.indices, res.mappings):
            assert m["a"] == acts[k].args[0]


def test_nearest_on_scenes():
    rng = np.random.default_rng(2)
    objs = ("a", "b", "c")
    query = Scene(objs, rng.normal(size=(3, 2)))
    cands = [Scene(objs, rng.normal(size=(3, 2))) for _ in range(10)]
    res = nearest(query, None, cands)
    ref = [scene_distance(query, c)[0] for c in cands]
    assert res.indices == (int(np.argmin(ref)),) and res.distance == pytest.approx(min(ref))


def test_permuted_words_pack_each_permuted_state():
    """Placing only the set bits gives the same words as packing every permuted state."""
    from groundsym.relational import all_permutations, pack_words, permuted_words
    rng = np.random.default_rng(5)
    for m, k, l, density in [(4, 1, 1, 0.3), (5, 3, 3, 0.5), (6, 2, 2, 0.05), (3, 0, 2, 1.0), (4, 1, 1, 0.0)]:
        q = _random_encoded(rng, m, k, l, density)
        sig = all_permutations(m)
        which = rng.choice(len(sig), size=min(len(sig), 40), replace=False)
        want = pack_words(np.stack([np.concatenate([q.unary[s].ravel(), q.binary[s][:, s].ravel()])
                                    for s in sig[which]]))
        assert np.array_equal(permuted_words(q, which), want)
        assert permuted_words(q).shape == (len(sig), want.shape[1])


def test_first_minimiser_is_the_first_minimising_order_of_the_enumeration():
    """relational.first_minimiser against brute force over every order (positions filled by the
    query's objects, lexicographic; arguments pinned to arguments), 2-7 objects, states with
    twins and without: from any minimiser it returns the first one."""
    from groundsym.relational import first_minimiser
    rng = np.random.default_rng(21)
    for _ in range(150):
        m = int(rng.integers(2, 8))
        density = float(rng.uniform(0.0, 0.4))
        lock_at = int(rng.integers(m)) if rng.random() < 0.6 else None
        a = _random_encoded(rng, m, int(rng.integers(1, 3)), int(rng.integers(1, 3)), density, lock_at)
        b = _random_encoded(rng, m, a.unary.shape[1], a.binary.shape[2], density, lock_at)
        a = Encoded(a.unary, a.binary, np.zeros(0, np.uint8), a.lock, 0)
        b = Encoded(b.unary, b.binary, np.zeros(0, np.uint8), b.lock, 0)
        d, perm = exact_state_distance(a, b)
        first = None
        for seq in itertools.permutations(range(m)):      # seq[p]: a's object at b's position p
            sigma = np.argsort(seq)
            if permutation_cost(a, b, sigma) == d:
                first = sigma
                break
        assert np.array_equal(first_minimiser(a, b, d, perm), first)
