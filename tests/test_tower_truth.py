"""The tower cell's size relations: ``small(X)`` and ``bigger(X,Y)`` beside ``big(X)``,
against the sizes the cell was built with, gradable by the grounding F1 code and usable as truth
symbols."""

from __future__ import annotations

import pytest

from groundsym.collect import collect_traces
from groundsym.evaluation.config import check_truth_symbols
from groundsym.evaluation.truth import TruthSymbols
from groundsym.grounding import fit_relation_symbol, match_symbols
from groundsym.symbols import SymbolSet
from sims.tower import TowerSim


@pytest.fixture(scope="module")
def cell():
    with TowerSim(cubes="4", big="2", balls="1", noise="0") as sim:
        ds = collect_traces(sim, 2, 3, seed=3, progress=False)
        yield sim, ds


def test_size_relations_follow_the_built_sizes(cell):
    sim, ds = cell
    assert ds.feature_names[3] == "size"          # pose features: the simulator's size of each object
    for tr in ds.traces:
        for scene in tr.scenes:
            size = dict(zip(tr.objects, scene.features[:, 3]))
            ball = {o for o in tr.objects if size[o] == 0.045}
            names = lambda p: {a.args for a in scene.truth if a.predicate == p}   # noqa: E731
            assert names("small") == {(o,) for o in sim.objects if size[o] == 0.04}
            assert names("bigger") == {(x, y) for x in sim.objects for y in sim.objects if size[x] > size[y]}
            # every object is exactly one of big, small, ball; bigger is a strict order
            kinds = [names(p) for p in ("big", "small", "ball")]
            assert kinds[2] == {(o,) for o in ball} and len(kinds[0]) == 2
            assert sorted(o for k in kinds for (o,) in k) == sorted(sim.objects)
            bigger = names("bigger")
            assert not any((y, x) in bigger for x, y in bigger)
            assert all((x, z) in bigger for x, y in bigger for y2, z in bigger if y == y2)
            assert {(b, s) for (b,) in names("big") for (s,) in names("small")} <= bigger


def test_graded_by_grounding_f1_and_usable_as_truth_symbols(cell):
    sim, ds = cell
    syms = [fit_relation_symbol("u1", "small", ds), fit_relation_symbol("b1", "bigger", ds)]
    matches = {m.symbol: m for m in match_symbols(SymbolSet.for_dataset(syms, ds), ds)}
    assert matches["u1"].best_match == "small" and matches["u1"].f1 == 1.0
    assert matches["b1"].best_match == "bigger" and matches["b1"].argument_order == "same" and matches["b1"].f1 > 0.9
    check_truth_symbols(["inhand", "on", "big", "bigger", "small"], sim.truth_predicates)
    sds = TruthSymbols(("inhand", "on", "bigger"), dict(sim.truth_predicates)).to_symbolic_dataset(ds)
    assert sds.predicates == {"inhand": 1, "on": 2, "bigger": 2}
    assert sum(a.predicate == "bigger" for a in sds.traces[0].states[0]) == 2 * 1 + 2 * 2 + 2   # big>ball>small
