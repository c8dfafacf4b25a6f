"""Symbolic trace files (``groundsym.symbolic-traces/1``).

The symbolic counterpart of :mod:`groundsym.traces`: each step holds the true ground atoms of its
state (closed world), the action taken and the reward of that state; ``final`` is the last
action's successor. Predicates and primitives are declared with their arities, so a trace that
mentions an undeclared atom is rejected with one line naming the file and field.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator

from .errors import UserError
from .fileio import atomic_write_json, read_json
from .logic import Atom
from .docreader import DocReader

SCHEMA = "groundsym.symbolic-traces/1"


@dataclass(eq=False)
class SymbolicTrace:
    """States ``0..T`` (frozensets of atoms), ``T`` actions, ``T`` rewards (one per step state).

    ``final_reward`` is the reward of the final state when known (optional in files).
    """

    objects: tuple[str, ...]
    states: list[frozenset]
    actions: list[Atom]
    rewards: list[float]
    final_reward: float | None = None

    def __post_init__(self) -> None:
        if len(self.states) != len(self.actions) + 1 or len(self.rewards) != len(self.actions):
            raise ValueError("a symbolic trace needs T+1 states, T actions and T rewards")

    def __len__(self) -> int:
        return len(self.actions)

    def transitions(self) -> Iterator[tuple[frozenset, Atom, frozenset]]:
        for t, a in enumerate(self.actions):
            yield self.states[t], a, self.states[t + 1]


@dataclass(eq=False)
class SymbolicDataset:
    traces: list[SymbolicTrace]
    predicates: dict[str, int]
    primitives: dict[str, int]
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def n_transitions(self) -> int:
        return sum(len(t) for t in self.traces)

    def transitions(self) -> Iterator[tuple[frozenset, Atom, frozenset]]:
        for tr in self.traces:
            yield from tr.transitions()


def object_types(ds: SymbolicDataset, where: str | Path = "symbolic traces") -> dict[str, str | None]:
    """The dataset's object types, ``meta.types``: type predicate -> parent type (null: a root
    type). A type is a unary predicate whose atoms are static (``(block b1)``); declaring it lets
    learning treat it as a type (docs/amlgym.md). Empty when the file declares none."""
    types = ds.meta.get("types", {})
    if not isinstance(types, dict):
        raise UserError(f"{where}: meta.types: expected an object of type -> parent type (or null)")
    for t, parent in types.items():
        if ds.predicates.get(t) != 1:
            raise UserError(f"{where}: meta.types: {t!r} is not a declared unary predicate")
        if parent is not None and parent not in types:
            raise UserError(f"{where}: meta.types: parent {parent!r} of {t!r} is not a declared type")
    return dict(types)


def symbolic_traces_doc(ds: SymbolicDataset) -> dict[str, Any]:
    traces = []
    for tr in ds.traces:
        steps = [{"state": [str(x) for x in sorted(tr.states[t])], "action": str(a), "reward": float(tr.rewards[t])}
                 for t, a in enumerate(tr.actions)]
        doc: dict[str, Any] = {"objects": list(tr.objects), "steps": steps,
                               "final": [str(x) for x in sorted(tr.states[-1])]}
        if tr.final_reward is not None:
            doc["final_reward"] = float(tr.final_reward)
        traces.append(doc)
    out: dict[str, Any] = {"schema": SCHEMA, "predicates": dict(sorted(ds.predicates.items())),
                           "primitives": dict(sorted(ds.primitives.items()))}
    if ds.meta:
        out["meta"] = ds.meta
    out["traces"] = traces
    return out


def write_symbolic_traces(path: str | Path, ds: SymbolicDataset) -> None:
    atomic_write_json(path, symbolic_traces_doc(ds), indent=None)


def symbolic_traces_from_doc(doc: Any, path: str | Path = "<symbolic traces>") -> SymbolicDataset:
    r = DocReader(path)
    if not isinstance(doc, dict):
        raise r.fail("document", "expected a JSON object")
    schema = r.get(doc, "schema", "", str)
    if schema != SCHEMA:
        raise r.fail("schema", f"expected {SCHEMA!r}, got {schema!r}")
    preds, prims = r.arities(doc, "predicates"), r.arities(doc, "primitives")
    traces = []
    for i, tdoc in enumerate(r.get(doc, "traces", "", list)):
        f = f"traces[{i}]"
        objs = r.get(tdoc, "objects", f, list)
        if not all(isinstance(o, str) for o in objs) or len(set(objs)) != len(objs):
            raise r.fail(f"{f}.objects", "expected a list of distinct object names")
        objset = set(objs)

        def state(val: Any, field: str) -> frozenset:
            if not isinstance(val, list):
                raise r.fail(field, "expected a list of atoms")
            return frozenset(r.atom(a, f"{field}[{k}]", objset, preds) for k, a in enumerate(val))

        states, actions, rewards = [], [], []
        for t, sdoc in enumerate(r.get(tdoc, "steps", f, list)):
            sf = f"{f}.steps[{t}]"
            states.append(state(r.get(sdoc, "state", sf, list), f"{sf}.state"))
            actions.append(r.atom(r.get(sdoc, "action", sf, str), f"{sf}.action", objset, prims))
            rewards.append(r.number(r.get(sdoc, "reward", sf, (int, float)), f"{sf}.reward"))
        states.append(state(r.get(tdoc, "final", f, list), f"{f}.final"))
        fr = tdoc.get("final_reward")
        final_reward = r.number(fr, f"{f}.final_reward") if fr is not None else None
        traces.append(SymbolicTrace(tuple(objs), states, actions, rewards, final_reward))
    meta = doc.get("meta", {})
    ds = SymbolicDataset(traces, preds, prims, meta if isinstance(meta, dict) else {})
    object_types(ds, path)              # a bad type declaration is reported before any work
    return ds


def read_symbolic_traces(path: str | Path) -> SymbolicDataset:
    return symbolic_traces_from_doc(read_json(path), path)


def require_transitions(ds: SymbolicDataset, path: str | Path, minimum: int = 1) -> None:
    if ds.n_transitions < minimum:
        raise UserError(f"{path}: traces: {ds.n_transitions} transitions, need at least {minimum}")
