"""PRADA's ``retry_memory`` (docs/kinder.md): with ``visit`` a primitive banned by ``retries`` in a
state may be tried again once the state has changed and come back; with ``episode`` (the default)
it stays banned there until the episode ends. The learned Obstruction2D symbols miss some blocking
configurations, so the state the planner sees can come back while the world has changed."""

from __future__ import annotations

from conftest import DATA
from groundsym.logic import parse_atom
from groundsym.planner import Observation, PlanningModel
from groundsym.rules.io import read_rules
from groundsym.rules.sample import ground_actions
from planners.prada import PradaPlanner

GRASP = parse_atom("(closeHandAround c)")
OBJECTS = ("a", "b", "c")


class StackedPairs:
    """A reward that counts stacked pairs: the grasp of c is the best first action in ``(on a b)``."""

    def expected(self, marginals, objects):
        return 0.5 + sum(p for a, p in marginals.items() if a.predicate == "on")


def decisions(memory: str | None) -> list:
    """Two grasps that change nothing in S, one decision in another state, then S again."""
    rules, meta = read_rules(DATA / "nid_tower_derived.rules.json")
    model = PlanningModel(meta["primitives"], predicates=meta["predicates"], rules=rules,
                          reward=StackedPairs(), gamma=0.8)
    acts = tuple(ground_actions(meta["primitives"], OBJECTS))
    opts = {"retries": "1"} | ({"retry_memory": memory} if memory else {})
    planner = PradaPlanner(model, opts, 0)
    s, elsewhere = frozenset({parse_atom("(on a b)")}), frozenset({parse_atom("(on b a)")})
    states = [s, s, s, elsewhere, s]
    return [planner.choose(Observation(OBJECTS, acts, st, None, t)) for t, st in enumerate(states)]


def test_visit_forgets_the_ban_when_the_state_changes_and_comes_back():
    chosen = decisions("visit")
    assert [d.action for d in chosen[:2]] == [GRASP, GRASP]
    assert chosen[2].action != GRASP and chosen[2].info["banned"] == [str(GRASP)]
    assert chosen[4].action == GRASP and "banned" not in chosen[4].info


def test_episode_memory_is_the_default_and_keeps_the_ban():
    default, episode = decisions(None), decisions("episode")
    assert [d.action for d in default] == [d.action for d in episode]
    assert default[4].action != GRASP and default[4].info["banned"] == [str(GRASP)]
