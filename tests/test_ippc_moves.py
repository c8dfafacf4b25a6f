"""IPPC moves with repeated arguments: offered wherever the domain allows them, with the domain's effects.

Hand-computed on the IPPC 2006 blocksworld (whose ``put-on-block`` has no ``(not (= ?b1 ?b2))``)
and the 2008 exploding blocksworld (whose ``put-on-block`` has it)."""

from __future__ import annotations

from pathlib import Path

from groundsym.logic import Atom, parse_atom
from groundsym.ppddl.parser import load
from groundsym.ppddl.simulate import Task
from groundsym.episode import ppddl_world

DATA = Path(__file__).parent / "data" / "ippc"


def _state(*atoms: str) -> frozenset:
    return frozenset(parse_atom(a) for a in atoms)


def test_put_on_block_on_itself_is_offered_and_does_what_the_domain_says():
    domain, problem = load(DATA / "ippc2006/blocksworld/domain.pddl", DATA / "ippc2006/blocksworld/p01.pddl")
    task = Task(domain, problem)
    offered = set(task.primitive_actions())
    assert Atom("put-on-block", ("b1", "b1")) in offered
    assert Atom("put-tower-on-block", ("b1", "b5", "b1")) in offered
    # b1 picked up from the table: pick-up-from-table leaves (clear b1), so b1 may go on itself
    s = _state("(holding b1)", "(clear b1)", "(clear b2)", "(on-table b2)")
    env, _ = ppddl_world(domain, problem)
    assert Atom("put-on-block", ("b1", "b1")) in env.actions(s)
    dist = {x.state: x.prob for x in task.distribution(s, Atom("put-on-block", ("b1", "b1")))}
    # 3/4: (on b1 b1) (emptyhand) (clear b1) added, (holding b1) (clear b1) deleted; deletes
    # apply first, so (clear b1) stays. 1/4: on the table instead.
    rest = {parse_atom("(clear b2)"), parse_atom("(on-table b2)")}
    assert dist == {
        _state("(on b1 b1)", "(emptyhand)", "(clear b1)") | rest: 0.75,
        _state("(on-table b1)", "(emptyhand)", "(clear b1)") | rest: 0.25,
    }
    # pick-up says (not (= ?b1 ?b2)): (pick-up b1 b1) is not offered
    assert Atom("pick-up", ("b1", "b1")) not in offered


def test_a_distinctness_precondition_keeps_repeated_arguments_out():
    """The 2008 ex-blocksworld problem files carry a domain without ``(not (= ?b1 ?b2))`` in
    ``put-on-block`` (offered on itself); the separate domain.pddl has it (not offered)."""
    _, problem = load(DATA / "ippc2008/ex-blocksworld/p01.pddl")
    with_eq, _ = load(DATA / "ippc2008/ex-blocksworld/domain.pddl")
    embedded, _ = load(DATA / "ippc2008/ex-blocksworld/p01.pddl")
    blocks = Task(with_eq, problem).objects_of("block")
    offered = set(Task(with_eq, problem).primitive_actions())
    assert not any(Atom("put-on-block", (b, b)) in offered for b in blocks)
    assert all(Atom("put-on-block", (b, c)) in offered for b in blocks for c in blocks if b != c)
    assert all(Atom("put-down", (b,)) in offered for b in blocks)
    assert all(Atom("put-on-block", (b, b)) in set(Task(embedded, problem).primitive_actions()) for b in blocks)


def test_applicable_primitives_equal_the_checked_candidates_on_random_states():
    """The trigger index gives exactly the primitives whose precondition holds (all 18 files' domains
    are covered by test_ippc_convert; here: states visited by a random walk)."""
    import numpy as np

    for sub in ("ippc2006/blocksworld/p02.pddl", "ippc2008/triangle-tireworld/p02.pddl"):
        domain, problem = load(DATA / sub.replace("p02", "domain") if "2006" in sub else DATA / sub,
                               DATA / sub if "2006" in sub else None)
        task = Task(domain, problem)
        rng = np.random.default_rng(0)
        state = task.initial_state
        for _ in range(30):
            ok = task.applicable_primitives(state)
            assert ok == [a for a in task.primitive_actions() if task.is_applicable(state, a)]
            if not ok:
                state = task.initial_state
                continue
            dist = task.distribution(state, ok[int(rng.integers(len(ok)))])
            state = dist[int(rng.choice(len(dist), p=[d.prob for d in dist]))].state
