"""The Planner protocol: what every policy that picks the next primitive looks like to the core.

A planner is built once per episode batch from a :class:`PlanningModel` (whatever was learned or
given: symbols, NID rules, a reward model, training traces, a PPDDL domain and problem), a dict of
``--planner-opt`` strings and a seed. Each step it gets an :class:`Observation` and returns a
:class:`Decision`. Like unified-planning's *problem kind*, a planner class declares in ``NEEDS``
which parts of the model it uses, so the CLI can refuse a model that lacks them with one clear line
instead of failing deep inside a planner. Its ``OPTIONS`` are :class:`groundsym.options.Option`
values read with :func:`groundsym.options.parse_options`, the type and parser of the simulations'
options too.

The core never imports ``planners``; it finds planner classes by name through
:func:`groundsym.registry.get_planner_class`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, Mapping, Protocol, runtime_checkable

from .errors import UserError
from .logic import Atom, Literal
from .options import Option
from .world import Scene

# What a planner may need from the model; the keys of PlanningModel that must not be None.
NEED_NAMES = {
    "symbols": "learned symbols (symbols.json)",
    "rules": "NID rules (rules.json) or a PPDDL domain",
    "reward": "a reward model (reward.json) or a PPDDL goal",
    "traces": "continuous training traces (traces.json)",
    "symbolic_traces": "symbolic training traces (symbolic-traces.json)",
    "ppddl": "a PPDDL domain and problem (--domain/--problem)",
}


@dataclass(frozen=True)
class Goal:
    """A conjunction of ground literals and the reward for reaching it (a PPDDL problem's goal)."""

    literals: tuple[Literal, ...]
    reward: float = 1.0

    def holds(self, state: frozenset) -> bool:
        return all(l.holds(state) for l in self.literals)

    def __str__(self) -> str:
        return "(and " + " ".join(map(str, self.literals)) + ")"


@dataclass(frozen=True)
class PlanningModel:
    """Everything a planner may use. Fields a source does not provide stay None.

    ``domain``/``problem`` are parsed PPDDL objects (groundsym.ppddl) when planning on a PPDDL
    domain; ``rules`` then holds the domain converted to NID rules and ``goal`` the problem's goal.
    """

    primitives: Mapping[str, int]
    predicates: Mapping[str, int] | None = None
    symbols: Any = None
    rules: Any = None
    reward: Any = None
    goal: Goal | None = None
    traces: Any = None
    symbolic_traces: Any = None
    domain: Any = None
    problem: Any = None
    ppddl: Any = None          # (domain, problem) pair when a PPDDL source was given
    gamma: float = 0.95

    def has(self, need: str) -> bool:
        if need == "reward":
            return self.reward is not None or self.goal is not None
        return getattr(self, need) is not None


@dataclass(frozen=True)
class Observation:
    """What the planner sees at one step.

    ``state`` is the abstract state (the model's symbols applied to ``scene``, or the PPDDL state);
    ``scene`` the continuous observation when there is one; ``actions`` the ground primitives that
    can be run now; ``t`` the step index and ``steps_left`` how many primitives remain.
    """

    objects: tuple[str, ...]
    actions: tuple[Atom, ...]
    state: frozenset | None = None
    scene: Scene | None = None
    t: int = 0
    steps_left: int = 1


@dataclass(frozen=True)
class Decision:
    """The chosen primitive, the planner's expected (discounted) value for it, and free-form info."""

    action: Atom
    expected_value: float = float("nan")
    info: Mapping[str, Any] = field(default_factory=dict)

    def __str__(self) -> str:
        return f"{self.action} (expected value {self.expected_value:.4g})"


@runtime_checkable
class Planner(Protocol):
    """A policy. ``NEEDS`` names the PlanningModel parts it requires (see :data:`NEED_NAMES`)."""

    name: ClassVar[str]
    NEEDS: ClassVar[frozenset[str]]
    OPTIONS: ClassVar[tuple[Option, ...]]

    def __init__(self, model: PlanningModel, options: Mapping[str, Any], seed: int) -> None: ...

    def choose(self, observation: Observation) -> Decision:
        """Pick the next primitive for this observation."""

    def observe(self, action: Atom, observation: Observation) -> None:
        """Told what happened after the chosen action (replanning planners use it)."""


def check_needs(planner: str, needs: frozenset[str], model: PlanningModel) -> None:
    """Refuse, in one line, a model that lacks what the planner needs."""
    missing = [n for n in sorted(needs) if not model.has(n)]
    if missing:
        what = "; ".join(NEED_NAMES.get(n, n) for n in missing)
        raise UserError(f"--planner {planner}: this planner needs {what}, which the given model does not provide")


def make_planner(name: str, model: PlanningModel, options: Mapping[str, Any], seed: int) -> Any:
    """Find the planner class by name, check what it needs, and build it."""
    from .registry import get_planner_class

    cls = get_planner_class(name)
    check_needs(name, frozenset(getattr(cls, "NEEDS", frozenset())), model)
    opts = dict(options)
    if ":" in name:  # ``external:fast-downward``: the suffix is the planner's ``engine`` option
        opts.setdefault("engine", name.split(":", 1)[1])
    return cls(model, opts, seed)
