"""Learning NID rule sets from symbolic transitions (LearnRuleSet of Pasula, Zettlemoyer & Kaelbling 2007; docs/algorithms.md, Learning a rule set).

Learning runs separately for each action name: the score adds up across actions, so each
search is small. A search starts from the default rule alone and applies the operators
ExplainExamples, DropRules, DropLits, DropRefs, AddLits, AddRefs and SplitOnLits, keeping the best
candidate of an operator when it raises

    S(R) = sum_e w_e log P(s'|s,a,R) - alpha * sum_r PEN(r)

until no operator helps. Every candidate rule is completed by :func:`induce_outcomes` on the
examples it covers, and ``integrate`` removes the rules it overlaps. The one exception is
AddExceptions, which adds a specialisation beside its rule: scoring follows the rule-set semantics
exactly, so an example two rules cover goes to the default rule, and each rule's outcomes
are fitted on the examples it covers alone.

Defaults (documented in docs/rules.md): ``alpha = 0.5`` and ``p_min = 1e-8`` (``1e-9`` for the
default rule), as in the libPRADA demos and GLIB; the default rule's noise share is the weighted
share of changed examples it covers, clipped to ``[0.001, 0.999]``; the final outcome
probabilities give "no change" a pseudo-count of 0.5 (docs/rules.md).

Why one module of about 500 lines: :class:`ActionLearner` is one search, and its operators are
methods over the state it keeps (the example table, the fits it has made, the declared
predicates); split across modules they would pass that state around. What is a function of a
context and a state alone lives in :mod:`groundsym.rules.contexts`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Iterable, Sequence

import numpy as np

from ..logic import Atom, Literal
from ..progress import Progress
from .coverage import Coverage, Example, ExampleTable
from .model import P_MIN, P_MIN_DEFAULT, DefaultRule, Derived, Outcome, Rule, RuleSet
from .contexts import (absent_literals, atoms_over, binds_uniquely, canonical_names, deictic_refs, fresh_variable,
                       lift_atoms, make_rule, valid_context)
from .outcomes import induce_outcomes

ALPHA = 0.5
DEFAULT_CLIP = (0.001, 0.999)


@dataclass(frozen=True)
class LearnOptions:
    """Knobs of the rule learner; the defaults are the documented ones (docs/rules.md, Defaults and options)."""

    alpha: float = ALPHA
    p_min: float = P_MIN
    p_min_default: float = P_MIN_DEFAULT
    injective: bool = True
    default_clip: tuple[float, float] = DEFAULT_CLIP
    max_seeds: int = 25          # ExplainExamples seed examples per call (GLIB uses 25)
    max_rounds: int = 100        # operator rounds per action
    maxdeictic_refs: int = 2         # deictic references per rule
    nochange_prior: float = 0.5  # pseudo-count of "no change" in the final outcome probabilities
    drop_order: str = "general"  # trimming tries the most general literals first ("sorted": by name)
    complete: bool = True        # add the positive literals the data say the action needs (_complete)
    derived: bool = True         # contexts may use "no p(x, _)" predicates (Derived.for_predicates)


@dataclass(frozen=True)
class RuleFit:
    """A rule with the training examples it covers and its log-likelihood on them."""

    rule: Rule
    covered: frozenset[int]
    loglik: float
    fitted_on: float = 0.0      # weight of the examples its outcome probabilities were fitted on

    @property
    def pen(self) -> int:
        return self.rule.complexity()


def examples_from_transitions(transitions: Iterable[tuple[frozenset, Atom, frozenset, tuple[str, ...]]]
                              ) -> list[Example]:
    """Merge identical transitions into weighted examples (same score, less work)."""
    counts: dict[tuple, float] = {}
    for s, a, s2, objs in transitions:
        key = (s, a, s2, tuple(objs))
        counts[key] = counts.get(key, 0.0) + 1.0
    return [Example(s, a, s2, objs, w) for (s, a, s2, objs), w in counts.items()]


def examples_from_dataset(ds) -> list[Example]:
    """Weighted examples of a :class:`~groundsym.symbolic_traces.SymbolicDataset`."""
    return examples_from_transitions((s, a, s2, tr.objects) for tr in ds.traces for s, a, s2 in tr.transitions())


@dataclass
class LearnReport:
    """What the search did, per action: score, rules, operator successes, examples. ``score`` is
    the search's ``S(R)`` with maximum-likelihood outcome probabilities (before the final
    "no change" pseudo-count, ``LearnOptions.nochange_prior``)."""

    per_action: dict[str, dict] = field(default_factory=dict)

    @property
    def score(self) -> float:
        return sum(v["score"] for v in self.per_action.values())


def learn_rules(examples: Sequence[Example], predicates: dict[str, int], options: LearnOptions = LearnOptions(),
                *, seed: int = 0, progress: bool = True) -> tuple[RuleSet, LearnReport]:
    """Learn one rule set (with one default rule per action name) from weighted examples."""
    rng = np.random.default_rng(seed)
    by_action: dict[tuple[str, int], list[Example]] = {}
    used = dict(predicates)
    for e in examples:
        by_action.setdefault((e.action.predicate, e.action.arity), []).append(e)
        for a in e.state | e.succ:
            used.setdefault(a.predicate, a.arity)
    derived = Derived.for_predicates(used) if options.derived else ()
    rules: list[Rule] = []
    defaults: list[tuple[str, DefaultRule]] = []
    report = LearnReport()
    bar = Progress(len(by_action), "learning rules", enabled=progress)
    for k, (name, arity) in enumerate(sorted(by_action)):
        learner = ActionLearner(ExampleTable(by_action[(name, arity)], predicates, derived), name, arity, options,
                                np.random.default_rng(rng.integers(2**63)))
        fits, default, stats = learner.learn(
            lambda r, n, sc, name=name, k=k: bar.update(k, f"{name}: round {r}, {n} rules, score {sc:.2f}"))
        rules.extend(canonical_names(f.rule) for f in fits)
        defaults.append((name, default))
        report.per_action[name] = stats
        bar.update(k + 1, f"{name}: {len(fits)} rules, score {stats['score']:.2f}")
    bar.close()
    named = {l.atom.predicate for r in rules for l in r.context}
    rs = RuleSet(tuple(rules), tuple(defaults), options.p_min, options.p_min_default, options.injective,
                 tuple(d for d in derived if d.name in named))
    return rs, report


class ActionLearner:
    """Rule-set search for the examples of one action name."""

    def __init__(self, table: ExampleTable, name: str, arity: int, opts: LearnOptions,
                 rng: np.random.Generator):
        self.table = table
        self.opts = opts
        self.rng = rng
        self.action = Atom(name, tuple(f"?x{i + 1}" for i in range(arity)))
        self._fits: dict[tuple[Literal, ...], RuleFit | None] = {}
        self._covs: dict[tuple[Literal, ...], Coverage] = {}
        self._refits: dict[tuple, RuleFit] = {}
        self._general: dict[Literal, float] = {}
        self.total_w = float(table.weights.sum())

    # --- fitting and scoring -------------------------------------------------------------------
    def fit(self, context: Iterable[Literal]) -> RuleFit | None:
        """The rule with this context, its outcomes induced on what it covers (None if invalid)."""
        ctx = tuple(sorted(set(context)))
        if ctx in self._fits:
            return self._fits[ctx]
        result = None
        if valid_context(ctx, self.action, self.opts.maxdeictic_refs):
            cov = self.table.cover(self.action, ctx, self.opts.injective)
            if len(cov):
                self._covs[ctx] = cov
                of = induce_outcomes(self.table, cov, self.opts.alpha, self.opts.p_min)
                result = RuleFit(make_rule(self.action, ctx, of), frozenset(cov.index.tolist()), of.loglik,
                                 float(self.table.weights[cov.index].sum()))
        self._fits[ctx] = result
        return result

    def _refit(self, f: RuleFit, unique: frozenset[int]) -> RuleFit:
        """``f`` with its outcomes fitted on the examples it covers alone (the rest go to the default
        rule); its ``covered`` set stays, so overlaps are still seen when the set changes."""
        if unique == f.covered:
            return f
        key = (f.rule.context, unique)
        if key not in self._refits:
            cov = self._covs[f.rule.context]
            keep = np.isin(cov.index, sorted(unique))
            sub = Coverage(cov.index[keep], cov.binding[keep], cov.variables)
            if len(sub):
                of = induce_outcomes(self.table, sub, self.opts.alpha, self.opts.p_min)
                rule, ll = make_rule(self.action, f.rule.context, of), of.loglik
                n = float(self.table.weights[sub.index].sum())
            else:                     # covers nothing alone: keeps its own fit, explains nothing here
                rule, ll, n = f.rule, 0.0, f.fitted_on
            self._refits[key] = RuleFit(rule, f.covered, ll, n)
        return self._refits[key]

    def resolve(self, fits: Sequence[RuleFit]) -> tuple[tuple[RuleFit, ...], np.ndarray]:
        """Rule-set semantics on the training data: each rule refitted on the examples it covers
        alone, and the mask of examples the default rule takes (covered by none, or by several)."""
        count = np.zeros(len(self.table), dtype=int)
        for f in fits:
            count[list(f.covered)] += 1
        if count.max(initial=0) <= 1:
            return tuple(fits), count == 0
        shared = set(np.flatnonzero(count > 1).tolist())
        return tuple(self._refit(f, f.covered - shared) for f in fits), count != 1

    def default(self, fits: Sequence[RuleFit]) -> tuple[DefaultRule, float]:
        """Fit the default rule on the examples no rule covers alone; its log-likelihood there."""
        return self._default(self.resolve(fits)[1])

    def _default(self, mask: np.ndarray) -> tuple[DefaultRule, float]:
        w = self.table.weights[mask]
        ch = self.table.changed[mask]
        lo, hi = self.opts.default_clip
        p_noise = float(np.clip(w[ch].sum() / w.sum(), lo, hi)) if w.sum() > 0 else 0.5
        d = DefaultRule(p_noise)
        pm = self.opts.p_min_default
        ll = float(w[~ch].sum() * np.log(d.p_nochange + p_noise * pm) + w[ch].sum() * np.log(p_noise * pm))
        return d, ll

    def score(self, fits: Sequence[RuleFit]) -> float:
        resolved, mask = self.resolve(fits)
        _, ll = self._default(mask)
        return ll + sum(f.loglik - self.opts.alpha * f.pen for f in resolved)

    @staticmethod
    def integrate(fits: Sequence[RuleFit], new: Sequence[RuleFit]) -> tuple[RuleFit, ...]:
        """Add ``new`` rules, removing every rule that shares a covered example with one of them."""
        out = list(fits)
        for r in new:
            out = [f for f in out if not (f.covered & r.covered)]
            out.append(r)
        return tuple(out)

    # --- the search ----------------------------------------------------------------------------
    def learn(self, report: Callable[[int, int, float], None] | None = None
              ) -> tuple[list[RuleFit], DefaultRule, dict]:
        """The search; ``report(round, rules, score)`` is called after every round (progress)."""
        ops: list[tuple[str, Callable[[tuple[RuleFit, ...]], Iterable[tuple[RuleFit, ...]]]]] = [
            ("ExplainExamples", self.explain_examples), ("DropRules", self.drop_rules),
            ("DropLits", self.drop_lits), ("DropRefs", self.drop_refs), ("AddLits", self.add_lits),
            ("AddRefs", self.add_refs), ("SplitOnLits", self.split_on_lits),
            ("AddExceptions", self.add_exceptions)]
        R: tuple[RuleFit, ...] = ()
        best = self.score(R)
        successes = {name: 0 for name, _ in ops}
        for rnd in range(self.opts.max_rounds):
            improved = False
            for name, op in ops:
                cand, sc = self._best_of(op(R))
                if cand is not None and sc > best + 1e-9:
                    R, best, improved = cand, sc, True
                    successes[name] += 1
            if report is not None:
                report(rnd + 1, len(R), best)
            if not improved:
                break
        d, _ = self.default(R)
        if self.table.derived:
            R = tuple(self._prefer_declared(f) for f in R)
        if self.opts.complete:
            R = tuple(self._complete(f) for f in R)
            best = self.score(R)        # same likelihood, the added literals' penalty
        fits = sorted((_smooth(f, self.opts.nochange_prior) for f in self.resolve(R)[0]),
                      key=lambda f: str(f.rule.context))
        stats = {"score": best, "rules": len(fits), "examples": int(len(self.table)),
                 "transitions": self.total_w, "successes": successes}
        return fits, d, stats

    def _complete(self, f: RuleFit) -> RuleFit:
        """``f`` with each positive literal over the action's arguments that the data say the action
        needs: it holds in every training example the rule covers (so coverage and fit stay), and
        in every training example of the action where it is false, nothing changed."""
        ctx = set(f.rule.context)
        for a in atoms_over(self.action.args, self._declared, self.opts.injective):
            lit = Literal(a, True)
            if Literal(a, False) in ctx or lit in ctx or not self._needed(a):
                continue
            g = self.fit(ctx | {lit})
            if g is not None and g.covered == f.covered:
                ctx.add(lit)
        return self.fit(ctx) if ctx != set(f.rule.context) else f

    def _prefer_declared(self, f: RuleFit) -> RuleFit:
        """``f`` with each derived literal replaced by a literal over the data's own predicates that
        covers the same training examples, where there is one (same fit, same score): in the blocks
        world ``(no-on-1 ?x)`` next to ``(clear ?x) (handempty)`` is ``(ontable ?x)``, and the data's
        vocabulary is what a reader (and a PPDDL export) expects."""
        derived = {d.name for d in self.table.derived}
        ctx = set(f.rule.context)
        for lit in sorted(l for l in f.rule.context if l.atom.predicate in derived):
            present = {l.atom for l in ctx}
            swaps = [Literal(a, sign) for sign in (lit.positive, not lit.positive)
                     for a in atoms_over(f.rule.variables, self._declared, self.opts.injective) if a not in present]
            for new in swaps:
                c = (ctx - {lit}) | {new}
                g = self.fit(c)
                if g is not None and g.covered == f.covered:
                    ctx = c
                    break
        return self.fit(ctx) if ctx != set(f.rule.context) else f

    @property
    def _declared(self) -> dict[str, int]:
        """The data's own predicates (completion adds literals over these only: a derived literal
        it needs is implied by declared ones or was chosen by the search)."""
        names = {d.name for d in self.table.derived}
        return {p: k for p, k in self.table.predicates.items() if p not in names}

    def _needed(self, atom: Atom) -> bool:
        """The action was tried with ``atom`` false, and never changed anything then."""
        idx = self.table.cover(self.action, (Literal(atom, False),), self.opts.injective).index
        return len(idx) > 0 and not self.table.changed[idx].any()

    def _best_of(self, cands: Iterable[tuple[RuleFit, ...]]) -> tuple[tuple[RuleFit, ...] | None, float]:
        best, best_sc = None, -np.inf
        for c in cands:
            sc = self.score(c)
            if sc > best_sc:
                best, best_sc = c, sc
        return best, best_sc

    # --- operators (Pasula et al. 2007) ---------------------------------------------------------------------
    def explain_examples(self, R: tuple[RuleFit, ...]) -> Iterable[tuple[RuleFit, ...]]:
        covered = set().union(*(f.covered for f in R)) if R else set()
        free = [i for i in range(len(self.table)) if i not in covered]
        changed = [i for i in free if self.table.changed[i]]
        same = [i for i in free if not self.table.changed[i]]
        order = list(self.rng.permutation(changed)) + list(self.rng.permutation(same))
        seen: set = set()
        starts: set = set()          # seeds that lift to the same rule give the same candidate
        for i in order[: self.opts.max_seeds]:
            f = self._explain(int(i), R, starts)
            if f is not None and f.rule.context not in seen:
                seen.add(f.rule.context)
                yield self.integrate(R, [f])

    def _explain(self, i: int, R: tuple[RuleFit, ...] = (), starts: set | None = None) -> RuleFit | None:
        """A rule built from example ``i`` (ExplainExamples, steps 1-4), trimmed greedily against ``R``;
        None if it starts as a rule in ``starts`` (already tried)."""
        ex = self.table.examples[i]
        if self.opts.injective and len(set(ex.action.args)) != len(ex.action.args):
            return None
        state = self.table.full_state(i)
        sigma = dict(zip(ex.action.args, self.action.args))       # object -> variable
        ctx = set(lift_atoms(state, sigma, positive=True))
        ctx |= set(absent_literals(state, sigma, self.table.predicates, self.opts.injective))
        changed_objs = sorted({x for a in ex.adds | ex.dels for x in a.args} - set(sigma))
        for c in changed_objs:
            if len(sigma) - len(self.action.args) >= self.opts.maxdeictic_refs:
                return None
            trial = dict(sigma, **{c: f"?y{len(sigma) - len(self.action.args) + 1}"})
            lits = [l for l in lift_atoms(state, trial, positive=True) if trial[c] in l.atom.args]
            if not (lits and binds_uniquely(state, ex, self.action, ctx | set(lits), self.opts.injective)):
                # a negated reference: "the one object that is not u1" (the held cube, when a learned
                # u1 is the negation of inhand), with the positive links if there are any
                lits += [l for l in absent_literals(state, trial, self.table.predicates, self.opts.injective)
                         if trial[c] in l.atom.args]
            if lits and binds_uniquely(state, ex, self.action, ctx | set(lits), self.opts.injective):
                sigma, ctx = trial, ctx | set(lits)
            else:
                return None
        key = (frozenset(ctx), frozenset(sigma[c] for c in changed_objs))
        if starts is not None:
            if key in starts:
                return None
            starts.add(key)
        if self.fit(ctx) is None or i not in self.fit(ctx).covered:
            return None
        return self._trim(ctx, i, {sigma[c] for c in changed_objs}, R)

    def _trim(self, ctx: set[Literal], seed: int, needed_vars: set[str], R: tuple[RuleFit, ...]) -> RuleFit | None:
        """Greedily drop literals, then whole references, while the score of the rule set with the
        rule integrated rises. (Pasula et al. score ``{r, default}`` alone; but then a rule that swallows
        examples it can only call noise costs nothing, since the default rule would call them noise
        too, and trimming over-generalises. Scoring against ``R`` prices what the rule displaces.)"""
        def ok(f: RuleFit | None) -> bool:
            return f is not None and seed in f.covered and needed_vars <= set(f.rule.variables)

        cur = self.fit(ctx)
        cur_sc = self.score(self.integrate(R, [cur]))
        for drop_vars in (False, True):
            changed = True
            while changed:                    # first-improvement sweeps: O(literals) fits per sweep
                changed = False
                units = deictic_refs(ctx, self.action) if drop_vars else self._drop_order(ctx)
                for u in units:
                    c = {l for l in ctx if u not in l.atom.args} if drop_vars else ctx - {u}
                    if c == ctx or (drop_vars and u not in {a for l in ctx for a in l.atom.args}):
                        continue
                    f = self.fit(c)
                    if ok(f):
                        sc = self.score(self.integrate(R, [f]))
                        if sc > cur_sc + 1e-9:
                            cur, cur_sc, ctx, changed = f, sc, c, True
        return cur

    def _drop_order(self, ctx: set[Literal]) -> list[Literal]:
        """The order in which trimming tries to drop literals: most general first.

        Literals that cover the same training examples are interchangeable for the score, and the
        sweep keeps whichever it reaches last. In name order that kept ``stack(X, Y): not
        ontable(X)`` rather than ``holding(X)``: both separate the training stacks from the failed
        ones, but the first also claims every block standing on another one, and on held-out data
        the rule then predicts a stack where nothing can happen. Trying the literal that holds in
        the most training examples of the action first keeps the most specific one of such a
        group, what an operator's precondition is (docs/rules.md)."""
        if self.opts.drop_order == "sorted":
            return sorted(ctx)
        derived = {d.name for d in self.table.derived}     # on a tie the derived literal goes first
        return sorted(ctx, key=lambda l: (-self._generality(l), l.atom.predicate not in derived, l))

    def _generality(self, lit: Literal) -> float:
        """Weight of this action's training examples in which ``lit`` holds for the action's
        arguments; a literal over a deictic reference counts as holding everywhere (tried first,
        as before: trimming references is a separate sweep)."""
        if any(a not in self.action.args for a in lit.atom.args):
            return self.total_w
        if lit not in self._general:
            cov = self.table.cover(self.action, (lit,), self.opts.injective)
            self._general[lit] = float(self.table.weights[cov.index].sum())
        return self._general[lit]

    def drop_rules(self, R: tuple[RuleFit, ...]) -> Iterable[tuple[RuleFit, ...]]:
        for k in range(len(R)):
            yield R[:k] + R[k + 1:]

    def _replace(self, R: tuple[RuleFit, ...], k: int, contexts: Iterable[Iterable[Literal]]
                 ) -> Iterable[tuple[RuleFit, ...]]:
        rest = R[:k] + R[k + 1:]
        for ctx in contexts:
            f = self.fit(ctx)
            if f is not None and f.rule.context != R[k].rule.context:
                yield self.integrate(rest, [f])

    def drop_lits(self, R: tuple[RuleFit, ...]) -> Iterable[tuple[RuleFit, ...]]:
        for k, f in enumerate(R):
            ctx = set(f.rule.context)
            yield from self._replace(R, k, (ctx - {l} for l in f.rule.context))

    def drop_refs(self, R: tuple[RuleFit, ...]) -> Iterable[tuple[RuleFit, ...]]:
        for k, f in enumerate(R):
            ctx = f.rule.context
            yield from self._replace(R, k, ([l for l in ctx if v not in l.atom.args] for v in f.rule.deictic))

    def add_lits(self, R: tuple[RuleFit, ...]) -> Iterable[tuple[RuleFit, ...]]:
        for k, f in enumerate(R):
            ctx = set(f.rule.context)
            yield from self._replace(R, k, (ctx | {l} for a in self._absent_atoms(f.rule)
                                            for l in (Literal(a, True), Literal(a, False))))

    def add_refs(self, R: tuple[RuleFit, ...]) -> Iterable[tuple[RuleFit, ...]]:
        for k, f in enumerate(R):
            if len(f.rule.deictic) >= self.opts.maxdeictic_refs:
                continue
            v = fresh_variable(f.rule)
            vars_ = (*f.rule.variables, v)
            atoms = [a for a in atoms_over(vars_, self.table.predicates, self.opts.injective) if v in a.args]
            ctx = set(f.rule.context)
            yield from self._replace(R, k, (ctx | {Literal(a, sign)} for a in atoms for sign in (True, False)))

    def split_on_lits(self, R: tuple[RuleFit, ...]) -> Iterable[tuple[RuleFit, ...]]:
        for k, f in enumerate(R):
            rest = R[:k] + R[k + 1:]
            ctx = set(f.rule.context)
            for a in self._absent_atoms(f.rule):
                halves = [h for h in (self.fit(ctx | {Literal(a, True)}), self.fit(ctx | {Literal(a, False)}))
                          if h is not None]
                if len(halves) == 2:
                    yield self.integrate(rest, halves)

    def add_exceptions(self, R: tuple[RuleFit, ...]) -> Iterable[tuple[RuleFit, ...]]:
        """A specialisation of a rule added *beside* it (not integrated): where both cover, neither
        applies and the default rule (no change) takes over. This states conditions NID
        contexts cannot, such as "the hand is empty" without a predicate for it: the exception
        ``closeHandAround(X): clear(X), inhand(Y)`` removes the full-hand cases from the grasp
        rule. Candidates: the rule's context plus one literal (AddLits) or one reference (AddRefs)."""
        for f in R:
            ctx = set(f.rule.context)
            specials = [ctx | {l} for a in self._absent_atoms(f.rule) for l in (Literal(a, True), Literal(a, False))]
            if len(f.rule.deictic) < self.opts.maxdeictic_refs:
                v = fresh_variable(f.rule)
                specials += [ctx | {Literal(a, True)} for a in
                             atoms_over((*f.rule.variables, v), self.table.predicates, self.opts.injective)
                             if v in a.args]
            for c in specials:
                g = self.fit(c)
                if g is not None and g.covered <= f.covered and g.rule.context not in {h.rule.context for h in R}:
                    yield R + (g,)

    def _absent_atoms(self, rule: Rule) -> list[Atom]:
        present = {l.atom for l in rule.context}
        return [a for a in atoms_over(rule.variables, self.table.predicates, self.opts.injective)
                if a not in present]


# --- helpers -------------------------------------------------------------------------------------
def _smooth(f: RuleFit, a: float) -> RuleFit:
    """The final outcome probabilities: "no change" gets ``a`` pseudo-counts on top of the ``n``
    examples the rule was fitted on, ``p_nochange = (n p + a) / (n + a)``, the rest shrinks by
    ``n / (n + a)``. The search scores maximum-likelihood fits; this estimate is for
    prediction. With little data a rule's context is often broader than the truth, or its failure
    was never seen; then "nothing happens" would cost ``log(noise * p_min)`` (about -20 nats) per
    held-out transition, and that is what loses the most likelihood (docs/rules.md)."""
    r, n = f.rule, f.fitted_on
    if a <= 0:
        return f
    outs, probs = list(r.outcomes), [p * n / (n + a) for p in r.probs]
    if Outcome() in outs:
        probs[outs.index(Outcome())] += a / (n + a)
    else:
        outs.append(Outcome())
        probs.append(a / (n + a))
    keep = [k for k, p in enumerate(probs) if p > 0]
    rule = Rule(r.action, r.context, tuple(outs[k] for k in keep), tuple(probs[k] for k in keep),
                r.noise * n / (n + a), r.noise_changes)
    return RuleFit(rule, f.covered, f.loglik, n)
