"""PRADA and A-PRADA (Lang & Toussaint 2010): planning with noisy probabilistic relational rules.

PRADA turns the NID rules into a dynamic Bayesian network over ground atoms and keeps only
per-atom marginals (the factored frontier; Lang & Toussaint 2010). It samples many action sequences,
each action drawn with weight "probability that a manipulating rule of it applies",
propagates the marginals along each sequence, scores it by the discounted expected reward
``sum_t gamma^t E_t[R]`` and runs the first action of the best sequence; it replans after
every primitive. A-PRADA then deletes actions from the best sequence while that raises its
value.

Everything about a sample is a row of a numpy matrix: the grounding (:class:`Grounding`) turns
rules into index tables once per object set, so one step of inference for all samples is a
gather, a product, two segment sums and two small matrix products. That is what makes a decision
at horizon 4 with 500 samples take milliseconds rather than seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from itertools import permutations, product
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from groundsym.logic import Atom, Literal, is_variable
from groundsym.rules.model import with_derived
from groundsym.planner import (Decision, Goal, Observation, PlannerOption, PlanningModel,
                               parse_planner_options, positive, unit_interval)

RULE_MIN_PROB = 0.03   # libPRADA prunes a rule whose context probability falls below this


# ----------------------------------------------------------------------------- grounding

@dataclass(frozen=True, eq=False)
class Grounding:
    """A rule set grounded over one object set, as numpy index tables.

    State variable ``i`` is the ground atom ``atoms[i]``; column ``V`` of a belief matrix is a
    constant 1 that pads contexts. Ground rules are sorted by ground action, so the rules of one
    action form the contiguous segment ``starts[g]:starts[g+1]`` and segment sums are
    ``np.add.reduceat``.
    """

    objects: tuple[str, ...]
    atoms: tuple[Atom, ...]
    index: Mapping[Atom, int]
    actions: tuple[Atom, ...]          # ground actions that have at least one ground rule
    starts: np.ndarray                 # (G,) first ground rule of each action
    rule_group: np.ndarray             # (R,) action index of each ground rule
    ctx: np.ndarray                    # (R, L) variable index of each context literal (V = pad)
    sign: np.ndarray                   # (R, L) True for a positive literal
    manipulating: np.ndarray           # (R,) rule has a non-empty non-noise outcome
    set_true: Any                      # (R, V+1) probability the rule makes the atom true (CSR)
    touched: Any                       # (R, V+1) probability the rule sets the atom at all (CSR)
    source: tuple[tuple[Any, dict], ...]   # (abstract rule, binding) of each ground rule
    derived_cols: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # (D,) derived atoms
    derived_of: np.ndarray = field(default_factory=lambda: np.zeros((1, 0)))   # (V+1, D) 1: base atom denies it

    @property
    def n_vars(self) -> int:
        return len(self.atoms)

    def belief(self, state: frozenset) -> np.ndarray:
        """Point-mass belief of a state as a (V+1,) row (last entry the constant 1)."""
        b = np.zeros(self.n_vars + 1)
        for a in state:
            i = self.index.get(a)
            if i is not None:
                b[i] = 1.0
        b[-1] = 1.0
        return b

    def derive(self, B: np.ndarray) -> np.ndarray:
        """``B`` (changed in place) with its derived atoms recomputed from their base atoms:
        ``P(no-on-1(x)) = prod_y (1 - P(on(x, y)))``, the factored frontier's independence
        (libPRADA computes its derived predicates the same way)."""
        if not len(self.derived_cols):
            return B
        B[:, self.derived_cols] = np.exp(np.log(np.maximum(1.0 - B, 1e-300)) @ self.derived_of)
        return B

    def marginals(self, row: np.ndarray) -> dict[Atom, float]:
        return {a: float(row[i]) for i, a in enumerate(self.atoms)}

    @cached_property
    def changing(self) -> tuple[np.ndarray | None, Any, Any]:
        """(the belief columns some rule touches, ``touched`` and ``set_true`` on those columns):
        a transition only computes those (on triangle-tireworld p03, 100 of 2453 atoms); None and
        the whole tables when most columns change (the tower). Tables of at most 2e6 entries are
        made dense here (BLAS products beat sparse ones on small tables)."""
        cols = np.unique(self.touched.indices)
        if 2 * len(cols) > self.touched.shape[1]:     # most columns change: no gain in selecting
            cols, touched, set_true = None, self.touched, self.set_true
        else:
            touched, set_true = self.touched[:, cols], self.set_true[:, cols]
        if touched.shape[0] * touched.shape[1] <= 2_000_000:     # small (<= 16 MB): dense, BLAS products
            return cols, touched.toarray(), set_true.toarray()
        return cols, touched.tocsc(), set_true.tocsc()


def ground_rules(rules: Any, objects: Sequence[str], predicates: Mapping[str, int],
                 noise_softener: float = 0.2) -> Grounding:
    """Ground every rule over every injective binding of its variables to ``objects``."""
    atoms = _ground_atoms(objects, predicates, rules)
    index = {a: i for i, a in enumerate(atoms)}
    V = len(atoms)
    changeable = _changeable(rules, atoms)
    n_changeable = max(int(changeable.sum()), 1)
    injective = getattr(rules, "injective", True)
    rows: list[tuple[Atom, Any, dict]] = []
    for rule in rules.rules:
        variables = rule.variables
        choose = permutations(objects, len(variables)) if injective else product(objects, repeat=len(variables))
        for combo in choose:
            binding = dict(zip(variables, combo))
            rows.append((rule.action.substitute(binding), rule, binding))
    rows.sort(key=lambda r: r[0])
    actions = tuple(sorted({r[0] for r in rows}))
    act_index = {a: g for g, a in enumerate(actions)}
    R = len(rows)
    L = max((len(r[1].context) for r in rows), default=0) or 1
    ctx = np.full((R, L), V, dtype=np.int64)
    sign = np.ones((R, L), dtype=bool)
    st: dict[tuple[int, int], float] = {}     # (ground rule, atom) -> probability; sparse: a rule
    tc: dict[tuple[int, int], float] = {}     # touches its outcomes' atoms only (0.1% of the table)
    manip = np.zeros(R, dtype=bool)
    group = np.zeros(R, dtype=np.int64)
    keep = np.ones(R, dtype=bool)
    for k, (act, rule, binding) in enumerate(rows):
        group[k] = act_index[act]
        for j, lit in enumerate(rule.context):
            atom = lit.atom.substitute(binding)
            i = index.get(atom)
            if i is None:               # an atom outside the grounding is always false
                if lit.positive:
                    keep[k] = False
                continue
            ctx[k, j], sign[k, j] = i, lit.positive
        for outcome, p in zip(rule.outcomes, rule.probs):
            if not outcome.is_empty:
                manip[k] = True
            adds, dels = outcome.ground(binding)
            for a in adds:
                if a in index:
                    st[k, index[a]] = st.get((k, index[a]), 0.0) + p
                    tc[k, index[a]] = tc.get((k, index[a]), 0.0) + p
            for a in dels:
                if a in index:
                    tc[k, index[a]] = tc.get((k, index[a]), 0.0) + p
        q = min(rule.noise_changes / n_changeable * noise_softener, 0.5)
        if rule.noise > 0 and q > 0:
            for i in np.flatnonzero(changeable):
                st[k, int(i)] = st.get((k, int(i)), 0.0) + rule.noise * q
                tc[k, int(i)] = tc.get((k, int(i)), 0.0) + 2 * rule.noise * q
    set_true, touched = _csr(st, (R, V + 1)), _csr(tc, (R, V + 1))
    ctx[~keep] = V           # a rule that can never fire gets context "false" via its sign
    sign[~keep, 0] = False
    starts = np.searchsorted(group, np.arange(len(actions))) if R else np.zeros(0, dtype=np.int64)
    dcols, dof = _derived_tables(getattr(rules, "derived", ()), atoms, index)
    return Grounding(tuple(objects), atoms, index, actions, starts, group, ctx, sign, manip,
                     set_true, touched, tuple((r[1], r[2]) for r in rows), dcols, dof)


def _derived_tables(derived: Sequence[Any], atoms: Sequence[Atom], index: Mapping[Atom, int]
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The columns of the derived atoms and, per derived atom, the base atoms that deny it."""
    by_name = {d.name: d for d in derived}
    cols = [i for i, a in enumerate(atoms) if a.predicate in by_name]
    dof = np.zeros((len(atoms) + 1, len(cols)))
    for j, i in enumerate(cols):
        d = by_name[atoms[i].predicate]
        for b, a in enumerate(atoms):
            if a.predicate == d.base and a.arity == d.base_arity and \
                    tuple(a.args[k] for k in d.keep) == atoms[i].args:
                dof[b, j] = 1.0
    return np.array(cols, dtype=np.int64), dof


def _ground_atoms(objects: Sequence[str], predicates: Mapping[str, int], rules: Any) -> tuple[Atom, ...]:
    preds = dict(predicates)
    for rule in rules.rules:
        for lit in list(rule.context) + [c for o in rule.outcomes for c in o.changes]:
            preds.setdefault(lit.atom.predicate, lit.atom.arity)
    out: set[Atom] = set()
    for p, k in preds.items():
        tuples = permutations(objects, k) if k > 1 else product(objects, repeat=k)
        out.update(Atom(p, t) for t in tuples)
    for rule in rules.rules:   # atoms over constants (PPDDL domains) and repeated objects that the permutations miss
        for lit in list(rule.context) + [c for o in rule.outcomes for c in o.changes]:
            args = lit.atom.args
            names = list(dict.fromkeys(a for a in args if is_variable(a)))
            if not names:
                out.add(lit.atom)
            elif len(names) < sum(map(is_variable, args)):     # (on ?x ?x) of a rule for a repeated-argument move
                out.update(lit.atom.substitute(dict(zip(names, combo))) for combo in permutations(objects, len(names)))
    return tuple(sorted(out))


def _csr(entries: Mapping[tuple[int, int], float], shape: tuple[int, int]) -> Any:
    """A CSR matrix of ``{(row, col): value}`` (empty entries: zero)."""
    from scipy.sparse import csr_matrix

    if not entries:
        return csr_matrix(shape)
    keys = np.array(list(entries.keys()), dtype=np.int64)
    return csr_matrix((np.fromiter(entries.values(), float, len(entries)), (keys[:, 0], keys[:, 1])), shape=shape)


def _changeable(rules: Any, atoms: Sequence[Atom]) -> np.ndarray:
    preds = {c.atom.predicate for r in rules.rules for o in r.outcomes for c in o.changes}
    return np.array([a.predicate in preds for a in atoms], dtype=float)


# ----------------------------------------------------------------------------- inference

def rule_probabilities(g: Grounding, B: np.ndarray, min_prob: float = RULE_MIN_PROB) -> np.ndarray:
    """P(U = r) for every sample (row of ``B``) and ground rule: context holds, no rival does.
    A context probability below ``min_prob`` counts as 0 (libPRADA's pruning)."""
    if not len(g.rule_group):
        return np.zeros((B.shape[0], 0))
    lit = B[:, g.ctx]
    lit = np.where(g.sign, lit, 1.0 - lit)
    phi = lit.prod(axis=2)
    phi[phi < min_prob] = 0.0
    z = 1.0 - phi
    zero = z <= 1e-12
    logz = np.log(np.where(zero, 1.0, z))
    seg_log = np.add.reduceat(logz, g.starts, axis=1)[:, g.rule_group]
    seg_zero = np.add.reduceat(zero.astype(np.int64), g.starts, axis=1)[:, g.rule_group]
    others_zero = seg_zero - zero
    return phi * np.exp(seg_log - logz) * (others_zero == 0)


def action_weights(g: Grounding, U: np.ndarray) -> np.ndarray:
    """Sampling weight of each ground action: P(a manipulating rule of it applies)."""
    if not U.shape[1]:
        return np.zeros((U.shape[0], 0))
    return np.add.reduceat(U * g.manipulating, g.starts, axis=1)


def transition(g: Grounding, B: np.ndarray, U: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """Marginals after each row's chosen action (``-1`` = none: everything persists).

    The rule tables are sparse (a rule touches a handful of atoms) and only the columns some rule
    touches change: the products cost the tables' non-zeros times the rows, not rules x atoms x rows."""
    Usel = U * (g.rule_group[None, :] == chosen[:, None])
    cols, touched, set_true = g.changing
    if isinstance(touched, np.ndarray):
        off, on = Usel @ touched, Usel @ set_true
    else:
        off, on = (touched.T @ Usel.T).T, (set_true.T @ Usel.T).T
    if cols is None:
        return g.derive(B * (1.0 - off) + on)
    out = B.copy()
    out[:, cols] = B[:, cols] * (1.0 - off) + on
    return g.derive(out)


# ----------------------------------------------------------------------------- rewards

class RewardFn:
    """Expected reward under factored marginals, for every row of a belief matrix at once."""

    def __call__(self, B: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError


@dataclass(frozen=True, eq=False)
class LinearReward(RewardFn):
    """``w0 + sum_i w_i P(atom_i)``: exact for rewards linear in atom indicators."""

    w0: float
    w: np.ndarray   # (V+1,) with 0 on the constant column

    def __call__(self, B: np.ndarray) -> np.ndarray:
        return self.w0 + B @ self.w


@dataclass(frozen=True, eq=False)
class GoalReward(RewardFn):
    """``R_goal * prod P(literal)``: a conjunctive goal under independent marginals (Lang & Toussaint 2010).

    ``share > 0`` adds ``share * R_goal * mean P(literal)``, the expected share of the goal's
    literals that hold: a goal further away than the horizon then still orders the sequences (one
    more goal literal is worth more), where the product is 0 for all of them and the choice is
    blind (blocksworld p02, reversing a tower of five, needs at least 8 primitives)."""

    index: np.ndarray      # (L,) variable index of each goal literal (V = outside the grounding)
    positive: np.ndarray   # (L,)
    value: float
    share: float = 0.0

    def __call__(self, B: np.ndarray) -> np.ndarray:
        lit = B[:, self.index]
        p = np.where(self.positive, lit, 1.0 - lit)
        out = self.value * p.prod(axis=1)
        return out + self.share * self.value * p.mean(axis=1) if self.share else out


@dataclass(frozen=True, eq=False)
class ModelReward(RewardFn):
    """A learned reward model's own ``expected(marginals, objects)``, called row by row."""

    model: Any
    g: Grounding

    def __call__(self, B: np.ndarray) -> np.ndarray:
        return np.array([float(self.model.expected(self.g.marginals(row), self.g.objects)) for row in B])


@dataclass(frozen=True, eq=False)
class ArrayReward(RewardFn):
    """A model with batched ``expected_arrays(arrays, n_objects)`` (groundsym.reward.RewardModel).

    ``columns[p]`` maps every cell of predicate ``p``'s M x ... x M array to a belief column; cells
    outside the grounding (e.g. ``on(x, x)``) read an appended column of zeros.
    """

    model: Any
    columns: Mapping[str, np.ndarray]
    n_objects: int

    def __call__(self, B: np.ndarray) -> np.ndarray:
        ext = np.hstack([B, np.zeros((B.shape[0], 1))])
        m, N = self.n_objects, B.shape[0]
        arrays = {p: ext[:, idx].reshape((N,) + (m,) * idx.ndim) for p, idx in self.columns.items()}
        return np.asarray(self.model.expected_arrays(arrays, m), dtype=float)


def array_reward(model: Any, g: Grounding) -> ArrayReward:
    m, zero = len(g.objects), g.n_vars + 1
    columns = {}
    for p, k in dict(model.predicates).items():
        idx = np.full((m,) * k, zero, dtype=np.int64)
        for cell in np.ndindex(*idx.shape):
            i = g.index.get(Atom(p, tuple(g.objects[c] for c in cell)))
            if i is not None:
                idx[cell] = i
        columns[p] = idx
    return ArrayReward(model, columns, m)


@dataclass(frozen=True, eq=False)
class SampledReward(RewardFn):
    """A model that only scores states (``predict(state, objects)``): Monte Carlo over states drawn
    from the factored belief, with one fixed set of uniforms for every row and step (common random
    numbers, so sequences are compared on the same draws) (docs/algorithms.md, PRADA and A-PRADA)."""

    model: Any
    g: Grounding
    uniforms: np.ndarray   # (M, V)

    def __call__(self, B: np.ndarray) -> np.ndarray:
        out = np.empty(B.shape[0])
        for n, row in enumerate(B):
            draws = self.uniforms < row[None, :self.g.n_vars]
            out[n] = np.mean([self.model.predict(frozenset(a for a, on in zip(self.g.atoms, d) if on),
                                                 self.g.objects) for d in draws])
        return out


def goal_reward(goal: Goal, g: Grounding, share: float = 0.0) -> GoalReward:
    idx, pos = [], []
    for lit in goal.literals:
        i = g.index.get(lit.atom)
        if i is None:               # an atom nobody can make true: P = 0 (or 1 when negated)
            i = g.n_vars
            pos.append(not lit.positive)
        else:
            pos.append(lit.positive)
        idx.append(i)
    return GoalReward(np.array(idx, dtype=np.int64), np.array(pos, dtype=bool), goal.reward, share)


def model_reward(model: Any, g: Grounding, rng: np.random.Generator) -> RewardFn:
    """Batched arrays for a groundsym RewardModel; Monte Carlo for a model with only ``predict``;
    for any other model with ``expected``: linear weights when the model's expectation is linear in the marginals, else row by row.

    Probing ``expected`` at the empty belief and at each unit vector gives the weights a linear
    model must have; three random beliefs then confirm linearity (a tree or product model fails
    and is used exactly, row by row).
    """
    if hasattr(model, "expected_arrays") and hasattr(model, "predicates"):
        return array_reward(model, g)
    if not hasattr(model, "expected"):
        return SampledReward(model, g, np.random.default_rng(0).random((32, g.n_vars)))
    full = ModelReward(model, g)
    V = g.n_vars
    probes = np.zeros((V + 1, V + 1))
    probes[:, -1] = 1.0
    probes[np.arange(V), np.arange(V)] = 1.0
    vals = full(probes)
    w0 = vals[-1]
    w = np.append(vals[:V] - w0, 0.0)
    check = np.hstack([rng.random((3, V)), np.ones((3, 1))])
    lin = LinearReward(w0, w)
    scale = 1e-9 * max(1.0, float(np.abs(vals).max()))
    if np.allclose(lin(check), full(check), atol=scale, rtol=1e-9):
        return lin
    return full


# ----------------------------------------------------------------------------- planning

@dataclass(frozen=True)
class Plan:
    """The best sampled sequence, its value, and what it was compared with."""

    actions: tuple[Atom, ...]
    value: float
    noop_value: float
    samples: int


class PradaCore:
    """PRADA over one grounding and reward: sample, propagate, evaluate, shorten."""

    def __init__(self, g: Grounding, reward: RewardFn, horizon: int, samples: int, gamma: float,
                 choice: str = "max", restricted: bool = False, min_prob: float = RULE_MIN_PROB,
                 threshold: float = 0.0, max_runs: int = 1):
        self.g, self.reward = g, reward
        self.horizon, self.samples, self.gamma, self.choice = horizon, samples, gamma, choice
        self.min_prob, self.threshold, self.max_runs = min_prob, threshold, max_runs
        self.discounts = gamma ** np.arange(horizon + 1)
        self.restricted = restricted
        self._static = np.asarray(g.touched.getnnz(axis=0) == 0) if not restricted else None
        if self._static is not None:
            self._static[g.derived_cols] = False       # derived atoms change with their base atoms
        self._subs: dict[bytes, PradaCore] = {}

    def restrict(self, b0: np.ndarray) -> "PradaCore":
        """The core over the ground rules that can fire from ``b0``: a rule whose context needs a
        static atom (one no rule changes) that is false in ``b0`` never fires (``road l-1-1 l-5-3``
        that is not there), and leaving it out changes no probability. Triangle-tireworld p03
        keeps 4% of its ground rules. Cached by the static atoms' values."""
        if self.restricted or not len(self.g.rule_group):
            return self
        static = self._static
        lit = b0[self.g.ctx]
        lit = np.where(self.g.sign, lit, 1.0 - lit)
        dead = (static[self.g.ctx] & (lit <= 0.0)).any(axis=1)
        if not dead.any():
            return self
        key = b0[:-1][static[:-1]].tobytes()
        if key not in self._subs:
            self._subs[key] = PradaCore(_subgrounding(self.g, ~dead), self.reward, self.horizon, self.samples,
                                        self.gamma, self.choice, True, self.min_prob, self.threshold,
                                        self.max_runs)
        return self._subs[key]

    def sample(self, b0: np.ndarray, rng: np.random.Generator, banned: Sequence[Atom] = ()
               ) -> tuple[np.ndarray, np.ndarray]:
        """N sequences of ground-action indices (-1 after a sequence ends) and their values;
        no sequence starts with an action in ``banned``."""
        g, N, T = self.g, self.samples, self.horizon
        B = np.repeat(b0[None, :], N, axis=0)
        seqs = np.full((N, T), -1, dtype=np.int64)
        value = self.reward(B) * self.discounts[0]
        banned = set(banned)
        ban = [i for i, a in enumerate(g.actions) if a in banned]
        for t in range(T):
            U = rule_probabilities(g, B, self.min_prob)
            W = action_weights(g, U)
            if t == 0 and ban:
                W[:, ban] = 0.0
            chosen = _sample_rows(W, rng)
            seqs[:, t] = chosen
            B = transition(g, B, U, chosen)
            value = value + self.discounts[t + 1] * self.reward(B)
        return seqs, value

    def evaluate(self, b0: np.ndarray, seqs: np.ndarray) -> np.ndarray:
        """Values of fixed sequences (rows of action indices, -1 = do nothing), all at once."""
        B = np.repeat(b0[None, :], len(seqs), axis=0)
        value = self.reward(B) * self.discounts[0]
        for t in range(self.horizon):
            col = seqs[:, t] if t < seqs.shape[1] else np.full(len(seqs), -1)
            U = rule_probabilities(self.g, B, self.min_prob)
            B = transition(self.g, B, U, col)
            value = value + self.discounts[t + 1] * self.reward(B)
        return value

    def best(self, seqs: np.ndarray, values: np.ndarray, rng: np.random.Generator | None = None) -> int:
        """Row of the chosen sequence: the best one, or the best of the best first action (top10).

        Sequences the model cannot tell apart (interchangeable objects give equal values up to
        rounding) are chosen among at random: taking the first would always favour the same object
        through floating-point order, and a robot would retry a cube that physically cannot be
        grasped for the rest of the episode.
        """
        if self.choice == "max":
            top = float(values.max())
            tied = np.flatnonzero(values >= top - 1e-9 * max(1.0, abs(top)))
            return int(tied[0] if rng is None or len(tied) == 1 else rng.choice(tied))
        firsts = np.unique(seqs[:, 0])
        best_row, best_mean = 0, -np.inf
        for a in firsts:
            rows = np.flatnonzero(seqs[:, 0] == a)
            top = rows[np.argsort(-values[rows], kind="stable")[:10]]
            if values[top].mean() > best_mean:
                best_mean, best_row = values[top].mean(), int(top[0])
        return best_row

    def shorten(self, b0: np.ndarray, seq: np.ndarray, value: float) -> tuple[np.ndarray, float]:
        """A-PRADA: delete actions while that raises the value; later actions move one step up."""
        seq = seq[seq >= 0]
        t = 0
        while t < len(seq) - 1 and len(seq) > 1:
            cand = np.delete(seq, t)
            vc = float(self.evaluate(b0, _pad(cand[None, :], self.horizon))[0])
            if vc > value:
                seq, value = cand, vc
            else:
                t += 1
        return seq, value

    def plan(self, b0: np.ndarray, rng: np.random.Generator, shorten: bool, banned: Sequence[Atom] = ()) -> Plan:
        core = self.restrict(b0)
        if core is not self:
            return core.plan(b0, rng, shorten, banned)
        noop = float(self.evaluate(b0, np.full((1, self.horizon), -1))[0])
        for _ in range(self.max_runs):      # libPRADA: sample again while no sequence beats doing
            seqs, values = self.sample(b0, rng, banned)   # nothing by the threshold ("no sensible action")
            row = self.best(seqs, values, rng)
            if float(values[row]) > noop + self.threshold:
                break
        seq, value = seqs[row], float(values[row])
        if shorten:
            seq, value = self.shorten(b0, seq, value)
        seq = seq[seq >= 0]
        return Plan(tuple(self.g.actions[i] for i in seq), value, noop, self.samples)


def _subgrounding(g: Grounding, keep: np.ndarray) -> Grounding:
    """``g`` with only the ground rules in ``keep`` (and the actions that still have one)."""
    from dataclasses import replace

    groups = g.rule_group[keep]
    kept_actions, group = np.unique(groups, return_inverse=True)
    starts = np.searchsorted(group, np.arange(len(kept_actions))) if len(group) else np.zeros(0, dtype=np.int64)
    rows = np.flatnonzero(keep)
    return replace(g, actions=tuple(g.actions[i] for i in kept_actions), starts=starts, rule_group=group,
                   ctx=g.ctx[keep], sign=g.sign[keep], manipulating=g.manipulating[keep],
                   set_true=g.set_true[rows], touched=g.touched[rows],
                   source=tuple(g.source[i] for i in rows))


def _sample_rows(W: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One column index per row with probability proportional to ``W``; -1 where the row is all 0."""
    if not W.shape[1]:
        return np.full(W.shape[0], -1, dtype=np.int64)
    cum = np.cumsum(W, axis=1)
    total = cum[:, -1]
    r = rng.random(W.shape[0]) * total
    idx = (cum <= r[:, None]).sum(axis=1)
    idx = np.minimum(idx, W.shape[1] - 1)
    return np.where(total > 0, idx, -1)


def _pad(seqs: np.ndarray, horizon: int) -> np.ndarray:
    out = np.full((seqs.shape[0], horizon), -1, dtype=np.int64)
    out[:, :seqs.shape[1]] = seqs[:, :horizon]
    return out


# ----------------------------------------------------------------------------- the planner

def _variant(text: str) -> str:
    if text not in ("prada", "a-prada"):
        raise ValueError("expected prada or a-prada")
    return text


def nonnegative(text: str) -> float:
    value = float(text)
    if not np.isfinite(value) or value < 0:
        raise ValueError("expected a number >= 0")
    return value


def _retries(text: str) -> int:
    value = int(text)
    if value < 0:
        raise ValueError("expected an integer >= 0")
    return value


def _choice(text: str) -> str:
    if text not in ("max", "top10"):
        raise ValueError("expected max or top10")
    return text


class PradaPlanner:
    """PRADA / A-PRADA as a :class:`groundsym.planner.Planner`, replanning at every step."""

    name = "prada"
    NEEDS = frozenset({"rules", "reward"})
    OPTIONS = (
        PlannerOption("horizon", positive(int, most=100), 4, "look-ahead in primitives (libPRADA demos: 4)"),
        PlannerOption("samples", positive(int, most=100_000), 500, "action sequences sampled per decision"),
        PlannerOption("gamma", unit_interval, None, "discount of the expected rewards (default: the task's, "
                      "e.g. the tower's 0.8; 0.95 as libPRADA on a PPDDL domain)"),
        PlannerOption("noise_softener", unit_interval, 0.2, "scales how much a rule's noise outcome "
                      "spreads over changeable atoms (libPRADA demos: 0.2)"),
        PlannerOption("variant", _variant, "prada", "prada, or a-prada (shorten the best sequence)"),
        PlannerOption("choice", _choice, "max", "max: first action of the best sequence; top10: the "
                      "first action whose 10 best sequences score highest on average"),
        PlannerOption("rule_min_prob", unit_interval, RULE_MIN_PROB, "a rule whose context holds with a "
                      "smaller probability is taken not to apply (libPRADA: 0.03)"),
        PlannerOption("threshold", nonnegative, 0.0, "libPRADA's 'no sensible action' test: while the best "
                      "sequence does not beat doing nothing by this much, sample again (max_runs times)"),
        PlannerOption("max_runs", positive(int, most=100), 1, "sampling rounds per decision while the "
                      "threshold is not met (then the best sequence found is run anyway)"),
        PlannerOption("retries", _retries, None, "a primitive that left the abstract state unchanged is "
                      "tried again in that same state at most this many times (then only other first "
                      "actions are sampled until the state changes); default: no limit, as libPRADA"),
        PlannerOption("goal_share", nonnegative, 0.0, "a PPDDL goal scores the probability that all its "
                      "literals hold plus this weight times the expected share of them that hold"),
    )

    def __init__(self, model: PlanningModel, options: Mapping[str, Any], seed: int):
        self.opts = parse_planner_options(self.name, self.OPTIONS, options)
        self.model = model
        self.rng = np.random.default_rng(seed)
        self._cores: dict[tuple[str, ...], PradaCore] = {}
        self._last: tuple[frozenset, Atom] | None = None
        self._unchanged: dict[tuple[frozenset, Atom], int] = {}    # (state, action) -> times it changed nothing

    def _predicates(self, state: frozenset) -> dict[str, int]:
        preds: dict[str, int] = dict(self.model.predicates or {})
        preds.update(dict(getattr(self.model.reward, "predicates", ()) or ()))
        if self.model.goal is not None:
            for lit in self.model.goal.literals:
                preds.setdefault(lit.atom.predicate, lit.atom.arity)
        for a in state:
            preds.setdefault(a.predicate, a.arity)
        return preds

    def core(self, objects: tuple[str, ...], state: frozenset) -> PradaCore:
        """The grounding and reward for this object set (built once, reused every step)."""
        if objects not in self._cores:
            g = ground_rules(self.model.rules, objects, self._predicates(state), self.opts["noise_softener"])
            if self.model.goal is not None:
                reward: RewardFn = goal_reward(self.model.goal, g, self.opts["goal_share"])
            else:
                reward = model_reward(self.model.reward, g, np.random.default_rng(0))
            gamma = self.opts["gamma"] if self.opts["gamma"] is not None else self.model.gamma
            o = self.opts
            self._cores[objects] = PradaCore(g, reward, o["horizon"], o["samples"], gamma, o["choice"],
                                             False, o["rule_min_prob"], o["threshold"], o["max_runs"])
        return self._cores[objects]

    def choose(self, observation: Observation) -> Decision:
        state = observation.state if observation.state is not None else frozenset()
        core = self.core(observation.objects, state)
        b0 = core.g.belief(with_derived(state, getattr(self.model.rules, "derived", ()), observation.objects))
        shorten = self.opts["variant"] == "a-prada"
        banned = self._banned(state, observation.t)
        plan = core.plan(b0, self.rng, shorten, banned)
        for _ in range(2 if shorten else 0):    # A-PRADA plan_full: first action must be covered
            if plan.actions and self._covered(state, plan.actions[0], observation.objects):
                break
            plan = core.plan(b0, self.rng, shorten, banned)
        legal = set(observation.actions) if observation.actions else None
        if plan.actions and (legal is None or plan.actions[0] in legal):
            action = plan.actions[0]
        else:   # nothing applicable is worth sampling: any legal primitive, chosen by the seed
            action = observation.actions[int(self.rng.integers(len(observation.actions)))]
        info = {"plan": [str(a) for a in plan.actions], "noop_value": plan.noop_value,
                "variant": self.opts["variant"]}
        if banned:
            info["banned"] = [str(a) for a in banned]
        self._last = (state, action)
        return Decision(action, plan.value, info)

    def _banned(self, state: frozenset, t: int) -> list[Atom]:
        """The actions ``retries`` rules out now: each left this very state unchanged more than
        ``retries`` times in this episode (counted from the previous decision's outcome)."""
        limit = self.opts["retries"]
        if limit is None:
            return []
        if t == 0:
            self._unchanged.clear()
        elif self._last is not None and self._last[0] == state:
            self._unchanged[self._last] = self._unchanged.get(self._last, 0) + 1
        return sorted(a for (s, a), n in self._unchanged.items() if s == state and n > limit)

    def _covered(self, state: frozenset, action: Atom, objects: Sequence[str]) -> bool:
        rule, _ = self.model.rules.covering(state, action, objects)
        return rule is not None

    def observe(self, action: Atom, observation: Observation) -> None:
        """PRADA replans from scratch every step; nothing to remember."""
