"""PRADA and A-PRADA (Lang & Toussaint 2010): planning with noisy probabilistic relational rules.

PRADA turns the NID rules into a dynamic Bayesian network over ground atoms and keeps only
per-atom marginals (the factored frontier; Lang & Toussaint 2010). It samples many action sequences,
each action drawn with weight "probability that a manipulating rule of it applies",
propagates the marginals along each sequence, scores it by the discounted expected reward
``sum_t gamma^t E_t[R]`` and runs the first action of the best sequence; it replans after
every primitive. A-PRADA then deletes actions from the best sequence while that raises its
value (docs/planning.md, PRADA and A-PRADA).

One module per job, each importing only the ones listed before it:

- :mod:`~planners.prada.grounding`: the rules over one object set as numpy index tables;
- :mod:`~planners.prada.frontier`: one step of factored-frontier inference for all samples;
- :mod:`~planners.prada.rewards`: the expected reward of a belief (a goal or a learned model);
- :mod:`~planners.prada.core`: sampling, scoring and shortening sequences (:class:`PradaCore`);
- :mod:`~planners.prada.planner`: :class:`PradaPlanner`, the ``--planner prada`` adapter.

The entry point ``planners.prada:PradaPlanner`` names the class through this package.
"""

from .core import Plan, PradaCore, sample_rows
from .frontier import RULE_MIN_PROB, action_weights, rule_probabilities, transition
from .grounding import Grounding, ground_rules, subgrounding
from .planner import PradaPlanner
from .rewards import (ArrayReward, GoalReward, LinearReward, ModelReward, RewardFn, SampledReward,
                      array_reward, goal_reward, model_reward)

__all__ = [
    "ArrayReward", "GoalReward", "Grounding", "LinearReward", "ModelReward", "Plan", "PradaCore",
    "PradaPlanner", "RULE_MIN_PROB", "RewardFn", "SampledReward", "action_weights", "array_reward",
    "goal_reward", "ground_rules", "model_reward", "rule_probabilities", "sample_rows", "subgrounding",
    "transition",
]
