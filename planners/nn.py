"""CONTINUOUS-NN and SYMBOLIC-NN: the paper's nearest-neighbour baselines (Section VI-A).

Every state ``y_t`` of the training traces that has an action gets the value
``V(y_t) = sum_{d=0..3} 0.8^d r_{t+d}``, with ``r_{t+d} := r_T`` past the end. Given a new state, the
planner retrieves the training states closest to it under the permutation-invariant distance
(continuous unary features for CONTINUOUS-NN, learned symbolic states for SYMBOLIC-NN), takes
the one with the largest value among them, and runs its action with the arguments mapped through
the best permutation.

"The closest states" (the paper's plural) are read as the ``k`` nearest, every state tied with the
k-th included (option ``k``, default 3). With ``k = 1`` only the states at the minimum distance
compete; in continuous space that is almost always one state, whose (random) training action is
then run regardless of its value, which would make CONTINUOUS-NN a random policy.

Reward indexing: in the paper's trace tuples ``<y_t, a_t, r_t>``, ``r_t`` is the reward that
follows ``a_t``. Our trace files store with each step the reward of that step's *scene* (before the
action), so ``r_t`` here is the reward of scene ``t+1`` and ``r_T`` that of the final scene. The
value of a state therefore starts with the consequence of its own action, which is what makes it
a value of that action.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from groundsym.logic import Atom
from groundsym.options import Option, parse_options, positive
from groundsym.planner import Decision, Observation, PlanningModel
from groundsym.relational import Neighbours, nearest, scene_distance, state_distance

DEPTH = 4        # d = 0..3
NN_GAMMA = 0.8   # the paper's discount for these values


def trace_values(scene_rewards: Sequence[float], depth: int = DEPTH, gamma: float = NN_GAMMA) -> np.ndarray:
    """``V_t`` for t = 0..T-1 from the T+1 scene rewards of one trace (see the module docstring)."""
    R = np.asarray(scene_rewards, dtype=float)
    T = len(R) - 1
    out = np.zeros(T)
    for t in range(T):
        for d in range(depth):
            out[t] += gamma ** d * R[min(t + 1 + d, T)]
    return out


@dataclass(frozen=True)
class Memory:
    """The retrievable training states: state, objects, action and value of each step."""

    states: tuple[Any, ...]
    objects: tuple[tuple[str, ...], ...]
    actions: tuple[Atom, ...]
    values: np.ndarray


def k_nearest(distances: Sequence[tuple[float, dict[str, str]]], k: int, tol: float = 1e-9) -> Neighbours:
    """The k nearest candidates (all ties with the k-th), in candidate order, with their mappings."""
    d = np.array([x for x, _ in distances])
    finite = np.flatnonzero(np.isfinite(d))
    if not len(finite):
        return Neighbours(float("inf"), (), ())
    kth = np.sort(d[finite])[min(k, len(finite)) - 1]
    idx = [int(i) for i in finite if d[i] <= kth + tol]
    return Neighbours(float(d[finite].min()), tuple(idx), tuple(distances[i][1] for i in idx))


def _choose(memory: Memory, hit: Any, observation: Observation, rng: np.random.Generator) -> Decision:
    """The highest-valued nearest neighbour whose mapped action can be run; else a random one."""
    legal = set(observation.actions)
    order = sorted(range(len(hit.indices)), key=lambda j: (-memory.values[hit.indices[j]], hit.indices[j]))
    for j in order:
        k = hit.indices[j]
        back = {v: q for q, v in hit.mappings[j].items()}   # neighbour's object -> query object
        a = memory.actions[k]
        if all(x in back for x in a.args):
            mapped = Atom(a.predicate, tuple(back[x] for x in a.args))
            if not legal or mapped in legal:
                return Decision(mapped, float(memory.values[k]),
                                {"neighbour": int(k), "distance": float(hit.distance), "ties": len(hit.indices),
                                 "neighbour_action": str(a)})
    a = observation.actions[int(rng.integers(len(observation.actions)))]
    return Decision(a, float("nan"), {"neighbour": None, "distance": float(hit.distance)})


class _NNPlanner:
    OPTIONS = (Option("depth", positive(int, most=1000), DEPTH, "rewards summed into a state's value (paper: 4)"),
               Option("gamma", float, NN_GAMMA, "discount of those rewards (paper: 0.8)"),
               Option("k", positive(int, most=1_000_000), 3, "closest training states that compete by value "
                      "(ties with the k-th included)"))

    def __init__(self, model: PlanningModel, options: Mapping[str, Any], seed: int):
        self.opts = parse_options("--planner-opt", "planner", self.name, self.OPTIONS, options)
        self.rng = np.random.default_rng(seed)
        self.memory = self._memory(model)
        if not self.memory.actions:
            raise ValueError("no training transitions to retrieve from")

    def _memory(self, model: PlanningModel) -> Memory:  # pragma: no cover - interface
        raise NotImplementedError

    def observe(self, action: Atom, observation: Observation) -> None:
        """Nearest-neighbour retrieval has no state between steps."""


class ContinuousNNPlanner(_NNPlanner):
    """Nearest neighbour over the continuous unary features ``y_i`` of the training scenes."""

    name = "continuous-nn"
    NEEDS = frozenset({"traces"})

    def _memory(self, model: PlanningModel) -> Memory:
        states, objects, actions, values = [], [], [], []
        for tr in model.traces.traces:
            v = trace_values([s.reward for s in tr.scenes], self.opts["depth"], self.opts["gamma"])
            for t, a in enumerate(tr.actions):
                states.append(tr.scenes[t])
                objects.append(tuple(tr.objects))
                actions.append(a)
                values.append(v[t])
        return Memory(tuple(states), tuple(objects), tuple(actions), np.array(values))

    def choose(self, observation: Observation) -> Decision:
        if observation.scene is None:
            raise ValueError("continuous-nn needs continuous observations (a simulation)")
        if self.opts["k"] == 1:
            hit = nearest(observation.scene, None, list(self.memory.states))
        else:
            hit = k_nearest([scene_distance(observation.scene, s) for s in self.memory.states], self.opts["k"])
        return _choose(self.memory, hit, observation, self.rng)


class SymbolicNNPlanner(_NNPlanner):
    """Nearest neighbour over the learned abstract states of the training traces."""

    name = "symbolic-nn"
    NEEDS = frozenset({"symbolic_traces"})

    def __init__(self, model: PlanningModel, options: Mapping[str, Any], seed: int):
        super().__init__(model, options, seed)
        self.predicates = dict(model.predicates or getattr(model.symbolic_traces, "predicates", {}) or {})

    def _memory(self, model: PlanningModel) -> Memory:
        states, objects, actions, values = [], [], [], []
        for tr in model.symbolic_traces.traces:
            final = tr.final_reward if tr.final_reward is not None else tr.rewards[-1]
            v = trace_values([*tr.rewards, final], self.opts["depth"], self.opts["gamma"])
            for t, a in enumerate(tr.actions):
                states.append(tr.states[t])
                objects.append(tuple(tr.objects))
                actions.append(a)
                values.append(v[t])
        return Memory(tuple(states), tuple(objects), tuple(actions), np.array(values))

    def choose(self, observation: Observation) -> Decision:
        if observation.state is None:
            raise ValueError("symbolic-nn needs abstract states (learned symbols or a symbolic domain)")
        cands = list(zip(self.memory.states, self.memory.objects))
        preds = self.predicates or None
        if self.opts["k"] == 1:
            hit = nearest(observation.state, observation.objects, cands, predicates=preds)
        else:
            hit = k_nearest([state_distance(observation.state, observation.objects, s, o, predicates=preds)
                             for s, o in cands], self.opts["k"])
        return _choose(self.memory, hit, observation, self.rng)
