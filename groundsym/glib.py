"""Goal-literal babbling (GLIB): explore by planning, with the model learned so far, to a novel goal.

Chitnis, Silver, Tenenbaum, Lozano-Perez & Kaelbling (2021), *GLIB: Efficient Exploration for
Relational Model-Based Reinforcement Learning via Goal-Literal Babbling* (AAAI). Random primitives
rarely reach the states a model is worst at (in the tower cell: a release over a tower of two or
three, which is where towers topple), and counting experience per rule (``groundsym.explore``,
Lang, Toussaint & Kersting 2012) only chooses among the primitives one step away. GLIB instead
*babbles a goal*: a small conjunction of lifted literals with an action (GLIB-L, the lifted variant),
novel when that action has never (here: fewer than ``known`` times) been run in a state where the
conjunction holds; then it plans to a grounding of the conjunction with the current model and runs
the action there. When the planner finds no plan the step is a random primitive, as in the paper.

What is implemented, and how it maps onto this package:

* goals (:func:`candidate_goals`) are an action of the sim with its arguments as variables and one or
  two positive literals of the learned predicates over those variables and at most ``extra`` more
  (each extra variable linked to the action's through the literals), up to renaming: GLIB-L's
  "conjunction of at most 2 literals" over the learned vocabulary;
* novelty (:func:`goal_counts`) is counted on all transitions so far and grows as the round runs;
* planning is any planner found by name (``groundsym.registry``; PRADA by default, Lang & Toussaint
  2010) on the round's NID rules, with the grounded conjunction as a PPDDL-style goal; a goal counts
  as *planned* while the best sequence's expected value beats doing nothing by ``min_value``;
* a goal that holds for some grounding now is run at once (no planning), the cheapest novelty;
  otherwise the grounding is drawn uniformly, up to ``tries`` goals per step before falling back.

Every choice draws from the trace's Generator, and each planner's seed from it too: the same seed
gives the same traces.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations, permutations
from typing import Any, Callable, Iterator, Mapping, Sequence

import numpy as np

from .errors import UserError
from .logic import Atom, Literal, parse_atom
from .options import parse_options
from .planner import Decision, Goal, Observation, PlanningModel, make_planner
from .registry import get_planner_class, planner_names
from .rules.sample import sample_successor
from .threads import decide
from .traces import Trace

#: A goal's key: the action with its arguments as variables and its sorted literals.
GoalKey = tuple[Atom, tuple[Atom, ...]]


def action_variables(arity: int) -> tuple[str, ...]:
    return tuple(f"?a{i}" for i in range(arity))


def extra_variables(extra: int) -> tuple[str, ...]:
    return tuple(f"?e{i}" for i in range(extra))


def canonical(action: Atom, literals: Sequence[Atom], extra: int) -> GoalKey:
    """The goal up to renaming of its extra variables (the smallest of its sorted renamings)."""
    names = extra_variables(extra)
    best = None
    for perm in permutations(names):
        rename = dict(zip(names, perm))
        key = tuple(sorted(a.substitute(rename) for a in literals))
        best = key if best is None or key < best else best
    return action, best


def candidate_goals(primitives: Mapping[str, int], predicates: Mapping[str, int], size: int = 2,
                    extra: int = 2) -> list[GoalKey]:
    """Every lifted goal: an action and 1..``size`` distinct positive literals, up to renaming.

    Variables within a literal are distinct (the learned binary symbols are over pairs of objects).
    A literal need not share a variable with the action: ``inhand(?e0)`` says the hand is full,
    which is what a release over a tower needs."""
    goals: set[GoalKey] = set()
    for name, arity in sorted(primitives.items()):
        action = Atom(name, action_variables(arity))
        names = action.args + extra_variables(extra)
        literals = [Atom(p, args) for p, n in sorted(predicates.items()) for args in permutations(names, n)]
        for k in range(1, size + 1):
            for conj in combinations(literals, k):
                goals.add(canonical(action, conj, extra))
    return sorted(goals)


def bindings(goal: GoalKey, action: Atom, objects: Sequence[str]) -> Iterator[dict[str, str]]:
    """The injective bindings of the goal's variables that run it as ``action``."""
    lifted, literals = goal
    base = dict(zip(lifted.args, action.args))
    free = sorted({v for a in literals for v in a.args} - set(base))
    others = [o for o in objects if o not in action.args]
    for chosen in permutations(others, len(free)):
        yield {**base, **dict(zip(free, chosen))}


def holds(goal: GoalKey, state: frozenset, action: Atom, objects: Sequence[str]) -> bool:
    """Whether ``action`` in ``state`` runs the goal: its conjunction holds for some binding."""
    if goal[0].predicate != action.predicate or goal[0].arity != action.arity:
        return False
    return any(all(a.substitute(b) in state for a in goal[1]) for b in bindings(goal, action, objects))


def goals_run(goals: Sequence[GoalKey], state: frozenset, action: Atom, objects: Sequence[str]) -> list[GoalKey]:
    return [g for g in goals if holds(g, state, action, objects)]


def goal_counts(goals: Sequence[GoalKey], transitions: Iterator[tuple[frozenset, Atom, Sequence[str]]]) -> dict:
    """How many of the transitions ran each goal (absent: never)."""
    counts: dict = {}
    for state, action, objects in transitions:
        for g in goals_run(goals, state, action, objects):
            counts[g] = counts.get(g, 0) + 1
    return counts


@dataclass(frozen=True)
class GlibOptions:
    """GLIB's own options: goal size, extra variables, novelty threshold, planner and its options."""

    size: int = 2
    extra: int = 2
    known: int = 1
    tries: int = 8
    give_up: int = 3
    max_steps: int = 6
    min_value: float = 1e-3
    rollouts: int = 20
    min_reach: float = 0.1
    random_share: float = 0.0
    planner: str = "prada"
    planner_opts: tuple[tuple[str, str], ...] = (("samples", "200"), ("retries", "1"))


@dataclass
class GlibModel:
    """What a round babbles with: the round's model, its candidate goals and how often each ran."""

    symbols: Any
    rules: Any
    goals: list[GoalKey]
    counts: dict
    primitives: dict[str, int]
    gamma: float = 0.9
    failures: dict = field(default_factory=dict)     # goal -> babbles without a plan, this round
    stats: dict = field(default_factory=lambda: {"here": 0, "babbled": 0, "planned": 0, "reached": 0,
                                                               "fallback": 0})

    def novel(self, known: int, give_up: int) -> list[GoalKey]:
        """The goals run fewer than ``known`` times; when every goal has been run that often, the
        least-run ones (so babbling goes on where GLIB's novelty runs out in a small vocabulary).
        A goal the planner found no plan for ``give_up`` times this round is left out: many
        conjunctions of learned symbols no state can hold, and they would stay novel for ever."""
        goals = [g for g in self.goals if self.failures.get(g, 0) < give_up]
        if not goals:
            return []
        counts = [self.counts.get(g, 0) for g in goals]
        cut = known if min(counts) < known else min(counts) + 1
        return [g for g, n in zip(goals, counts) if n < cut]

    def record(self, state: frozenset, action: Atom, objects: Sequence[str]) -> None:
        for g in goals_run(self.goals, state, action, objects):
            self.counts[g] = self.counts.get(g, 0) + 1

    def planning_model(self, goal: Goal) -> PlanningModel:
        return PlanningModel(self.primitives, predicates=dict(self.symbols.predicates), symbols=self.symbols,
                             rules=self.rules, goal=goal, gamma=self.gamma)


@dataclass
class Pursuit:
    """A babbled goal being pursued: its ground literals, the action to run there, the planner."""

    goal: Goal
    action: Atom
    planner: Any
    steps: int = 0
    first: Decision | None = None


def planned(decision: Decision, min_value: float) -> bool:
    """The planner found a sequence that reaches the goal with some probability (beats doing nothing)."""
    value = float(decision.expected_value)
    noop = float(decision.info.get("noop_value", 0.0) or 0.0)
    return np.isfinite(value) and value - noop > min_value


def plan_reach(rules: Any, state: frozenset, objects: Sequence[str], plan: Sequence[Atom], goal: Goal,
               rng: np.random.Generator, rollouts: int) -> float:
    """The share of ``rollouts`` runs of ``plan`` in the rules (outcomes drawn jointly) that reach ``goal``.

    PRADA scores a sequence on per-atom marginals (the factored frontier), so a conjunction no
    state can hold, ``inhand(a)`` with ``on(a, b)`` say, still gets a positive value from two
    marginals that are each likely at some step; sampling whole successor states does not."""
    hits = 0
    for _ in range(rollouts):
        s = state
        for action in plan:
            s = sample_successor(rules, s, action, rng, objects)
            if goal.holds(s):
                hits += 1
                break
    return hits / max(rollouts, 1)


def verified(model: GlibModel, opts: GlibOptions, obs: Observation, decision: Decision, goal: Goal,
             rng: np.random.Generator) -> bool:
    """A plan, checked by sampling when the planner says which sequence it means (``info['plan']``)."""
    if not planned(decision, opts.min_value):
        return False
    plan = [parse_atom(a) for a in decision.info.get("plan", ())]
    if not plan:
        return True
    return plan_reach(model.rules, obs.state, obs.objects, plan, goal, rng, opts.rollouts) >= opts.min_reach


def babble(model: GlibModel, opts: GlibOptions, obs: Observation, rng: np.random.Generator) -> Pursuit | None:
    """A novel goal to pursue from ``obs`` (one that holds now if any does), or None: no novel goal
    or no plan to one in ``opts.tries`` draws."""
    novel = model.novel(opts.known, opts.give_up)
    if not novel:
        return None
    here = [(g, a) for g in novel for a in obs.actions if holds(g, obs.state, a, obs.objects)]
    if here:
        g, a = sorted(here)[int(rng.integers(len(here)))]
        model.stats["here"] += 1
        return Pursuit(Goal(()), a, None)
    for _ in range(opts.tries):
        g = novel[int(rng.integers(len(novel)))]
        lifted, literals = g
        mine = [a for a in obs.actions if a.predicate == lifted.predicate and a.arity == lifted.arity]
        if not mine:
            continue
        action = mine[int(rng.integers(len(mine)))]
        choices = list(bindings(g, action, obs.objects))
        if not choices:
            continue
        b = choices[int(rng.integers(len(choices)))]
        goal = Goal(tuple(Literal(a.substitute(b)) for a in literals))
        planner = make_planner(opts.planner, model.planning_model(goal), dict(opts.planner_opts),
                               int(rng.integers(2 ** 31)))
        decision = decide(planner, obs)
        model.stats["babbled"] += 1
        if verified(model, opts, obs, decision, goal, rng):
            model.stats["planned"] += 1
            return Pursuit(goal, action, planner, first=decision)
        model.failures[g] = model.failures.get(g, 0) + 1
    return None


def next_action(model: GlibModel, opts: GlibOptions, pursuit: Pursuit | None, obs: Observation,
                rng: np.random.Generator) -> tuple[Atom, Pursuit | None]:
    """The primitive to run now and the pursuit still going after it."""
    if pursuit is not None and pursuit.goal.holds(obs.state):
        model.stats["reached"] += 1
        return pursuit.action, None
    if pursuit is not None and pursuit.steps >= opts.max_steps:
        pursuit = None                      # not reached in time: babble afresh
    if pursuit is None and opts.random_share and rng.random() < opts.random_share:
        model.stats["random"] = model.stats.get("random", 0) + 1      # an epsilon-greedy mixture
        return obs.actions[int(rng.integers(len(obs.actions)))], None
    if pursuit is None:
        pursuit = babble(model, opts, obs, rng)
    if pursuit is None:
        model.stats["fallback"] += 1
        return obs.actions[int(rng.integers(len(obs.actions)))], None
    if pursuit.planner is None:             # the goal holds now: run its action
        return pursuit.action, None
    decision = pursuit.first or decide(pursuit.planner, Observation(obs.objects, obs.actions, obs.state, obs.scene,
                                                                   pursuit.steps, obs.steps_left))
    pursuit.first = None
    pursuit.steps += 1
    return decision.action, pursuit if planned(decision, opts.min_value) else None


def glib_trace(sim: Any, model: GlibModel, opts: GlibOptions, length: int, reset_seed: int,
               rng: np.random.Generator, on_step: Callable[[], None] | None = None) -> Trace:
    """One trace from ``reset_seed`` whose primitives pursue babbled goals; counts grow as it goes."""
    scenes = [sim.reset(reset_seed)]
    actions: list[Atom] = []
    pursuit: Pursuit | None = None
    for t in range(length):
        objects = tuple(scenes[-1].objects)
        state = model.symbols.abstract_scene(scenes[-1])
        obs = Observation(objects, tuple(sim.actions()), state, scenes[-1], t, length - t)
        action, pursuit = next_action(model, opts, pursuit, obs, rng)
        model.record(state, action, objects)
        actions.append(action)
        scenes.append(sim.step(action))
        if on_step is not None:
            on_step()
    return Trace(scenes[0].objects, scenes, actions)


def symbolic_transitions(symbols: Any, ds: Any) -> Iterator[tuple[frozenset, Atom, tuple[str, ...]]]:
    for tr in symbols.to_symbolic_dataset(ds).traces:
        for s, a, _ in tr.transitions():
            yield s, a, tuple(tr.objects)


def glib_model(symbols: Any, rules: Any, ds: Any, opts: GlibOptions, gamma: float = 0.9) -> GlibModel:
    """The round's model with its candidate goals counted on all traces so far."""
    goals = candidate_goals(dict(ds.primitives), dict(symbols.predicates), opts.size, opts.extra)
    return GlibModel(symbols, rules, goals, goal_counts(goals, symbolic_transitions(symbols, ds)),
                     dict(ds.primitives), gamma)


def planner_check(opts: GlibOptions) -> None:
    """The planner exists, takes the options and needs nothing a goal and rules do not give: checked
    before any work starts."""
    if opts.planner.split(":", 1)[0] not in planner_names():
        raise UserError(f"--explore-planner {opts.planner}: unknown planner (available: {', '.join(planner_names())})")
    cls = get_planner_class(opts.planner)
    parse_options("--explore-planner-opt", "planner", opts.planner, tuple(getattr(cls, "OPTIONS", ())),
                  dict(opts.planner_opts))
    missing = set(getattr(cls, "NEEDS", frozenset())) - {"rules", "reward", "symbols"}
    if missing:
        raise UserError(f"--explore-planner {opts.planner}: needs {', '.join(sorted(missing))}, which "
                        f"exploration does not give (it plans on the round's rules to a goal)")

