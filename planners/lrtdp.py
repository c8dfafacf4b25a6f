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

The heuristic (``heuristic=``, :mod:`planners.relaxation`) is h_max of the all-outcomes
determinisation by default (admissible: the solved values are optimal), or h_add (not admissible,
far better informed where the goal is many atoms, as in blocks worlds: h_max's weak values make
trials wander for minutes there). Where either is infinite the goal is unreachable in the domain,
so the state is a proven dead end.

Per decision, trials run from the current state until it is labelled solved (its greedy policy
has converged to within ``epsilon`` on every state it reaches) or the budget (``trials`` or
``seconds``) runs out; the greedy action of the values so far is then run. Successor sampling in
trials uses the planner's seed.

The search (states, values, labels, successors) is kept across the decisions of an episode and,
with ``share=1`` (the default), across the episodes of one process on the same problem: a table
is keyed by the domain's and problem's printed text and every option that changes values
(heuristic, dead-end cost, epsilon), and the 4 most recent tables are kept. As in the IPPC,
where a planner ran 30 rounds of one problem, later episodes start from what earlier ones
learned. ``share=0`` gives every episode a fresh table.

States are interned: each distinct state is one int, so values, labels and successor lists are
list lookups, and a state's frozenset is hashed once, when it is first met.
"""

from __future__ import annotations

import hashlib
import time
from collections import OrderedDict
from typing import Any, Mapping

import numpy as np

from groundsym.errors import UserError
from groundsym.logic import Atom
from groundsym.options import Option, one_of, parse_options, positive
from groundsym.planner import Decision, Observation, PlanningModel

from .relaxation import HEURISTICS, INF, Relaxation, relaxed_goal_atoms

_SHARED: "OrderedDict[tuple, Search]" = OrderedDict()
_KEEP = 4          # search tables kept for sharing across episodes (most recently used)


def _flag(text: str) -> bool:
    if text not in ("0", "1"):
        raise ValueError("expected 0 or 1")
    return text == "1"


class Search:
    """What LRTDP learns about one problem: interned states with values, labels and successors.

    State ``i`` is ``states[i]``; ``succ[i]`` (filled when the state is expanded) lists
    ``(ground action, probabilities, successor ids)`` for every applicable ground action, sorted."""

    def __init__(self, task: Any, goal: Any, h: Relaxation, dead: float) -> None:
        self.task, self.goal, self.h, self.dead = task, goal, h, dead
        self.index: dict[frozenset, int] = {}
        self.states: list[frozenset] = []
        self.value: list[float] = []
        self.solved: list[bool] = []
        self.dead_end: list[bool] = []
        self.actions: list[list[Atom]] = []
        self.succ: list[list[tuple[Atom, list[float], list[int]]] | None] = []

    def intern(self, states: list[frozenset]) -> list[int]:
        """Ids of ``states``; new ones are valued in one batch (goal 0, proven dead ends ``dead``, else h)."""
        new = list(dict.fromkeys(s for s in states if s not in self.index))
        if new:
            open_ = [s for s in new if not self.goal.holds(s)]
            hs = dict(zip(open_, self.h.batch(open_)))
            for s in new:
                self._add(s, hs.get(s, 0.0))
        return [self.index[s] for s in states]

    def _add(self, s: frozenset, h: float) -> None:
        i = len(self.states)
        self.index[s] = i
        self.states.append(s)
        goal = self.goal.holds(s)
        acts = [] if goal or h == INF else self.task.applicable_actions(s)
        dead = not goal and not acts
        self.value.append(0.0 if goal else self.dead if dead else min(float(h), self.dead))
        self.solved.append(goal or dead)
        self.dead_end.append(dead)
        self.actions.append(acts)
        self.succ.append(None)

    def successors(self, i: int) -> list[tuple[Atom, list[float], list[int]]]:
        if self.succ[i] is None:
            s, task = self.states[i], self.task
            rows: list[tuple[Atom, list[float], list[frozenset]]] = []
            for a in self.actions[i]:
                merged: dict[frozenset, float] = {}
                for p, adds, dels, _ in task.ground(a).deltas(task, s):
                    if p > 0:
                        s2 = (s - dels) | adds
                        merged[s2] = merged.get(s2, 0.0) + p
                rows.append((a, list(merged.values()), list(merged)))
            ids = self.intern([x for _, _, xs in rows for x in xs])
            out, k = [], 0
            for a, ps, xs in rows:
                out.append((a, ps, ids[k:k + len(xs)]))
                k += len(xs)
            self.succ[i] = out
        return self.succ[i]

    def greedy(self, i: int) -> tuple[int, float]:
        """The index (into ``successors(i)``) of the action of least Q (ties: the first) and that Q,
        capped at the dead-end cost; (-1, dead) without actions."""
        value = self.value
        best, best_q = -1, INF
        for k, (_, ps, ids) in enumerate(self.successors(i)):
            q = 1.0
            for p, j in zip(ps, ids):
                q += p * value[j]
            if q < best_q - 1e-12:
                best, best_q = k, q
        return best, min(best_q, self.dead)


def _search_for(task: Any, model: PlanningModel, opts: Mapping[str, Any], share: bool) -> Search:
    """A fresh search table, or the one kept for the same problem and value-changing options."""
    domain, problem = model.ppddl
    goal_atoms = relaxed_goal_atoms(model.goal.literals)
    key = None
    if share:
        text = hashlib.sha256((str(domain) + "\n" + str(problem)).encode()).hexdigest()
        key = (text, opts["heuristic"], float(opts["dead_end_cost"]), float(opts["epsilon"]))
        if key in _SHARED:
            _SHARED.move_to_end(key)
            return _SHARED[key]
    found = Search(task, model.goal, Relaxation(task, goal_atoms, opts["heuristic"]), float(opts["dead_end_cost"]))
    if key is not None:
        _SHARED[key] = found
        while len(_SHARED) > _KEEP:
            _SHARED.popitem(last=False)
    return found


class LrtdpPlanner:
    """Labeled RTDP on the PPDDL task, replanning (with kept values) at every step."""

    name = "lrtdp"
    NEEDS = frozenset({"ppddl"})
    OPTIONS = (
        Option("trials", positive(int, most=10_000_000), 10_000, "most trials per decision"),
        Option("seconds", positive(float), 10.0, "most seconds of trials per decision"),
        Option("epsilon", positive(float), 1e-3, "residual below which a state's value has converged"),
        Option("dead_end_cost", positive(float), 500.0, "cost of a state the goal cannot be reached from"),
        Option("depth", positive(int, most=1_000_000), 1000, "longest trial, in steps"),
        Option("heuristic", one_of(*HEURISTICS), "hmax", "hmax (admissible) or hadd (informed, not admissible)"),
        Option("share", _flag, "1", "1: keep the values across episodes of the same problem"),
    )

    def __init__(self, model: PlanningModel, options: Mapping[str, Any], seed: int):
        from groundsym.ppddl.simulate import Task

        self.opts = parse_options("--planner-opt", "planner", self.name, self.OPTIONS, options)
        domain, problem = model.ppddl
        if problem is None or problem.goal is None:
            raise UserError("--planner lrtdp: the problem has no goal to plan for")
        if model.goal is None:
            raise UserError("--planner lrtdp: only goals that are conjunctions of literals can be planned for")
        share = self.opts["share"]
        share = share if isinstance(share, bool) else _flag(str(share))
        self.search = _search_for(Task(domain, problem), model, self.opts, share)
        self.task, self.h, self.dead = self.search.task, self.search.h, self.search.dead
        self.rng = np.random.default_rng(seed)

    # ------------------------------------------------------------------ views by state
    def value_of(self, s: frozenset) -> float:
        return self.search.value[self.search.intern([s])[0]]

    def is_solved(self, s: frozenset) -> bool:
        return self.search.solved[self.search.intern([s])[0]]

    # ------------------------------------------------------------------ LRTDP
    def trial(self, i: int, deadline: float = float("inf")) -> None:
        """One trial from state ``i``; its walk stops at ``deadline`` (a ``perf_counter`` time), so
        a decision keeps its budget even where trials are long (h_max on blocks worlds)."""
        S, visited = self.search, []
        while not S.solved[i] and len(visited) < self.opts["depth"] and time.perf_counter() < deadline:
            visited.append(i)
            k, q = S.greedy(i)
            S.value[i] = q
            _, ps, ids = S.successors(i)[k]
            r, acc, pick = self.rng.random() * sum(ps), 0.0, ids[-1]
            for p, j in zip(ps, ids):
                acc += p
                if r < acc:
                    pick = j
                    break
            i = pick
        while visited:
            if not self.check_solved(visited.pop()):
                break

    def check_solved(self, i: int) -> bool:
        S, eps = self.search, self.opts["epsilon"]
        ok, open_, closed, seen = True, [], [], {i}
        if not S.solved[i]:
            open_.append(i)
        while open_:
            x = open_.pop()
            closed.append(x)
            if S.solved[x]:
                continue
            k, q = S.greedy(x)
            if abs(q - S.value[x]) > eps:
                ok = False
                continue
            for y in S.successors(x)[k][2]:
                if not S.solved[y] and y not in seen:
                    seen.add(y)
                    open_.append(y)
        if ok:
            for x in closed:
                S.solved[x] = True
        else:
            for x in reversed(closed):
                if not S.solved[x]:
                    S.value[x] = S.greedy(x)[1]
        return ok

    def choose(self, observation: Observation) -> Decision:
        S = self.search
        i = S.intern([observation.state])[0]
        start, trials = time.perf_counter(), 0
        while (not S.solved[i] and trials < self.opts["trials"]
               and time.perf_counter() - start < self.opts["seconds"]):
            self.trial(i, start + self.opts["seconds"])
            trials += 1
        k, q = S.greedy(i) if not S.dead_end[i] else (-1, S.dead)
        info = {"trials": trials, "solved": S.solved[i], "expected_cost": q,
                "seconds": time.perf_counter() - start, "states": len(S.states)}
        if k < 0:      # proven: the goal cannot be reached from here
            return Decision(observation.actions[0], float("nan"), {**info, "dead_end": True})
        a = S.successors(i)[k][0]
        name, n = self.task._primitive_of[a.predicate]
        return Decision(Atom(name, a.args[:n]), float("nan"), info)

    def observe(self, action: Atom, observation: Observation) -> None:
        """Values and labels are kept; the next :meth:`choose` starts from the new state."""
