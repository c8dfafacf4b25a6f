"""Does pyRDDLGym's simulator of an exported RDDL model step as our PPDDL semantics says?

The check (docs/rddl.md, "Round trips"): from the problem's initial state, the states our
simulator (:class:`groundsym.ppddl.simulate.Task`) reaches are visited breadth first; in each, every
ground primitive is run ``samples`` times by pyRDDLGym's own simulator (the state set on it
directly). A successor (with its reward) that ours gives probability 0 is a failure outright; an
outcome's sampled share may differ from ours by at most Hoeffding's bound
``eps = sqrt(ln(2 m / delta) / (2 n))`` over all ``m`` outcome shares checked (a union bound), so a
correct export fails with probability below ``delta`` (default 1e-3). pyRDDLGym is imported here
only, when a check runs: the export itself does not need it.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from ..logic import Atom
from ..ppddl.ast import Domain, Effect, Problem
from ..ppddl.simulate import Task
from ..rules.model import Derived
from .writer import RddlWriter, without_state_reward

REWARD_DECIMALS = 9        # rewards are compared after rounding to this many decimals


@dataclass(frozen=True)
class RoundTrip:
    """What one check found."""

    states: int
    pairs: int                      # (state, ground primitive) pairs stepped
    steps: int                      # pyRDDLGym steps taken
    outcomes: int                   # outcome shares compared
    eps: float                      # Hoeffding's bound on each share
    worst: float                    # largest |sampled share - ours|
    failures: tuple[str, ...] = field(default=())

    @property
    def ok(self) -> bool:
        return not self.failures


class PyRddlStepper:
    """pyRDDLGym's simulator of a written RDDL model, stepped from states we give it."""

    def __init__(self, writer: RddlWriter, folder: Path, seed: int) -> None:
        import pyRDDLGym
        from pyRDDLGym.core.simulator import RDDLSimulator
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "domain.rddl").write_text(writer.domain_text())
        (folder / "instance.rddl").write_text(writer.instance_text())
        env = pyRDDLGym.make(str(folder / "domain.rddl"), str(folder / "instance.rddl"))
        self.model = env.model
        self.sim = RDDLSimulator(self.model, rng=np.random.default_rng(seed))
        self.sim.reset()
        self.writer = writer
        self.start = {k: np.copy(v) for k, v in self.sim.subs.items()}

    def step(self, state: frozenset, primitive: Atom) -> tuple[frozenset, float]:
        ids = self.writer.ids
        subs = self.sim.subs
        subs.update({k: np.copy(v) for k, v in self.start.items()})
        subs.update(fluent_arrays(self.model, self.writer, state, self.start))
        name = self.model.ground_var(ids(primitive.predicate), [ids(x) for x in primitive.args])
        obs, reward, _ = self.sim.step(self.sim.prepare_actions_for_sim({name: True}))
        after = set()
        for ground, value in obs.items():
            if value:
                var, objects = self.model.parse_grounded(ground)
                after.add(Atom(ids.name_of(var), tuple(ids.name_of(o) for o in objects)))
        static = frozenset(a for a in state if a.predicate not in self.writer.fluents)
        return frozenset(after) | static, float(reward)


def fluent_arrays(model, writer: RddlWriter, state: frozenset, like: dict) -> dict[str, np.ndarray]:
    """``state`` as pyRDDLGym's arrays of the state fluents (``like``: arrays of the right shapes,
    e.g. the simulator's initial ones); ``model``: pyRDDLGym's compiled model of ``writer``'s text."""
    ids = writer.ids
    out = {var: np.zeros_like(like[var]) for var in model.state_fluents}
    for a in state:
        if a.predicate in writer.fluents:
            var = ids(a.predicate)
            if a.args:
                out[var][model.object_indices([ids(x) for x in a.args])] = True
            else:
                out[var] = np.True_
    return out


def reachable(task: Task, limit: int) -> list[frozenset]:
    """Up to ``limit`` states our simulator reaches from the initial state, breadth first (a
    goal state ends an episode and is not expanded)."""
    seen = [task.initial_state]
    known = {task.initial_state}
    i = 0
    while i < len(seen) and len(seen) < limit:
        s = seen[i]
        i += 1
        if task.goal_holds(s):
            continue
        for prim in task.applicable_primitives(s):
            for succ in task.distribution(s, prim):
                if succ.prob > 0 and succ.state not in known and len(seen) < limit:
                    known.add(succ.state)
                    seen.append(succ.state)
    return seen


def check(domain: Domain, problem: Problem, folder: Path, *, state_reward: Effect | None = None,
          max_states: int = 20, samples: int = 200, delta: float = 1e-3, seed: int = 0, inapplicable: int = 2,
          written: Domain | None = None, derived: Sequence[Derived] = ()) -> RoundTrip:
    """Compare pyRDDLGym's successor distributions and rewards with ours (module docstring).
    ``domain``/``problem``: the PPDDL our simulator runs; the RDDL is written from them (with
    ``state_reward`` written once, when the domain's actions all carry it). ``inapplicable``:
    in each state, how many primitives that change nothing are also stepped (they must).
    ``written``: the domain the RDDL is written from (default ``domain``; a test gives a wrong
    one to see the check fail). ``derived``: a rule set's derived predicates (derived fluents)."""
    writer = RddlWriter(without_state_reward(written or domain, state_reward), problem, state_reward,
                        derived=derived)
    stepper = PyRddlStepper(writer, folder, seed)
    task = Task(domain, problem)
    rng = np.random.default_rng(seed)
    bonus = float(writer.goal_reward() or 0) if writer.goal else 0.0
    plan: list[tuple[frozenset, Atom, Counter]] = []
    everything = task.primitive_actions()
    for s in (s for s in reachable(task, max_states) if not task.goal_holds(s)):
        runnable = task.applicable_primitives(s)
        idle = [a for a in everything if a not in set(runnable)]
        picked = [idle[i] for i in rng.choice(len(idle), min(inapplicable, len(idle)), replace=False)] if idle else []
        for prim in [*runnable, *picked]:
            want: Counter = Counter()
            for prob, after, reward in task.distribution(s, prim) or [(1.0, s, None)]:
                r = None if reward is None else round(reward + bonus * task.goal_holds(after), REWARD_DECIMALS)
                want[(after, r)] += prob
            plan.append((s, prim, want))
    m = sum(len(w) for _, _, w in plan)
    eps = math.sqrt(math.log(2 * max(m, 1) / delta) / (2 * samples))
    failures, worst = [], 0.0
    for s, prim, want in plan:
        got: Counter = Counter()
        for _ in range(samples):
            after, reward = stepper.step(s, prim)
            key = (after, round(reward, REWARD_DECIMALS))
            got[key if (after, None) not in want else (after, None)] += 1
        for key in got:
            if key not in want:
                failures.append(f"{prim} in {_show(s)}: pyRDDLGym reached {_show(key[0])} (reward {key[1]}), "
                                "which ours gives probability 0")
        for key, p in want.items():
            gap = abs(got[key] / samples - p)
            worst = max(worst, gap)
            if gap > eps:
                failures.append(f"{prim} in {_show(s)}: outcome share {got[key] / samples:.3f}, ours {p:.4f}")
    return RoundTrip(len({s for s, _, _ in plan}), len(plan), len(plan) * samples, m, eps, worst,
                     tuple(failures))


def _show(state: frozenset) -> str:
    return "{" + " ".join(sorted(map(str, state))) + "}"
