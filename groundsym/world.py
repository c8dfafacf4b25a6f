"""Continuous observations: scenes and actions.

A :class:`Scene` is one observation of the world: object ids, unary features ``Y`` (M x n) and pair
features ``Y2`` (M x M x n'; by default ``y_i - y_j``), the reward of that scene and, for evaluation
only, the simulator's ground-truth atoms. An action is a ground :class:`~groundsym.logic.Atom`,
e.g. ``(closeHandAround o3)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .logic import Atom

Action = Atom


def default_pair_features(features: np.ndarray) -> np.ndarray:
    """``Y2[i, j] = y_i - y_j`` for an M x n feature matrix (M x M x n)."""
    return features[:, None, :] - features[None, :, :]


@dataclass(frozen=True, eq=False)
class Scene:
    """One observation. ``pair_features`` is None when it is the default ``y_i - y_j``; ``unseen``
    names the objects a sensor did not see in it (their features are the last ones it saw)."""

    objects: tuple[str, ...]
    features: np.ndarray
    reward: float = 0.0
    truth: frozenset = field(default_factory=frozenset)
    pair_features: np.ndarray | None = None
    unseen: tuple[str, ...] = ()

    @property
    def n_objects(self) -> int:
        return len(self.objects)

    def pairs(self) -> np.ndarray:
        """The pair features, computing the default ``y_i - y_j`` when none were given."""
        if self.pair_features is not None:
            return self.pair_features
        return default_pair_features(self.features)

    def index(self, obj: str) -> int:
        return self.objects.index(obj)
