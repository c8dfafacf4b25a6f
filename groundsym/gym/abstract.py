"""Learned symbols as what a reinforcement-learning agent observes.

``groundsym learn`` writes ``symbols.json`` into a model directory: RBF groundings that map a
scene's continuous features to the ground atoms that hold (the abstraction ``phi``). An agent that
sees ``phi(scene)`` instead of raw coordinates works on the learned abstract state space, which is
the point of learning grounded symbols. :class:`SymbolObservation` turns scenes into 0/1 vectors
over a fixed order of the symbols' ground atoms; :class:`AbstractStates` is the Gymnasium
observation wrapper that gives a wrapped simulation environment's agent those vectors.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

import gymnasium
import numpy as np
from gymnasium import spaces

from ..errors import UserError
from ..modeldir import SYMBOLS
from ..symbols import SymbolSet, load_symbols
from ..world import Scene
from .atoms import AtomIndex, symbol_atoms

ATOMS_KEY = "atoms"


def load_symbol_set(model: str | Path | SymbolSet, feature_names: Sequence[str]) -> SymbolSet:
    """The symbols of a model directory, of a ``symbols.json`` file, or a SymbolSet as it is;
    their feature space must be the environment's."""
    if isinstance(model, SymbolSet):
        model.check_features(feature_names, "model")
        return model
    if not isinstance(model, (str, os.PathLike)):     # a number reached Path() as a bare TypeError
        raise UserError(f"model={model!r}: expected a model directory, a symbols.json file or a SymbolSet")
    path = Path(model)
    if path.is_dir():
        path = path / SYMBOLS
        if not path.exists():
            raise UserError(f"{model}: model directory without {SYMBOLS} (was it learned from symbolic "
                            f"traces? an abstract observation needs symbols learned from continuous data)")
    elif not path.exists():
        raise UserError(f"{model}: no such model directory or symbols file")
    return load_symbols(path, feature_names)


class SymbolObservation:
    """Scenes of one environment as 0/1 vectors over the ground atoms of a symbol set."""

    def __init__(self, model: str | Path | SymbolSet, objects: Sequence[str], feature_names: Sequence[str]):
        self.symbols = load_symbol_set(model, feature_names)
        where = str(model) if not isinstance(model, SymbolSet) else "model"
        if not self.symbols.symbols:
            raise UserError(f"{where}: the model has no symbols (all were pruned as never or always true)")
        self.index = AtomIndex(symbol_atoms(self.symbols.predicates, objects), where)

    def vector(self, scene: Scene) -> np.ndarray:
        return self.index.vector(self.symbols.abstract_scene(scene))


class AbstractStates(gymnasium.ObservationWrapper, gymnasium.utils.RecordConstructorArgs):
    """Observe the learned abstract state of a simulation environment instead of its features.

    ``AbstractStates(gymnasium.make("groundsym/Tower-v0", cubes=4), "model/")``: each observation
    becomes a ``MultiBinary`` vector, one entry per ground atom of the model's symbols in sorted
    order (``env.atoms`` lists them; ``env.decode(obs)`` gives the atoms back). With
    ``keep_features=True`` the features stay and the vector is added under the key ``"atoms"``.
    The symbols are evaluated on the simulator's current scene, so pair features a sim defines
    itself are used as they are.
    """

    def __init__(self, env: gymnasium.Env, model: str | Path | SymbolSet, keep_features: bool = False):
        gymnasium.utils.RecordConstructorArgs.__init__(self, model=model, keep_features=keep_features)
        gymnasium.ObservationWrapper.__init__(self, env)
        base = env.unwrapped
        if not hasattr(base, "current_scene"):
            raise UserError(f"AbstractStates wraps a groundsym simulation environment, not {type(base).__name__}")
        self.abstraction = SymbolObservation(model, base.objects, base.feature_names)
        self.keep_features = keep_features
        atoms_space = self.abstraction.index.space()
        if keep_features:
            if not isinstance(env.observation_space, spaces.Dict) or ATOMS_KEY in env.observation_space.spaces:
                raise UserError("AbstractStates(keep_features=True): the environment's observation must be a "
                                f"Dict without an {ATOMS_KEY!r} key")
            self.observation_space = spaces.Dict({**env.observation_space.spaces, ATOMS_KEY: atoms_space})
        else:
            self.observation_space = atoms_space

    @property
    def atoms(self) -> tuple:
        return self.abstraction.index.atoms

    def decode(self, observation: Any) -> frozenset:
        vec = observation[ATOMS_KEY] if isinstance(observation, dict) else observation
        return self.abstraction.index.state(vec)

    def observation(self, observation: Any) -> Any:
        vec = self.abstraction.vector(self.env.unwrapped.current_scene())
        return {**observation, ATOMS_KEY: vec} if self.keep_features else vec
