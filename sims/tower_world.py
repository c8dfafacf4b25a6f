"""The tower cell's physical world: a table, a Franka Panda with its hand, cubes and balls.

:class:`TowerWorld` is what :mod:`sims.tower` (and the tests, examples and benchmarks) hold: one
pybullet world with an arm that runs the two primitives. It knows nothing about features, atoms
or rewards (``sims/tower.py`` reads those from its poses and contacts). It is a facade over five
modules, one concern each, in the order they build on each other:

- :mod:`sims.tower_scene`: the pybullet client, the bodies in it, reading and stepping it;
- :mod:`sims.tower_hand`: the fingers and the fixed-constraint grasp (what is held);
- :mod:`sims.tower_control`: the arm's joint motors tracking trajectories, and the guards;
- :mod:`sims.tower_approach`: hand yaws and approach paths, planned on the kinematic copy;
- :mod:`sims.tower_skills`: the primitives, running those plans, counting what they meet.

The parts are attributes (``scene``, ``hand``, ``arm``, ``planner``, ``skills``, ``kin``) for code
that needs one of them (the tests watch the controller's moves and the hand's grasps); what the
rest of the code reads is forwarded here. docs/tower.md describes the world and the primitives.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from .tower_approach import ApproachPlanner
from .tower_control import ArmController
from .tower_hand import Hand
from .tower_kinematics import ArmKinematics
from .tower_scene import FINGER_OPEN, HOME_Q, TABLE_CENTRE, TABLE_HALF, Body, TowerScene
from .tower_skills import TowerSkills


class TowerWorld:
    """A fresh pybullet world; :meth:`build` makes the same world from the same placement."""

    def __init__(self, table_half: tuple[float, float, float] = TABLE_HALF,
                 table_centre: tuple[float, float] = TABLE_CENTRE) -> None:
        self.scene = TowerScene(table_half, table_centre)
        self.kin = ArmKinematics()
        self.hand = Hand(self.scene)
        self.arm = ArmController(self.scene, self.hand, self.kin)
        self.planner = ApproachPlanner(self.scene, self.hand, self.kin)
        self.skills = TowerSkills(self.scene, self.hand, self.arm, self.planner, self.kin)

    def build(self, placements: list[tuple[str, float, float, float, float]]) -> None:
        """Reset the simulation and create the table, the arm at home and the objects.

        ``placements`` holds ``(shape, size, x, y, yaw)`` for each object, resting on the table.
        The motors hold the home pose and the open hand before the objects appear, then the world
        settles; this order of pybullet calls is the cell's (a reordered call changes the traces).
        """
        self.scene.reset()
        self.arm.command(HOME_Q, np.zeros(7))
        self.hand.set_fingers(FINGER_OPEN)
        self.scene.place_objects(placements)
        self.hand.reset()
        self.scene.settle()

    def close(self) -> None:
        self.scene.close()
        self.kin.close()

    def __del__(self) -> None:  # a forgotten close() must not leak physics servers
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown may have torn pybullet down
            pass

    # ------------------------------------------------------------------ the primitives

    def close_hand_around(self, index: int, offset: np.ndarray) -> None:
        """See :meth:`sims.tower_skills.TowerSkills.close_hand_around`."""
        self.skills.close_hand_around(index, offset)

    def open_hand_over(self, index: int, offset: np.ndarray) -> None:
        """See :meth:`sims.tower_skills.TowerSkills.open_hand_over`."""
        self.skills.open_hand_over(index, offset)

    # ------------------------------------------------------------------ reading the world

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Object centres (M x 3) and orientations as quaternions (M x 4), from the simulator."""
        return self.scene.poses()

    def contacts(self, a: int, b: int, link_b: int | None = None) -> list:
        """Touching contact points between bodies ``a`` and ``b`` (penetration or gap under 2 mm)."""
        return self.scene.contacts(a, b, link_b)

    def step(self, n: int = 1) -> None:
        """Step the physics ``n`` times (see :meth:`sims.tower_scene.TowerScene.step`)."""
        self.scene.step(n)

    @property
    def client(self) -> int:
        """The pybullet client id of the world (-1 once closed)."""
        return self.scene.client

    @property
    def robot(self) -> int:
        """The arm's pybullet body id."""
        return self.scene.robot

    @property
    def table(self) -> int:
        """The table's pybullet body id."""
        return self.scene.table

    @property
    def bodies(self) -> list[Body]:
        """The objects, in the order of the placements :meth:`build` was given."""
        return self.scene.bodies

    @property
    def held(self) -> int | None:
        """Index into :attr:`bodies` of the object in the stabilised grasp, if any."""
        return self.hand.held

    @property
    def events(self) -> Counter[str]:
        """What the controller met, over the world's life (see :class:`sims.tower_skills.TowerSkills`)."""
        return self.skills.events

    @property
    def clearance(self) -> float | None:
        """When not None: the least transit clearance seen (m); set it to ``inf`` to start watching."""
        return self.arm.clearance

    @clearance.setter
    def clearance(self, value: float | None) -> None:
        self.arm.clearance = value
