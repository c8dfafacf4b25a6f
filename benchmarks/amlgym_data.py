"""AMLGym's inputs as groundsym sees them (docs/amlgym.md): trajectories as symbolic traces, with
object types from the learning problems, and the same trajectories with flipped atoms (noise).

AMLGym (PyPI ``amlgym``) gives each learner a domain file (predicates, operator signatures,
types; the preconditions and effects are what is learned) and trajectory files: ``(:state ...)``
and ``(:action (...))`` in turn. The objects' types are not in the trajectories; they are in the
learning problem each trajectory was generated from (``problems/learning/<domain>/<i>_..._prob.pddl``).
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from groundsym.logic import Atom
from groundsym.symbolic_traces import SymbolicDataset, SymbolicTrace

_ATOM = re.compile(r"\(([^()]*)\)")
_ACTION = re.compile(r"\(:action\s+\((.*?)\)\)")


@dataclass(frozen=True)
class DomainSignature:
    """What every learner is given: types (type -> parent), predicates with their argument types,
    operators with their parameter names and types."""

    name: str
    types: dict[str, str | None]
    predicates: dict[str, tuple[str, ...]]
    operators: dict[str, tuple[tuple[str, str], ...]]
    constants: dict[str, str] = field(default_factory=dict)
    requirements: tuple[str, ...] = ()

    @property
    def negative_preconditions(self) -> bool:
        """May a precondition be negated? Only where the domain declares it (or ``:adl``)."""
        return bool({":negative-preconditions", ":adl"} & set(self.requirements))

    def type_predicate(self, t: str) -> str:
        """The unary predicate that says an object has type ``t`` (``type-t`` if ``t`` is a predicate)."""
        return f"type-{t}" if t in self.predicates else t

    def ancestors(self, t: str) -> list[str]:
        out = [t]
        while self.types.get(out[-1]):
            out.append(self.types[out[-1]])  # type: ignore[arg-type]
        return [x for x in out if x != "object"]


def read_signature(domain_path: str | Path) -> DomainSignature:
    """The domain's signature through unified-planning's PDDL reader (AMLGym's own)."""
    from unified_planning.io import PDDLReader
    problem = PDDLReader().parse_problem(str(domain_path))
    types = {t.name: (t.father.name if t.father is not None else None) for t in problem.user_types}
    preds = {f.name: tuple(p.type.name for p in f.signature) for f in problem.fluents}
    ops = {a.name: tuple((p.name, p.type.name) for p in a.parameters) for a in problem.actions}
    consts = {o.name: o.type.name for o in problem.all_objects}
    text = Path(domain_path).read_text().lower()
    req = re.search(r"\(:requirements([^)]*)\)", text)
    return DomainSignature(problem.name, types, preds, ops, consts, tuple(req.group(1).split()) if req else ())


def problem_objects(problem_path: str | Path) -> dict[str, str]:
    """Object -> type of a problem's ``(:objects ...)`` section."""
    text = Path(problem_path).read_text().lower()
    m = re.search(r"\(:objects(.*?)\)", text, re.S)
    out: dict[str, str] = {}
    if m is None:
        return out
    pending: list[str] = []
    tokens = m.group(1).split()
    i = 0
    while i < len(tokens):
        if tokens[i] == "-" and i + 1 < len(tokens):
            out.update({o: tokens[i + 1] for o in pending})
            pending, i = [], i + 2
        else:
            pending.append(tokens[i])
            i += 1
    out.update({o: "object" for o in pending})
    return out


def read_trajectory(path: str | Path) -> tuple[list[frozenset], list[Atom]]:
    """States (sets of ground atoms) and actions of one AMLGym trajectory file."""
    text = re.sub(r" +", " ", Path(path).read_text().lower())
    states = [frozenset(Atom(t.split()[0], tuple(t.split()[1:])) for t in _ATOM.findall(line) if t.strip()
                        and t.split()[0] != "and")
              for line in text.split("\n") if line.strip().startswith("(:state ")]
    actions = [Atom(a.split()[0], tuple(a.split()[1:])) for a in _ACTION.findall(text)]
    return states, actions


def write_trajectory(path: str | Path, states: list[frozenset], actions: list[Atom]) -> None:
    """An AMLGym trajectory file (the format :func:`read_trajectory` reads)."""
    def atom(a: Atom) -> str:
        return f"({' '.join((a.predicate, *a.args))})"
    parts = ["(:trajectory\n"]
    for s, a in zip(states, actions):
        parts += [f"(:state {' '.join(atom(x) for x in sorted(s))})\n", f"(:action {atom(a)})\n"]
    parts += [f"(:state {' '.join(atom(x) for x in sorted(states[-1]))})\n", ")\n"]
    Path(path).write_text("\n".join(parts))


def flip_atoms(states: list[frozenset], sig: DomainSignature, objects: dict[str, str], share: float,
               rng: np.random.Generator) -> list[frozenset]:
    """Each state with every well-typed ground atom flipped with probability ``share`` (the noise
    of NOLAM's paper: observations wrong at random, independently per atom and state)."""
    if share <= 0:
        return list(states)
    of_type: dict[str, list[str]] = {}
    for o, t in sorted(objects.items()):
        for k in sig.ancestors(t) + ["object"]:
            of_type.setdefault(k, []).append(o)
    universe = sorted(Atom(p, args) for p, ts in sig.predicates.items()
                      for args in itertools.product(*(of_type.get(t, []) for t in ts)))
    out = []
    for s in states:
        flip = rng.random(len(universe)) < share
        out.append(frozenset(s ^ {a for a, f in zip(universe, flip) if f}))
    return out


def symbolic_dataset(sig: DomainSignature, runs: list[tuple[list[frozenset], list[Atom], dict[str, str]]]
                     ) -> SymbolicDataset:
    """Trajectories as symbolic traces: each state with the objects' type atoms (a type and its
    ancestors), the types declared so learning treats them as types."""
    traces = []
    for states, actions, objects in runs:
        objects = {**sig.constants, **objects}
        statics = frozenset(Atom(sig.type_predicate(k), (o,)) for o, t in objects.items() for k in sig.ancestors(t))
        objs = set(objects) | {x for s in states for a in s for x in a.args} | {x for a in actions for x in a.args}
        traces.append(SymbolicTrace(tuple(sorted(objs)), [s | statics for s in states], list(actions),
                                    [0.0] * len(actions)))
    predicates = {p: len(ts) for p, ts in sig.predicates.items()}
    predicates.update({sig.type_predicate(t): 1 for t in sig.types})
    primitives = {a: len(ps) for a, ps in sig.operators.items()}
    return SymbolicDataset(traces, predicates, primitives, {"types": {sig.type_predicate(t): (
        sig.type_predicate(p) if p else None) for t, p in sig.types.items()}})
