"""PRADA's sparse rule tables and restricted groundings give the dense computation's numbers.

Truth: the dense formula of the factored-frontier transition (Lang & Toussaint 2010) written out here
with numpy, and the unrestricted grounding's values of the same action sequences."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import planners.prada as prada
from groundsym.episode import ppddl_model, ppddl_world
from groundsym.logic import Atom
from groundsym.planner import make_planner

DATA = Path(__file__).parent / "data" / "ippc"


def _core(path: Path):
    from groundsym.ppddl.parser import load

    domain, problem = load(path)
    env, task = ppddl_world(domain, problem)
    model = ppddl_model(domain, problem, task)
    planner = make_planner("prada", model, {"samples": "50"}, 0)
    state = task.initial_state
    return planner.core(tuple(sorted(task.objects)), state), state


def test_sparse_transition_equals_the_dense_formula():
    core, state = _core(DATA / "ippc2008/ex-blocksworld/p01.pddl")
    g = core.g
    rng = np.random.default_rng(0)
    B = np.repeat(g.belief(state)[None, :], 20, axis=0)
    B[:, :-1] = np.clip(B[:, :-1] + 0.3 * rng.random(B[:, :-1].shape), 0, 1)     # beliefs, not points
    U = prada.rule_probabilities(g, B)
    chosen = rng.integers(-1, len(g.actions), size=20)
    Usel = U * (g.rule_group[None, :] == chosen[:, None])
    dense = B * (1.0 - Usel @ g.touched.toarray()) + Usel @ g.set_true.toarray()
    assert np.allclose(prada.transition(g, B, U, chosen), dense, atol=1e-12)


def test_the_restricted_grounding_scores_sequences_as_the_full_one():
    core, state = _core(DATA / "ippc2008/triangle-tireworld/p01.pddl")
    b0 = core.g.belief(state)
    sub = core.restrict(b0)
    assert sub is not core and len(sub.g.rule_group) < len(core.g.rule_group)
    rng = np.random.default_rng(1)
    seqs, values = sub.sample(b0, rng)
    full_index = {a: i for i, a in enumerate(core.g.actions)}
    mapped = np.where(seqs >= 0, np.array([full_index[a] for a in sub.g.actions])[seqs], -1)
    assert np.allclose(core.evaluate(b0, mapped), values, atol=1e-12)


# ---------------------------------------------------------------------------- all 18 IPPC files
FILES = [pytest.param(p, marks=pytest.mark.slow) if "triangle-tireworld/p03" in str(p) else p   # 2.5 s grounding
         for p in sorted(DATA.glob("*/*/p*.pddl"))]


def _load_ippc(path: Path):
    from groundsym.ppddl.parser import load

    return load(path.parent / "domain.pddl", path) if "ippc2006" in str(path) else load(path)


@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.parent.name}/{p.parent.name}/{p.stem}"
                         if isinstance(p, Path) else None)
def test_prada_plans_on_every_ippc_file_over_the_simulators_moves(path):
    """Parse, convert to rules, one decision: the action is the first of PRADA's best sequence and
    legal in the simulator; PRADA's ground moves are exactly the simulator's (repeated arguments
    included where the domain allows them, e.g. ``(put-on-block b1 b1)`` in the 2006 blocksworld)."""
    from groundsym.planner import Observation

    domain, problem = _load_ippc(path)
    env, task = ppddl_world(domain, problem)
    model = ppddl_model(domain, problem, task)
    planner = make_planner("prada", model, {"samples": "30", "horizon": "3"}, 0)
    obs = env.reset(0)
    decision = planner.choose(obs)
    assert decision.action in task.applicable_primitives(obs.state)
    assert decision.info["plan"] and decision.info["plan"][0] == str(decision.action)
    core = planner.core(obs.objects, obs.state)
    assert set(core.g.actions) == set(task.primitive_actions())
    if "blocksworld" in str(path) and "ex-" not in str(path) and "ippc2006" in str(path):
        assert Atom("put-on-block", ("b1", "b1")) in core.g.actions
