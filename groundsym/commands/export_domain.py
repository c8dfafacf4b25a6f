"""``groundsym export-domain``: a learned model as a PPDDL domain and problem a person can read.

Predicates of learned symbols carry comments that say what each means geometrically; each NID
rule becomes an action (groundsym.ppddl.convert); the problem holds the objects and initial state
of a scene, a goal (given, or the highest-reward abstract state in the data) and the reward
model as reward effects. With ``--determinize`` plain PDDL for classical planners is written too.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..errors import UserError
from ..fileio import atomic_write_text, read_json
from ..logic import Atom, Literal, is_variable, parse_literal
from ..modeldir import SYMBOLS, Model, load_model
from ..ppddl.ast import And, AndEffect, Domain, Effect, ForallEffect, Not, Problem, RewardEffect, Typed, When
from ..ppddl.convert import NOISE_MODES, action_to_rule, probability, requirements, rules_equal, rules_to_domain
from ..ppddl.determinize import MODES, determinize
from ..ppddl.parser import parse_domain, parse_problem

NAME = "export-domain"
HELP = "write a learned model as PPDDL (domain.ppddl, problem.ppddl), optionally determinised PDDL too"
ORDER = 45


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("model", help="model directory (rules.json, reward.json, symbolic-traces.json, symbols.json)")
    p.add_argument("-o", "--output", required=True, help="directory to write domain.ppddl and problem.ppddl into")
    p.add_argument("--scene", metavar="FILE:TRACE:STEP",
                   help="initial state: the abstraction of this scene of a traces or symbolic traces file "
                        "(default: the first state of the model's first training trace)")
    p.add_argument("--goal", metavar="ATOMS",
                   help='goal literals, e.g. "(on o1 o2) (not (inhand o1))" (default: the highest-reward '
                        "abstract state in the data)")
    p.add_argument("--noise", choices=NOISE_MODES, default="no-change",
                   help="a rule's noise outcome: no change (default) or pessimistic (a dead end)")
    p.add_argument("--determinize", choices=MODES, help="also write plain domain.pddl and problem.pddl")
    p.add_argument("--name", default="learned", help="domain name (default: learned)")


# ------------------------------------------------------------------------------ predicate comments
def predicate_comments(model: Model) -> dict[str, str]:
    """What each learned predicate means geometrically: the symbol module's plain-words description
    (groundsym.describe, when present), then the RBF centre ± width per feature and the share of
    the data where it holds, from ``symbols.json``."""
    path = model.path / SYMBOLS
    if not path.exists():
        return {}
    doc = read_json(path)
    names = doc.get("feature_names") or []
    pair = doc.get("pair_feature_names") or [f"d{n}" for n in names]
    shares = {s["name"]: s["share"] for s in doc.get("symbols") or [] if isinstance(s.get("share"), (int, float))}
    words = _described(model, shares)
    out = {}
    for s in doc.get("symbols") or []:
        space = names if s.get("arity") == 1 else pair
        dims = ", ".join(f"{n}={c:.3g}±{w:.3g}" for n, c, w in zip(space, s.get("centre", []), s.get("widths", [])))
        what = "of one object" if s.get("arity") == 1 else "of an ordered pair (features of ?x1 minus ?x2)"
        share = f"; holds for {100 * shares[s['name']]:.1f}% of the data" if s["name"] in shares else ""
        plain = f"{words[s['name']]}; " if s["name"] in words else ""
        out[s["name"]] = f"{plain}learned RBF symbol {what}: centre±width {dims}{share}"
    return out


def _described(model: Model, shares: dict[str, float]) -> dict[str, str]:
    """``groundsym.describe`` lines by symbol name; {} when that module or the data is missing."""
    try:
        from ..describe import describe
        from ..symbols import dataset_arrays
    except ImportError:
        return {}
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
        return tr.objects, tr.states[0], f"the first state of the model's first training trace ({model.path})"
    parts = scene.rsplit(":", 2)
    if len(parts) != 3 or not parts[1].isdigit() or not parts[2].isdigit():
        raise UserError(f"--scene: expected FILE:TRACE:STEP, got {scene!r}")
    path, ti, si = parts[0], int(parts[1]), int(parts[2])
    doc = read_json(path)
    schema = doc.get("schema") if isinstance(doc, dict) else None
    if schema == "groundsym.symbolic-traces/1":
        from ..symbolic_traces import doc_to_dataset
        traces = doc_to_dataset(doc, path).traces
        tr = _pick(traces, ti, path, "traces")
        if si > len(tr):
            raise UserError(f"{path}: traces[{ti}]: has {len(tr) + 1} states, no step {si}")
        return tr.objects, tr.states[si], f"{path} trace {ti} step {si}"
    if schema == "groundsym.traces/1":
        from ..traces import read_traces
        symbols = model.symbols
        if symbols is None:
            raise UserError(f"{model.path}: no {SYMBOLS} to abstract the continuous scene of {path}")
        tr = _pick(read_traces(path).traces, ti, path, "traces")
        if si >= len(tr.scenes):
            raise UserError(f"{path}: traces[{ti}]: has {len(tr.scenes)} scenes, no step {si}")
        return tuple(tr.objects), symbols.abstract_scene(tr.scenes[si]), f"{path} trace {ti} step {si}"
    raise UserError(f"{path}: schema: expected a traces or symbolic traces file, got {schema!r}")


def _pick(items: list, i: int, path: str, field: str) -> Any:
    if i >= len(items):
        raise UserError(f"{path}: {field}: has {len(items)} traces, no trace {i}")
    return items[i]


# ------------------------------------------------------------------------------ goal
def parse_goal(text: str, predicates: dict[str, int], objects: tuple[str, ...]) -> list[Literal]:
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
def reward_effect(model: Model) -> Effect | None:
    """``r(s) = c + sum_k w_k #groundings(f_k)`` as effects: one ``forall .. when`` per feature, read
    in the state the action is taken in (the reward of that step's state)."""
    rm = model.reward
    parts: list[Effect] = []
    if rm.intercept != 0:
        parts.append(RewardEffect(probability(rm.intercept)))
    for f, w in zip(rm.features, rm.weights):
        if w == 0:
            continue
        vs = f.variables
        cond = list(f.atoms) + [Not(Atom("=", (u, v))) for i, u in enumerate(vs) for v in vs[i + 1:]]
        body: Effect = When(cond[0] if len(cond) == 1 else And(tuple(cond)), RewardEffect(probability(w)))
        parts.append(ForallEffect(tuple(Typed(v) for v in vs), body) if vs else body)
    return AndEffect(tuple(parts)) if parts else None


def with_reward(domain: Domain, effect: Effect | None) -> Domain:
    if effect is None:
        return domain
    actions = tuple(replace(a, effect=AndEffect((a.effect, effect))) for a in domain.actions)
    d = replace(domain, actions=actions)
    return replace(d, requirements=requirements(d))


# ------------------------------------------------------------------------------ the command
def run(args: argparse.Namespace) -> int:
    model = load_model(args.model)
    if not model.rules.rules:
        raise UserError(f"{args.model}: rules.json holds no rules (only default rules): nothing to export")
    predicates = dict(model.predicates)
    for r in model.rules.rules:
        for l in (*r.context, *(c for o in r.outcomes for c in o.changes)):
            predicates.setdefault(l.atom.predicate, l.atom.arity)
    if (model.path / SYMBOLS).exists():
        predicates.update(model.symbols.predicates)
    objects, state, source = initial_state(model, args.scene)
    for a in state:                       # a scene file may know predicates no rule uses
        predicates.setdefault(a.predicate, a.arity)
    if args.goal:
        goal, goal_note = parse_goal(args.goal, predicates, objects), "goal: given with --goal"
    else:
        goal, goal_note = derived_goal(model, objects)
    header = (f"NID rules of {model.path} as PPDDL (groundsym export-domain); one action per rule, "
              f"noise as {args.noise}")
    domain = rules_to_domain(model.rules, predicates, args.name, args.noise, predicate_comments(model), header)
    domain = with_reward(domain, reward_effect(model))
    reward_note = ("reward: the relational reward model is written as reward effects of every action"
                   if reward_effect(model) is not None else "reward: none (the model has no reward terms)")
    problem = Problem("scene", domain.name, tuple(Typed(o) for o in objects), tuple(sorted(state)),
                      (And(tuple(l.atom if l.positive else Not(l.atom) for l in goal)) if goal else None),
                      None, ("maximize", "reward") if ":rewards" in domain.requirements else None,
                      comment=f"initial state: {source}\n{goal_note}\n{reward_note}")
    _check_round_trip(model, domain, problem)
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a directory")
    atomic_write_text(out / "domain.ppddl", str(domain))
    atomic_write_text(out / "problem.ppddl", str(problem))
    written = ["domain.ppddl", "problem.ppddl"]
    if args.determinize:
        plain_d, plain_p = determinize(domain, problem, args.determinize)
        atomic_write_text(out / "domain.pddl", str(plain_d))
        written.append("domain.pddl")
        if plain_p is not None and plain_p.goal is not None:
            atomic_write_text(out / "problem.pddl", str(plain_p))
            written.append("problem.pddl")
        else:
            print(f"{out}: problem.pddl not written: {goal_note}", file=sys.stderr)
    print(f"{out}: wrote {', '.join(written)} ({len(domain.actions)} actions, {len(objects)} objects"
          f"{', no goal' if not goal else ''})")
    return 0


def _check_round_trip(model: Model, domain: Domain, problem: Problem) -> None:
    """The written text must parse back to the same rules: a bug here must not reach a user."""
    parsed = parse_domain(str(domain), "<exported domain>")
    parse_problem(str(problem), parsed, "<exported problem>")
    back = {a.name: action_to_rule(a) for a in parsed.actions}
    for prim_k, rule in _numbered(model.rules.rules):
        again = back.pop(prim_k, None)
        if again is None or not rules_equal(rule, again):
            raise RuntimeError(f"exported PPDDL does not read back as the model's rule {prim_k}")
    if back:
        raise RuntimeError(f"exported PPDDL has actions for no rule: {sorted(back)}")


def _numbered(rules: Any) -> list[tuple[str, Any]]:
    """(action name ``<primitive>_r<k>``, rule), as :func:`rules_to_domain` names them."""
    count: dict[str, int] = {}
    out = []
    for r in rules:
        count[r.action.predicate] = count.get(r.action.predicate, 0) + 1
        out.append((f"{r.action.predicate}_r{count[r.action.predicate]}", r))
    return out
