"""LRTDP: Labeled Real-Time Dynamic Programming (Bonet & Geffner 2003) for goal-based PPDDL.

Why: FF-Replan and PRADA are not probabilistically aware for goals. On triangle-tireworld the
shortest road risks a flat tyre with no spare; only a planner that weighs the probability of
getting stuck takes the longer road past the spares. LRTDP computes a policy for the stochastic
shortest path problem from the current state only over the states the greedy policy can reach.

The problem: every primitive costs 1; a goal state costs nothing more; a state from which the goal
cannot be reached (the heuristic proves it, or nothing is applicable) costs ``dead_end_cost`` (a
penalty, the usual way to keep an SSP with dead ends finite: with the default 500 a policy that
gets stuck with probability p pays 500p, so reaching the goal for sure is worth up to 500 extra
steps). Reward effects of the domain are ignored: the planner plans for the goal.

The heuristic is h_max on the all-outcomes determinisation, relaxed further: delete effects,
negative and non-conjunctive preconditions and the conditions of ``when`` are ignored, and every
outcome of an action is an action of its own (Bonet & Geffner 2001). It is admissible: no real
trajectory reaches the goal in fewer steps than the relaxed one needs. Where it is infinite the
goal is unreachable in the domain, so the state is a proven dead end.

Per decision, trials run from the current state until it is labelled solved (its greedy policy
has converged to within ``epsilon`` on every state it reaches) or the budget (``trials`` or
``seconds``) runs out; the greedy action is then run. Values and labels are kept across the
decisions of an episode. Successor sampling in trials uses the planner's seed.
"""

from __future__ import annotations

import heapq
import time
from typing import Any, Mapping

import numpy as np

from groundsym.errors import UserError
from groundsym.logic import Atom
from groundsym.planner import Decision, Observation, PlannerOption, PlanningModel, parse_planner_options, positive
from groundsym.ppddl.ast import AndEffect, Probabilistic, When

INF = float("inf")


class Relaxation:
    """h_max over the ground actions of a task, with preconditions and adds as atom ids."""

    def __init__(self, task: Any, goal_atoms: frozenset) -> None:
        ids: dict[Atom, int] = {}

        def idx(a: Atom) -> int:
            return ids.setdefault(a, len(ids))

        self.pre: list[list[int]] = []
        self.add: list[list[int]] = []
        triggered, always = task._trigger_index()
        ground = [g for gs in triggered.values() for g in gs] + list(always)
        effects = [_all_outcomes(task, ga) for ga in ground]
        changing = {a.predicate for outs in effects for _, ad, de, _ in outs for a in ad | de}
        init = task.initial_state
        for ga, outs in zip(ground, effects):
            adds = {a for _, ad, _, _ in outs for a in ad}
            static = {a for a in ga.pos if a.predicate not in changing}
            if adds and static <= init:     # static atoms hold in every reachable state as in the start
                self.pre.append(sorted(idx(a) for a in ga.pos - static))
                self.add.append(sorted(idx(a) for a in adds))
        self.ids = ids
        self.goal = [ids.get(a, -1) for a in goal_atoms]
        self.users: list[list[int]] = [[] for _ in ids]
        for k, pre in enumerate(self.pre):
            for i in pre:
                self.users[i].append(k)

    def __call__(self, state: frozenset) -> float:
        if any(g < 0 for g in self.goal):
            return INF
        cost = [INF] * len(self.ids)
        waiting = [len(p) for p in self.pre]
        heap = [(0.0, self.ids[a]) for a in state if a in self.ids]
        for _, i in heap:
            cost[i] = 0.0
        heapq.heapify(heap)
        todo = set(self.goal)
        fired = [k for k, n in enumerate(waiting) if n == 0]
        for k in fired:
            self._fire(k, 0.0, cost, heap)
        while heap and todo:
            c, i = heapq.heappop(heap)
            if c > cost[i]:
                continue
            todo.discard(i)
            for k in self.users[i]:
                waiting[k] -= 1
                if waiting[k] == 0:
                    self._fire(k, c, cost, heap)
        return max((cost[g] for g in self.goal), default=0.0)

    def _fire(self, k: int, c: float, cost: list[float], heap: list) -> None:
        for j in self.add[k]:
            if c + 1 < cost[j]:
                cost[j] = c + 1
                heapq.heappush(heap, (c + 1, j))


def _all_outcomes(task: Any, ga: Any) -> list:
    """Every outcome of a ground action with the conditions of ``when`` taken as true."""
    return task._effect(_unconditional(ga.effect), frozenset(), {})


def _unconditional(e: Any) -> Any:
    if isinstance(e, When):
        return _unconditional(e.effect)
    if isinstance(e, AndEffect):
        return AndEffect(tuple(_unconditional(x) for x in e.effects))
    if isinstance(e, Probabilistic):
        return Probabilistic(tuple((p, _unconditional(x)) for p, x in e.branches))
    return e


class LrtdpPlanner:
    """Labeled RTDP on the PPDDL task, replanning (with kept values) at every step."""

    name = "lrtdp"
    NEEDS = frozenset({"ppddl"})
    OPTIONS = (
        PlannerOption("trials", positive(int, most=10_000_000), 10_000, "most trials per decision"),
        PlannerOption("seconds", positive(float), 10.0, "most seconds of trials per decision"),
        PlannerOption("epsilon", positive(float), 1e-3, "residual below which a state's value has converged"),
        PlannerOption("dead_end_cost", positive(float), 500.0, "cost of a state the goal cannot be reached from"),
        PlannerOption("depth", positive(int, most=1_000_000), 1000, "longest trial, in steps"),
    )

    def __init__(self, model: PlanningModel, options: Mapping[str, Any], seed: int):
        from groundsym.ppddl.simulate import Task

        self.opts = parse_planner_options(self.name, self.OPTIONS, options)
        domain, problem = model.ppddl
        if problem is None or problem.goal is None:
            raise UserError("--planner lrtdp: the problem has no goal to plan for")
        if model.goal is None:
            raise UserError("--planner lrtdp: only goals that are conjunctions of literals can be planned for")
        self.task = Task(domain, problem)
        self.goal = model.goal
        self.h = Relaxation(self.task, frozenset(l.atom for l in model.goal.literals if l.positive))
        self.dead = float(self.opts["dead_end_cost"])
        self.rng = np.random.default_rng(seed)
        self.value: dict[frozenset, float] = {}
        self.solved: set[frozenset] = set()
        self.dead_ends: set[frozenset] = set()       # proven: the goal cannot be reached from them
        self._succ: dict[frozenset, list[tuple[Atom, list[tuple[float, frozenset]]]]] = {}

    # ------------------------------------------------------------------ the model
    def successors(self, s: frozenset) -> list[tuple[Atom, list[tuple[float, frozenset]]]]:
        """(ground action, [(probability, next state)]) for every applicable ground action (sorted)."""
        if s not in self._succ:
            out = []
            for a in self.task.applicable_actions(s):
                merged: dict[frozenset, float] = {}
                for p, adds, dels, _ in self.task.ground(a).deltas(self.task, s):
                    if p > 0:
                        s2 = (s - dels) | adds
                        merged[s2] = merged.get(s2, 0.0) + p
                out.append((a, list(merged.items())))
            self._succ[s] = [(a, [(p, x) for x, p in d]) for a, d in out]
        return self._succ[s]

    def v(self, s: frozenset) -> float:
        if s not in self.value:
            if self.goal.holds(s):
                self.value[s] = 0.0
                self.solved.add(s)
            else:
                h = self.h(s)
                if h == INF or not self.successors(s):
                    self.value[s] = self.dead
                    self.solved.add(s)
                    self.dead_ends.add(s)
                else:
                    self.value[s] = min(h, self.dead)
        return self.value[s]

    def q(self, dist: list[tuple[float, frozenset]]) -> float:
        return 1.0 + sum(p * self.v(s2) for p, s2 in dist)

    def greedy(self, s: frozenset) -> tuple[Atom | None, float]:
        """The action of least Q (ties: the first in sorted order) and that Q, capped at the dead-end cost."""
        best, best_q = None, INF
        for a, dist in self.successors(s):
            qa = self.q(dist)
            if qa < best_q - 1e-12:
                best, best_q = a, qa
        return best, min(best_q, self.dead)

    def residual(self, s: frozenset) -> float:
        return abs(self.greedy(s)[1] - self.v(s))

    # ------------------------------------------------------------------ LRTDP
    def trial(self, s: frozenset) -> None:
        visited = []
        while s not in self.solved and len(visited) < self.opts["depth"]:
            self.v(s)
            if s in self.solved:
                break
            visited.append(s)
            a, qa = self.greedy(s)
            self.value[s] = qa
            dist = dict(self.successors(s))[a]
            k = int(self.rng.choice(len(dist), p=np.array([p for p, _ in dist]) / sum(p for p, _ in dist)))
            s = dist[k][1]
        while visited:
            if not self.check_solved(visited.pop()):
                break

    def check_solved(self, s: frozenset) -> bool:
        ok, open_, closed = True, [], []
        seen = {s}
        if s not in self.solved:
            open_.append(s)
        while open_:
            x = open_.pop()
            closed.append(x)
            self.v(x)
            if x in self.solved:
                continue
            if self.residual(x) > self.opts["epsilon"]:
                ok = False
                continue
            a, _ = self.greedy(x)
            for _, y in dict(self.successors(x))[a]:
                if y not in self.solved and y not in seen:
                    seen.add(y)
                    open_.append(y)
        if ok:
            self.solved.update(closed)
        else:
            for x in reversed(closed):
                if x not in self.solved:
                    self.value[x] = self.greedy(x)[1]
        return ok

    def choose(self, observation: Observation) -> Decision:
        s = observation.state
        start, trials = time.perf_counter(), 0
        while (s not in self.solved and trials < self.opts["trials"]
               and time.perf_counter() - start < self.opts["seconds"]):
            self.trial(s)
            trials += 1
        a, qa = self.greedy(s)
        info = {"trials": trials, "solved": s in self.solved, "expected_cost": qa,
                "seconds": time.perf_counter() - start, "states": len(self.value)}
        if a is None or s in self.dead_ends:      # proven: the goal cannot be reached from here
            return Decision(observation.actions[0], float("nan"), {**info, "dead_end": True})
        name, n = self.task._primitive_of[a.predicate]
        return Decision(Atom(name, a.args[:n]), float("nan"), info)

    def observe(self, action: Atom, observation: Observation) -> None:
        """Values and labels are kept; the next :meth:`choose` starts from the new state."""
