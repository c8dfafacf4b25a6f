"""NID rules: what a rule is, which rule covers an example, and how likely a transition is.

Semantics follow Pasula, Zettlemoyer & Kaelbling (2007), as libPRADA implements them (docs/rules.md):

* A :class:`Rule` has an action template over variables (``(openHandOver ?x)``), a context of
  literals over the action variables and deictic references (any other variable in the context),
  outcomes (sets of literal changes) with probabilities, and a noise probability ``noise``.
* A rule *covers* ``(s, a)`` iff exactly one injective binding of its variables makes every
  context literal true in ``s`` (closed world). An action template may repeat a variable
  (``(put-on-block ?x ?x)``, read from a PPDDL domain that allows the move): it then covers only
  actions whose arguments repeat in the same places.
* A :class:`RuleSet` covers ``(s, a)`` with its unique covering non-default rule, or else with the
  action's default rule (no change, or noise).
* ``P(s' | s, a) = noise * p_min + sum of p_i over outcomes i that turn s into s'``.
* A rule set may name *derived predicates* (:class:`Derived`): "no atom of ``base`` has these
  arguments in these places", e.g. ``(no-on-1 ?x)``: nothing is under ``?x``. Contexts may use
  them; they are computed from the state before coverage is checked and never appear in outcomes
  (they change when their base atoms do). They say what a negated deictic reference would ("no
  ``?y`` with ``(on ?x ?y)``"), which plain NID contexts cannot.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import permutations
from typing import Iterable, Iterator, Mapping

from ..logic import Atom, Literal, is_variable

P_MIN = 1e-8            # likelihood of any transition under a rule's noise outcome
P_MIN_DEFAULT = 1e-9    # ... under a default rule's noise outcome


@dataclass(frozen=True, order=True)
class Outcome:
    """A set of literal changes over rule variables: positive = becomes true, negated = becomes false."""

    changes: tuple[Literal, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "changes", tuple(sorted(set(self.changes))))

    @property
    def is_empty(self) -> bool:
        return not self.changes

    def ground(self, binding: Mapping[str, str]) -> tuple[frozenset, frozenset]:
        """(adds, dels) of the outcome under ``binding``."""
        adds = frozenset(l.atom.substitute(binding) for l in self.changes if l.positive)
        dels = frozenset(l.atom.substitute(binding) for l in self.changes if not l.positive)
        return adds, dels

    def apply(self, state: frozenset, binding: Mapping[str, str]) -> frozenset:
        adds, dels = self.ground(binding)
        return (state - dels) | adds

    def __str__(self) -> str:
        return " ".join(str(c) for c in self.changes) if self.changes else "(no change)"


@dataclass(frozen=True)
class Rule:
    """One NID rule. ``probs[i]`` belongs to ``outcomes[i]``; ``noise`` is the rest of the mass.

    ``noise_changes`` is the mean number of atoms that changed in the examples this rule explained
    as noise (PRADA spreads the noise mass with it).
    """

    action: Atom
    context: tuple[Literal, ...]
    outcomes: tuple[Outcome, ...]
    probs: tuple[float, ...]
    noise: float
    noise_changes: float = 0.0

    def __post_init__(self) -> None:
        if len(self.outcomes) != len(self.probs):
            raise ValueError("one probability per outcome")
        if any(p < -1e-12 for p in self.probs) or self.noise < -1e-12:
            raise ValueError("negative probability")
        if abs(sum(self.probs) + self.noise - 1.0) > 1e-6:
            raise ValueError(f"probabilities sum to {sum(self.probs) + self.noise}, not 1")
        if not all(map(is_variable, self.action.args)):
            raise ValueError(f"action template needs variables: {self.action}")

    @property
    def variables(self) -> tuple[str, ...]:
        """Action variables first (each once), then deictic references in order of first appearance."""
        seen = list(dict.fromkeys(self.action.args))
        for lit in self.context:
            for a in lit.atom.args:
                if is_variable(a) and a not in seen:
                    seen.append(a)
        return tuple(seen)

    @property
    def deictic(self) -> tuple[str, ...]:
        return self.variables[len(set(self.action.args)):]

    def complexity(self) -> int:
        """PEN(r): context literals plus literals across all outcomes (Pasula et al. 2007, the complexity penalty)."""
        return len(self.context) + sum(len(o.changes) for o in self.outcomes)

    def bindings(self, state: frozenset, action: Atom, injective: bool = True,
                 objects: Iterable[str] | None = None, limit: int = 2) -> list[dict[str, str]]:
        """Up to ``limit`` bindings of all variables under which the context holds in ``state``."""
        if action.predicate != self.action.predicate or action.arity != self.action.arity:
            return []
        base: dict[str, str] = {}
        for var, obj in zip(self.action.args, action.args):
            if base.setdefault(var, obj) != obj:      # a repeated variable needs a repeated argument
                return []
        if injective and len(set(action.args)) != len(base):
            return []
        return list(_bindings(self.context, state, base, injective, objects, limit))

    def covers(self, state: frozenset, action: Atom, injective: bool = True,
               objects: Iterable[str] | None = None) -> dict[str, str] | None:
        """The unique binding if this rule covers ``(state, action)``, else None."""
        found = self.bindings(state, action, injective, objects, limit=2)
        return found[0] if len(found) == 1 else None

    def likelihood(self, state: frozenset, binding: Mapping[str, str], succ: frozenset,
                   p_min: float = P_MIN) -> float:
        p = self.noise * p_min
        for o, po in zip(self.outcomes, self.probs):
            if o.apply(state, binding) == succ:
                p += po
        return p


@dataclass(frozen=True, order=True)
class Derived:
    """A derived predicate ``name(kept arguments)``: true iff no atom of ``base`` (arity
    ``base_arity``) has the derived atom's arguments at positions ``keep`` (0-based), whatever
    objects fill its other places. ``no-on-1`` = ``Derived("no-on-1", "on", 2, (0,))``: no
    ``(on ?x _)``, nothing under ``?x``; ``no-on-2``: nothing on ``?x``; ``no-inhand``
    (nullary): no object in the hand."""

    name: str
    base: str
    base_arity: int
    keep: tuple[int, ...]

    @property
    def arity(self) -> int:
        return len(self.keep)

    @staticmethod
    def for_predicates(predicates: Mapping[str, int]) -> tuple["Derived", ...]:
        """The derived predicates :func:`learn_rules` offers: for a unary ``p``, nullary ``no-p``;
        for a binary ``p``, ``no-p-1(x)`` (no ``p(x, _)``) and ``no-p-2(x)`` (no ``p(_, x)``).
        A name the predicates already use is left out."""
        out = []
        for p, k in sorted(predicates.items()):
            cands = [Derived(f"no-{p}", p, 1, ())] if k == 1 else \
                [Derived(f"no-{p}-{i + 1}", p, 2, (i,)) for i in range(2)] if k == 2 else []
            out.extend(d for d in cands if d.name not in predicates)
        return tuple(out)

    def holding(self, state: Iterable[Atom], objects: Iterable[str]) -> frozenset:
        """The derived atoms of this predicate that hold in ``state`` over ``objects``."""
        taken = {tuple(a.args[i] for i in self.keep) for a in state
                 if a.predicate == self.base and a.arity == self.base_arity}
        objs = sorted(set(objects))
        cands = [()] if not self.keep else [(o,) for o in objs] if len(self.keep) == 1 else \
            list(permutations(objs, len(self.keep)))
        return frozenset(Atom(self.name, t) for t in cands if t not in taken)


def with_derived(state: frozenset, derived: Iterable[Derived], objects: Iterable[str] | None = None) -> frozenset:
    """``state`` plus the derived atoms that hold in it (objects: those of ``state`` if not given)."""
    derived = tuple(derived)
    if not derived:
        return state
    objs = list(objects) if objects is not None else sorted({x for a in state for x in a.args})
    out = set(state)
    for d in derived:
        out |= d.holding(state, objs)
    return frozenset(out)


@dataclass(frozen=True)
class DefaultRule:
    """What happens when no rule (or more than one) covers: no change, or noise."""

    p_noise: float = 0.5

    @property
    def p_nochange(self) -> float:
        return 1.0 - self.p_noise

    def likelihood(self, state: frozenset, succ: frozenset, p_min: float = P_MIN_DEFAULT) -> float:
        return self.p_nochange * (state == succ) + self.p_noise * p_min


@dataclass(frozen=True)
class RuleSet:
    """Rules for all actions, with one default rule per action name."""

    rules: tuple[Rule, ...] = ()
    defaults: tuple[tuple[str, DefaultRule], ...] = ()
    p_min: float = P_MIN
    p_min_default: float = P_MIN_DEFAULT
    injective: bool = True
    derived: tuple[Derived, ...] = ()
    _by_action: dict = field(default=None, compare=False, repr=False)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        table: dict[str, list[Rule]] = {}
        for r in self.rules:
            table.setdefault(r.action.predicate, []).append(r)
        object.__setattr__(self, "_by_action", table)

    def rules_for(self, action_name: str) -> list[Rule]:
        return self._by_action.get(action_name, [])

    def default_for(self, action_name: str) -> DefaultRule:
        for name, d in self.defaults:
            if name == action_name:
                return d
        return DefaultRule()

    def covering(self, state: frozenset, action: Atom,
                 objects: Iterable[str] | None = None) -> tuple[Rule | None, dict[str, str] | None]:
        """The unique covering non-default rule and its binding, or (None, None) for the default.
        ``state`` holds the base atoms only: the derived ones are added here."""
        state = with_derived(state, self.derived, objects)
        hit: tuple[Rule, dict[str, str]] | None = None
        for r in self.rules_for(action.predicate):
            b = r.covers(state, action, self.injective, objects)
            if b is not None:
                if hit is not None:
                    return None, None
                hit = (r, b)
        return hit if hit is not None else (None, None)

    def likelihood(self, state: frozenset, action: Atom, succ: frozenset,
                   objects: Iterable[str] | None = None) -> float:
        r, b = self.covering(state, action, objects)
        if r is None:
            return self.default_for(action.predicate).likelihood(state, succ, self.p_min_default)
        return r.likelihood(state, b, succ, self.p_min)


def drop_noise(rules: RuleSet) -> RuleSet:
    """The rule set conditioned on "no noise": each rule's outcome probabilities renormalised over
    its outcomes, the noise mass gone (``export-domain --noise drop``). Under heavy observation
    noise the noise outcome can take most of a rule's mass and the most-likely determinisation
    would drop every effect; here it keeps the most probable real outcome (docs/ppddl.md)."""
    out = []
    for r in rules.rules:
        total = sum(r.probs)
        if total <= 0 or r.noise <= 0:
            out.append(r)
            continue
        out.append(Rule(r.action, r.context, r.outcomes, tuple(p / total for p in r.probs), 0.0, 0.0))
    return RuleSet(tuple(out), rules.defaults, rules.p_min, rules.p_min_default, rules.injective, rules.derived)


def _bindings(context: tuple[Literal, ...], state: frozenset, base: dict[str, str], injective: bool,
              objects: Iterable[str] | None, limit: int) -> Iterator[dict[str, str]]:
    """Backtracking search: bind variables through positive literals, then check the rest."""
    pos = [l for l in context if l.positive]
    neg = [l for l in context if not l.positive]
    index: dict[tuple[str, int], list[tuple[str, ...]]] = {}
    for a in state:
        index.setdefault((a.predicate, a.arity), []).append(a.args)
    free_in_neg = {v for l in neg for v in l.atom.args if is_variable(v)}
    free_in_pos = {v for l in pos for v in l.atom.args if is_variable(v)}
    unbound_neg_only = free_in_neg - free_in_pos - set(base)
    universe = sorted(set(objects) if objects is not None else {x for a in state for x in a.args})
    count = 0

    def check_rest(b: dict[str, str]) -> Iterator[dict[str, str]]:
        # variables only in negated literals ("the one object that is not u1"): enumerate
        extra = sorted(unbound_neg_only)
        used = set(b.values())
        pool = [o for o in universe if not (injective and o in used)]
        for combo in permutations(pool, len(extra)) if extra else [()]:
            bb = dict(b, **dict(zip(extra, combo)))
            if all((l.atom.substitute(bb) in state) is False for l in neg):
                yield bb

    def rec(i: int, b: dict[str, str]) -> Iterator[dict[str, str]]:
        if i == len(pos):
            yield from check_rest(b)
            return
        lit = pos[i]
        for args in index.get((lit.atom.predicate, lit.atom.arity), ()):
            nb = b
            ok = True
            for term, val in zip(lit.atom.args, args):
                if is_variable(term):
                    cur = nb.get(term)
                    if cur is None:
                        if injective and val in nb.values():
                            ok = False
                            break
                        if nb is b:
                            nb = dict(b)
                        nb[term] = val
                    elif cur != val:
                        ok = False
                        break
                elif term != val:
                    ok = False
                    break
            if ok:
                yield from rec(i + 1, nb)

    seen: set[tuple] = set()
    for b in rec(0, dict(base)):
        key = tuple(sorted(b.items()))
        if key in seen:
            continue
        seen.add(key)
        yield b
        count += 1
        if count >= limit:
            return
