"""AMLGym's own data and metrics (the ``amlgym`` extra; skipped without it, as in CI, where it
cannot share the test venv: it pins up-fast-downward 0.5.2). The blocks world learned from its
ten learning trajectories must score syntactic precision and recall 1.0 against the reference
domain, by AMLGym's own metric (docs/amlgym.md)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

amlgym = pytest.importorskip("amlgym", reason="the amlgym extra is not installed (it needs a venv of its own)")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from amlgym_data import problem_objects, read_signature, read_trajectory  # noqa: E402
from amlgym_table import learn_groundsym  # noqa: E402


def _inputs(domain: str, k: int):
    from amlgym.benchmarks import get_domain_path, get_problems_path, get_trajectories_path
    trajs = get_trajectories_path(domain, "learning")[:k]
    probs = {int(Path(p).name.split("_")[0]): p for p in get_problems_path(domain, "learning")}
    consts = read_signature(get_domain_path(domain)).constants
    return get_domain_path(domain), trajs, [{**consts, **problem_objects(probs[int(Path(t).name.split("_")[0])])}
                                            for t in trajs]


def test_trajectory_reading_matches_the_file():
    _, trajs, objs = _inputs("blocksworld", 1)
    states, actions = read_trajectory(trajs[0])
    text = Path(trajs[0]).read_text()
    assert len(states) == len(actions) + 1 == text.count("(:state") and len(actions) == text.count("(:action")
    assert set(objs[0].values()) == {"block"}


@pytest.mark.parametrize("domain", ["blocksworld", "ferry", "miconic", "childsnack", "tpp"])
def test_clean_trajectories_give_the_reference_operators(domain, tmp_path):
    """miconic: no negated precondition the plans merely never contradict (its requirements lack
    :negative-preconditions); childsnack: ``put_on_tray`` needs ``(at ?t kitchen)``, a constant;
    tpp: every ``load`` repeats a level among its arguments (no injective binding)."""
    from amlgym.metrics import syntactic_precision, syntactic_recall
    ref, trajs, objs = _inputs(domain, 10)
    path = tmp_path / "learned.pddl"
    path.write_text(learn_groundsym(ref, trajs, objs))
    assert syntactic_recall(str(path), ref)["mean"] == 1.0
    assert syntactic_precision(str(path), ref)["mean"] == 1.0
