"""PRADA's grounding: a NID rule set over one object set, turned into numpy index tables.

Everything about a sample is a row of a numpy matrix: the grounding (:class:`Grounding`) turns
rules into index tables once per object set, so one step of inference for all samples
(:mod:`planners.prada.frontier`) is a gather, a product, two segment sums and two small matrix
products. That is what makes a decision at horizon 4 with 500 samples take milliseconds rather than
seconds (docs/planning.md, PRADA and A-PRADA).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from itertools import permutations, product
from typing import Any, Mapping, Sequence

import numpy as np

from groundsym.logic import Atom, is_variable

from .segments import csr_union


#: Rule tables up to this many entries are dense (BLAS products); larger ones sparse, and their
#: transition walks each sample's own action's rules (:mod:`planners.prada.segments`).
DENSE_MAX_ENTRIES = 2_000_000


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
    family: np.ndarray | None = None   # (R,) with unique references: ground rules of one rule and one
                                       # ground action (bindings of its references) share a number

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
        if touched.shape[0] * touched.shape[1] <= DENSE_MAX_ENTRIES:     # small (<= 16 MB): dense, BLAS products
            return cols, touched.toarray(), set_true.toarray()
        return cols, touched.tocsc(), set_true.tocsc()

    @cached_property
    def changing_rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The tables of :attr:`changing` by rule, on one CSR structure (indptr, columns, touched,
        set_true): what :mod:`planners.prada.segments` walks per sample."""
        from scipy.sparse import csr_matrix

        _, touched, set_true = self.changing
        return csr_union(csr_matrix(touched), csr_matrix(set_true))


def ground_rules(rules: Any, objects: Sequence[str], predicates: Mapping[str, int],
                 noise_softener: float = 0.2, unique_references: bool = False) -> Grounding:
    """Ground every rule over every injective binding of its variables to ``objects``; with
    ``unique_references``, record which ground rules are bindings of one rule's references for
    one ground action (:attr:`Grounding.family`), so that :func:`planners.prada.frontier.rule_probabilities`
    can apply NID's semantics: a rule covers only when exactly one binding of its references does
    (Pasula, Zettlemoyer & Kaelbling 2007), instead of each binding being a rival of every other."""
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
    family = None
    if unique_references:     # rows of one action are contiguous and, within them, one rule's rows
        keys = [(act, id(rule)) for act, rule, _ in rows]
        family = np.cumsum([k == 0 or keys[k] != keys[k - 1] for k in range(R)], dtype=np.int64) - 1
    return Grounding(tuple(objects), atoms, index, actions, starts, group, ctx, sign, manip,
                     set_true, touched, tuple((r[1], r[2]) for r in rows), dcols, dof, family)


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


def subgrounding(g: Grounding, keep: np.ndarray) -> Grounding:
    """``g`` with only the ground rules in ``keep`` (and the actions that still have one): what
    :meth:`planners.prada.core.PradaCore.restrict` plans with when most rules cannot fire."""
    groups = g.rule_group[keep]
    kept_actions, group = np.unique(groups, return_inverse=True)
    starts = np.searchsorted(group, np.arange(len(kept_actions))) if len(group) else np.zeros(0, dtype=np.int64)
    rows = np.flatnonzero(keep)
    return replace(g, actions=tuple(g.actions[i] for i in kept_actions), starts=starts, rule_group=group,
                   ctx=g.ctx[keep], sign=g.sign[keep], manipulating=g.manipulating[keep],
                   set_true=g.set_true[rows], touched=g.touched[rows],
                   source=tuple(g.source[i] for i in rows),
                   family=None if g.family is None else np.unique(g.family[keep], return_inverse=True)[1])
