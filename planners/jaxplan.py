"""JaxPlan (pyRDDLGym-jax; Gimelfarb, Taitler and Sanner 2024) on a learned model's RDDL export.

``--planner jaxplan``: the model's rules and reward model are written as RDDL
(:mod:`groundsym.rddl.writer`, the same text ``export-domain --format rddl`` writes, with the
current scene as the instance), pyRDDLGym compiles it, and JaxPlan's online controller optimises
a straight-line plan of ``horizon`` primitives by gradient descent through a relaxed model from
the current abstract state at every step, then runs its first action. The model is compiled once
per object set. A fixed number of gradient steps (``epochs``), not a time budget, so a seed gives
the same decisions on any machine. Needs the extra ``jaxplan`` (pyRDDLGym-jax, jax).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from groundsym.errors import UserError
from groundsym.export import DECIMALS, reward_effect
from groundsym.logic import Atom
from groundsym.options import Option, parse_options, positive
from groundsym.planner import Decision, Observation, PlanningModel
from groundsym.ppddl.ast import Problem, Typed
from groundsym.ppddl.from_rules import RulesWriter
from groundsym.rddl.roundtrip import fluent_arrays
from groundsym.rddl.writer import RddlWriter


class JaxPlanPlanner:
    """JaxPlan's online (replanning) controller as a :class:`groundsym.planner.Planner`."""

    name = "jaxplan"
    NEEDS = frozenset({"rules", "reward"})
    OPTIONS = (
        Option("horizon", positive(int, most=100), 5, "look-ahead of the optimised plan in primitives"),
        Option("epochs", positive(int, most=100_000), 100, "gradient steps per decision"),
        Option("batch", positive(int, most=4096), 16, "sampled rollouts per gradient step"),
    )

    def __init__(self, model: PlanningModel, options: Mapping[str, Any], seed: int):
        self.opts = parse_options("--planner-opt", "planner", self.name, self.OPTIONS, options)
        try:
            import pyRDDLGym_jax  # noqa: F401
        except ImportError:
            raise UserError("--planner jaxplan: pyRDDLGym-jax is not installed (pip install -e '.[jaxplan]')") from None
        if model.reward is None:
            raise UserError("--planner jaxplan: plans on a learned reward model (reward.json); this model has a goal")
        self.model = model
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self._built: dict[tuple[str, ...], tuple[Any, Any, RddlWriter, dict]] = {}
        self._tmp = tempfile.TemporaryDirectory(prefix="groundsym-jaxplan-")

    def _writer(self, objects: tuple[str, ...], state: frozenset) -> RddlWriter:
        preds = dict(self.model.predicates or {})
        preds.update(dict(getattr(self.model.reward, "predicates", ()) or ()))
        for a in state:
            preds.setdefault(a.predicate, a.arity)
        derived = {d.name for d in self.model.rules.derived}
        domain, _ = RulesWriter(self.model.rules, "no-change", DECIMALS, simple=True).domain(preds)
        init = tuple(sorted(a for a in state if a.predicate not in derived))
        problem = Problem("scene", domain.name, tuple(Typed(o) for o in objects), init)
        return RddlWriter(domain, problem, reward_effect(self.model), derived=self.model.rules.derived)

    def _build(self, objects: tuple[str, ...], state: frozenset) -> tuple[Any, Any, RddlWriter, dict]:
        """pyRDDLGym's model of this object set, JaxPlan's controller, the writer and array shapes."""
        if objects not in self._built:
            import jax
            import pyRDDLGym
            from pyRDDLGym_jax.core.planner import JaxBackpropPlanner, JaxOnlineController, JaxStraightLinePlan
            writer = self._writer(objects, state)
            folder = Path(self._tmp.name) / str(len(self._built))
            folder.mkdir()
            (folder / "domain.rddl").write_text(writer.domain_text())
            (folder / "instance.rddl").write_text(writer.instance_text())
            env = pyRDDLGym.make(str(folder / "domain.rddl"), str(folder / "instance.rddl"), vectorized=True)
            like, _ = env.reset(seed=self.seed)
            planner = JaxBackpropPlanner(rddl=env.model, plan=JaxStraightLinePlan(),
                                         rollout_horizon=self.opts["horizon"], batch_size_train=self.opts["batch"])
            controller = JaxOnlineController(planner, key=jax.random.PRNGKey(self.seed), epochs=self.opts["epochs"],
                                             train_seconds=1e9, print_summary=False, print_progress=False)
            self._built[objects] = (env.model, controller, writer, like)
        return self._built[objects]

    def choose(self, observation: Observation) -> Decision:
        start = time.process_time()
        state = observation.state if observation.state is not None else frozenset()
        model, controller, writer, like = self._build(observation.objects, state)
        arrays = fluent_arrays(model, writer, state, like)
        chosen = controller.sample_action(arrays)
        action = self._decode(model, writer, chosen)
        legal = list(observation.actions)
        info: dict[str, Any] = {"jaxplan": str(action) if action is not None else "no action",
                                "cpu_seconds": round(time.process_time() - start, 3)}   # compiling included
        if action is None or (legal and action not in legal):    # JaxPlan chose nothing it may run
            action = legal[int(self.rng.integers(len(legal)))]
            info["fallback"] = True
        return Decision(action, float("nan"), info)

    @staticmethod
    def _decode(model: Any, writer: RddlWriter, chosen: Mapping[str, Any]) -> Atom | None:
        """The one true action fluent of JaxPlan's (vectorized) action, as a primitive atom."""
        ids = writer.ids
        for var, value in chosen.items():
            where = np.argwhere(np.asarray(value, dtype=bool))
            if where.size == 0 and not (np.ndim(value) == 0 and bool(value)):
                continue
            types = model.variable_params[var]
            index = where[0] if where.size else ()
            objects = tuple(ids.name_of(model.type_to_objects[t][i]) for t, i in zip(types, index))
            return Atom(ids.name_of(var), objects)
        return None

    def observe(self, action: Atom, observation: Observation) -> None:
        """JaxPlan replans from the observed state every step; nothing to remember."""
