"""Trace files: round trip, validation errors naming file and field, atomic writes."""

import json

import numpy as np
import pytest

from groundsym.errors import UserError
from groundsym.logic import Atom, parse_atom, parse_literal
from groundsym.rules.model import Outcome, Rule, RuleSet, DefaultRule
from groundsym.symbolic_traces import (SymbolicDataset, SymbolicTrace, read_symbolic_traces,
                                       write_symbolic_traces)
from groundsym.traces import Dataset, Trace, read_traces, write_traces
from groundsym.world import Scene


def _dataset():
    objs = ("o1", "o2")
    s0 = Scene(objs, np.array([[0.0, 0, 0.02, 0.04], [0.1, 0, 0.02, 0.05]]), 0.0,
               frozenset({parse_atom("(ontable o1)")}))
    s1 = Scene(objs, np.array([[0.1, 0, 0.07, 0.04], [0.1, 0, 0.02, 0.05]]), 0.025,
               frozenset({parse_atom("(on o1 o2)")}))
    tr = Trace(objs, [s0, s1], [parse_atom("(openHandOver o2)")])
    return Dataset([tr], ("x", "y", "z", "size"), {"closeHandAround": 1, "openHandOver": 1}, {"seed": 3})


def test_traces_round_trip(tmp_path):
    path = tmp_path / "t.json"
    write_traces(path, _dataset())
    ds = read_traces(path)
    assert ds.feature_names == ("x", "y", "z", "size")
    assert ds.traces[0].actions == [Atom("openHandOver", ("o2",))]
    assert ds.traces[0].scenes[1].truth == {Atom("on", ("o1", "o2"))}
    np.testing.assert_array_equal(ds.traces[0].scenes[1].features[0], [0.1, 0, 0.07, 0.04])
    assert ds.traces[0].scenes[1].reward == 0.025
    # pair features default to y_i - y_j
    np.testing.assert_allclose(ds.traces[0].scenes[0].pairs()[0, 1], [-0.1, 0, 0, -0.01])


@pytest.mark.parametrize("mutate, field", [
    (lambda d: d["traces"][0]["steps"][0].__setitem__("features", [[1, 2, 3]]), "traces[0].steps[0].features"),
    (lambda d: d["traces"][0]["steps"][0]["features"][0].__setitem__(0, float("nan")), "traces[0].steps[0].features"),
    (lambda d: d["traces"][0]["steps"][0].__setitem__("action", "(fly o1)"), "traces[0].steps[0].action"),
    (lambda d: d["traces"][0]["steps"][0].__setitem__("action", "(openHandOver o9)"), "traces[0].steps[0].action"),
    (lambda d: d["traces"][0].pop("final"), "traces[0].final"),
    (lambda d: d.__setitem__("schema", "other/1"), "schema"),
])
def test_traces_errors_name_the_field(tmp_path, mutate, field):
    path = tmp_path / "t.json"
    write_traces(path, _dataset())
    doc = json.loads(path.read_text())
    mutate(doc)
    path.write_text(json.dumps(doc))
    with pytest.raises(UserError) as e:
        read_traces(path)
    assert str(e.value).startswith(f"{path}: {field}")


def test_truncated_file(tmp_path):
    path = tmp_path / "t.json"
    write_traces(path, _dataset())
    path.write_text(path.read_text()[:50])
    with pytest.raises(UserError, match="malformed JSON at line"):
        read_traces(path)


def test_symbolic_round_trip_and_undeclared(tmp_path):
    st = SymbolicTrace(("a", "b"), [frozenset({parse_atom("(not-flattire)")}), frozenset()],
                       [parse_atom("(move-car a b)")], [0.0], 1.0)
    ds = SymbolicDataset([st], {"not-flattire": 0}, {"move-car": 2})
    path = tmp_path / "s.json"
    write_symbolic_traces(path, ds)
    back = read_symbolic_traces(path)
    assert back.traces[0].states == st.states and back.traces[0].final_reward == 1.0
    doc = json.loads(path.read_text())
    doc["traces"][0]["final"] = ["(flat a)"]
    path.write_text(json.dumps(doc))
    with pytest.raises(UserError, match=r"traces\[0\].final\[0\]: unknown name 'flat'"):
        read_symbolic_traces(path)


def test_literal_parse():
    assert str(parse_literal("(not (on a b))")) == "(not (on a b))"
    with pytest.raises(ValueError):
        parse_atom("on a b")


def test_coverage_ambiguity_example():
    """A rule covers an action only with a unique binding: puton(X): block(X), inhand(Y) covers {block(a), inhand(b)} only."""
    r = Rule(parse_atom("(puton ?x)"), (parse_literal("(block ?x)"), parse_literal("(inhand ?y)")),
             (Outcome((parse_literal("(on ?y ?x)"),)),), (0.75,), 0.25)
    a = parse_atom("(puton a)")
    s1 = frozenset(map(parse_atom, ["(block a)", "(inhand b)"]))
    s2 = s1 | {parse_atom("(inhand c)")}
    s0 = frozenset(map(parse_atom, ["(block a)"]))
    assert r.covers(s1, a) == {"?x": "a", "?y": "b"}
    assert r.covers(s2, a) is None       # two referents: ambiguous
    assert r.covers(s0, a) is None       # no referent
    rs = RuleSet((r,), (("puton", DefaultRule(0.2)),))
    succ = s1 | {parse_atom("(on b a)")}
    assert rs.likelihood(s1, a, succ) == pytest.approx(0.75 + 0.25 * rs.p_min)
    # default rule for the ambiguous state: no change has probability 0.8
    assert rs.likelihood(s2, a, s2) == pytest.approx(0.8 + 0.2 * rs.p_min_default)
