"""Simulated annealing: determinism, worker independence, checkpoint resume, pruning, and (slow) that
it finds what the loss asks for in the kinematic fixture world (`on`, and what tells `inhand`)."""

from pathlib import Path

import numpy as np
import pytest

from groundsym.anneal import (IGNORE_WIDTH, AnnealConfig, exchange, perturb, random_symbol, anneal, hops, prune, settle,
                             share_radius, temperature)
from groundsym.grounding import match_symbols, truth_arrays
from groundsym.loss import Loss, LossConfig, prepare
from groundsym.symbols import Symbol, SymbolSet, dataset_arrays
from tests.test_loss import SIZES, intended_symbols, kinematic_tower


@pytest.fixture(scope="module")
def data():
    return prepare(kinematic_tower(6, seed=3))


def _same(a, b):
    assert [s.name for s in a.candidate] == [s.name for s in b.candidate]
    for x, y in zip(a.candidate, b.candidate):
        assert np.array_equal(x.centre, y.centre) and np.array_equal(x.widths, y.widths)
    assert a.terms == b.terms and a.restarts == b.restarts


def test_result_does_not_depend_on_workers(data):
    cfg = AnnealConfig(evals=120, restarts=2, chunk=30)
    one = anneal(data, LossConfig(), cfg, seed=5, workers=1)
    two = anneal(data, LossConfig(), cfg, seed=5, workers=2)
    _same(one, two)
    assert one.evaluations == 120
    other = anneal(data, LossConfig(), cfg, seed=6, workers=1)
    assert other.terms != one.terms or not np.array_equal(other.candidate[0].centre, one.candidate[0].centre)


def test_result_does_not_depend_on_where_rounds_end(data):
    """Rounds of 500, 37 or 1 evaluations draw the same moves: a swap (two evaluations) at a round's
    last evaluation is made, not turned into a re-seed."""
    runs = [anneal(data, LossConfig(), AnnealConfig(evals=300, restarts=2, chunk=chunk), seed=4)
            for chunk in (500, 37, 1)]
    for other in runs[1:]:
        _same(runs[0], other)
        assert other.evaluations == 300


def test_proposals_use_the_change_tolerance_the_data_was_prepared_with():
    """New symbols centre on objects a primitive moved by more than the loss's ``change_tol``."""
    from groundsym.anneal import proposal_points
    from groundsym.traces import read_traces
    ds = read_traces(Path(__file__).resolve().parent / "data" / "tower_16.json")   # real jitter: small moves
    loose, strict = prepare(ds, LossConfig(change_tol=0.01)), prepare(ds, LossConfig(change_tol=2.0))
    assert (loose.change_tol, strict.change_tol) == (0.01, 2.0)
    moved_loose = proposal_points(loose)[2]
    moved_strict = proposal_points(strict)[2]
    assert len(moved_strict) < len(moved_loose)


def test_pair_centres_are_pairs_a_primitive_involved_after_it():
    """Half of the new binary symbols centre on a pair of objects a primitive involved (an
    argument or an object it moved), in the scene after it: the pool is computed here again from
    the traces' own objects, and on real tower traces it is rich in the simulator's ``on``, the
    reason for it (docs/symbols.md)."""
    from groundsym.anneal import proposal_points
    from groundsym.traces import read_traces
    ds = read_traces(Path(__file__).resolve().parent / "data" / "tower_16.json")
    data = prepare(ds)
    spread = np.concatenate([np.asarray(s.features) for tr in ds.traces for s in tr.scenes]).std(0)
    want, on_pool = [], []
    for tr in ds.traces:
        for before, act, after in tr.transitions():
            moved = (np.abs(np.asarray(after.features) - np.asarray(before.features)) / spread).max(1) > 0.05
            involved = {i for i, o in enumerate(tr.objects) if moved[i] or o in act.args}
            for i in sorted(involved):
                for j in sorted(involved - {i}):
                    want.append(np.asarray(after.features)[i] - np.asarray(after.features)[j])
                    on_pool.append(any(a.predicate == "on" and set(a.args) == {tr.objects[i], tr.objects[j]}
                                       for a in after.truth))
    got, want = proposal_points(data)[3], np.array(want)
    rows = lambda a: a[np.lexsort(a.T[::-1])]       # noqa: E731  the same rows, in one order
    assert len(got) == len(want) > 0
    assert np.allclose(rows(got), rows(want))
    on_all = np.mean([any(a.predicate == "on" and set(a.args) == {tr.objects[i], tr.objects[j]} for a in s.truth)
                      for tr in ds.traces for s in tr.scenes
                      for i in range(len(tr.objects)) for j in range(len(tr.objects)) if i != j])
    assert np.mean(on_pool) >= 0.5 and np.mean(on_pool) > 10 * on_all


def test_best_is_the_best_of_all_restarts_and_really_scores_that(data):
    cfg = AnnealConfig(evals=200, restarts=2, chunk=50)
    res = anneal(data, LossConfig(), cfg, seed=1)
    assert res.terms.total == min(r["total"] for r in res.restarts)
    assert Loss(data)(res.candidate) == res.terms   # a fresh loss (empty caches) agrees


def test_checkpoint_resumes_to_the_same_result(data, tmp_path):
    cfg = AnnealConfig(evals=240, restarts=2, chunk=40)
    full = anneal(data, LossConfig(), cfg, seed=2)
    ck = tmp_path / "ck.json"
    rounds = []

    def interrupt(done, total, best):
        rounds.append(done)
        if len(rounds) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        anneal(data, LossConfig(), cfg, seed=2, checkpoint=ck, report=interrupt)
    assert ck.exists()
    resumed = anneal(data, LossConfig(), cfg, seed=2, checkpoint=ck)
    _same(full, resumed)


def test_checkpoint_of_other_settings_is_refused(data, tmp_path):
    from groundsym.errors import UserError
    ck = tmp_path / "ck.json"
    anneal(data, LossConfig(), AnnealConfig(evals=20, restarts=1, chunk=10), seed=0, checkpoint=ck)
    with pytest.raises(UserError, match="ck.json: seed"):
        anneal(data, LossConfig(), AnnealConfig(evals=20, restarts=1, chunk=10), seed=1, checkpoint=ck)


def test_loss_is_a_pure_function_of_the_symbols(data):
    """Caches only save time: a used Loss and a fresh one give identical terms."""
    rng = np.random.default_rng(0)
    used = Loss(data)
    cands = []
    for _ in range(15):
        c = [Symbol("u1", 1, data.features[rng.integers(len(data.features)), rng.integers(7)], data.unary_scale),
             Symbol("b1", 2, data.pairs[rng.integers(len(data.pairs)), 0, 1], data.pair_scale * rng.uniform(0.1, 1, 4))]
        cands.append(c)
        used(c)
    for c in reversed(cands):
        assert used(c) == Loss(data)(c)


def test_temperature_schedule_is_geometric():
    cfg = AnnealConfig(t_start=0.1, t_end=0.001)
    assert temperature(cfg, 0, 100, 10) == pytest.approx(1.0)
    assert temperature(cfg, 100, 100, 10) == pytest.approx(0.01)
    assert temperature(cfg, 50, 100, 10) == pytest.approx(0.1)


def test_prune_drops_never_and_always_true_symbols_and_renames(data):
    never = Symbol("u1", 1, np.full(4, 9.0), np.full(4, 0.01))
    always = Symbol("b1", 2, np.zeros(4), np.full(4, 100.0))
    good = intended_symbols()
    kept, pruned = prune([never, good[0].with_name("u2"), always, good[1].with_name("b2")], data)
    assert [s.name for s in kept] == ["u1", "b1"]
    assert np.array_equal(kept[0].centre, good[0].centre) and pruned == [never, always]


@pytest.mark.slow
def test_finds_on_and_what_tells_inhand_in_the_fixture_world():
    """The search reaches the loss's level of the known answer, learns `on`, and its abstraction
    tells which object is in the hand.

    Why not `inhand` itself: on this fixture the loss prefers a height band ("low": the table and
    the second level) to `inhand`, by 4 nats over the best `inhand` set the search finds (-332.2
    against -327.9 at seed 0); with `on` the band tells the held object just as well (neither low
    nor on anything). Before commit 766fa51 the search missed the band at seed 0 and this test
    asked for `inhand` or its complement."""
    ds = kinematic_tower(16, seed=11)
    data = prepare(ds)
    res = anneal(data, LossConfig(), AnnealConfig(evals=32000, restarts=4), seed=0, workers=2)
    assert res.terms.total <= Loss(data)(intended_symbols()).total   # at least as good as the known answer
    test = kinematic_tower(20, seed=99)
    matches = {m.arity: m for m in match_symbols(SymbolSet(tuple(res.symbols), ds.feature_names), test)}
    assert matches[2].best_match == "on" and matches[2].f1 >= 0.8
    # the abstract state tells `inhand`: the best function of (u1(o), o is b1's first argument for
    # some object, its second argument) is right for 99% of the held-out objects (the majority
    # answer, "not in the hand", for 94%)
    feats, pairs = dataset_arrays(test)
    held = truth_arrays(test)[0]["inhand"]
    u = [s for s in res.symbols if s.arity == 1][0].holds(feats)
    b = [s for s in res.symbols if s.arity == 2][0].holds(pairs) & ~np.eye(feats.shape[1], dtype=bool)
    key = 4 * u + 2 * b.any(axis=2) + b.any(axis=1)
    right = sum(max(held[key == k].sum(), (~held[key == k]).sum()) for k in range(8))
    assert right / key.size >= 0.99 > 1 - held.mean()


def test_new_symbols_ignore_dimensions_at_the_configured_rate():
    d = prepare(kinematic_tower(4, seed=2))
    rng = np.random.default_rng(0)
    for p, lo, hi in ((0.0, 0.0, 0.0), (0.25, 0.18, 0.32)):
        cfg = AnnealConfig(p_ignore=p)
        ratios = np.stack([random_symbol(rng, 1, "u", d, cfg).widths / d.unary_scale for _ in range(400)])
        # the share scaling shapes only the dimensions a symbol looks at: an ignored one keeps its width
        ignored = np.isclose(ratios, IGNORE_WIDTH)
        assert lo <= ignored.mean() <= hi
        assert not ignored.all(axis=1).any()


def test_share_radius_falls_between_points():
    # discrete distances (a feature with few values): the radius keeps whole groups of ties
    dist = np.array([0.0] * 4 + [1.0] * 6 + [3.0] * 10)
    assert share_radius(dist, 0.1) == 0.5        # the four at 0, none at 1
    assert share_radius(dist, 0.3) == 2.0        # 0 and 1 kept, 3 left out
    assert share_radius(dist, 1.0) == pytest.approx(3.0003)
    rng = np.random.default_rng(1)
    cont = rng.random(1000)
    for share in (0.01, 0.2, 0.5):
        assert (cont < share_radius(cont, share)).mean() == pytest.approx(share, abs=0.002)


def test_a_size_only_symbol_centred_on_a_ball_holds_for_the_balls():
    """With sizes of three values, a new symbol that looks at size only is ``ball`` exactly."""
    from groundsym.symbols import unary_truth
    d = prepare(kinematic_tower(4, seed=2))
    sizes = d.features[..., 3]
    ball = np.isclose(sizes, SIZES[0])          # the small cubes play the balls here
    rng = np.random.default_rng(4)
    seen = 0
    for _ in range(3000):
        s = random_symbol(rng, 1, "u", d, AnnealConfig(p_ignore=0.7))
        size_only = np.isclose(s.widths[:3] / d.unary_scale[:3], IGNORE_WIDTH).all()
        if size_only and np.isclose(s.centre[3], SIZES[0]):
            seen += 1
            truth = unary_truth([s], d.features)[..., 0]
            assert np.array_equal(truth, ball)
    assert seen >= 5


def test_subset_looks_draws_the_number_of_dimensions_uniformly():
    d = prepare(kinematic_tower(4, seed=2))
    rng = np.random.default_rng(2)
    cfg = AnnealConfig(looks="subset")
    looked = [int((~np.isclose(random_symbol(rng, 1, "u", d, cfg).widths / d.unary_scale, IGNORE_WIDTH)).sum())
              for _ in range(800)]
    counts = np.bincount(looked, minlength=5)
    assert counts[0] == 0 and all(150 <= c <= 250 for c in counts[1:])   # 200 each expected
    with pytest.raises(ValueError, match="looks must be one of"):
        AnnealConfig(looks="sometimes")


def test_hops_come_late_and_only_when_they_fit_the_budget():
    cfg = AnnealConfig(hop_steps=10, hop_after=0.5)
    assert [hops(cfg, done, 100) for done in (0, 49, 50, 89, 90)] == [False, False, True, True, False]
    assert not hops(AnnealConfig(), 99, 100)                  # hop_steps 0: never
    assert hops(AnnealConfig(hop_steps=3, hop_after=0.0), 0, 100)
    for bad in ({"hop_steps": -1}, {"hop_after": 1.5}, {"hop_after": -0.1}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            AnnealConfig(**bad)


class _Counting:
    """A loss that counts its calls (the evaluations a move costs)."""

    def __init__(self, loss):
        self.loss, self.data, self.calls = loss, loss.data, 0

    def __call__(self, cand):
        self.calls += 1
        return self.loss(cand)


def test_a_hop_settles_its_own_slot_greedily_and_costs_one_plus_hop_steps(data):
    loss = _Counting(Loss(data))
    rng = np.random.default_rng(3)
    cfg = AnnealConfig(hop_steps=25)
    start = [random_symbol(rng, 1, "u1", data, cfg), random_symbol(rng, 2, "b1", data, cfg)]
    raw = Loss(data)(start).total
    settled, terms = settle(rng, loss, start, 1, cfg)
    assert loss.calls == 26
    assert terms == Loss(data)(settled) and terms.total <= raw
    assert settled[0] is start[0]                               # the other slot is left as it was
    # greedy: replaying the same draws, every accepted step was no worse than the one before
    rng2 = np.random.default_rng(3)
    [random_symbol(rng2, 1, "u1", data, cfg), random_symbol(rng2, 2, "b1", data, cfg)]
    best, path = start, [raw]
    for _ in range(25):
        trial = [best[0], perturb(rng2, best[1], cfg)]
        t = Loss(data)(trial).total
        if t <= path[-1]:
            best, path = trial, path + [t]
    assert path == sorted(path, reverse=True) and path[-1] == terms.total


@pytest.mark.parametrize("ladder", [1.0, 3.0])
def test_hops_do_not_depend_on_where_rounds_end_or_on_workers(data, ladder):
    """A hop costs 1 + hop_steps evaluations and may end a round past its end: over 4,000
    evaluations the moves drawn stay the same for any round length and worker count, at one
    temperature and on a ladder, and the whole budget is spent."""
    runs = [anneal(data, LossConfig(), AnnealConfig(evals=4000, restarts=2, chunk=chunk, hop_steps=12,
                                                    hop_after=0.3, ladder=ladder), seed=7, workers=workers)
            for chunk, workers in ((500, 1), (37, 2), (1, 1))]
    for other in runs[1:]:
        _same(runs[0], other)
        assert other.evaluations == 4000
    plain = anneal(data, LossConfig(), AnnealConfig(evals=4000, restarts=2, ladder=ladder), seed=7)
    assert plain.terms != runs[0].terms                         # the hops did change the search


def test_replica_exchange_follows_the_parallel_tempering_rule():
    """Neighbours trade states with probability min(1, exp((L_cold - L_warm)(1/T_cold - 1/T_warm))):
    always when the cold rung holds the worse state, else e^-2.5 here (hand-computed)."""
    rng = np.random.default_rng(0)
    pop, losses = [["worse"], ["better"]], [10.0, 5.0]
    exchange(rng, pop, losses, 0, 1.0, [1.0, 2.0])
    assert pop == [["better"], ["worse"]] and losses == [5.0, 10.0]
    trades = 0
    for _ in range(20000):
        pop, losses = [["a"], ["b"]], [5.0, 10.0]
        exchange(rng, pop, losses, 0, 1.0, [1.0, 2.0])
        trades += pop[0] == ["b"]
    assert trades / 20000 == pytest.approx(np.exp(-2.5), abs=0.006)


def test_a_ladder_does_not_depend_on_where_rounds_end_or_on_workers(data):
    """Exchanges cost no evaluation and are drawn before a move, so over 4,000 evaluations the
    rounds' length and the workers change nothing."""
    runs = [anneal(data, LossConfig(), AnnealConfig(evals=4000, restarts=2, chunk=chunk, ladder=3.0,
                                                    p_exchange=0.3), seed=8, workers=workers)
            for chunk, workers in ((500, 1), (41, 2), (1, 1))]
    for other in runs[1:]:
        _same(runs[0], other)
        assert other.evaluations == 4000
    less = anneal(data, LossConfig(), AnnealConfig(evals=4000, restarts=2, ladder=3.0, p_exchange=0.05), seed=8)
    assert less.terms != runs[0].terms                          # the exchanges do act


def test_one_temperature_draws_no_exchanges(data):
    """With ladder=1 there is nothing to exchange and no random number is drawn for it: the search
    is the same whatever p_exchange says (the search of before the ladder)."""
    a, b = (anneal(data, LossConfig(), AnnealConfig(evals=2000, restarts=2, ladder=1.0, p_exchange=p), seed=3)
            for p in (0.0, 0.9))
    _same(a, b)
    for bad in ({"ladder": 0.5}, {"ladder": float("inf")}, {"p_exchange": 2.0}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            AnnealConfig(**bad)
