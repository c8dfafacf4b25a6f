"""The Sim protocol every simulation implements, and what a sim's options and cell record.

A simulation owns a physical world and exposes it the way the learner sees it: the scene's objects
with their geometric features and reward, the primitives it can run, and, for evaluation only,
ground-truth atoms. ``sims/tower.py`` and ``sims/bowling.py`` implement it; users can plug in their
own through the ``groundsym.sims`` entry-point group. A sim declares its ``--sim-opt`` options as
:class:`groundsym.options.Option` values, the same type the planners' options have.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, ClassVar, Mapping, Protocol, runtime_checkable

from .errors import UserError
from .logic import Atom
from .options import Option, parse_options
from .world import Scene


def recorded_options(spec: tuple[Option, ...], options: Mapping[str, Any]) -> dict[str, Any]:
    """The options a traces file or a result records: all of them, except later additions at their
    default (so files and results made before such an option existed keep their identity)."""
    skip = {o.name for o in spec if not o.recorded_at_default and options.get(o.name) == o.default}
    return {k: v for k, v in options.items() if k not in skip}


def feature_names_for(cls: Any, options: Mapping[str, Any]) -> tuple[str, ...]:
    """The unary feature names an instance of sim class ``cls`` made with ``options`` will have
    (a sim whose feature space is an option declares ``features_for(options)``), known before the
    physics starts."""
    fn = getattr(cls, "features_for", None)
    return tuple(fn(options)) if fn is not None else tuple(cls.feature_names)


@runtime_checkable
class Sim(Protocol):
    """What the core needs from a simulation.

    Class attributes describe the task; instances hold one physical world. All randomness comes
    from the seed given to :meth:`reset`, so the same seed and options give the same trace.
    """

    name: ClassVar[str]
    OPTIONS: ClassVar[tuple[Option, ...]]
    feature_names: tuple[str, ...]         # names of the n unary feature dimensions
    primitives: dict[str, int]             # primitive name -> arity
    truth_predicates: dict[str, int]       # ground-truth relation name -> arity (evaluation only)
    episode_length: int                    # T of the task (10 for the tower, 2 for bowling)
    gamma: float                           # discount of the episode value sum_t gamma^(t-1) r_t

    def reset(self, seed: int) -> Scene:
        """Start a new episode from a random start state drawn with ``seed``."""

    def scene(self) -> Scene:
        """The current observation (features, reward, ground truth)."""

    def actions(self) -> list[Atom]:
        """All ground primitives that can be run now."""

    def step(self, action: Atom) -> Scene:
        """Run one primitive until the world settles; return the new scene."""

    def render(self, path: str | Path, width: int = 640, height: int = 480) -> None:
        """Write a PNG of the current scene."""

    def close(self) -> None:
        """Release the physics engine."""


def cell_meta(sim: Any) -> dict[str, Any]:
    """What a traces file records about the cell beyond its options: the version of the cell's
    physics and controller (``CELL_VERSION``, when the sim declares one)."""
    version = getattr(sim, "CELL_VERSION", None)
    return {} if version is None else {"cell_version": int(version)}


def cell_identity(name: str, given: Mapping[str, Any]) -> dict[str, Any]:
    """The sim's options with its defaults filled in, and its cell version: what results made with
    ``--sim NAME --sim-opt given`` depend on beyond the options a user typed (a default that
    changes, such as the tower's noise, must not mix old and new results)."""
    from .registry import get_sim_class

    cls = get_sim_class(name)
    spec = getattr(cls, "OPTIONS", None)
    options = recorded_options(spec, parse_options("--sim-opt", "sim", name, spec, given)) if spec else dict(given)
    return {"options": {k: options[k] for k in sorted(options)}, **cell_meta(cls)}


def warn_if_older_cell(meta: Mapping[str, Any], where: str) -> bool:
    """One warning line on stderr when ``meta`` (of traces, a model or results) was made by an
    older version of its sim's cell than the one installed; a file without ``cell_version`` comes
    from version 1. Returns whether it warned."""
    from .registry import get_sim_class

    name = meta.get("sim")
    try:
        current = getattr(get_sim_class(str(name)), "CELL_VERSION", None) if name else None
    except UserError:                                # a sim that is not installed: nothing to compare
        return False
    made = meta.get("cell_version", 1)
    if current is None or not isinstance(made, int) or made >= current:
        return False
    print(f"warning: {where}: made by {name} cell version {made}, the installed cell is version {current} "
          f"(its primitives changed; figures from this file may not hold for the current cell)", file=sys.stderr)
    return True
