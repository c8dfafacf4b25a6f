"""Simulations and planners found by name.

Built-in ones are listed here; more come from the entry-point groups ``groundsym.sims`` and
``groundsym.planners`` of any installed distribution, so a user can plug in their own robot or
planner without touching this package. The core never imports ``sims`` or ``planners`` directly.

:data:`BUILTIN_SIMS` and :data:`BUILTIN_PLANNERS` are the one list of what this repository
provides: they work from a checkout that is not installed, and pyproject.toml registers the same
names as entry points for an installed one (tests/test_registry.py fails when the two differ).
"""

from __future__ import annotations

import importlib
from importlib.metadata import entry_points
from typing import Any

from .errors import UserError

BUILTIN_SIMS = {
    "tower": "sims.tower:TowerSim",
    "bowling": "sims.bowling:BowlingSim",
    "kinder-stickbutton": "sims.kinder2d:StickButtonSim",
    "kinder-obstruction": "sims.kinder2d:ObstructionSim",
    "kinder-cluttered": "sims.kinder_cluttered:ClutteredSim",
}
BUILTIN_PLANNERS = {
    "prada": "planners.prada:PradaPlanner",
    "jaxplan": "planners.jaxplan:JaxPlanPlanner",
    "random": "planners.random:RandomPlanner",
    "symbolic-nn": "planners.nn:SymbolicNNPlanner",
    "continuous-nn": "planners.nn:ContinuousNNPlanner",
    "external": "planners.external:ExternalPlanner",
    "lrtdp": "planners.lrtdp:LrtdpPlanner",
}


def _available(group: str, builtin: dict[str, str]) -> dict[str, str]:
    found = dict(builtin)
    for ep in entry_points(group=group):
        found.setdefault(ep.name, ep.value)
    return found


def _load(target: str) -> Any:
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def sim_names() -> list[str]:
    return sorted(_available("groundsym.sims", BUILTIN_SIMS))


def planner_names() -> list[str]:
    return sorted(_available("groundsym.planners", BUILTIN_PLANNERS))


def get_sim_class(name: str) -> Any:
    table = _available("groundsym.sims", BUILTIN_SIMS)
    if name not in table:
        raise UserError(f"--sim {name}: unknown simulation (available: {', '.join(sorted(table))})")
    return _load(table[name])


def make_sim(name: str, options: dict[str, str] | None = None) -> Any:
    """Instantiate a simulation by name with ``--sim-opt`` style options."""
    return get_sim_class(name)(**(options or {}))


def get_planner_class(name: str) -> Any:
    """``external:fast-downward`` finds ``external``; the part after ':' is the planner's own choice."""
    base = name.split(":", 1)[0]
    table = _available("groundsym.planners", BUILTIN_PLANNERS)
    if base not in table:
        raise UserError(f"--planner {name}: unknown planner (available: {', '.join(sorted(table))})")
    return _load(table[base])
