"""A PPDDL domain and problem as an RDDL domain and instance (docs/rddl.md).

The translation (Sanner 2010 for RDDL; Younes et al. 2005 for the PPDDL semantics it keeps):

* every predicate an effect changes is a boolean state fluent, every other one a non-fluent;
* one boolean action fluent per primitive (a learned model's ``pickup_r1 ?x1 ?y1`` and
  ``pickup_r2 ?x1`` both run ``pickup(?x1)``, :func:`groundsym.ppddl.rule_actions.primitive_of`),
  at most one action a step (``max-nondef-actions = 1``); an action whose precondition fails
  changes nothing, as a primitive no rule covers changes nothing;
* each ``probabilistic`` block draws one ``Uniform(0, 1)`` interm fluent (per binding of the
  ``forall`` variables around it), and branch ``i`` happens when the draw falls in
  ``[p_1 + .. + p_{i-1}, p_1 + .. + p_i)``: a branch's changes happen together (correlated
  outcomes stay joint), blocks are independent, and the mass left over changes nothing;
* a fluent's next value: some effect adds it, or it held and none deletes it (deletes before adds);
* reward: the reward effects of the action taken, summed; a state reward (a learned model's
  reward model, written once) is ``c + sum_k w_k * sum_{vars}[features]``; a goal with a
  ``:goal-reward`` ends the episode (``termination``) and pays on arrival.
"""

from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Iterator, Sequence

from ..errors import UserError
from ..logic import Atom, Literal
from ..ppddl.ast import (OBJECT, Action, And, AndEffect, Domain, Effect, ForallEffect, Not, Probabilistic,
                         Problem, RewardEffect, Typed, When)
from ..ppddl.ground import effect_literals
from ..ppddl.rule_actions import primitive_of
from ..rules.model import Derived
from .derived import definition, fold
from .expressions import OBJECT_TYPE, Condition, Expressions, Pick, real, type_namer
from .names import Identifiers, variable

INDENT = "    "


@dataclass(frozen=True)
class Change:
    """One literal (or reward) an action's effect makes, under the conditions that lead to it,
    inside the ``forall`` variables around it."""

    action: Action | None
    conditions: tuple[Condition, ...]
    params: tuple[Typed, ...]
    literal: Literal | None = None
    amount: Fraction | None = None


@dataclass(frozen=True)
class RddlOptions:
    """What the instance says beyond the problem: the horizon and discount of an episode."""

    horizon: int = 40
    discount: float = 1.0


class RddlWriter:
    """Translates one domain and problem (the module docstring says how)."""

    def __init__(self, domain: Domain, problem: Problem, state_reward: Effect | None = None,
                 options: RddlOptions = RddlOptions(), derived: Sequence[Derived] = ()) -> None:
        if derived:      # written out in the PPDDL, declared once here (.derived)
            domain = replace(domain, actions=tuple(replace(a, precondition=fold(a.precondition, derived))
                                                   for a in domain.actions))
            used = {x for a in domain.actions for x in re.findall(r"\(([^\s()]+)", str(a.precondition))}
            derived = [d for d in derived if d.name in used]
        self.derived = tuple(derived)
        self.domain, self.problem, self.options = domain, problem, options
        self.state_reward = state_reward
        self.ids = Identifiers(f"domain {domain.name}")
        self.types = type_namer(self.ids)
        self._check_types()
        changed = {l.atom.predicate for a in domain.actions for l in effect_literals(a.effect)}
        self.fluents = {p.name for p in domain.predicates if p.name in changed}
        self.expr = Expressions(self.ids, self.types, self._fluent_name)
        self.primitives: dict[str, tuple[int, Action]] = {}
        for a in domain.actions:
            name, n = primitive_of(a)
            self.primitives.setdefault(name, (n, a))
        self.draws: dict[str, tuple[Typed, ...]] = {}
        self.changes = [c for a in domain.actions for c in self._walk(a, a.effect, (), (), a.name, [0])]
        self.heads = self._head_variables()
        self.goal = self._goal_literals()
        for name in self._goal_marks():
            self.ids.reserve(name, "the goal's objects")

    # -------------------------------------------------------------------------- checks and names
    def _check_types(self) -> None:
        deep = [t for t in self.domain.types if t.type != OBJECT]
        if deep:
            raise UserError(f"domain {self.domain.name}: type {deep[0].name} - {deep[0].type}: the RDDL export "
                            "writes flat types only (every type a direct subtype of object)")
        self.ids.reserve(OBJECT_TYPE, "the type of untyped objects")

    def _fluent_name(self, predicate: str, primed: bool) -> str:
        name = self.ids(predicate)
        return name + "'" if primed and predicate in self.fluents else name

    def _head_variables(self) -> list[str]:
        """Variable names for a fluent's own arguments that no action or formula uses."""
        used = {variable(p.name) for a in self.domain.actions for p in a.parameters}
        used |= set(_all_variables(self.domain))
        names, i = [], 1
        while len(names) < max((p.arity for p in self.domain.predicates), default=0):
            v = f"?o{i}"
            if v not in used:
                names.append(v)
            i += 1
        return names

    # -------------------------------------------------------------------------- effects
    def _walk(self, action: Action | None, e: Effect, conds: tuple[Condition, ...], params: tuple[Typed, ...],
              owner: str, count: list[int]) -> Iterator[Change]:
        if isinstance(e, Literal):
            yield Change(action, conds, params, literal=e)
        elif isinstance(e, RewardEffect):
            yield Change(action, conds, params, amount=e.amount)
        elif isinstance(e, AndEffect):
            for x in e.effects:
                yield from self._walk(action, x, conds, params, owner, count)
        elif isinstance(e, When):
            yield from self._walk(action, e.effect, conds + (e.condition,), params, owner, count)
        elif isinstance(e, ForallEffect):
            yield from self._walk(action, e.effect, conds, params + e.params, owner, count)
        elif isinstance(e, Probabilistic):
            count[0] += 1
            draw = self._draw_name(owner, count[0], params)
            low = Fraction(0)
            for p, sub in e.branches:
                pick = Pick(draw, tuple(x.name for x in params), low, low + p)
                low += p
                if p > 0:
                    yield from self._walk(action, sub, conds + (pick,), params, owner, count)
        else:
            raise TypeError(f"not an effect: {e!r}")

    def _draw_name(self, owner: str, k: int, params: tuple[Typed, ...]) -> str:
        name = f"draw_{self.ids(owner)}" + ("" if k == 1 else f"_{k}")
        self.ids.reserve(name, f"the outcome draw of {owner}")
        self.draws[name] = params
        return name

    def _fired(self, a: Action) -> list[Condition]:
        """The action fluent of ``a``'s primitive with ``a``'s first parameters, and ``a``'s precondition."""
        name, n = primitive_of(a)
        return [_ActionAtom(Atom(name, tuple(p.name for p in a.parameters[:n]))), a.precondition]

    def _case(self, c: Change, head: Sequence[str] | None) -> str:
        """The condition under which change ``c`` happens (to the fluent with arguments ``head``)."""
        scope = list(c.action.parameters if c.action else ()) + list(c.params)
        ren: dict[str, str] = {}
        eqs: list[str] = []
        if head is not None and c.literal is not None:
            for arg, h in zip(c.literal.atom.args, head):
                if any(p.name == arg for p in scope) and arg not in ren:
                    ren[arg] = h
                else:
                    eqs.append(f"({self.expr.term(arg, ren)} == {h})")
        parts = [self._cond(x, ren) for x in (self._fired(c.action) if c.action else [])]
        parts += [self._cond(x, ren) for x in c.conditions] + eqs
        parts = [p for p in parts if p != "true"] or ["true"]
        body = " ^ ".join(parts)
        rest = [p for p in scope if p.name not in ren]
        if not rest:
            return f"({body})" if len(parts) > 1 else body
        return f"({'exists_' if head is not None else 'sum_'}{{{self.expr.typed(rest)}}}[{body}])"

    def _cond(self, x: Condition, ren: dict[str, str]) -> str:
        if isinstance(x, _ActionAtom):
            a = x.atom
            return f"{self.ids(a.predicate)}({', '.join(ren.get(t, variable(t)) for t in a.args)})" if a.args \
                else self.ids(a.predicate)
        return self.expr.formula(x, ren)

    # -------------------------------------------------------------------------- the domain
    def domain_text(self) -> str:
        d = self.domain
        lines = _comment(d.comment)
        lines.append(f"domain {self.ids(d.name)} {{")
        type_names = sorted(self._type_names())
        lines += [f"{INDENT}types {{", *(f"{INDENT * 2}{t} : object;" for t in type_names), f"{INDENT}}};", ""]
        lines += [f"{INDENT}pvariables {{", *self._pvariables(), f"{INDENT}}};", ""]
        lines += [f"{INDENT}cpfs {{", *self._cpfs(), f"{INDENT}}};", ""]
        lines += [f"{INDENT}reward ={self._reward()};"]      # one term a line
        if self.goal:
            lines += ["", f"{INDENT}termination {{", f"{INDENT * 2}{self._goal_text(False)};", f"{INDENT}}};"]
        lines.append("}")
        return "\n".join(lines) + "\n"

    def _type_names(self) -> set[str]:
        """The RDDL types: the domain's, and ``obj`` when something is untyped."""
        names = {self.types(t.name) for t in self.domain.types}
        untyped = [o for o in (*self.domain.constants, *self.problem.objects) if o.type == OBJECT]
        return names | {OBJECT_TYPE} if untyped or not names else names

    def _pvariables(self) -> list[str]:
        out = []
        for p in self.domain.predicates:
            kind = "state-fluent" if p.name in self.fluents else "non-fluent"
            args = f"({', '.join(self.types(t.type) for t in p.params)})" if p.params else ""
            note = f"  // {p.comment}" if p.comment else ""
            out.append(f"{INDENT * 2}{self.ids(p.name)}{args} : {{ {kind}, bool, default = false }};{note}")
        for name, l in self._goal_marks().items():
            args = ", ".join(self.types(t.type) for t in self.domain.predicate(l.atom.predicate).params)
            out.append(f"{INDENT * 2}{name}({args}) : {{ non-fluent, bool, default = false }};  "
                       f"// the goal asks {'' if l.positive else 'not '}{self.ids(l.atom.predicate)} here")
        for d in self.derived:
            args = f"({', '.join([OBJECT_TYPE] * d.arity)})" if d.arity else ""
            out.append(f"{INDENT * 2}{self.ids(d.name)}{args} : {{ interm-fluent, bool }};  "
                       f"// a derived predicate: no {d.base} atom with these arguments")
        for name, (n, a) in sorted(self.primitives.items()):
            args = f"({', '.join(self.types(t.type) for t in a.parameters[:n])})" if n else ""
            out.append(f"{INDENT * 2}{self.ids(name)}{args} : {{ action-fluent, bool, default = false }};")
        for name, params in self.draws.items():
            args = f"({', '.join(self.types(t.type) for t in params)})" if params else ""
            out.append(f"{INDENT * 2}{name}{args} : {{ interm-fluent, real }};  // picks an outcome")
        return out

    def _cpfs(self) -> list[str]:
        out = []
        for name, params in self.draws.items():
            head = f"{name}({', '.join(variable(p.name) for p in params)})" if params else name
            out.append(f"{INDENT * 2}{head} = Uniform(0.0, 1.0);")
        for d in self.derived:
            params, body = definition(d)
            head = f"({', '.join(variable(p.name) for p in params)})" if params else ""
            out.append(f"{INDENT * 2}{self.ids(d.name)}{head} = {self.expr.formula(body)};")
        sep = "\n" + INDENT * 3
        for p in self.domain.predicates:
            if p.name not in self.fluents:
                continue
            head = self.heads[:p.arity]
            now = self.expr.atom(_atom(p.name, head), {})
            adds = [self._case(c, head) for c in self.changes
                    if c.literal is not None and c.literal.positive and c.literal.atom.predicate == p.name]
            dels = [self._case(c, head) for c in self.changes
                    if c.literal is not None and not c.literal.positive and c.literal.atom.predicate == p.name]
            keep = f"({now} ^ ~({(sep + INDENT + '| ').join(dels)}))" if dels else now
            body = (sep + "| ").join([*adds, keep])
            out.append(f"{INDENT * 2}{self._fluent_name(p.name, True)}{'(' + ', '.join(head) + ')' if head else ''} ="
                       f"{sep}  {body};")
        return out

    def _reward(self) -> str:
        terms = [c for c in self.changes if c.amount is not None]
        if self.state_reward is not None:
            terms += list(self._walk(None, self.state_reward, (), (), "reward", [0]))
        parts = []
        for c in terms:
            case = self._case(c, None)
            parts.append(real(c.amount) if case == "true" else f"{real(c.amount)} * {case}")
        if self.goal:
            parts.append(f"{real(self.goal_reward())} * {self._goal_text(True)}")
        if not parts:
            return " 0.0"
        sep = "\n" + INDENT * 3
        return sep + "  " + (sep + "+ ").join(parts).replace("+ -", "- ")

    def goal_reward(self) -> Fraction | None:
        """What reaching the goal pays (None: no goal, or the rewards say what is good instead)."""
        p = self.problem
        if p.goal is None:
            return None
        if p.goal_reward is not None:
            return p.goal_reward
        has_rewards = self.state_reward is not None or any(c.amount is not None for c in self.changes)
        return None if has_rewards else Fraction(1)

    def _goal_literals(self) -> list[Literal]:
        """The goal as literals (empty: no goal, or no goal reward to pay for it). RDDL's domain
        cannot name an instance's objects, so the instance marks them: ``goal_on(a, b)``."""
        if not self.goal_reward():
            return []
        g = self.problem.goal
        items = list(g.args) if isinstance(g, And) else [g]
        lits = [Literal(x) if isinstance(x, Atom) else Literal(x.arg, False) if isinstance(x, Not)
                and isinstance(x.arg, Atom) else None for x in items]
        if any(l is None or l.atom.predicate == "=" for l in lits):
            raise UserError(f"problem {self.problem.name}: :goal: the RDDL export writes a conjunction of "
                            "literals only")
        return lits  # type: ignore[return-value]

    def _mark(self, l: Literal) -> str:
        """The non-fluent that marks the objects of goal literal ``l`` in the instance."""
        return f"goal_{'' if l.positive else 'not_'}{self.ids(l.atom.predicate)}"

    def _goal_marks(self) -> dict[str, Literal]:
        """Goal non-fluent name -> one literal it marks, for the goal's literals with arguments."""
        return {self._mark(l): l for l in self.goal if l.atom.args}

    def _goal_text(self, primed: bool) -> str:
        parts = [self.expr.formula(l.atom if l.positive else Not(l.atom), primed=primed)
                 for l in self.goal if not l.atom.args]
        for name, l in self._goal_marks().items():
            pred = self.domain.predicate(l.atom.predicate)
            head = self.heads[:l.atom.arity]
            now = self.expr.atom(_atom(l.atom.predicate, head), {}, primed)
            typed = ", ".join(f"{h} : {self.types(t.type)}" for h, t in zip(head, pred.params))
            parts.append(f"(forall_{{{typed}}}[{name}({', '.join(head)}) => {'' if l.positive else '~'}{now}])")
        return "(" + " ^ ".join(parts) + ")" if len(parts) > 1 else parts[0]

    # -------------------------------------------------------------------------- the instance
    def instance_text(self) -> str:
        p, d = self.problem, self.domain
        name = self.ids(p.name)
        by_type: dict[str, list[str]] = {}
        for o in (*d.constants, *p.objects):
            by_type.setdefault(self.types(o.type), []).append(self.ids(o.name))
        empty = sorted(self._type_names() - set(by_type))
        if empty:
            raise UserError(f"problem {p.name}: type {empty[0]} has no objects (RDDL needs objects of every type)")
        static = [a for a in p.init if a.predicate not in self.fluents]
        static += [_atom(self._mark(l), l.atom.args) for l in self.goal if l.atom.args]
        fluent = [a for a in p.init if a.predicate in self.fluents]
        lines = _comment(p.comment)
        lines += [f"non-fluents nf_{name} {{", f"{INDENT}domain = {self.ids(d.name)};", f"{INDENT}objects {{"]
        lines += [f"{INDENT * 2}{t} : {{{', '.join(sorted(os))}}};" for t, os in sorted(by_type.items())]
        lines.append(f"{INDENT}}};")
        if static:
            lines += [f"{INDENT}non-fluents {{", *(f"{INDENT * 2}{self._ground(a)} = true;" for a in static),
                      f"{INDENT}}};"]
        lines += ["}", "", f"instance {name} {{", f"{INDENT}domain = {self.ids(d.name)};",
                  f"{INDENT}non-fluents = nf_{name};"]
        if fluent:
            lines += [f"{INDENT}init-state {{", *(f"{INDENT * 2}{self._ground(a)} = true;" for a in fluent),
                      f"{INDENT}}};"]
        lines += [f"{INDENT}max-nondef-actions = 1;", f"{INDENT}horizon = {self.options.horizon};",
                  f"{INDENT}discount = {real(self.options.discount)};", "}"]
        return "\n".join(lines) + "\n"

    def _ground(self, a: Atom) -> str:
        name = a.predicate if a.predicate in self._goal_marks() else self.ids(a.predicate)
        return f"{name}({', '.join(self.ids(x) for x in a.args)})" if a.args else name


def _comment(text: str, width: int = 100) -> list[str]:
    """``//`` comment lines of at most ``width`` characters, indentation kept."""
    out = []
    for line in (text or "").splitlines():
        pad = " " * (len(line) - len(line.lstrip()))
        out += ["// " + x for x in textwrap.wrap(line.lstrip(), width - 3, initial_indent=pad, subsequent_indent=pad + "  ",
                                                 break_long_words=False) or [""]]
    return out


def without_state_reward(domain: Domain, reward: Effect | None) -> Domain:
    """``domain`` with the state reward every action carries as its last effect
    (:func:`groundsym.export.with_reward`) taken off again, to be written once."""
    if reward is None:
        return domain
    actions = []
    for a in domain.actions:
        if not (isinstance(a.effect, AndEffect) and a.effect.effects and a.effect.effects[-1] == reward):
            raise ValueError(f"action {a.name} does not carry the state reward as its last effect")
        rest = a.effect.effects[:-1]
        actions.append(replace(a, effect=rest[0] if len(rest) == 1 else AndEffect(rest)))
    return replace(domain, actions=tuple(actions))


def rddl_files(domain: Domain, problem: Problem, state_reward: Effect | None = None,
               options: RddlOptions = RddlOptions(), derived: Sequence[Derived] = ()) -> dict[str, str]:
    """``domain.rddl`` and ``instance.rddl`` of a PPDDL domain and problem (``state_reward``: the
    reward every action of ``domain`` carries, written once; ``derived``: the rule set's derived
    predicates, declared as derived fluents)."""
    w = RddlWriter(without_state_reward(domain, state_reward), problem, state_reward, options, derived)
    return {"domain.rddl": w.domain_text(), "instance.rddl": w.instance_text()}


@dataclass(frozen=True)
class _ActionAtom:
    """The action fluent a change needs (written with the action's names, not as a formula)."""

    atom: Atom


def _atom(predicate: str, args: Sequence[str]) -> Atom:
    return Atom(predicate, tuple(args))


def _all_variables(domain: Domain) -> Iterator[str]:
    """Every variable name the domain's text uses, as RDDL writes it."""
    for a in domain.actions:
        yield from (variable(v) for v in re.findall(r"\?[^\s()]+", str(a)))
