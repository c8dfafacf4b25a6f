"""Gymnasium environments: the groundsym simulations and any PPDDL problem (docs/gymnasium.md).

Importing this package registers, in Gymnasium's registry:

- ``groundsym/Tower-v0``: the tower cell (``cubes=``, ``balls=``, ``noise=``, ... as keywords);
- ``groundsym/Bowling-v0``: the bowling alley (``pins=``, ``spots=``, ...);
- ``groundsym/Sim-v0``: any simulation of the sim registry by name (``sim="tower"``, plug-ins too);
- ``groundsym/PPDDL-v0``: a PPDDL domain and problem (``domain=``, ``problem=`` paths).

Gymnasium 1.x finds third-party environments by importing their module, so either
``import groundsym.gym`` before ``gymnasium.make("groundsym/Tower-v0")``, or name the module in
the id, ``gymnasium.make("groundsym.gym:groundsym/Tower-v0")``, which imports it for you.
"""

from __future__ import annotations

try:
    import gymnasium
except ImportError as exc:                          # the optional extra is not installed
    raise ImportError("groundsym.gym needs Gymnasium: pip install 'groundsym[gym]'") from exc

from .abstract import AbstractStates, SymbolObservation
from .atoms import AtomIndex
from .ppddl_env import PPDDLGymEnv
from .sim_env import SimGymEnv

NAMESPACE = "groundsym"
ENVIRONMENTS = {
    "Tower-v0": ("groundsym.gym.sim_env:SimGymEnv", {"sim": "tower"}),
    "Bowling-v0": ("groundsym.gym.sim_env:SimGymEnv", {"sim": "bowling"}),
    "Sim-v0": ("groundsym.gym.sim_env:SimGymEnv", {}),
    "PPDDL-v0": ("groundsym.gym.ppddl_env:PPDDLGymEnv", {}),
}


def register_envs() -> None:
    """Register the environments under ``groundsym/``; ids already registered are left as they are."""
    for name, (entry_point, kwargs) in ENVIRONMENTS.items():
        env_id = f"{NAMESPACE}/{name}"
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=entry_point, kwargs=dict(kwargs))


register_envs()

__all__ = ["AbstractStates", "AtomIndex", "PPDDLGymEnv", "SimGymEnv", "SymbolObservation", "register_envs"]
