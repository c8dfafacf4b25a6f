"""PPDDL semantics: grounding, applicability, outcome distributions and random traces.

Why: any PPDDL domain becomes data (ground truth for teaching and for testing rule learning), and
a domain can be scored as a model (``P(s' | s, a)``). Semantics follow PPDDL 1.0 (Younes et al.):
conditions of ``when`` are read in the state before the action; independent ``probabilistic``
blocks combine as a product; the mass a ``probabilistic`` leaves unassigned means no change;
deletes apply before adds; ``(increase (reward) n)`` adds to the step's reward.

Robot primitives: a domain exported from NID rules names its actions ``<primitive>_r<k>`` and
carries deictic references as extra parameters (see :mod:`groundsym.ppddl.from_rules`). A
:class:`Task` maps every PPDDL action onto the primitive a robot would run, so simulated traces
hold ``(openHandOver o2)`` rather than ``(openHandOver_r1 o2 o5)``. For ordinary domains the
primitive is the action itself. A primitive with no applicable PPDDL action changes nothing.

Why one module of about 470 lines: :class:`Task` is the semantics of one grounded problem, and
its caches (ground actions, the trigger index, outcome distributions) serve every query; the pure
grounding of formulas and effects is apart, in :mod:`groundsym.ppddl.ground`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cmp_to_key
from itertools import product
from typing import Iterable, Mapping, Sequence

import numpy as np

from ..errors import UserError
from ..logic import Atom, Literal
from ..symbolic_traces import SymbolicDataset, SymbolicTrace
from .ast import (OBJECT, Action, And, AndEffect, Domain, Effect, Exists, Forall, ForallEffect, Formula, Imply, Not,
                  Or, Probabilistic, Problem, RewardEffect, Typed, When)
from .ground import (FALSE, NOTHING, Outcome, distinct_pairs, effect_literals, ground_effect, ground_formula,
                     ground_literals, has_when, is_a, product_of)
from .rule_actions import primitive_of



@dataclass(frozen=True)
class Successor:
    """One possible result of a ground action: probability, next state and the reward effects."""

    prob: float
    state: frozenset
    reward: float

    def __iter__(self):  # unpacks as (prob, state, reward)
        return iter((self.prob, self.state, self.reward))


class Task:
    """A domain grounded on a set of typed objects (a problem's, or given)."""

    def __init__(self, domain: Domain, problem_or_objects: Problem | Mapping[str, str] | Iterable[str]) -> None:
        self.domain = domain
        self.problem = problem_or_objects if isinstance(problem_or_objects, Problem) else None
        if self.problem is not None:
            given = {o.name: o.type for o in self.problem.objects}
        elif isinstance(problem_or_objects, Mapping):
            given = dict(problem_or_objects)
        else:
            given = {o: OBJECT for o in problem_or_objects}
        self.objects: dict[str, str] = {**{c.name: c.type for c in domain.constants}, **given}
        parents = {t.name: t.type for t in domain.types}
        self._by_type: dict[str, tuple[str, ...]] = {}
        for tname in {OBJECT, *parents}:
            self._by_type[tname] = tuple(sorted(o for o, t in self.objects.items() if is_a(t, tname, parents)))
        self._parents = parents
        self._actions = {a.name: a for a in domain.actions}
        self._primitives = _primitive_table(domain)
        self._primitive_of = {a: (name, n) for name, (n, acts) in self._primitives.items() for a in acts}
        self._ground_cache: dict[str, list[tuple[str, ...]]] = {}
        self._compiled: dict[Atom, _GroundAction | None] = {}
        self._index: tuple[dict[Atom, list[_GroundAction]], list[_GroundAction]] | None = None

    # ------------------------------------------------------------------ objects and types
    def objects_of(self, tname: str) -> tuple[str, ...]:
        if tname not in self._by_type:
            raise UserError(f"unknown type {tname!r} in domain {self.domain.name}")
        return self._by_type[tname]

    def type_atoms(self) -> frozenset:
        """Type membership as unary atoms, ``(block b1)``: static facts untyped learners can see."""
        return frozenset(Atom(self.type_predicate(t), (o,)) for t in self._parents for o in self._by_type[t])

    def type_predicate(self, tname: str) -> str:
        """The unary predicate that writes membership of ``tname`` (``type-X`` if X is also a predicate)."""
        return f"type-{tname}" if self.domain.predicate(tname) is not None else tname

    def strip_types(self, state: frozenset) -> frozenset:
        """A state without the type atoms :meth:`type_atoms` adds (so data written by us reads back)."""
        names = {self.type_predicate(t) for t in self._parents}
        return frozenset(a for a in state if not (a.arity == 1 and a.predicate in names))

    @property
    def initial_state(self) -> frozenset:
        if self.problem is None:
            raise UserError("no problem given: the initial state is unknown")
        return frozenset(self.problem.init)

    # ------------------------------------------------------------------ formulas
    def holds(self, f: Formula, state: frozenset, binding: Mapping[str, str] | None = None) -> bool:
        b = binding or {}
        if isinstance(f, Atom):
            if f.predicate == "=":
                x, y = (b.get(a, a) for a in f.args)
                return x == y
            return f.substitute(b) in state
        if isinstance(f, Not):
            return not self.holds(f.arg, state, b)
        if isinstance(f, And):
            return all(self.holds(g, state, b) for g in f.args)
        if isinstance(f, Or):
            return any(self.holds(g, state, b) for g in f.args)
        if isinstance(f, Imply):
            return not self.holds(f.left, state, b) or self.holds(f.right, state, b)
        if isinstance(f, (Forall, Exists)):
            combos = (dict(b, **dict(zip((p.name for p in f.params), vals))) for vals in self._groundings(f.params))
            test = (self.holds(f.body, state, bb) for bb in combos)
            return all(test) if isinstance(f, Forall) else any(test)
        raise TypeError(f"not a formula: {f!r}")

    def _groundings(self, params: Sequence[Typed]) -> Iterable[tuple[str, ...]]:
        return product(*(self.objects_of(p.type) for p in params))

    def goal_holds(self, state: frozenset) -> bool:
        return self.problem is not None and self.problem.goal is not None and self.holds(self.problem.goal, state)

    @property
    def goal_reward(self) -> float:
        """The problem's ``:goal-reward``; 1 when it has a goal but declares none (IPPC-2006)."""
        if self.problem is None or self.problem.goal is None:
            return 0.0
        return float(self.problem.goal_reward) if self.problem.goal_reward is not None else 1.0

    # ------------------------------------------------------------------ ground actions
    def action(self, name: str) -> Action:
        a = self._actions.get(name)
        if a is None:
            raise UserError(f"domain {self.domain.name} has no action {name!r}")
        return a

    def groundings(self, name: str) -> list[tuple[str, ...]]:
        """Every argument tuple of action ``name`` allowed by its parameter types."""
        if name not in self._ground_cache:
            self._ground_cache[name] = list(self._groundings(self.action(name).parameters))
        return self._ground_cache[name]

    def applicable(self, state: frozenset, action: Atom) -> bool:
        a = self.action(action.predicate)
        if len(a.parameters) != action.arity:
            return False
        if any(self.objects.get(x) is None or not is_a(self.objects[x], p.type, self._parents)
               for x, p in zip(action.args, a.parameters)):
            return False
        ga = self.ground(action)
        return ga is not None and ga.applicable(self, state)

    def ground(self, action: Atom) -> "_GroundAction | None":
        """The compiled ground action (precondition and effect with the arguments substituted,
        equality decided, ``forall`` effects expanded); None when equality alone rules it out.
        Built once per ground action: this is what makes a simulator step cheap."""
        if action not in self._compiled:
            self._compiled[action] = _GroundAction.build(self, action)
        return self._compiled[action]

    def outcomes(self, state: frozenset, action: Atom) -> list[Successor]:
        """The distribution over successors of an applicable ground PPDDL action (merged, sorted)."""
        ga = self.ground(action)
        if ga is None:
            return []
        merged: dict[tuple[frozenset, float], float] = {}
        for p, adds, dels, r in ga.deltas(self, state):
            if p > 0:
                key = ((state - dels) | adds, r)
                merged[key] = merged.get(key, 0.0) + p
        return _in_order(Successor(p, s, r) for (s, r), p in merged.items())

    def applicable_actions(self, state: frozenset) -> list[Atom]:
        """Every applicable ground PPDDL action, sorted. Ground actions are indexed by one atom
        their precondition needs, so a step looks only at those whose trigger holds."""
        triggered, always = self._trigger_index()
        seen: list[_GroundAction] = list(always)
        for atom in state:
            seen.extend(triggered.get(atom, ()))
        return sorted((ga.atom for ga in seen if ga.applicable(self, state)), key=_atom_key)

    def _trigger_index(self) -> tuple[dict[Atom, list["_GroundAction"]], list["_GroundAction"]]:
        if self._index is None:
            triggered: dict[Atom, list[_GroundAction]] = {}
            always: list[_GroundAction] = []
            changing = {l.atom.predicate for a in self.domain.actions for l in effect_literals(a.effect)}
            for a in self.domain.actions:
                for args in self.groundings(a.name):
                    ga = self.ground(Atom(a.name, args))
                    if ga is None:
                        continue
                    if ga.pos:      # a changing atom (static ones hold all along), the one with most arguments
                        trigger = max(ga.pos, key=lambda x: (x.predicate in changing, len(x.args), _atom_key(x)))
                        triggered.setdefault(trigger, []).append(ga)
                    else:
                        always.append(ga)
            self._index = (triggered, always)
        return self._index

    def _effect(self, e: Effect, state: frozenset, b: Mapping[str, str]) -> list[Outcome]:
        if isinstance(e, Literal):
            atom = frozenset((e.atom.substitute(b),))
            return [(1.0, atom, frozenset(), 0.0)] if e.positive else [(1.0, frozenset(), atom, 0.0)]
        if isinstance(e, AndEffect):
            return product_of([self._effect(x, state, b) for x in e.effects])
        if isinstance(e, Probabilistic):
            out: list[Outcome] = []
            for p, sub in e.branches:
                out += [(float(p) * q, ad, de, r) for q, ad, de, r in self._effect(sub, state, b)]
            if e.rest > 0:
                out.append((float(e.rest), frozenset(), frozenset(), 0.0))
            return out
        if isinstance(e, When):
            return self._effect(e.effect, state, b) if self.holds(e.condition, state, b) else [NOTHING]
        if isinstance(e, ForallEffect):
            names = [p.name for p in e.params]
            return product_of([self._effect(e.effect, state, dict(b, **dict(zip(names, vals))))
                             for vals in self._groundings(e.params)])
        if isinstance(e, RewardEffect):
            return [(1.0, frozenset(), frozenset(), float(e.amount))]
        raise TypeError(f"not an effect: {e!r}")

    # ------------------------------------------------------------------ robot primitives
    @property
    def primitives(self) -> dict[str, int]:
        """Primitive name -> arity."""
        return {name: n for name, (n, _) in sorted(self._primitives.items())}

    def primitive_actions(self) -> list[Atom]:
        """Every ground primitive allowed by the parameter types, sorted.

        Repeated arguments (``(put-on-block b1 b1)``) are offered wherever the domain allows them:
        a primitive is left out only when its action's precondition says ``(not (= ?x ?y))`` for
        two of the primitive's own parameters at the top level (as domains exported from NID rules
        do: rules bind injectively)."""
        out: set[Atom] = set()
        for name, (n, actions) in self._primitives.items():
            for aname in actions:
                apart = distinct_pairs(self.action(aname), n)
                out.update(Atom(name, args[:n]) for args in self.groundings(aname)
                           if not any(args[i] == args[j] for i, j in apart))
        return sorted(out)

    def applicable_primitives(self, state: frozenset) -> list[Atom]:
        """The primitives that can run in ``state`` (sorted): what a robot, or an episode, may try."""
        out = set()
        for ga in self.applicable_actions(state):  # (ga: a ground PPDDL action atom)
            name, n = self._primitive_of[ga.predicate]
            out.add(Atom(name, ga.args[:n]))
        return sorted(out)

    def _instances(self, state: frozenset, prim: Atom) -> list[Atom]:
        """The applicable ground PPDDL actions that run primitive ``prim``."""
        n, actions = self._primitives.get(prim.predicate, (None, ()))
        if n != prim.arity:
            return []
        found = []
        for aname in actions:
            params = self.action(aname).parameters
            extra = params[n:]
            for tail in self._groundings(extra):
                ga = self.ground(Atom(aname, prim.args + tuple(tail)))
                if ga is not None and ga.applicable(self, state):
                    found.append(ga.atom)
        return found

    def is_applicable(self, state: frozenset, prim: Atom) -> bool:
        return bool(self._instances(state, prim))

    def distribution(self, state: frozenset, action: Atom) -> list[Successor]:
        """Successors of a ground PPDDL action or primitive; [] where nothing applies.

        Should several PPDDL actions run the same primitive (rules that are not exclusive), each
        applicable one is taken as equally likely, a documented choice for ill-formed exports.
        """
        if action.predicate in self._actions and action.predicate not in self._primitives:
            return self.outcomes(state, action) if self.applicable(state, action) else []
        inst = self._instances(state, action)
        if len(inst) == 1:
            return self.outcomes(state, inst[0])
        merged: dict[tuple[frozenset, float], float] = {}
        for ga in inst:
            for s in self.outcomes(state, ga):
                merged[(s.state, s.reward)] = merged.get((s.state, s.reward), 0.0) + s.prob / len(inst)
        return _in_order(Successor(p, s, r) for (s, r), p in merged.items())

    def probability(self, state: frozenset, action: Atom, succ: frozenset) -> float:
        """``P(succ | state, action)`` of a primitive; an inapplicable one changes nothing.

        Type atoms written by :func:`simulate_traces` are ignored on both sides.
        """
        s, s2 = self.strip_types(state), self.strip_types(succ)
        dist = self.distribution(s, action)
        if not dist:
            return 1.0 if s == s2 else 0.0
        return sum(x.prob for x in dist if x.state == s2)


def _atom_key(a: Atom) -> tuple:
    """Atoms' own order as a tuple (compared in C: sorting is the simulator's hot spot)."""
    return a.predicate, a.args


def _compare(x: Successor, y: Successor) -> int:
    """The order of ``(sorted(state), reward)`` without sorting whole states: sorted states first
    differ at the least atom of their symmetric difference, and the state holding it comes first."""
    diff = x.state ^ y.state
    if diff:
        return -1 if min(diff, key=_atom_key) in x.state else 1
    return (x.reward > y.reward) - (x.reward < y.reward)


def _in_order(successors: Iterable[Successor]) -> list[Successor]:
    return sorted(successors, key=cmp_to_key(_compare))
class _GroundAction:
    """One ground PPDDL action, compiled: a precondition that is a conjunction of ground literals
    becomes two atom sets (``pos`` must hold, ``neg`` must not); any other precondition keeps its
    ground formula. The effect is ground too; without ``when`` its outcomes do not depend on the
    state and are computed once."""

    __slots__ = ("atom", "pos", "neg", "formula", "effect", "fixed")

    def __init__(self, atom: Atom, pos: frozenset, neg: frozenset, formula: Formula | None, effect: Effect,
                 fixed: list[Outcome] | None) -> None:
        self.atom, self.pos, self.neg, self.formula, self.effect, self.fixed = atom, pos, neg, formula, effect, fixed

    @staticmethod
    def build(task: "Task", action: Atom) -> "_GroundAction | None":
        a = task.action(action.predicate)
        if len(a.parameters) != action.arity or any(
                task.objects.get(x) is None or not is_a(task.objects[x], p.type, task._parents)
                for x, p in zip(action.args, a.parameters)):
            return None
        b = dict(zip((p.name for p in a.parameters), action.args))
        pre = ground_formula(a.precondition, b)
        if pre == FALSE:
            return None
        lits = ground_literals(pre)
        pos = frozenset(x for x, positive in lits if positive) if lits is not None else frozenset()
        neg = frozenset(x for x, positive in lits if not positive) if lits is not None else frozenset()
        effect = ground_effect(a.effect, b, task._groundings)
        fixed = task._effect(effect, frozenset(), {}) if not has_when(effect) else None
        return _GroundAction(action, pos, neg, None if lits is not None else pre, effect, fixed)

    def applicable(self, task: "Task", state: frozenset) -> bool:
        if self.formula is not None:
            return task.holds(self.formula, state)
        return self.pos <= state and self.neg.isdisjoint(state)

    def deltas(self, task: "Task", state: frozenset) -> list[Outcome]:
        return self.fixed if self.fixed is not None else task._effect(self.effect, state, {})


def _primitive_table(domain: Domain) -> dict[str, tuple[int, list[str]]]:
    """primitive name -> (arity, PPDDL actions that run it)."""
    table: dict[str, tuple[int, list[str]]] = {}
    for a in domain.actions:
        name, n = primitive_of(a)
        if name in table and table[name][0] != n:
            raise UserError(f"domain {domain.name}: actions for primitive {name!r} disagree on its arity "
                            f"({table[name][0]} and {n})")
        table.setdefault(name, (n, []))[1].append(a.name)
    return table


def default_steps(task: Task) -> int:
    """Primitives per episode when none are given: 5 per object, at least 50. Why: rebuilding a
    blocks world of n blocks takes about 4n primitives when nothing fails, and the IPPC domains
    fail a quarter of the time or more; a fixed 30 cut FF-Replan's 38-step plans short."""
    return max(50, 5 * len(task.objects))


def successor_distribution(domain: Domain, problem_or_objects: Problem | Mapping[str, str] | Iterable[str],
                           state: frozenset, action: Atom) -> list[tuple[float, frozenset, float]]:
    """``[(probability, successor state, reward)]`` of a ground action (or primitive) in ``state``;
    empty when it is not applicable. Build a :class:`Task` once instead when calling this often."""
    return [tuple(s) for s in Task(domain, problem_or_objects).distribution(state, action)]  # type: ignore[misc]


# ------------------------------------------------------------------------------ random traces
def simulate_traces(task: Task, n_traces: int, length: int, rng: np.random.Generator,
                    inapplicable: float = 0.0, meta: dict | None = None, progress=None) -> SymbolicDataset:
    """Random walks from the problem's initial state.

    Each step picks, with probability ``inapplicable``, a primitive whose precondition fails
    (nothing changes, as when a robot tries), else a uniformly random applicable primitive, and
    samples its outcome. A trace ends after ``length`` steps or at a dead end (nothing applicable).
    A step's reward is the goal reward when the goal holds in that step's state, plus the reward
    effects of the sampled outcome. States carry the type atoms (``(block b1)``).
    """
    if not 0.0 <= inapplicable <= 1.0:
        raise UserError(f"--inapplicable: expected a share in [0, 1], got {inapplicable}")
    candidates = task.primitive_actions()
    statics = task.type_atoms()
    traces = []
    for i in range(n_traces):
        state = task.initial_state
        states, actions, rewards = [state | statics], [], []
        for _ in range(length):
            ok = task.applicable_primitives(state)
            if not ok:
                break
            allowed = set(ok)
            bad = [a for a in candidates if a not in allowed]
            r = task.goal_reward if task.goal_holds(state) else 0.0
            if bad and rng.random() < inapplicable:
                action = bad[int(rng.integers(len(bad)))]
                succ = state
            else:
                action = ok[int(rng.integers(len(ok)))]
                dist = task.distribution(state, action)
                probs = np.array([s.prob for s in dist])
                pick = dist[int(rng.choice(len(dist), p=probs / probs.sum()))]
                succ, r = pick.state, r + pick.reward
            actions.append(action)
            rewards.append(r)
            state = succ
            states.append(state | statics)
        final_reward = task.goal_reward if task.goal_holds(state) else 0.0
        traces.append(SymbolicTrace(tuple(sorted(task.objects)), states, actions, rewards, final_reward))
        if progress is not None:
            progress.update(i + 1, f"{sum(len(t) for t in traces)} transitions")
    predicates = {p.name: p.arity for p in task.domain.predicates}
    predicates.update({task.type_predicate(t.name): 1 for t in task.domain.types})
    return SymbolicDataset(traces, predicates, task.primitives, dict(meta or {}))



# ------------------------------------------------------------------------------ a domain as a model
def typed_objects(domain: Domain, objects: Iterable[str], state: frozenset) -> dict[str, str]:
    """Each object's most specific type, read from the type atoms ``(block b1)`` that
    :func:`simulate_traces` writes; ``object`` where there are none."""
    parents = {t.name: t.type for t in domain.types}
    probe = Task(domain, {})
    out = {}
    for o in objects:
        kinds = [t for t in parents if Atom(probe.type_predicate(t), (o,)) in state]
        deepest = [t for t in kinds if all(is_a(t, k, parents) for k in kinds)]
        out[o] = deepest[0] if deepest else OBJECT
    return out


def transition_model(path, ds: SymbolicDataset | None = None):
    """A PPDDL domain file as a transition model for scoring data against its true dynamics.

    Returns ``(probability, names)``: ``probability(s, a, s2, objects) -> (p, key)`` gives
    ``P(s2 | s, a)`` of primitive ``a`` (an inapplicable one changes nothing) and as ``key`` the
    PPDDL action that ran it, or None when none applied; ``names`` maps keys to readable names.
    Object types come from the type atoms in the states; type atoms are ignored as changes.
    """
    from .parser import load

    domain, _ = load(path)
    tasks: dict[tuple, Task] = {}

    def probability(s: frozenset, a: Atom, s2: frozenset, objects: Sequence[str]) -> tuple[float, str | None]:
        key = tuple(objects)
        if key not in tasks:
            tasks[key] = Task(domain, typed_objects(domain, objects, s))
        task = tasks[key]
        plain = task.strip_types(s)
        inst = task._instances(plain, a) if a.predicate in task.primitives else []
        return task.probability(s, a, s2), (inst[0].predicate if inst else None)

    names = {a.name: f"{a.name} ({domain.name})" for a in domain.actions}
    return probability, names
