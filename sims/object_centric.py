"""Any Gymnasium environment with an object-centric state, as a groundsym simulation.

The opposite direction of ``groundsym/gym/`` (which wraps our sims as Gymnasium environments): a
world written elsewhere, whose observation names typed objects with features (as KinDER's
``observation_space.devectorize(obs)`` does), plus a few object-parameterised primitives, becomes
a :class:`groundsym.sim.Sim` that ``collect``, ``learn``, ``plan`` and ``evaluate`` use by name.

A primitive is a closed-loop controller over the environment's own actions (the skills of bilevel
planning, Silver et al., *Learning Neuro-Symbolic Skills for Bilevel Planning*, CoRL 2022): built
for its object arguments with continuous parameters drawn from the episode's seeded generator, it
picks one low-level action per environment step from the current state until it says it is done,
the task ends, or its step limit is reached. Every environment step is counted
(:attr:`ObjectCentricSim.env_steps`), so a planner's success can be judged against a budget of
environment steps, as KinDER judges it. What the learner sees is one feature vector per object,
given per object type by :attr:`WorldSpec.type_features`; objects of types the map leaves out
(walls, a table that never moves) are not objects of the scene. docs/byo.md walks through it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import permutations
from pathlib import Path
from typing import Any, Callable, ClassVar, Iterable, Mapping, Protocol, Sequence

import numpy as np

from groundsym.errors import UserError
from groundsym.logic import Atom
from groundsym.options import Option, parse_options
from groundsym.world import Scene


@dataclass(frozen=True)
class ObjectState:
    """One object-centric observation: each object's type and named features."""

    types: Mapping[str, str]
    values: Mapping[str, Mapping[str, float]]

    def get(self, obj: str, feature: str) -> float:
        try:
            return float(self.values[obj][feature])
        except KeyError:
            raise UserError(f"object state: {obj}.{feature}: no such object or feature "
                            f"(objects: {', '.join(sorted(self.values))})") from None

    def of_type(self, type_name: str) -> list[str]:
        return [o for o, t in self.types.items() if t == type_name]


class Controller(Protocol):
    """A primitive's closed loop: the next low-level action for ``state``, or None when done."""

    def act(self, state: ObjectState) -> np.ndarray | None: ...


MakeController = Callable[[ObjectState, tuple[str, ...], np.random.Generator], Controller]


@dataclass(frozen=True)
class Primitive:
    """An object-parameterised skill: ``arg_types[k]`` is the object type (or a tuple of types)
    argument k takes; ``make(state, args, rng)`` builds its controller for one run."""

    name: str
    arg_types: tuple[str | tuple[str, ...], ...]
    make: MakeController
    max_steps: int = 300

    @property
    def arity(self) -> int:
        return len(self.arg_types)

    def accepts(self, k: int) -> tuple[str, ...]:
        """The object types argument ``k`` may be."""
        t = self.arg_types[k]
        return (t,) if isinstance(t, str) else tuple(t)


class Chained:
    """Runs ``first`` to its end, then the controller ``then`` builds from the state reached."""

    def __init__(self, first: Controller, then: Callable[[ObjectState], Controller]):
        self.current: Controller = first
        self.then: Callable[[ObjectState], Controller] | None = then

    def act(self, state: ObjectState) -> np.ndarray | None:
        action = self.current.act(state)
        if action is None and self.then is not None:
            self.current, self.then = self.then(state), None
            action = self.current.act(state)
        return action


def chain(first: MakeController, then: MakeController) -> MakeController:
    """A primitive made of two skills run one after the other (e.g. pick, then place): the second
    is built from the state the first ends in, so its parameters see where the first got to."""
    def make(state: ObjectState, args: tuple[str, ...], rng: np.random.Generator) -> Controller:
        return Chained(first(state, args, rng), lambda reached: then(reached, args, rng))
    return make


FeatureMap = Callable[[ObjectState, str], Sequence[float]]


def pick(*names: str) -> FeatureMap:
    """A per-type map that reads the named features of the object itself, in this order."""
    def features(state: ObjectState, obj: str) -> list[float]:
        return [state.get(obj, n) for n in names]
    return features


@dataclass(frozen=True)
class WorldSpec:
    """Everything the adapter needs to know about a world (see the module docstring).

    ``make_env(options)`` builds the Gymnasium environment; ``read_state(env, obs)`` turns an
    observation into an :class:`ObjectState`; ``reward(state, env_reward, terminated)`` is the
    scene's reward (default: the environment's own); ``graded_reward(state)``, when given, is the
    reward instead where the sim's option ``reward`` is ``graded`` (a task whose own reward is too
    sparse for random traces, said so in its docs); ``truth(state)`` the atoms that hold, for
    evaluation only; ``success(state, terminated)`` whether the task is solved (default: the
    environment terminated).
    """

    name: str
    make_env: Callable[[Mapping[str, Any]], Any]
    read_state: Callable[[Any, Any], ObjectState]
    feature_names: tuple[str, ...]
    type_features: Mapping[str, FeatureMap]
    primitives: tuple[Primitive, ...]
    reward: Callable[[ObjectState, float, bool], float] | None = None
    graded_reward: Callable[[ObjectState], float] | None = None
    truth: Callable[[ObjectState], Iterable[Atom]] | None = None
    truth_predicates: Mapping[str, int] = field(default_factory=dict)
    success: Callable[[ObjectState, bool], bool] | None = None
    episode_length: int = 10
    gamma: float = 0.95
    options: tuple[Option, ...] = ()


class ObjectCentricSim:
    """The :class:`groundsym.sim.Sim` of a :class:`WorldSpec`; :func:`sim_class` makes one per world."""

    SPEC: ClassVar[WorldSpec]
    name: ClassVar[str]
    OPTIONS: ClassVar[tuple[Option, ...]]
    feature_names: ClassVar[tuple[str, ...]]
    primitives: ClassVar[dict[str, int]]
    truth_predicates: ClassVar[dict[str, int]]
    episode_length: ClassVar[int]
    gamma: ClassVar[float]

    def __init__(self, **options: Any):
        self.options = parse_options("--sim-opt", "sim", self.name, self.OPTIONS, options)
        self.env = self.SPEC.make_env(self.options)
        self.rng = np.random.default_rng(0)
        self.state: ObjectState | None = None
        self.objects: tuple[str, ...] = ()
        self.env_reward, self.terminated = 0.0, False
        self.env_steps = 0              # environment steps since the last reset, all primitives counted
        self.events: dict[str, int] = {"primitives": 0, "env_steps": 0, "step_limit": 0}

    # -- episode --------------------------------------------------------------------------------
    def reset(self, seed: int) -> Scene:
        """A start state drawn by the environment with ``seed``; primitive parameters from [seed, 1]."""
        obs, _ = self.env.reset(seed=int(seed))
        self.rng = np.random.default_rng([int(seed), 1])
        self.state = self.SPEC.read_state(self.env, obs)
        self.objects = tuple(o for o in self.state.types if self.state.types[o] in self.SPEC.type_features)
        self.env_reward, self.terminated, self.env_steps = 0.0, False, 0
        return self.scene()

    def actions(self) -> list[Atom]:
        """Every primitive with every tuple of distinct objects of its argument types."""
        out = []
        for prim in self.SPEC.primitives:
            for args in permutations(self.objects, prim.arity):
                if all(self._state().types[a] in prim.accepts(k) for k, a in enumerate(args)):
                    out.append(Atom(prim.name, args))
        return out

    def step(self, action: Atom) -> Scene:
        """Run the primitive's controller in closed loop until it is done (see the module docstring)."""
        prim = self._primitive(action)
        controller = prim.make(self._state(), action.args, self.rng)
        self.events["primitives"] += 1
        for _ in range(prim.max_steps):
            if self.terminated:
                break
            low = controller.act(self._state())
            if low is None:
                break
            self._env_step(low)
        else:
            self.events["step_limit"] += 1
        return self.scene()

    def _env_step(self, low: np.ndarray) -> None:
        obs, reward, terminated, _truncated, _ = self.env.step(np.asarray(low, dtype=self.env.action_space.dtype))
        self.state = self.SPEC.read_state(self.env, obs)
        self.env_reward, self.terminated = float(reward), bool(terminated)
        self.env_steps += 1
        self.events["env_steps"] += 1

    def _primitive(self, action: Atom) -> Primitive:
        for prim in self.SPEC.primitives:
            if prim.name == action.predicate and prim.arity == len(action.args):
                if not all(a in self.objects for a in action.args):
                    raise ValueError(f"{self.name}: {action} names an object not in the scene "
                                     f"({', '.join(self.objects)})")
                return prim
        raise ValueError(f"{self.name}: unknown primitive {action} (known: {', '.join(self.primitives)})")

    def _state(self) -> ObjectState:
        if self.state is None:
            raise RuntimeError(f"{self.name}: reset() first")
        return self.state

    # -- observation ----------------------------------------------------------------------------
    def scene(self) -> Scene:
        state = self._state()
        rows = [np.asarray(self.SPEC.type_features[state.types[o]](state, o), dtype=float) for o in self.objects]
        features = np.vstack(rows) if rows else np.zeros((0, len(self.feature_names)))
        if features.shape[1] != len(self.feature_names):
            raise ValueError(f"{self.name}: a type map gave {features.shape[1]} features, "
                             f"feature_names has {len(self.feature_names)}")
        spec = self.SPEC
        if spec.graded_reward is not None and self.options.get("reward") == "graded":
            reward = spec.graded_reward(state)
        else:
            reward = spec.reward(state, self.env_reward, self.terminated) if spec.reward else self.env_reward
        truth = frozenset(spec.truth(state)) if spec.truth else frozenset()
        return Scene(self.objects, features, float(reward), truth)

    def solved(self) -> bool:
        """Whether the task is solved in the current state (the environment's own termination by default)."""
        if self.SPEC.success is not None:
            return bool(self.SPEC.success(self._state(), self.terminated))
        return self.terminated

    def render(self, path: str | Path, width: int = 640, height: int = 480) -> None:
        """A PNG of the environment's own ``rgb_array`` rendering."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        from groundsym.fileio import atomic_write_bytes
        import io

        rgb = self.env.render()
        fig = Figure(figsize=(width / 100, height / 100), dpi=100)
        ax = fig.add_axes((0, 0, 1, 1))
        ax.imshow(rgb)
        ax.set_axis_off()
        buf = io.BytesIO()
        FigureCanvasAgg(fig).print_png(buf)
        atomic_write_bytes(path, buf.getvalue())

    def close(self) -> None:
        close = getattr(self.env, "close", None)
        if close is not None:
            close()

    def __enter__(self) -> "ObjectCentricSim":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def sim_class(spec: WorldSpec, class_name: str | None = None) -> type[ObjectCentricSim]:
    """A Sim class for ``spec``, with the class attributes the registry and ``collect`` read."""
    names = [p.name for p in spec.primitives]
    if len(set(names)) != len(names):
        raise ValueError(f"{spec.name}: primitive names must be distinct, got {names}")
    attrs = {"SPEC": spec, "name": spec.name, "OPTIONS": tuple(spec.options),
             "feature_names": tuple(spec.feature_names), "primitives": {p.name: p.arity for p in spec.primitives},
             "truth_predicates": dict(spec.truth_predicates), "episode_length": int(spec.episode_length),
             "gamma": float(spec.gamma), "__doc__": f"The {spec.name} world as a groundsym Sim (sims.object_centric)."}
    return type(class_name or f"{spec.name.title().replace('-', '')}Sim", (ObjectCentricSim,), attrs)
