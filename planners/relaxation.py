"""Delete-relaxation heuristics (h_max, h_add) of the all-outcomes determinisation of a PPDDL task.

Why: LRTDP needs a cost-to-goal estimate for the states it has not yet valued. Both heuristics
read the task the same way: every outcome of a ground action is an action of its own, delete
effects, negative and non-conjunctive preconditions and the conditions of ``when`` are ignored,
and static atoms (no action changes them) are pruned (Bonet & Geffner 2001).

- ``h_max`` (the cost of the dearest goal atom, each atom costing its dearest precondition plus
  one) is admissible: no real trajectory reaches the goal in fewer steps than the relaxation
  needs. It is weak where goals are many independent atoms (blocks worlds).
- ``h_add`` (sums instead of maxima) is informative but NOT admissible: it counts an action that
  serves two goal atoms twice. LRTDP with it still converges, to values that may overestimate.

Both are infinite exactly when the goal is unreachable even in the relaxation, so either proves
dead ends. States are valued in batches (all new successors of a state at once) by a
Bellman-Ford fixpoint on numpy arrays: an action's cost is the max (or sum) of its precondition
atoms' costs, an atom's cost the least over its achievers, until nothing changes.
"""

from __future__ import annotations

from typing import Any, Iterable, Sequence

import numpy as np

from groundsym.logic import Atom
from groundsym.ppddl.ast import AndEffect, Probabilistic, When

INF = float("inf")
HEURISTICS = ("hmax", "hadd")


class Relaxation:
    """h_max or h_add over the ground actions of a task, with preconditions and adds as atom ids."""

    def __init__(self, task: Any, goal_atoms: frozenset, kind: str = "hmax") -> None:
        if kind not in HEURISTICS:
            raise ValueError(f"heuristic must be one of {', '.join(HEURISTICS)}")
        self.kind = kind
        pres, adds = _relaxed_actions(task)
        atoms = sorted({a for p in pres for a in p} | {a for d in adds for a in d} | set(goal_atoms))
        self.ids = {a: i for i, a in enumerate(atoms)}
        n = len(atoms)
        self.n = n
        self.reachable_goal = all(a in self.ids for a in goal_atoms)
        self.goal = np.array([self.ids[a] for a in goal_atoms], dtype=np.intp)
        # preconditions padded with atom n (cost 0 always); achievers padded with action A (cost inf)
        width = max([len(p) for p in pres] + [1])
        self.pre = np.full((len(pres), width), n, dtype=np.intp)
        for k, p in enumerate(pres):
            self.pre[k, :len(p)] = [self.ids[a] for a in p]
        achievers: list[list[int]] = [[] for _ in range(n)]
        for k, d in enumerate(adds):
            for a in d:
                achievers[self.ids[a]].append(k)
        width = max([len(x) for x in achievers] + [1])
        self.ach = np.full((n, width), len(pres), dtype=np.intp)
        for j, ks in enumerate(achievers):
            self.ach[j, :len(ks)] = ks

    def __call__(self, state: frozenset) -> float:
        return float(self.batch([state])[0])

    def batch(self, states: Sequence[frozenset]) -> np.ndarray:
        """The heuristic of every state in ``states`` (inf where the goal is relaxed-unreachable)."""
        if not states:
            return np.zeros(0)
        if not self.reachable_goal:
            return np.full(len(states), INF)
        cost = np.full((len(states), self.n + 1), INF)
        cost[:, self.n] = 0.0
        rows, cols = self._true_atoms(states)
        cost[rows, cols] = 0.0
        combine = np.max if self.kind == "hmax" else np.sum
        inf_col = np.full((len(states), 1), INF)
        for _ in range(self.n + 1):
            act = np.concatenate([combine(cost[:, self.pre], axis=2), inf_col], axis=1)
            new = np.minimum(cost[:, :self.n], act[:, self.ach].min(axis=2) + 1.0)
            if np.array_equal(new, cost[:, :self.n]):
                break
            cost[:, :self.n] = new
        goal = cost[:, self.goal]
        return goal.max(axis=1, initial=0.0) if self.kind == "hmax" else goal.sum(axis=1)

    def _true_atoms(self, states: Sequence[frozenset]) -> tuple[list[int], list[int]]:
        rows: list[int] = []
        cols: list[int] = []
        ids = self.ids
        for r, s in enumerate(states):
            found = [ids[a] for a in s if a in ids]
            rows.extend([r] * len(found))
            cols.extend(found)
        return rows, cols


def _relaxed_actions(task: Any) -> tuple[list[list[Atom]], list[list[Atom]]]:
    """(precondition atoms, added atoms) per ground action that adds something and whose static
    precondition atoms hold initially (static atoms hold in every reachable state as at the start)."""
    triggered, always = task._trigger_index()
    ground = [g for gs in triggered.values() for g in gs] + list(always)
    effects = [_all_outcomes(task, ga) for ga in ground]
    changing = {a.predicate for outs in effects for _, ad, de, _ in outs for a in ad | de}
    init = task.initial_state
    pres: list[list[Atom]] = []
    adds: list[list[Atom]] = []
    for ga, outs in zip(ground, effects):
        added = {a for _, ad, _, _ in outs for a in ad}
        static = {a for a in ga.pos if a.predicate not in changing}
        if added and static <= init:
            pres.append(sorted(ga.pos - static))
            adds.append(sorted(added))
    return pres, adds


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


def relaxed_goal_atoms(literals: Iterable[Any]) -> frozenset:
    """The positive atoms of a goal (negative goal literals are relaxed away)."""
    return frozenset(l.atom for l in literals if l.positive)
