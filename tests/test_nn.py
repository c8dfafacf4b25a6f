"""The paper's nearest-neighbour baselines: values by hand, retrieval under renamed objects,
the neighbour's action mapped back through the best permutation, ties broken by value."""

from __future__ import annotations

import numpy as np
import pytest

from groundsym.logic import Atom, parse_atom
from groundsym.planner import Observation, PlanningModel
from groundsym.symbolic_traces import SymbolicDataset, SymbolicTrace
from groundsym.traces import Dataset, Trace
from groundsym.world import Scene
from planners.nn import ContinuousNNPlanner, SymbolicNNPlanner, trace_values

A = parse_atom
PRIMS = {"grab": 1, "drop": 1}


def test_values_by_hand():
    # scene rewards r(y_0..y_3) = 0, 1, 2, 3; r_t follows a_t, so V_0 = 1 + .8*2 + .64*3 + .512*3
    v = trace_values([0.0, 1.0, 2.0, 3.0])
    assert v == pytest.approx([1 + 0.8 * 2 + 0.64 * 3 + 0.512 * 3, 2 + 0.8 * 3 + 0.64 * 3 + 0.512 * 3,
                               3 * (1 + 0.8 + 0.64 + 0.512)])


def state(*atoms):
    return frozenset(A(a) for a in atoms)


def symbolic_model():
    objs = ("x", "y", "z")
    t1 = SymbolicTrace(objs, [state("(inhand x)"), state("(on x y)"), state("(on x y)")],
                       [A("(drop y)"), A("(grab z)")], [0.0, 1.0], final_reward=1.0)
    # the same first state, but a worse action (dropping onto the floor-level z gives nothing)
    t2 = SymbolicTrace(objs, [state("(inhand x)"), state()], [A("(grab y)")], [0.0], final_reward=0.0)
    ds = SymbolicDataset([t2, t1], {"inhand": 1, "on": 2}, PRIMS)
    return PlanningModel(PRIMS, predicates={"inhand": 1, "on": 2}, symbolic_traces=ds)


def test_symbolic_nn_maps_the_best_tied_neighbours_action_onto_the_query_objects():
    planner = SymbolicNNPlanner(symbolic_model(), {"k": "1"}, seed=0)
    objs = ("a", "b", "c")
    acts = tuple(Atom(p, (o,)) for p in PRIMS for o in objs)
    # "c in hand": the nearest states (distance 0) are both first states; the better one says drop on y
    d = planner.choose(Observation(objs, acts, state("(inhand c)")))
    assert d.info["distance"] == 0 and d.info["ties"] == 2
    assert d.expected_value == pytest.approx(trace_values([0, 1, 1])[0])
    # y is mapped to whichever of a, b is free: both are equivalent, and it is never the held c
    assert d.action.predicate == "drop" and d.action.args[0] in ("a", "b")


def test_symbolic_nn_respects_relations_when_mapping():
    planner = SymbolicNNPlanner(symbolic_model(), {"k": "1"}, seed=0)
    objs = ("a", "b", "c")
    acts = tuple(Atom(p, (o,)) for p in PRIMS for o in objs)
    d = planner.choose(Observation(objs, acts, state("(on b a)")))   # matches t1's second state, x->b, y->a
    assert d.action == A("(grab c)") and d.info["distance"] == 0


def scene(objs, feats, reward=0.0):
    return Scene(tuple(objs), np.asarray(feats, dtype=float), reward)


def test_continuous_nn_maps_arguments_through_the_assignment():
    objs = ("o1", "o2", "o3")
    f0 = [[0.0, 0.0, 0.02, 0.04], [0.3, 0.0, 0.02, 0.05], [0.0, 0.3, 0.02, 0.04]]
    f1 = [[0.0, 0.0, 0.02, 0.04], [0.3, 0.0, 0.06, 0.05], [0.0, 0.3, 0.02, 0.04]]
    tr = Trace(objs, [scene(objs, f0), scene(objs, f1, 0.04)], [A("(grab o2)")])
    model = PlanningModel(PRIMS, traces=Dataset([tr], ("x", "y", "z", "size"), PRIMS))
    planner = ContinuousNNPlanner(model, {"k": "1"}, seed=0)
    q_objs = ("a", "b", "c")
    perm = [2, 0, 1]                      # a is the old o3, b the old o1, c the old o2 (+ a little noise)
    q = scene(q_objs, np.asarray(f0)[perm] + 0.001)
    acts = tuple(Atom(p, (o,)) for p in PRIMS for o in q_objs)
    d = planner.choose(Observation(q_objs, acts, None, q))
    assert d.action == A("(grab c)")
    assert d.expected_value == pytest.approx(0.04 * (1 + 0.8 + 0.64 + 0.512))


def test_needs_and_bad_observations():
    planner = SymbolicNNPlanner(symbolic_model(), {}, seed=0)
    with pytest.raises(ValueError):
        planner.choose(Observation(("a",), (A("(grab a)"),), None))
    assert SymbolicNNPlanner.NEEDS == {"symbolic_traces"} and ContinuousNNPlanner.NEEDS == {"traces"}


def test_k_nearest_states_compete_by_value():
    """Three training states; the query is nearest to the worst one. With k = 1 its action runs;
    with k = 3 the best-valued of the three (mapped through its own permutation) runs instead."""
    objs = ("o1", "o2")
    near = [[0.0, 0.0, 0.02, 0.04], [0.3, 0.0, 0.02, 0.04]]
    mid = [[0.0, 0.0, 0.02, 0.04], [0.3, 0.05, 0.02, 0.04]]
    far = [[0.0, 0.0, 0.02, 0.04], [0.3, 0.2, 0.02, 0.04]]
    trs = [Trace(objs, [scene(objs, f), scene(objs, f, r)], [A(a)])
           for f, r, a in ((near, 0.0, "(drop o1)"), (mid, 0.01, "(grab o1)"), (far, 0.05, "(grab o2)"))]
    model = PlanningModel(PRIMS, traces=Dataset(trs, ("x", "y", "z", "size"), PRIMS))
    q = scene(("a", "b"), near)
    acts = tuple(Atom(p, (o,)) for p in PRIMS for o in ("a", "b"))
    assert ContinuousNNPlanner(model, {"k": "1"}, 0).choose(Observation(("a", "b"), acts, None, q)).action == A("(drop a)")
    best = ContinuousNNPlanner(model, {"k": "3"}, 0).choose(Observation(("a", "b"), acts, None, q))
    assert best.action == A("(grab b)") and best.expected_value == pytest.approx(0.05 * 2.952)
    assert ContinuousNNPlanner(model, {"k": "2"}, 0).choose(Observation(("a", "b"), acts, None, q)).action == A("(grab a)")
