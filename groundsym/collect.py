"""Experience collection: random primitives from random start states, recorded as a Dataset.

The paper's data ``Delta = {<y_t, a_t, r_t>}`` is ``n`` traces of ``T`` random primitives, each from
a fresh random start state. Trace ``i`` is started with ``reset(seed_i)`` and its primitives drawn
from its own Generator, where ``seed_i`` and the action stream both derive from ``seed`` through
``numpy.random.SeedSequence``: the same seed and options give the same file, and trace ``i`` does
not depend on how many traces come before or after it. Works with any :class:`~groundsym.sim.Sim`.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from .progress import Progress
from .sim import Sim, cell_meta
from .traces import Dataset, Trace


def trace_seeds(seed: int, n_traces: int) -> list[tuple[int, np.random.Generator]]:
    """For each trace: the sim's reset seed and the Generator that picks its random primitives."""
    out = []
    for child in np.random.SeedSequence(seed).spawn(n_traces):
        reset_seed, action_seed = child.generate_state(2)
        out.append((int(reset_seed), np.random.default_rng(int(action_seed))))
    return out


def collect_trace(sim: Sim, length: int, reset_seed: int, rng: np.random.Generator,
                  on_step: Callable[[], None] | None = None) -> Trace:
    """One trace: a start state from ``reset_seed``, then ``length`` uniformly random primitives."""
    scenes = [sim.reset(reset_seed)]
    actions = []
    for _ in range(length):
        choices = sim.actions()
        action = choices[int(rng.integers(len(choices)))]
        actions.append(action)
        scenes.append(sim.step(action))
        if on_step is not None:
            on_step()
    return Trace(scenes[0].objects, scenes, actions)


def collect_traces(sim: Sim, n_traces: int, length: int, seed: int, progress: bool = True,
                   meta: dict[str, Any] | None = None) -> Dataset:
    """``n_traces`` random traces of ``length`` primitives each, with a progress bar on stderr."""
    if n_traces < 1 or length < 1:
        raise ValueError("need at least one trace of at least one primitive")
    bar = Progress(n_traces * length, f"collect {sim.name}", enabled=progress)
    traces: list[Trace] = []
    events_before = dict(getattr(sim, "events", {}))

    def tick() -> None:
        bar.update(bar.done + 1, f"trace {len(traces) + 1}/{n_traces}")

    for reset_seed, rng in trace_seeds(seed, n_traces):
        traces.append(collect_trace(sim, length, reset_seed, rng, tick))
    bar.close()
    info = {"sim": sim.name, "options": dict(getattr(sim, "options", {})), "seed": seed,
            "traces": n_traces, "length": length, **cell_meta(sim)}
    if getattr(sim, "pair_feature_names", None):   # a sim's own pair features (not y_i - y_j)
        info["pair_feature_names"] = list(sim.pair_feature_names)
    if hasattr(sim, "events"):     # what the sim's controller met while collecting (counts), if it keeps any
        info["events"] = {k: int(v) - int(events_before.get(k, 0)) for k, v in sorted(sim.events.items())}
    info.update(meta or {})
    return Dataset(traces, tuple(sim.feature_names), dict(sim.primitives), info)
