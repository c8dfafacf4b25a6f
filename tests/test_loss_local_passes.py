"""The compiled passes of ``distance=signature`` and of the local distances' reward term
(groundsym/compiled/profiles.py, ``signature_classes`` of groundsym/compiled/signatures.py)
against the numpy passes they replaced, kept here as references: the numpy profile pass
(``profile_neighbours_reference``) and the signature pass as four steps with the keys grouped by
``neighbourhood.group_rows``. Classes may be numbered otherwise (tested: the same partition, the
same lone items, nearest distances, hit members and orders); the loss values must be the same
bit for bit, tested over annealing runs of thousands of evaluations with the references swapped
in.
"""

from __future__ import annotations

import numpy as np
import pytest

import groundsym.loss as loss_module
from groundsym.anneal import AnnealConfig, advance, start_restart
from groundsym.compiled.signatures import nearest_by_signature, view_keys
from groundsym.loss import Loss, LossConfig, prepare
from groundsym.neighbourhood import Neighbourhood, group_rows
from groundsym.profile_neighbours import profile_neighbours, profile_neighbours_reference
from groundsym.signature_neighbours import argument_view, most_arguments, signature_neighbours
from tests.test_loss import kinematic_tower
from tests.test_loss_local_signature import _random_transitions


def _signature_reference(u, b, lock, label) -> Neighbourhood:
    """The signature pass before ``signature_classes``: keys, numpy grouping, then the search."""
    n, m, w = u.shape
    n_args = most_arguments(lock)
    lock = np.ascontiguousarray(lock, dtype=np.int64)
    perms, sigs, keys = view_keys(np.ascontiguousarray(u), lock, np.ascontiguousarray(label, dtype=np.int64), n_args)
    first, cls = group_rows(keys)
    sizes = np.bincount(cls, minlength=len(first))
    lone = np.flatnonzero(sizes == 1).astype(np.int64)
    arg_lo = 1 + n_args
    n_free = (m - (lock != 0).sum(axis=1)).astype(np.int64)
    best, hq, hc, hs = nearest_by_signature(keys, sigs, n_free, first.astype(np.int64), lone,
                                            arg_lo, arg_lo + n_args * w, w)
    return Neighbourhood(cls.astype(np.int64), perms, lone, best, hq, hc, hs)


def _by_item(nb: Neighbourhood) -> dict[int, tuple]:
    """What a neighbourhood says of each item, whatever the class numbering: its class's members
    and, for a lone item, its nearest distance and each nearest member with its order."""
    members, hits = nb.members, nb.hits
    out = {}
    for i in range(len(nb.cls)):
        group = tuple(members[nb.cls[i]].tolist())
        if len(group) > 1:
            out[i] = (group,)
            continue
        dist, found = hits[int(nb.cls[i])]
        near = sorted((int(j), tuple(sigma.tolist())) for c, sigma in found for j in members[c].tolist())
        out[i] = (group, dist, tuple(near))
    return out


@pytest.mark.parametrize("seed", range(6))
def test_profile_pass_equals_the_numpy_reference(seed):
    rng = np.random.default_rng(seed)
    for _ in range(40):
        n, m = int(rng.integers(2, 70)), int(rng.integers(2, 14))
        k, l = int(rng.integers(0, 3)), int(rng.integers(0, 3))
        u = (rng.random((n, m, k)) < rng.uniform(0.05, 0.6)).astype(np.uint8)
        b = (rng.random((n, m, m, l)) < rng.uniform(0.02, 0.4)).astype(np.uint8)
        b[:, np.arange(m), np.arange(m)] = 0
        twins = rng.integers(0, n, size=n // 2)        # repeated states: classes of several members
        u[rng.integers(0, n, size=n // 2)] = u[twins]
        got, want = profile_neighbours(u, b), profile_neighbours_reference(u, b)
        assert _by_item(got) == _by_item(want)
        rows = rng.permutation(n)[: max(2, n // 2)]       # a subset of scenes, as the loss passes them
        assert _by_item(profile_neighbours(u, b, rows)) == _by_item(profile_neighbours_reference(u[rows], b[rows]))


@pytest.mark.parametrize("seed,m,k,l", [(0, 6, 1, 1), (1, 9, 2, 1), (2, 12, 1, 2), (3, 20, 1, 1), (4, 30, 2, 1)])
def test_signature_pass_equals_the_four_step_reference(seed, m, k, l):
    u, b, pre, post, lock, label = _random_transitions(seed, 90, m, k, l)
    su, sb, p2, _ = argument_view(u, b, pre, post, lock)
    got = signature_neighbours(su[p2], sb[p2], lock, label)
    want = _signature_reference(su[p2], sb[p2], lock, label)
    assert np.array_equal(got.perms, want.perms)
    assert _by_item(got) == _by_item(want)


def _values(monkeypatch, m: int, n_unary: int, evals: int, reference: bool) -> list:
    """Every population loss and best terms, round by round, of one annealing restart on the
    fixture world with ``distance=signature``; with the reference passes swapped in if asked."""
    if reference:
        monkeypatch.setattr(loss_module, "profile_neighbours", lambda u, b: profile_neighbours_reference(u, b))
        monkeypatch.setattr(loss_module, "signature_neighbours", _signature_reference)
    else:
        monkeypatch.undo()
    data = prepare(kinematic_tower(16, seed=2, n_cubes=m))
    cfg = AnnealConfig(n_unary=n_unary, n_binary=1, evals=evals * 4, restarts=4)
    loss = Loss(data, LossConfig(distance="signature"))
    state = start_restart(0, 5, loss, cfg)
    out = []
    while state.done < evals:
        state = advance(state, loss, cfg, 100)
        out.append((list(state.losses), state.best_terms.to_doc()))
    return out


@pytest.mark.parametrize("m,n_unary,evals", [(9, 1, 1000), pytest.param(20, 2, 3000, marks=pytest.mark.slow),
                                              pytest.param(40, 1, 2000, marks=pytest.mark.slow)])
def test_signature_loss_values_are_bit_identical_to_the_references(monkeypatch, m, n_unary, evals):
    """The same moves, the same accepted candidates and the same loss values, bit for bit, as with
    the numpy profile pass and the four-step signature pass (every value compared with ==)."""
    want = _values(monkeypatch, m, n_unary, evals, reference=True)
    got = _values(monkeypatch, m, n_unary, evals, reference=False)
    assert got == want


def _terms_of(config: LossConfig, data, candidates) -> list[dict]:
    loss = Loss(data, config)
    return [loss(c).to_doc() for c in candidates]


def test_auto_is_exact_up_to_ten_objects_and_signature_above(monkeypatch):
    """``auto``: the exact loss's values at 10 objects, ``signature``'s at 11, and ``local:1``'s at
    11 when the symbols need more signature bits than a word (the bound lowered here to 2, below
    the 3 bits of 1+1 symbols with one argument)."""
    from groundsym.anneal.proposals import random_symbol
    from groundsym.relational.local import AUTO_EXACT_MAX, Distance
    assert not Distance.parse("auto").by_signature(AUTO_EXACT_MAX)
    assert Distance.parse("auto").by_signature(AUTO_EXACT_MAX + 1) and Distance.parse("signature").by_signature(3)
    assert not Distance.parse("local:1").by_signature(40) and not Distance.parse("exact").by_signature(40)
    cfg = AnnealConfig()
    for m, same_as in ((AUTO_EXACT_MAX, "exact"), (AUTO_EXACT_MAX + 1, "signature")):
        data = prepare(kinematic_tower(6, seed=4, n_cubes=m))
        rng = np.random.default_rng(m)
        cands = [[random_symbol(rng, 1, "u1", data, cfg), random_symbol(rng, 2, "b1", data, cfg)] for _ in range(60)]
        auto = _terms_of(LossConfig(distance="auto"), data, cands)
        assert auto == _terms_of(LossConfig(distance=same_as), data, cands)
        if same_as == "signature":
            monkeypatch.setattr(loss_module, "MAX_SIGNATURE_BITS", 2)
            assert _terms_of(LossConfig(distance="auto"), data, cands) == _terms_of(LossConfig(distance="local:1"),
                                                                                    data, cands)
