"""PRADA and A-PRADA as a :class:`groundsym.planner.Planner` (``--planner prada``).

The planner grounds the model's rules once per object set, builds the reward (a PPDDL goal or the
learned reward model) and a :class:`~planners.prada.core.PradaCore`, and replans from the current
abstract state at every primitive. Its options follow libPRADA's demos (docs/planning.md).
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from groundsym.logic import Atom
from groundsym.options import Option, nonnegative, one_of, parse_options, positive, unit_interval
from groundsym.planner import Decision, Observation, PlanningModel
from groundsym.rules.model import with_derived

from .core import PradaCore
from .frontier import RULE_MIN_PROB, TRANSITION_MODES
from .grounding import ground_rules, subgrounding
from .rewards import RewardFn, goal_reward, model_reward


def _retries(text: str) -> int:
    value = int(text)
    if value < 0:
        raise ValueError("expected an integer >= 0")
    return value


class PradaPlanner:
    """PRADA / A-PRADA as a :class:`groundsym.planner.Planner`, replanning at every step."""

    name = "prada"
    NEEDS = frozenset({"rules", "reward"})
    OPTIONS = (
        Option("horizon", positive(int, most=100), 4, "look-ahead in primitives (libPRADA demos: 4)"),
        Option("samples", positive(int, most=100_000), 500, "action sequences sampled per decision"),
        Option("gamma", unit_interval, None, "discount of the expected rewards (default: the task's, "
               "e.g. the tower's 0.8; 0.95 as libPRADA on a PPDDL domain)"),
        Option("noise_softener", unit_interval, 0.2, "scales how much a rule's noise outcome "
               "spreads over changeable atoms (libPRADA demos: 0.2)"),
        Option("variant", one_of("prada", "a-prada"), "prada", "prada, or a-prada (shorten the best sequence)"),
        Option("choice", one_of("max", "top10"), "max", "max: first action of the best sequence; top10: the "
               "first action whose 10 best sequences score highest on average"),
        Option("rule_min_prob", unit_interval, RULE_MIN_PROB, "a rule whose context holds with a "
               "smaller probability is taken not to apply (libPRADA: 0.03)"),
        Option("threshold", nonnegative, 0.0, "libPRADA's 'no sensible action' test: while the best "
               "sequence does not beat doing nothing by this much, sample again (max_runs times)"),
        Option("max_runs", positive(int, most=100), 1, "sampling rounds per decision while the "
               "threshold is not met (then the best sequence found is run anyway)"),
        Option("retries", _retries, None, "a primitive that left the abstract state unchanged is "
               "tried again in that same state at most this many times (then only other first "
               "actions are sampled in that state, for as long as retry_memory says); default: no "
               "limit, as libPRADA"),
        Option("retry_memory", one_of("episode", "visit"), "episode", "episode: a primitive banned by "
               "retries stays banned in that state for the rest of the episode; visit: the counts are "
               "forgotten when the state changes, so a return to the state may try it again (the world "
               "may have changed where the symbols cannot see it; docs/kinder.md)"),
        Option("goal_share", nonnegative, 0.0, "a PPDDL goal scores the probability that all its "
               "literals hold plus this weight times the expected share of them that hold"),
        Option("actions", one_of("all", "legal"), "all", "all: sample every grounding of the rules "
               "(libPRADA); legal: only the primitives the world offers (the observation's actions, "
               "e.g. with object types), at every step of a sequence"),
        Option("transition", one_of(*TRANSITION_MODES), "auto", "how a step multiplies the chosen rules "
               "into the atoms: segments (each sample's own action's rules), tables (all rules), auto "
               "(segments where the tables are sparse, the same bits; docs/tower.md)"),
        Option("references", one_of("rivals", "unique"), "rivals", "rivals: every binding of a rule's "
               "references is a ground rule that rivals the others; unique: NID's semantics, a rule "
               "covers only when exactly one binding does (docs/kinder.md)"),
    )

    def __init__(self, model: PlanningModel, options: Mapping[str, Any], seed: int):
        self.opts = parse_options("--planner-opt", "planner", self.name, self.OPTIONS, options)
        self.model = model
        self.rng = np.random.default_rng(seed)
        self._cores: dict[tuple[str, ...], PradaCore] = {}
        self._last: tuple[frozenset, Atom] | None = None
        self._unchanged: dict[tuple[frozenset, Atom], int] = {}    # (state, action) -> times it changed nothing

    def _predicates(self, state: frozenset) -> dict[str, int]:
        preds: dict[str, int] = dict(self.model.predicates or {})
        preds.update(dict(getattr(self.model.reward, "predicates", ()) or ()))
        if self.model.goal is not None:
            for lit in self.model.goal.literals:
                preds.setdefault(lit.atom.predicate, lit.atom.arity)
        for a in state:
            preds.setdefault(a.predicate, a.arity)
        return preds

    def core(self, objects: tuple[str, ...], state: frozenset, legal: Sequence[Atom] = ()) -> PradaCore:
        """The grounding and reward for this object set (built once, reused every step); with
        ``actions=legal``, only the ground rules of the ``legal`` actions (a world with typed
        arguments: a rule learned without types would otherwise promise effects of actions that
        cannot be run, and sequences of them outscore every real plan)."""
        key: Any = (objects, frozenset(legal)) if self.opts["actions"] == "legal" and legal else objects
        if key not in self._cores:
            g = ground_rules(self.model.rules, objects, self._predicates(state), self.opts["noise_softener"],
                             self.opts["references"] == "unique")
            if key is not objects:
                g = subgrounding(g, np.isin(g.rule_group, [k for k, a in enumerate(g.actions) if a in key[1]]))
            if self.model.goal is not None:
                reward: RewardFn = goal_reward(self.model.goal, g, self.opts["goal_share"])
            else:
                reward = model_reward(self.model.reward, g, np.random.default_rng(0))
            gamma = self.opts["gamma"] if self.opts["gamma"] is not None else self.model.gamma
            o = self.opts
            self._cores[key] = PradaCore(g, reward, o["horizon"], o["samples"], gamma, o["choice"],
                                         False, o["rule_min_prob"], o["threshold"], o["max_runs"], o["transition"])
        return self._cores[key]

    def choose(self, observation: Observation) -> Decision:
        state = observation.state if observation.state is not None else frozenset()
        core = self.core(observation.objects, state, observation.actions or ())
        b0 = core.g.belief(with_derived(state, getattr(self.model.rules, "derived", ()), observation.objects))
        shorten = self.opts["variant"] == "a-prada"
        banned = self._banned(state, observation.t)
        plan = core.plan(b0, self.rng, shorten, banned)
        for _ in range(2 if shorten else 0):    # A-PRADA plan_full: first action must be covered
            if plan.actions and self._covered(state, plan.actions[0], observation.objects):
                break
            plan = core.plan(b0, self.rng, shorten, banned)
        legal = set(observation.actions) if observation.actions else None
        if plan.actions and (legal is None or plan.actions[0] in legal):
            action = plan.actions[0]
        else:   # nothing applicable is worth sampling: any legal primitive, chosen by the seed
            action = observation.actions[int(self.rng.integers(len(observation.actions)))]
        info = {"plan": [str(a) for a in plan.actions], "noop_value": plan.noop_value,
                "variant": self.opts["variant"]}
        if banned:
            info["banned"] = [str(a) for a in banned]
        self._last = (state, action)
        return Decision(action, plan.value, info)

    def _banned(self, state: frozenset, t: int) -> list[Atom]:
        """The actions ``retries`` rules out now: each left this very state unchanged more than
        ``retries`` times in this episode (counted from the previous decision's outcome)."""
        limit = self.opts["retries"]
        if limit is None:
            return []
        if t == 0 or (self.opts["retry_memory"] == "visit" and self._last is not None and self._last[0] != state):
            self._unchanged.clear()
        elif self._last is not None and self._last[0] == state:
            self._unchanged[self._last] = self._unchanged.get(self._last, 0) + 1
        return sorted(a for (s, a), n in self._unchanged.items() if s == state and n > limit)

    def _covered(self, state: frozenset, action: Atom, objects: Sequence[str]) -> bool:
        rule, _ = self.model.rules.covering(state, action, objects)
        return rule is not None

    def observe(self, action: Atom, observation: Observation) -> None:
        """PRADA replans from scratch every step; nothing to remember."""
