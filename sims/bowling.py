"""The bowling alley as a :class:`groundsym.sim.Sim` (``--sim bowling``), the paper's Section VI-C.

A game is two throws at a rack of pins. Each throw is a primitive aimed at one pin:
``throwAtCenter(X)`` rolls the ball straight down the lane (+y) through the centre of pin X,
``throwRightOfCenter(X)`` 7.5 cm to the right (+x) of it. The ball's start carries noise (a lateral
offset and a speed change drawn from the episode's generator), so the same aim gives different
outcomes, as the collisions of the paper's ODE simulation did. Fallen pins stay where they lie for
the next throw. Each throw runs until everything has settled, so features are read at rest.

Pin ids ``p1..pM`` are assigned in a random order per episode (option ``shuffle_ids``), as the
relational methods assume: an id must not tell which spot a pin stands on, or a planner that
copies a training action by argument name could exploit it where the features say nothing.

What the learner sees per pin ``p1..pM``: its centre of mass (x, y, z) and its long axis (ux, uy, uz)
in the world, ``y_i`` in R^6; pair features are the default ``y_i - y_j``. A scene's reward is the
number of pins down in it; ``r_t`` after the t-th throw is therefore the pins down after the
throws so far, and a game's score (the paper's "points after 2 hits") is the last scene's reward.

Ground truth, for evaluation only: ``upright(X)`` (standing on the deck), ``sameColumn(X, Y)``
(centres less than 5 cm apart across the lane, so one straight throw passes both) and
``behind(X, Y)`` (X lies more than half a row further down the lane than Y). docs/bowling.md
explains the model, the options and their defaults.
"""

from __future__ import annotations

from math import cos, radians
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from groundsym.errors import UserError
from groundsym.logic import Atom
from groundsym.options import Option, parse_bool, parse_options
from groundsym.world import Scene

from .bowling_world import PIN_COM_Z, PIN_HEIGHT, PIN_SPACING, ROW_DEPTH, Alley, rack_positions, save_png

RIGHT_OFFSET = 0.075            # throwRightOfCenter aims this far right (+x) of the pin's centre
UPRIGHT_COS = cos(radians(20))  # a pin stands if its axis is within 20 degrees of vertical ...
ON_DECK_DROP = 0.02             # ... and its centre has not dropped into a gutter or the pit
COLUMN_TOL = PIN_SPACING / 4    # 5 cm: half the lateral distance between neighbouring columns
BEHIND_TOL = ROW_DEPTH / 2      # 8.7 cm: half the distance between rows
N_SPOTS = 10


def _spot_list(text: str | list[int] | tuple[int, ...]) -> tuple[int, ...]:
    """``"1,5,7"`` -> ``(1, 5, 7)``: rack spots numbered as in bowling (1 head pin, 7-10 back row).

    A list is taken as it is, so options read back from a traces file's ``meta`` rebuild the sim.
    """
    if isinstance(text, (list, tuple)):
        return tuple(int(t) for t in text)
    text = str(text).strip()
    return tuple(int(t) for t in text.split(",")) if text else ()


_spot_list.__name__ = "comma-separated spot numbers"


class BowlingSim:
    """Ten-pin bowling on a 0.656 scale alley in pybullet (see the module docstring)."""

    name: ClassVar[str] = "bowling"
    OPTIONS: ClassVar[tuple[Option, ...]] = (
        Option("pins", int, 10, "number of pins: 10 is the full rack; fewer stand on a random subset of "
                                "the 10 spots, drawn per episode (the paper's symbol data uses 5)"),
        Option("spots", _spot_list, (), "fixed spots instead of a random subset, e.g. 1,5,7,10 "
                                        "(bowling numbers: 1 head pin, 7-10 back row)"),
        Option("shuffle_ids", parse_bool, True, "name the pins p1..pM in a random order per episode, so an "
                                               "id says nothing about a pin's spot (false: in spot order)"),
        Option("noise", float, 0.01, "standard deviation in metres of the ball's lateral start offset"),
        Option("speed", float, 6.0, "mean ball speed in m/s (regulation 8 m/s, Froude-scaled)"),
        Option("speed_noise", float, 0.05, "relative standard deviation of the ball's speed"),
        Option("timestep", float, 1 / 240, "physics time step in seconds"),
        Option("max_time", float, 6.0, "longest simulated time of one throw in seconds; a throw ends "
                                       "earlier, as soon as everything has settled"),
    )
    feature_names: ClassVar[tuple[str, ...]] = ("x", "y", "z", "ux", "uy", "uz")
    primitives: ClassVar[dict[str, int]] = {"throwAtCenter": 1, "throwRightOfCenter": 1}
    truth_predicates: ClassVar[dict[str, int]] = {"upright": 1, "sameColumn": 2, "behind": 2}
    episode_length: ClassVar[int] = 2
    gamma: ClassVar[float] = 1.0
    # How a game is scored: "final" = the reward of the last scene (pins down after both throws),
    # not the discounted sum of scene rewards, which would count the first throw's pins twice.
    episode_score: ClassVar[str] = "final"

    def __init__(self, **options: Any):
        opts = parse_options("--sim-opt", "sim", self.name, self.OPTIONS, options)
        self.options = _validated(opts, pins_given="pins" in options)
        self.alley = Alley(timestep=self.options["timestep"])
        self.rng = np.random.default_rng(0)
        self.spots: tuple[int, ...] = ()
        self.objects: tuple[str, ...] = ()

    # -- episode --------------------------------------------------------------------------------
    def reset(self, seed: int) -> Scene:
        """A fresh rack: all 10 spots, the ``spots`` option, or ``pins`` spots drawn with ``seed``."""
        self.rng = np.random.default_rng(seed)
        n = self.options["pins"]
        fixed = self.options["spots"]
        if fixed:
            spots = fixed
        elif n == N_SPOTS:
            spots = tuple(range(1, N_SPOTS + 1))
        else:
            spots = tuple(int(s) + 1 for s in np.sort(self.rng.choice(N_SPOTS, size=n, replace=False)))
        order = self.rng.permutation(len(spots))  # drawn always: the stream after it ignores shuffle_ids
        if self.options["shuffle_ids"]:
            spots = tuple(spots[i] for i in order)
        self.spots = spots                        # spots[i] is where pin objects[i] stands
        self.objects = tuple(f"p{i + 1}" for i in range(len(spots)))
        self.alley.build(rack_positions()[np.array(spots) - 1])
        self.alley.run(1.0)
        return self.scene()

    def actions(self) -> list[Atom]:
        """Both throws at every pin, standing or not (a fallen pin still marks a line down the lane)."""
        return [Atom(p, (o,)) for p in self.primitives for o in self.objects]

    def step(self, action: Atom) -> Scene:
        """Roll the ball at the pin named by ``action`` and wait until everything has settled."""
        target = self._target(action)
        aim = self.alley.poses().positions[target, 0]
        if action.predicate == "throwRightOfCenter":
            aim += RIGHT_OFFSET
        # both draws happen whatever the options, so a seed gives the same stream with noise off
        dx, dv = self.rng.standard_normal(2)
        speed = self.options["speed"] * max(0.5, 1.0 + self.options["speed_noise"] * dv)
        self.alley.launch(aim + self.options["noise"] * dx, speed)
        self.alley.run(self.options["max_time"])
        return self.scene()

    def _target(self, action: Atom) -> int:
        if action.predicate not in self.primitives or len(action.args) != 1:
            raise ValueError(f"bowling: unknown primitive {action} (known: throwAtCenter(X), throwRightOfCenter(X))")
        if action.args[0] not in self.objects:
            raise ValueError(f"bowling: {action} names no pin of this rack ({', '.join(self.objects)})")
        return self.objects.index(action.args[0])

    # -- observation ----------------------------------------------------------------------------
    def scene(self) -> Scene:
        poses = self.alley.poses()
        features = np.hstack([poses.positions, poses.axes])
        standing = upright_mask(features)
        return Scene(objects=self.objects, features=features, reward=float(np.count_nonzero(~standing)),
                     truth=truth_atoms(self.objects, features))

    def render(self, path: str | Path, width: int = 640, height: int = 480) -> None:
        """A PNG of the alley with each pin's id written just above it."""
        poses = self.alley.poses()
        head_z = poses.positions[:, 2] + poses.axes[:, 2] * (PIN_HEIGHT - PIN_COM_Z)
        foot_z = poses.positions[:, 2] - poses.axes[:, 2] * PIN_COM_Z
        tops = poses.positions.copy()
        tops[:, 2] = np.maximum(head_z, foot_z) + 0.03     # just above the pin's highest end
        at = self.alley.pixels(tops, width, height)
        save_png(path, self.alley.image(width, height), [(c, r, o) for (c, r), o in zip(at, self.objects)])

    def close(self) -> None:
        self.alley.close()

    def __enter__(self) -> "BowlingSim":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def upright_mask(features: np.ndarray) -> np.ndarray:
    """Which pins stand: axis within 20 degrees of vertical and the centre still at deck height.

    A settled pin tilted by more than about 10 degrees is leaning on something (it tips over past
    that), so 20 degrees separates standing from fallen with room for wobble.
    """
    return (features[:, 5] > UPRIGHT_COS) & (features[:, 2] > PIN_COM_Z - ON_DECK_DROP)


def truth_atoms(objects: tuple[str, ...], features: np.ndarray) -> frozenset[Atom]:
    """``upright``, ``sameColumn`` and ``behind`` from the pins' features (evaluation only)."""
    standing = upright_mask(features)
    dx = np.abs(features[:, None, 0] - features[None, :, 0])
    dy = features[:, None, 1] - features[None, :, 1]
    off_diagonal = ~np.eye(len(objects), dtype=bool)
    atoms = {Atom("upright", (objects[i],)) for i in np.flatnonzero(standing)}
    for name, mask in (("sameColumn", (dx < COLUMN_TOL) & off_diagonal), ("behind", dy > BEHIND_TOL)):
        atoms.update(Atom(name, (objects[i], objects[j])) for i, j in zip(*np.nonzero(mask)))
    return frozenset(atoms)


def _validated(opts: dict[str, Any], pins_given: bool) -> dict[str, Any]:
    """Range checks the option types cannot express; each failure names the option."""
    spots = opts["spots"]
    if spots:
        if any(s < 1 or s > N_SPOTS for s in spots) or len(set(spots)) != len(spots):
            raise UserError(f"--sim-opt spots={','.join(map(str, spots))}: expected distinct spot numbers 1..10")
        if pins_given and opts["pins"] != len(spots):
            raise UserError(f"--sim-opt pins={opts['pins']}: contradicts spots ({len(spots)} spots given)")
        opts["pins"] = len(spots)
    checks = (
        ("pins", 1 <= opts["pins"] <= N_SPOTS, "must be between 1 and 10"),
        ("noise", 0 <= opts["noise"] < 0.5, "must be at least 0 and below 0.5 (metres)"),
        ("speed", 0.5 <= opts["speed"] <= 20, "must be between 0.5 and 20 (m/s)"),
        ("speed_noise", 0 <= opts["speed_noise"] < 0.5, "must be at least 0 and below 0.5"),
        ("timestep", 1e-4 <= opts["timestep"] <= 1 / 60, "must be between 0.0001 and 1/60 (seconds)"),
        ("max_time", 0.5 <= opts["max_time"] <= 60, "must be between 0.5 and 60 (seconds)"),
    )
    for key, ok, why in checks:
        if not ok:  # NaN fails every comparison, so it lands here too
            raise UserError(f"--sim-opt {key}={opts[key]}: {why}")
    return opts
