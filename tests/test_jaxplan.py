"""``--planner jaxplan``: JaxPlan (pyRDDLGym-jax) on a model's RDDL export picks the action a
hand-computed case calls for. Needs the extra ``jaxplan``; compiling with jax takes a minute, so
the planning test is slow.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from groundsym.errors import UserError
from groundsym.logic import parse_atom
from groundsym.planner import Observation, PlanningModel, make_planner
from groundsym.reward import Feature, RewardModel
from groundsym.rules.io import read_rules

RULES = Path(__file__).parent / "data" / "nid_blocks.rules.json"


def _model(reward: RewardModel | None) -> PlanningModel:
    rules, _ = read_rules(RULES)
    return PlanningModel(primitives={"pickup": 1, "putdown": 0, "puton": 1}, rules=rules, reward=reward,
                         predicates={"clear": 1, "handempty": 0, "inhand": 1, "on": 2, "ontable": 1})


def test_needs_a_reward_model_and_the_extra():
    pytest.importorskip("pyRDDLGym_jax", reason="pyRDDLGym-jax is not installed (pip install -e '.[jaxplan]')")
    with pytest.raises(UserError, match="reward model"):
        make_planner("jaxplan", _model(None), {}, 0)
    with pytest.raises(UserError, match="horizon"):
        make_planner("jaxplan", _model(RewardModel((), (), 0.0, ())), {"horizon": "0"}, 0)


@pytest.mark.slow
def test_jaxplan_puts_the_held_block_on_the_other():
    """Block a in the hand, b clear on the table, reward 1 per (on ?x ?y): putting a on b (0.8
    in the hand-written rules) is the only action that can earn reward within the horizon."""
    pytest.importorskip("pyRDDLGym_jax", reason="pyRDDLGym-jax is not installed (pip install -e '.[jaxplan]')")
    on = Feature((parse_atom("(on ?a ?b)"),))
    planner = make_planner("jaxplan", _model(RewardModel((on,), (1.0,), 0.0, (("on", 2),))),
                           {"horizon": "2", "epochs": "200"}, 0)
    state = frozenset(map(parse_atom, ["(inhand a)", "(clear b)", "(ontable b)"]))
    actions = tuple(map(parse_atom, ["(putdown)", "(puton b)", "(pickup b)"]))
    decision = planner.choose(Observation(("a", "b"), actions, state))
    assert decision.action == parse_atom("(puton b)") and "fallback" not in decision.info
