"""A learned model as a PPDDL domain and problem: what ``export-domain`` writes and the report shows.

Predicates of learned symbols carry comments that say what each means geometrically; each NID
rule becomes an action (:mod:`groundsym.ppddl.from_rules`); the problem holds the objects and
initial state of a scene, a goal (given, or the highest-reward abstract state in the data) and the
reward model as reward effects (docs/ppddl.md). :func:`build_export` checks that the text reads
back as the model's rules before anyone sees it; :func:`plain_export` determinises it (and
compiles it to STRIPS) for classical planners.

Why here and not in :mod:`groundsym.ppddl`: the export reads a model directory (its symbols,
traces and reward), which the PPDDL package knows nothing of; and not in the command, since
``groundsym report`` shows the same domain.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from fractions import Fraction
from pathlib import Path
from typing import Any, Callable

from .describe import describe
from .errors import UserError
from .fileio import read_json
from .logic import Atom, Literal, is_variable, parse_literal
from .modeldir import SYMBOLS, Model
from .ppddl.ast import (And, AndEffect, Domain, Effect, ForallEffect, Not, Problem, RewardEffect, Typed, When,
                        number)
from .ppddl.axioms import inline
from .ppddl.compare import context_key, rules_close
from .ppddl.determinize import determinize
from .ppddl.from_rules import RulesWriter
from .ppddl.operators import deepest_type, named_constants, operator_domain
from .ppddl.parser import parse_domain, parse_problem
from .ppddl.requirements import requirements
from .ppddl.rule_actions import rule_action_names
from .ppddl.strips import relaxed_reachable, to_strips
from .ppddl.to_rules import action_to_rule, domain_to_rules
from .reward import Feature
from .rules.model import drop_noise
from .symbolic_traces import object_types, symbolic_traces_from_doc
from .symbols import dataset_arrays
from .traces import read_traces

DECIMALS = 4                # decimals of an exported probability


@dataclass(frozen=True)
class ExportOptions:
    """What to export besides the model: the scene of the problem (``FILE:TRACE:STEP``; None: the
    first state of the model's first training trace), its goal (literals as text; None: the
    highest-reward abstract state in the data), the noise mode
    (:data:`groundsym.ppddl.rule_actions.NOISE_MODES`, or ``drop``), the domain's name, whether
    derived predicates are declared once as axioms (:mod:`groundsym.ppddl.axioms`) or written out,
    and whether to write one typed operator per action (:mod:`groundsym.ppddl.operators`)."""

    scene: str | None = None
    goal: str | None = None
    noise: str = "no-change"
    name: str = "learned"
    axioms: bool = False            # derived predicates as (:derived ...) axioms, declared once
    operators: bool = False


@dataclass(frozen=True)
class Export:
    """What ``export-domain`` writes, before it is written (the report shows the same domain)."""

    domain: Domain
    problem: Problem
    dropped: tuple[str, ...]
    objects: tuple[str, ...]
    goal: tuple[Literal, ...]
    goal_note: str
    reward: Effect | None = None       # the state reward every action carries (RDDL writes it once)


def build_export(model: Model, options: ExportOptions = ExportOptions(), where: str | Path | None = None) -> Export:
    """The domain and problem of ``model``, checked to read back as the model's rules. ``where``:
    the model as messages name it (the path the user gave; default ``model.path``)."""
    if not model.rules.rules:
        raise UserError(f"{model.path if where is None else where}: rules.json holds no rules (only default rules): "
                        "nothing to export")
    predicates = dict(model.predicates)
    for r in model.rules.rules:
        for l in (*r.context, *(c for o in r.outcomes for c in o.changes)):
            predicates.setdefault(l.atom.predicate, l.atom.arity)
    if (model.path / SYMBOLS).exists():
        predicates.update(model.symbols.predicates)
    objects, state, source = initial_state(model, options.scene)
    for a in state:                       # a scene file may know predicates no rule uses
        predicates.setdefault(a.predicate, a.arity)
    if options.goal is not None:         # --goal "" is a mistake to report, not a request for the default
        goal, goal_note = parse_goal(options.goal, predicates, objects), "goal: given with --goal"
    else:
        goal, goal_note = derived_goal(model, objects)
    reward = reward_effect(model)
    if options.noise == "drop":          # conditioned on "no noise" (docs/ppddl.md, Determinisation)
        model, options = replace(model, rules=drop_noise(model.rules)), replace(options, noise="no-change")
    if options.operators:
        return _operator_export(model, options, predicates, (objects, state, source), (goal, goal_note))
    writer = RulesWriter(model.rules, options.noise, DECIMALS, simple=True, drop_no_change=reward is None,
                         axioms=options.axioms)
    domain, dropped = writer.domain(predicates, options.name, predicate_comments(model), "")
    header = ["learned NID rules as PPDDL (groundsym export-domain): one action per rule",
              f"probabilities rounded to {DECIMALS} decimals; the mass an outcome list leaves unassigned is "
              + ("no change (the rule's noise)" if options.noise == "no-change" else "a dead end (noise-happened)"),
              "a precondition's last (and ...) lists the other rules of the action that must not apply"]
    if dropped:
        header.append(f"left out: {len(dropped)} rule(s) that can never apply (another rule always applies "
                      f"with them) or change nothing: {', '.join(dropped)}")
    domain = replace(with_reward(domain, reward), comment="\n".join(header + reward_words(model)))
    problem = Problem("scene", domain.name, tuple(Typed(o) for o in objects), tuple(sorted(state)),
                      (And(tuple(l.atom if l.positive else Not(l.atom) for l in goal)) if goal else None),
                      None, ("maximize", "reward") if ":rewards" in domain.requirements else None,
                      comment=f"initial state: {source}\n{goal_note}")
    _check_round_trip(model, domain, problem, dropped)
    return Export(domain, problem, dropped, objects, tuple(goal), goal_note, reward)


def _operator_export(model: Model, options: ExportOptions, predicates: dict[str, int], scene: tuple,
                     goal_of: tuple) -> Export:
    """``--operators``: one typed operator per action (:mod:`groundsym.ppddl.operators`); the
    problem's objects typed by their type atoms, which leave the initial state. No reward effects:
    the task is the goal, as in the planning benchmarks this form is for (docs/amlgym.md)."""
    (objects, state, source), (goal, goal_note) = scene, goal_of
    sds = model.symbolic_traces
    types = object_types(sds, model.path / "symbolic-traces.json") if sds is not None else {}
    constants = named_constants(model.rules, [state, *(s for tr in (sds.traces if sds else ()) for s in tr.states)],
                                types)
    domain = operator_domain(model.rules, predicates, name=options.name, types=types, noise=options.noise,
                             decimals=DECIMALS, constants=constants)
    kinds = {o: [a.predicate for a in state if a.arity == 1 and a.args[0] == o and a.predicate in types]
             for o in objects}
    problem = Problem("scene", domain.name, tuple(Typed(o, deepest_type(kinds[o], types)) for o in objects
                                                  if o not in constants),
                      tuple(sorted(a for a in state if a.predicate not in types)),
                      (And(tuple(l.atom if l.positive else Not(l.atom) for l in goal)) if goal else None),
                      None, ("maximize", "reward") if ":rewards" in domain.requirements else None,
                      comment=f"initial state: {source}\n{goal_note}")
    parse_problem(str(problem), parse_domain(str(domain), "<exported domain>"), "<exported problem>")
    return Export(domain, problem, (), objects, tuple(goal), goal_note)


# ------------------------------------------------------------------------------ predicate comments
def predicate_comments(model: Model) -> dict[str, str]:
    """What each learned predicate means, in words (groundsym.describe: only the dimensions that
    decide the symbol on the training data), and the share of the data where it holds."""
    path = model.path / SYMBOLS
    if not path.exists():
        return {}
    doc = read_json(path)
    shares = {s["name"]: s["share"] for s in doc.get("symbols") or [] if isinstance(s.get("share"), (int, float))}
    words = _described(model)
    out = {}
    for s in doc.get("symbols") or []:
        of = "objects" if s.get("arity") == 1 else "ordered pairs (?x1, ?x2)"
        share = f"; true for {100 * shares[s['name']]:.1f}% of {of} in the data" if s["name"] in shares else ""
        out[s["name"]] = f"{words.get(s['name'], 'a learned symbol')}{share}"
    return out


def _described(model: Model) -> dict[str, str]:
    """``groundsym.describe`` lines by symbol name, over the training data when there is some."""
    symbols = model.symbols
    features = pairs = None
    if model.traces is not None:
        try:
            features, pairs = dataset_arrays(model.traces)
        except UserError:        # traces of different sizes: describe without the data
            features = pairs = None
    lines = describe(symbols, features, pairs)
    return {s.name: line.split(": ", 1)[-1] for s, line in zip(symbols.symbols, lines)}


# ------------------------------------------------------------------------------ initial state
def initial_state(model: Model, scene: str | None) -> tuple[tuple[str, ...], frozenset, str]:
    """(objects, state, where it came from)."""
    if scene is None:
        sds = model.symbolic_traces
        if sds is None or not sds.traces:
            raise UserError(f"{model.path}: no symbolic-traces.json to take the initial state from; give --scene")
        tr = sds.traces[0]
        return tr.objects, tr.states[0], "the first state of the model's first training trace"
    parts = scene.rsplit(":", 2)
    if len(parts) != 3 or not parts[1].isdigit() or not parts[2].isdigit():
        raise UserError(f"--scene: expected FILE:TRACE:STEP, got {scene!r}")
    path, ti, si = parts[0], int(parts[1]), int(parts[2])
    doc = read_json(path)
    schema = doc.get("schema") if isinstance(doc, dict) else None
    if schema == "groundsym.symbolic-traces/1":
        traces = symbolic_traces_from_doc(doc, path).traces
        tr = _pick(traces, ti, path, "traces")
        if si > len(tr):
            raise UserError(f"{path}: traces[{ti}]: has {len(tr) + 1} states, no step {si}")
        return tr.objects, tr.states[si], f"{Path(path).name} trace {ti} step {si}"
    if schema == "groundsym.traces/1":
        symbols = model.symbols
        if symbols is None:
            raise UserError(f"{model.path}: no {SYMBOLS} to abstract the continuous scene of {path}")
        tr = _pick(read_traces(path).traces, ti, path, "traces")
        if si >= len(tr.scenes):
            raise UserError(f"{path}: traces[{ti}]: has {len(tr.scenes)} scenes, no step {si}")
        return tuple(tr.objects), symbols.abstract_scene(tr.scenes[si]), f"{Path(path).name} trace {ti} step {si}"
    raise UserError(f"{path}: schema: expected a traces or symbolic traces file, got {schema!r}")


def _pick(items: list, i: int, path: str, field: str) -> Any:
    """``items[i]``, or an error naming the file and how many traces it has."""
    if i >= len(items):
        raise UserError(f"{path}: {field}: has {len(items)} traces, no trace {i}")
    return items[i]


# ------------------------------------------------------------------------------ goal
def parse_goal(text: str, predicates: dict[str, int], objects: tuple[str, ...]) -> list[Literal]:
    """``--goal`` text (literals like ``(on o1 o2) (not (inhand o1))``) over the known predicates
    and the scene's objects; one error line naming what is wrong, and a goal no state reaches."""
    lits = []
    depth, start = 0, None
    for i, ch in enumerate(text):
        if ch == "(":
            if depth == 0:
                start = i
            depth += 1
        elif ch == ")":
            depth -= 1
            if depth == 0 and start is not None:
                lits.append(text[start:i + 1])
            if depth < 0:
                break
        elif depth == 0 and not ch.isspace():
            depth = -1
            break
    if depth != 0 or not lits:
        raise UserError(f"--goal: expected literals like \"(on o1 o2) (not (inhand o1))\", got {text!r}")
    out = []
    for t in lits:
        try:
            lit = parse_literal(t)
        except ValueError as exc:
            raise UserError(f"--goal: {exc}") from None
        a = lit.atom
        if a.predicate not in predicates:
            raise UserError(f"--goal: unknown predicate {a.predicate!r} in {t} (known: {', '.join(sorted(predicates))})")
        if predicates[a.predicate] != a.arity:
            raise UserError(f"--goal: {a.predicate} takes {predicates[a.predicate]} argument(s), got {t}")
        if any(is_variable(x) or x not in objects for x in a.args):
            raise UserError(f"--goal: {t} names an object that is not in the scene ({', '.join(objects)})")
        out.append(lit)
    clash = {l.atom for l in out if l.positive} & {l.atom for l in out if not l.positive}
    if clash:
        raise UserError(f"--goal: {min(map(str, clash))} is both required and forbidden: no state reaches this goal")
    return out


def derived_goal(model: Model, objects: tuple[str, ...]) -> tuple[list[Literal], str]:
    """The highest-reward abstract state in the data over the scene's objects, as literals, or
    ([], why) when there is none to take (constant reward, no data)."""
    sds = model.symbolic_traces
    if sds is None:
        return [], "no goal: the model directory has no symbolic-traces.json to derive one from"
    scored = [(r, s) for tr in sds.traces for s, r in
              zip(tr.states, [*tr.rewards, *([tr.final_reward] if tr.final_reward is not None else [])])]
    rewards = [r for r, _ in scored]
    if not scored or max(rewards) - min(rewards) <= 1e-12 * max(1.0, abs(max(rewards))):
        return [], (f"no goal: the reward is constant ({rewards[0]:g}) in the data, so no state is better "
                    "than another" if scored else "no goal: the data holds no states")
    keep = {a.predicate for f in model.reward.features for a in f.atoms}
    best = max(r for r, s in scored if all(x in objects for a in s for x in a.args)) \
        if any(all(x in objects for a in s for x in a.args) for _, s in scored) else None
    if best is None:
        return [], "no goal: no state of the data is over this scene's objects"
    state = next(s for r, s in scored if r == best and all(x in objects for a in s for x in a.args))
    atoms = sorted(a for a in state if not keep or a.predicate in keep)
    if not atoms:
        return [], (f"no goal: the highest-reward abstract state in the data (reward {best:.4g}) has no true atoms"
                    + (" over the reward model's predicates" if keep else "") + ", so there is nothing to reach")
    note = (f"goal: the highest-reward abstract state in the data (reward {best:.4g} of "
            f"{min(rewards):.4g}..{max(rewards):.4g})" + (", restricted to the reward model's predicates" if keep else ""))
    return [Literal(a) for a in atoms], note


# ------------------------------------------------------------------------------ reward effects
REWARD_DIGITS = 4           # significant digits of an exported reward term
REWARD_DROP = 1e-3          # terms smaller than this share of the largest are left out


@dataclass(frozen=True)
class RewardTerms:
    """The reward model as exported: rounded, with the negligible terms left out; ``constant``:
    the one reward of every training state, when they are all equal (then nothing is exported)."""

    intercept: Fraction
    terms: tuple[tuple[Feature, Fraction], ...]
    dropped: int
    constant: float | None = None


def constant_training_reward(model: Model) -> float | None:
    """The reward every state of the training data has, when they are all equal (a domain
    without rewards); None when they differ or the model has no symbolic traces."""
    sds = model.symbolic_traces
    rewards = [] if sds is None else [r for tr in sds.traces for r in
                                      [*tr.rewards, *([tr.final_reward] if tr.final_reward is not None else [])]]
    if not rewards or max(rewards) - min(rewards) > 1e-12 * max(1.0, abs(max(rewards))):
        return None
    return rewards[0]


def reward_terms(model: Model) -> RewardTerms:
    """The model's reward as the export states it (:data:`REWARD_DIGITS`, :data:`REWARD_DROP`);
    nothing where the training rewards are all equal: a fit to one value has only terms of
    rounding noise (REWARD_DROP is relative to the largest term, so all-tiny terms would survive)."""
    rm = model.reward
    constant = constant_training_reward(model)
    if constant is not None:
        nonzero = sum(1 for x in (rm.intercept, *rm.weights) if x != 0)
        return RewardTerms(Fraction(0), (), nonzero, constant)
    big = max([abs(rm.intercept), *(abs(w) for w in rm.weights)], default=0.0)

    def kept(x: float) -> bool:
        return x != 0 and abs(x) >= REWARD_DROP * big

    def rounded(x: float) -> Fraction:
        return Fraction(f"{x:.{REWARD_DIGITS}g}")

    terms = tuple((f, rounded(w)) for f, w in zip(rm.features, rm.weights) if kept(w))
    dropped = sum(1 for x in (rm.intercept, *rm.weights) if x != 0 and not kept(x))
    return RewardTerms(rounded(rm.intercept) if kept(rm.intercept) else Fraction(0), terms, dropped)


def reward_effect(model: Model) -> Effect | None:
    """``r(s) = c + sum_k w_k #groundings(f_k)`` as effects: one ``forall .. when`` per feature, read
    in the state the action is taken in (the reward of that step's state)."""
    rt = reward_terms(model)
    parts: list[Effect] = []
    if rt.intercept != 0:
        parts.append(RewardEffect(rt.intercept))
    for f, w in rt.terms:
        vs = f.variables
        cond = list(f.atoms) + [Not(Atom("=", (u, v))) for i, u in enumerate(vs) for v in vs[i + 1:]]
        body: Effect = When(cond[0] if len(cond) == 1 else And(tuple(cond)), RewardEffect(w))
        parts.append(ForallEffect(tuple(Typed(v) for v in vs), body) if vs else body)
    return AndEffect(tuple(parts)) if parts else None


_GROUPS = {1: "object", 2: "pair", 3: "triple"}


def reward_words(model: Model) -> list[str]:
    """The reward model once, in words, for the domain's header comment."""
    rt = reward_terms(model)
    if rt.intercept == 0 and not rt.terms and not rt.dropped:
        return ["reward: none (the model has no reward terms)"]
    if rt.constant is not None:
        return [f"reward: none (every training state has reward {rt.constant:g}, so no reward tells states apart; "
                f"the model's {rt.dropped} fitted term(s) left out)"]
    lines = ["reward of a step, read in the state the action is taken in (every action carries it as "
             "reward effects):", f"  r = {number(rt.intercept)}"]
    for f, w in rt.terms:
        vs = f.variables
        atoms = " ".join(str(a) for a in f.atoms)
        what = (f"if {atoms}" if not vs else
                f"for each {_GROUPS.get(len(vs), f'{len(vs)}-tuple')} ({' '.join(vs)})"
                + (" of distinct objects" if len(vs) > 1 else "") + f" with {atoms}")
        lines.append(f"    {'+' if w >= 0 else '-'} {number(abs(w))} {what}")
    lines.append(f"  (terms rounded to {REWARD_DIGITS} significant digits"
                 + (f"; {rt.dropped} below 1/1000 of the largest left out)" if rt.dropped else ")"))
    return lines


def with_reward(domain: Domain, effect: Effect | None) -> Domain:
    """``domain`` with ``effect`` (:func:`reward_effect`) added to every action's effect, and the
    requirements it then uses."""
    if effect is None:
        return domain
    actions = tuple(replace(a, effect=AndEffect((a.effect, effect))) for a in domain.actions)
    d = replace(domain, actions=actions)
    return replace(d, requirements=requirements(d))


# ------------------------------------------------------------------------------ the round trip
def _check_round_trip(model: Model, domain: Domain, problem: Problem, dropped: tuple[str, ...]) -> None:
    """The written text must parse back to the model's rules, within the rounding of the
    probabilities; a rule that was left out must come back as a blocking rule. A bug here must
    not reach a user."""
    parsed = parse_domain(str(domain), "<exported domain>")
    parse_problem(str(problem), parsed, "<exported problem>")
    back = {a.name: action_to_rule(a) for a in parsed.actions}
    blocking = {context_key(r) for r in domain_to_rules(parsed).rules}
    for prim_k, rule in zip(rule_action_names(model.rules.rules), model.rules.rules):
        if prim_k in dropped:
            if context_key(rule) not in blocking and any(not o.is_empty for o in rule.outcomes):
                raise RuntimeError(f"exported PPDDL does not block where the left-out rule {prim_k} does")
            continue
        again = back.pop(prim_k, None)
        tol = 10.0 ** -DECIMALS * (len(rule.outcomes) + 1)
        if again is None or not rules_close(rule, again, tol):
            raise RuntimeError(f"exported PPDDL does not read back as the model's rule {prim_k}")
    if back:
        raise RuntimeError(f"exported PPDDL has actions for no rule: {sorted(back)}")


# ------------------------------------------------------------------------------ for classical planners
def plain_export(domain: Domain, problem: Problem, mode: str, strips: bool,
                 warn: Callable[[str], None]) -> tuple[Domain, Problem | None]:
    """The determinised (``mode``: one of :data:`groundsym.ppddl.determinize.MODES`; with
    ``strips`` also compiled to STRIPS) domain and problem. ``warn`` is told, as each step finds
    it, what makes the result useless to a classical planner (no actions; a goal that cannot be
    reached): told at once, so a user hears it before a later step fails, and so ``warn`` may
    raise to stop there (``--strict``)."""
    plain_d, plain_p = determinize(domain, problem, mode)
    if not plain_d.actions:
        warn(f"the {mode} determinisation has no actions (no rule changes anything): "
             "a classical planner can do nothing with it")
    if strips:
        plain_d, plain_p = to_strips(inline(plain_d), plain_p)
    if plain_p is not None and plain_p.goal is not None and plain_d.actions:
        if relaxed_reachable(inline(plain_d), plain_p) is False:
            warn("the goal cannot be reached from the initial state even with delete effects and negative "
                 "conditions ignored "
                 f"(relaxed reachability over the {mode} determinisation)")
    return plain_d, plain_p
