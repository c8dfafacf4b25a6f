"""Learning rules from successful-only traces: plans and demonstrations, where no action ever fails.

The NID search (:mod:`groundsym.rules.learner`) adds a context literal only where the data show the
action failing without it; a trace of successful actions shows no failure, so every context there
stays ``(always)``. Here the context of an action is instead the *most specific* set of literals
over its arguments that the examples support, as SAM's safe preconditions (Juba, Le & Stern 2021,
"Safe learning of lifted action models", KR): a literal is kept when it holds in (nearly) every
example of the action. Under observation noise a true precondition is seen false now and then,
so literals are kept by *frequency* with a threshold, as NOLAM's model of noisy traces does
(Lamanna & Serafini 2024, ICAPS); the threshold is chosen on held-out examples (below).
Effects are the lifted changes seen often enough; the rule's outcomes and their probabilities are
then induced on the examples as for any NID rule (:func:`induce_outcomes`), so stochastic
actions keep several outcomes and a noise outcome (docs/rules.md, Successful-only traces).

Choosing the threshold and the noise rate: :mod:`groundsym.rules.frequency`. Negated literals the
context's positive literals already exclude in every observed state are left out (state
invariants, as mutexes).

Types: a unary predicate named in ``types`` is an object type (static, from the trace file); a
literal over it is kept positive only (the operator's parameter type) and only when it holds in
every example, noise or not: types are declared with the objects, not observed, so a type seen in
most examples is a coincidence of the data (depots' ``lift`` from a pallet in most steps at 5%
noise became a lift from pallets only, and 2 of 3 problems unsolvable); and a negated literal whose
atom is badly typed (its predicate never holds for objects of those types in the data) is never
offered, so ``(not (on ?x ?y))`` appears only where ``on`` can hold at all.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..logic import Atom, Literal, is_variable
from .contexts import atoms_over
from .coverage import Coverage, Example, ExampleTable
from .frequency import THRESHOLDS, accept_frequency, choose_threshold, context_mask, noise_rate
from .language import types_of
from .learner import DEFAULT_CLIP, LearnReport, RuleFit, _smooth
from .model import P_MIN, P_MIN_DEFAULT, DefaultRule, Outcome, Rule, RuleSet, _bindings
from .outcomes import induce_outcomes



@dataclass(frozen=True)
class SuccessOptions:
    """Knobs of successful-only learning (docs/rules.md, Successful-only traces). ``threshold``
    fixes the frequency a context literal needs (None: chosen on held-out examples from
    ``thresholds``); ``holdout`` is the share of examples held out for that choice; ``slack`` the
    held-out log-likelihood (nats) a lower (more specific) threshold may lose; ``effect_share`` the share of the
    examples where a lifted change could show in which it must show to be an effect; ``negative``
    offers negated context literals (False for a language without negative preconditions: a PDDL
    domain whose requirements lack ``:negative-preconditions``, see :func:`learn_from_successes`)."""

    threshold: float | None = None
    thresholds: tuple[float, ...] = THRESHOLDS
    holdout: float = 0.3
    slack: float = 1.0
    effect_share: float = 0.1
    alpha: float = 0.5
    p_min: float = P_MIN
    p_min_default: float = P_MIN_DEFAULT
    nochange_prior: float = 0.5
    prune: bool = True
    negative: bool = True


def has_failures(examples: Sequence[Example]) -> bool:
    """Does some action leave the state unchanged (a failure, or an action that does nothing)?"""
    return any(not e.changed for e in examples)


@dataclass
class _ActionData:
    """One action's examples over its own arguments: the candidate literals, whether each holds
    (``truth``: examples x literals) and the lifted changes seen."""

    name: str
    variables: tuple[str, ...]
    literals: list[Literal]
    truth: np.ndarray
    weights: np.ndarray
    reduced: list[Example] = field(default_factory=list)
    n_types: int = 0
    changes: tuple = ()                       # (examples, atoms, before, after) for the effects
    effects: tuple = ()                       # masks over those atoms: (added, deleted)


def learn_from_successes(examples: Sequence[Example], predicates: dict[str, int], types: Sequence[str] = (),
                         options: SuccessOptions = SuccessOptions(), *, seed: int = 0,
                         constants: Sequence[str] = ()) -> tuple[RuleSet, LearnReport]:
    """One rule per action name: the frequency context, its induced outcomes, a default rule.

    ``constants``: objects a context may name beside the action's arguments (PDDL's
    ``:constants``: childsnack's ``put_on_tray`` needs ``(at ?t kitchen)``); they are the same
    object in every example, so a literal over them is as safe as one over the arguments.
    ``options.negative`` False keeps every context positive: data of successful actions cannot
    tell a negated precondition from a literal that plans merely never contradict (a plan never
    boards a passenger twice), so where the domain's language has no negative preconditions
    (its requirements lack ``:negative-preconditions``, as in every AMLGym domain) none is
    offered; OffLAM (Lamanna et al. 2025) makes the same assumption for every domain."""
    types = frozenset(types)
    sig = _signatures(examples, types)
    groups: dict[tuple[str, int], list[Example]] = {}
    for e in examples:
        groups.setdefault((e.action.predicate, e.action.arity), []).append(e)
    consts = tuple(sorted(set(constants)))
    data = [_action_data(name, arity, groups[(name, arity)], predicates, types, sig, consts, options.negative)
            for name, arity in sorted(groups)]
    eps = noise_rate(examples, types, sig, consts)
    for d in data:                   # a change noise alone explains is no effect
        _reduce_all(d, max(options.effect_share, 3 * eps), types, eps)
    if options.threshold is not None:
        theta, curve = options.threshold, {}
    elif eps == 0:                   # noise-free: SAM's safe preconditions, nothing to choose
        theta, curve = 1.0, {}
    else:
        theta, curve = choose_threshold([(d.truth, d.weights) for d in data], options.thresholds, options.holdout,
                                        options.slack, np.random.default_rng(seed))
    rules, defaults, report = [], [], LearnReport()
    index = _state_index(examples, types)
    for d in data:
        rule, default, stats = _fit_action(d, theta, options, index, eps)
        if rule is not None:
            rules.append(rule)
        defaults.append((d.name, default))
        report.per_action[d.name] = {**stats, "heldout_threshold": theta, "noise": eps, "heldout_loglik": curve}
    return RuleSet(tuple(rules), tuple(defaults), options.p_min, options.p_min_default, True, ()), report


def _signatures(examples: Sequence[Example], types: frozenset) -> dict[tuple[str, int], set[frozenset]]:
    """For each (predicate, position): the types of the objects seen there, each object's as the
    set of its type atoms (a type and its ancestors; ``object`` without types). A negated literal
    is offered only where its atom is well typed by these."""
    sig: dict[tuple[str, int], set[frozenset]] = {}
    for e in examples:
        for s in (e.state, e.succ):
            kinds = types_of(s, types)
            for a in s:
                if a.predicate not in types:
                    for k, o in enumerate(a.args):
                        sig.setdefault((a.predicate, k), set()).add(frozenset(kinds.get(o, {"object"})))
    return sig


def _action_data(name: str, arity: int, examples: list[Example], predicates: dict[str, int], types: frozenset,
                 sig: dict, constants: tuple[str, ...] = (), negative: bool = True) -> _ActionData:
    variables = tuple(f"?x{i + 1}" for i in range(arity))
    fluents = {p: k for p, k in predicates.items() if p not in types}
    atoms = atoms_over(variables + constants, fluents, True)
    kept = list(examples)        # also (move r1 a a): in PDDL parameters may repeat, and such an
    #                              example says "(not (at ?r ?to))" is no precondition
    lits = [Literal(Atom(t, (v,)), True) for t in sorted(types) for v in variables] + \
        [Literal(a, s) for a in atoms for s in (True, False)]
    truth = np.zeros((len(kept), len(lits)), dtype=bool)
    before = np.zeros((len(kept), len(atoms)), dtype=bool)
    after = np.zeros_like(before)
    for i, e in enumerate(kept):
        ground = dict(zip(variables, e.action.args))
        kinds = types_of(e.state, types)
        for j, a in enumerate(atoms):
            g = a.substitute(ground)
            before[i, j], after[i, j] = g in e.state, g in e.succ
        typed = np.array([all(frozenset(kinds.get(ground.get(v, v), {"object"})) in sig.get((a.predicate, k), set())
                              for k, v in enumerate(a.args)) for a in atoms], dtype=bool)
        nt = len(types) * arity
        truth[i, :nt] = [ground[l.atom.args[0]] in {o for o, ks in kinds.items() if l.atom.predicate in ks}
                         for l in lits[:nt]]
        truth[i, nt::2] = before[i]
        truth[i, nt + 1::2] = ~before[i] & typed & negative
    w = np.array([e.weight for e in kept], dtype=float)
    return _ActionData(name, variables, lits, truth, w, [], len(types) * arity, (kept, atoms, before, after))


def _reduce_all(d: _ActionData, share: float, types: frozenset, eps: float = 0.0) -> None:
    """``d.reduced``: its examples over the action's arguments, changes below ``share`` (or that
    flips at rate ``eps`` explain) dropped."""
    kept, atoms, before, after = d.changes
    effects = d.effects = _effects(atoms, before, after, d.weights, share, eps)
    d.reduced = [_reduce(e, d.variables, atoms, before[i], after[i], effects, types) for i, e in enumerate(kept)
                 if len(set(e.action.args)) == len(e.action.args)]   # outcomes: NID's injective bindings


def _effects(atoms: list[Atom], before: np.ndarray, after: np.ndarray, w: np.ndarray, share: float,
             eps: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Masks of the atoms whose addition (deletion) shows in at least ``share`` of the examples
    where it could show (the atom false before; true before): the effects, with changes that noise
    alone explains left out (``share`` is at least three times the estimated noise). With flips
    (``eps`` > 0) a change must also show in more than half of the steps where it could: an
    effect shows there with chance ``1 - eps``, a flip with chance about ``eps``, so the
    likelihood favours the effect exactly then. Rovers' ``communicate_rock_data`` (10 steps at 5%)
    showed ``(can_traverse ?r ?p ?x)`` deleted in 2 of 8 such steps: a share of 0.25, no effect."""
    cut = max(share, 0.5 + 1e-9) if eps > 0 else share

    def frac(could: np.ndarray, did: np.ndarray) -> np.ndarray:
        den, num = w @ could, w @ (could & did)
        often = num >= share * w.sum()   # and in that share of all the examples: a rarely true atom
        return np.where((den > 0) & often, num / np.maximum(den, 1e-300), 0.0)   # flipped back is noise
    return frac(~before, after) >= cut, frac(before, ~after) >= cut


def _reduce(e: Example, variables: tuple[str, ...], atoms: list[Atom], before: np.ndarray, after: np.ndarray,
            effects: tuple[np.ndarray, np.ndarray], types: frozenset) -> Example:
    """The example over the action's arguments alone: its state there, and its successor with only
    the effect changes applied (changes elsewhere, or that noise explains, are dropped)."""
    adds, dels = effects
    ground = dict(zip(variables, e.action.args))
    args = set(e.action.args)
    state = frozenset([a.substitute(ground) for a, b in zip(atoms, before) if b]
                      + [a for a in e.state if a.predicate in types and a.arity == 1 and a.args[0] in args])
    add = {a.substitute(ground) for a, b, c, m in zip(atoms, before, after, adds) if m and c and not b}
    rm = {a.substitute(ground) for a, b, c, m in zip(atoms, before, after, dels) if m and b and not c}
    return Example(state, e.action, (state - rm) | add, tuple(e.action.args), e.weight)


def _state_index(examples: Sequence[Example], types: frozenset) -> tuple[list[frozenset], list[dict]]:
    """The distinct observed states (types left out), and each as predicate -> argument tuples."""
    seen = {frozenset(a for a in s if a.predicate not in types) for e in examples for s in (e.state, e.succ)}
    states = sorted(seen, key=sorted)
    index = []
    for s in states:
        by: dict[str, list[tuple[str, ...]]] = {}
        for a in s:
            by.setdefault(a.predicate, []).append(a.args)
        index.append(by)
    return states, index


def _implied(pos: tuple[Literal, ...], neg: Atom, bound: list[tuple[dict, list[dict[str, str]]]],
             tolerance: float) -> bool:
    """Wherever the positive literals ``pos`` hold together in an observed state (``bound``: each
    state's index and the bindings of ``pos`` in it), ``neg`` is false (for every object its
    other variables could take), but as often as noise at rate ``tolerance`` explains:
    ``(holding ?x)`` excludes ``(handempty)``; ``(power_on ?i) (on_board ?i ?s)`` excludes
    ``(power_avail ?s)``. Parameters need not differ (PDDL), except where ``pos`` itself keeps them
    apart: ``sail ?from ?to`` alone keeps ``(not (at-ferry ?to))``, beside ``(not-eq ?from ?to)`` it goes."""
    free = [k for k, v in enumerate(neg.args) if not any(v in l.atom.args for l in pos)]
    fan = 1
    for k in free:                  # the groundings of the negated atom's other variables
        fan *= max(1, len({qargs[k] for by, _ in bound for qargs in by.get(neg.predicate, ())}))
    seen = both = 0
    for by, binds in bound:
        seen += len(binds)
        both += sum(any(_extends(b, neg.args, qargs) for qargs in by.get(neg.predicate, ())) for b in binds)
    # noise makes some grounding of the free variables true now and then: 1 - (1 - r)^fan
    return seen > 0 and both <= 3 * (1 - (1 - tolerance) ** fan) * seen


def _extends(b: dict[str, str], variables: tuple[str, ...], args: tuple[str, ...]) -> bool:
    """Do ``args`` fit ``variables`` under ``b`` (new variables take any object)?"""
    b = dict(b)
    return all(b.setdefault(v, x) == x for v, x in zip(variables, args))


def _prune(ctx: list[Literal], types: set[str], states: list[frozenset], index: list,
           tolerance: float) -> list[Literal]:
    """``ctx`` without the negated literals its positive literals already exclude in the observed
    states (state invariants, as mutexes): the operator a reader (and a benchmark) expects,
    ``pick-up: (clear ?x) (ontable ?x) (handempty)`` rather than also ``(not (holding ?x))``."""
    pos = tuple(l for l in ctx if l.positive and l.atom.predicate not in types)
    if not pos:
        return ctx
    out = ctx
    if not all(l.positive for l in ctx):
        bound = [(by, list(_bindings(pos, state, {}, False, None, 10 ** 6))) for state, by in zip(states, index)]
        out = [l for l in ctx if l.positive or not _implied(pos, l.atom, bound, tolerance)]
    return [l for l in out if not _mirrored(l, [l.atom for l in pos], index)]


def _mirrored(lit: Literal, pos: list[Atom], index: list) -> bool:
    """``lit`` is ``(p ?b ?a)`` beside ``(p ?a ?b)`` (parameters in order) and ``p`` is symmetric in
    every observed state: ferry's ``(not-eq ?to ?from)`` says nothing ``(not-eq ?from ?to)`` does not."""
    a = lit.atom
    if not lit.positive or a.arity != 2 or a.args[0] <= a.args[1] or Atom(a.predicate, a.args[::-1]) not in pos:
        return False
    return all((y, x) in set(by.get(a.predicate, ())) for by in index for x, y in by.get(a.predicate, ()))


def _fit_action(d: _ActionData, theta: float, o: SuccessOptions, index: list, eps: float = 0.0
                ) -> tuple[Rule | None, DefaultRule, dict]:
    """The action's rule (context at ``theta``, outcomes induced on what it covers), its default.

    Where no injective example meets the context (noise and few such examples: rovers'
    ``communicate_*`` repeat a waypoint in most steps) the context stays, as it rests on every
    step, and the outcome is SAM's lifted one, as where no step is injective. Falling back to a
    noise-free context instead dropped every literal seen false once, and the operator applied
    where the true one does not (rovers at 5%: false plans 0.33; tests/test_successful_repeated.py)."""
    lo, hi = DEFAULT_CLIP
    accept = theta if o.threshold is not None else accept_frequency(theta, eps, d.weights)
    stats = {"rules": 0, "examples": len(d.reduced), "transitions": float(d.weights.sum()), "score": 0.0,
             "threshold": accept}
    if not len(d.weights):
        return None, DefaultRule(0.5), stats
    keep = context_mask(d.truth, d.weights, accept)
    keep[:d.n_types] = context_mask(d.truth[:, :d.n_types], d.weights, 1.0)   # types are declared, not observed:
    ctx = [l for l, m in zip(d.literals, keep) if m]                     # no noise excuses a wrong one
    if o.prune:
        ctx = _prune(ctx, {l.atom.predicate for l in d.literals[:d.n_types]}, *index, eps)
    ctx = tuple(sorted(ctx))
    if not d.reduced:             # every example repeats an argument (tpp's levels): no injective
        return _lifted_rule(d, ctx, accept), DefaultRule(0.5), {**stats, "rules": 1}   # binding for NID's outcomes
    named = tuple(sorted({x for l in ctx for x in l.atom.args if not is_variable(x)}))
    table, action, table_ctx = _table(d, ctx, named)
    cov: Coverage = table.cover(action, table_ctx, True)
    if not len(cov) and accept < 1.0:   # no injective example meets the frequent literals together
        return _lifted_rule(d, ctx, accept), DefaultRule(0.5), {**stats, "rules": 1}
    rest = np.ones(len(table), dtype=bool)
    rest[cov.index] = False
    wr, ch = table.weights[rest], table.changed[rest]
    default = DefaultRule(float(np.clip(wr[ch].sum() / wr.sum(), lo, hi)) if wr.sum() > 0 else 0.5)
    if not len(cov):
        return None, default, stats
    of = induce_outcomes(table, cov, o.alpha, o.p_min)
    back = {v: c for v, c in zip(action.args[len(d.variables):], named)}
    outcomes = tuple(Outcome(tuple(l.substitute(back) for l in out.changes)) for out in of.outcomes)
    rule = Rule(Atom(d.name, d.variables), ctx, outcomes, of.probs, of.noise, of.noise_changes)
    n = float(table.weights[cov.index].sum())
    fit = _smooth(RuleFit(rule, frozenset(cov.index.tolist()), of.loglik, n), o.nochange_prior)
    stats.update(rules=1, score=of.loglik - o.alpha * rule.complexity(), covered=n)
    return (_misobserved_nochange(fit.rule) if eps > 0 else fit.rule), default, stats


def _misobserved_nochange(rule: Rule) -> Rule:
    """``rule`` with its "no change" outcome's mass moved to the noise outcome: every step of a
    successful-only trace changed the state (the mode's premise), so on noisy data a step whose
    effects all failed to show was misobserved. Left as an outcome it can take the most mass in an
    action seen a few times (barman's ``clean_shaker`` at 5% flips: 3 steps, one with its effect
    flipped, plus the smoothing's pseudo-count), and the most-likely determinisation then drops
    every effect of the action. Noise-free data keep NID's smoothing outcome as it is."""
    if Outcome() not in rule.outcomes:
        return rule
    k = rule.outcomes.index(Outcome())
    noise = rule.noise + rule.probs[k]            # the moved steps changed no atom: the mean shrinks
    return Rule(rule.action, rule.context, rule.outcomes[:k] + rule.outcomes[k + 1:],
                rule.probs[:k] + rule.probs[k + 1:], noise, rule.noise_changes * rule.noise / noise)


def _lifted_rule(d: _ActionData, ctx: tuple[Literal, ...], accept: float) -> Rule:
    """SAM's rule where no example binds the action's arguments injectively (PDDL lets them
    coincide, NID's outcome induction does not): one deterministic outcome, the lifted changes
    that :func:`_effects` found and that hold afterwards in (at least ``accept`` of) the examples;
    where arguments coincide a change fits several lifted atoms, and only the one that is an
    effect holds after every step (tpp's ``(loaded ?p ?v ?l4)``, not ``(loaded ?p ?v ?l5)``)."""
    _, atoms, _, after = d.changes
    share = (d.weights @ after) / d.weights.sum()
    adds, dels = d.effects
    adds, dels = adds & (share >= accept - 1e-12), dels & (1.0 - share >= accept - 1e-12)
    changes = [Literal(a, True) for a, m in zip(atoms, adds) if m] + \
              [Literal(a, False) for a, m in zip(atoms, dels) if m]
    return Rule(Atom(d.name, d.variables), ctx, (Outcome(tuple(changes)),), (1.0,), 0.0)


def _table(d: _ActionData, ctx: tuple[Literal, ...], named: tuple[str, ...]
           ) -> tuple[ExampleTable, Atom, tuple[Literal, ...]]:
    """The action's reduced examples as a coverage table, with the action template and context
    it is queried with. Constants the context names (``named``) become extra action arguments
    bound to themselves in every example (the table binds variables only); an example whose own
    argument is such a constant then has repeated arguments and stays uncovered (the default
    rule's), as NID's injective bindings want. Atoms over constants the context does not name
    are left out: they are no effect the operator can state over its parameters."""
    cvars = tuple(f"?k{i + 1}" for i in range(len(named)))
    merged: dict[tuple, float] = {}
    for e in d.reduced:
        objects = tuple(dict.fromkeys(e.objects + named))
        known = set(objects)
        state, succ = (frozenset(a for a in s if set(a.args) <= known) for s in (e.state, e.succ))
        key = (state, Atom(e.action.predicate, e.action.args + named), succ, objects)
        merged[key] = merged.get(key, 0.0) + e.weight
    table = ExampleTable([Example(*k, w) for k, w in merged.items()], {l.atom.predicate: l.atom.arity
                                                                        for l in d.literals})
    ren = dict(zip(named, cvars))
    return table, Atom(d.name, d.variables + cvars), tuple(l.substitute(ren) for l in ctx)
