"""The PPDDL simulator against plado (an independent PPDDL implementation) and hand-computed cases."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dataclasses import replace

from groundsym.cli import main
from groundsym.ppddl.ast import AndEffect
from groundsym.logic import Atom, parse_atom
from groundsym.ppddl.parser import load
from groundsym.ppddl.simulate import Task, simulate_traces, successor_distribution
from groundsym.symbolic_traces import read_symbolic_traces

DATA = Path(__file__).parent / "data" / "ippc"
REF = Path(__file__).parent.parent / "domains" / "reference"

# (domain file, problem file): IPPC-2008 problem files repeat their domain; plado reads one define
# per file, so it gets the domain file and our printed problem. Exploding blocksworld is left out:
# for `(and <det> (probabilistic 2/5 (when c e)))` plado 0.1.x returns a third successor (mass 0.2)
# that drops the deterministic part, against PPDDL's semantics; test_hand_computed_exploding_put_down
# checks that domain by hand instead. plado cannot read our tower reference (a `when` over a
# conjunction inside `forall` inside `probabilistic` trips an assertion in its normaliser):
# test_tower_reference_by_hand covers it; its rule form (rules.ppddl) is compared.
CASES = [
    (DATA / "ippc2006/blocksworld/domain.pddl", DATA / "ippc2006/blocksworld/p01.pddl"),
    (DATA / "ippc2006/tireworld/domain.pddl", DATA / "ippc2006/tireworld/p01.pddl"),
    (DATA / "ippc2008/blocksworld/domain.pddl", DATA / "ippc2008/blocksworld/p02.pddl"),
    (DATA / "ippc2008/triangle-tireworld/domain.pddl", DATA / "ippc2008/triangle-tireworld/p01.pddl"),
    (REF / "blocksworld/domain.ppddl", REF / "blocksworld/p01.ppddl"),
    (REF / "tower/rules.ppddl", REF / "tower/p01.ppddl"),
]


class Plado:
    """plado's grounded semantics over our states (fluent atoms as frozensets of Atom)."""

    def __init__(self, domain_path: Path, problem_path: Path):
        import plado.parser as pp
        from plado.semantics.applicable_actions_generator import ApplicableActionsGenerator
        from plado.semantics.successor_generator import SuccessorGenerator
        from plado.semantics.task import Task as PTask

        d, p = pp.parse_and_normalize(str(domain_path), str(problem_path))
        self.t = PTask(d, p)
        self.aag, self.sg = ApplicableActionsGenerator(self.t), SuccessorGenerator(self.t)
        self.obj = {o: i for i, o in enumerate(self.t.objects)}
        self.pred = {self.t.predicates[i].name: i for i in range(self.t.num_fluent_predicates)}
        self.reward = next((i for i, f in enumerate(self.t.functions) if f.name == "reward"), None)

    def state(self, atoms: frozenset):
        s = self.t.initial_state.duplicate()
        for i in range(self.t.num_fluent_predicates):
            s.atoms[i] = set()
        for a in atoms:
            if a.predicate in self.pred:
                s.atoms[self.pred[a.predicate]].add(tuple(self.obj[x] for x in a.args))
        return s

    def atoms(self, s) -> frozenset:
        return frozenset(parse_atom(f"({self.t.predicates[p].name} {' '.join(self.t.objects[o] for o in args)})")
                         for p in range(self.t.num_fluent_predicates) for args in s.atoms[p])

    def applicable(self, atoms: frozenset) -> set[Atom]:
        return {parse_atom(self.t.dump_action(*a)) for a in self.aag(self.state(atoms))}

    def successors(self, atoms: frozenset, action: Atom) -> dict[tuple[frozenset, float], float]:
        aid = next(i for i, a in enumerate(self.t.actions) if a.name == action.predicate.lower())
        s = self.state(atoms)
        r0 = s.fluents[self.reward].get((), 0.0) if self.reward is not None else 0.0
        out: dict[tuple[frozenset, float], float] = {}
        for succ, prob in self.sg(s, (aid, tuple(self.obj[x] for x in action.args))):
            r = float(succ.fluents[self.reward].get((), 0.0)) - float(r0) if self.reward is not None else 0.0
            key = (self.atoms(succ), round(r, 9))
            out[key] = out.get(key, 0.0) + float(prob)
        return out


def _low(a: Atom) -> Atom:
    return Atom(a.predicate.lower(), a.args)


def _fluent(task: Task, state: frozenset) -> frozenset:
    """Our state without static atoms (plado keeps those apart)."""
    static = {p.name for p in task.domain.predicates} - _changing(task)
    return frozenset(a for a in state if a.predicate not in static)


def _changing(task: Task) -> set[str]:
    from groundsym.ppddl.ast import AndEffect, ForallEffect, Probabilistic, When
    from groundsym.logic import Literal

    names: set[str] = set()

    def walk(e):
        if isinstance(e, Literal):
            names.add(e.atom.predicate)
        elif isinstance(e, AndEffect):
            for x in e.effects:
                walk(x)
        elif isinstance(e, Probabilistic):
            for _, x in e.branches:
                walk(x)
        elif isinstance(e, (When, ForallEffect)):
            walk(e.effect)
    for a in task.domain.actions:
        walk(a.effect)
    return names


@pytest.mark.parametrize("domain_path,problem_path", CASES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_applicable_actions_and_successors_match_plado(domain_path, problem_path, tmp_path):
    domain, problem = load(domain_path, problem_path)
    plain_problem = tmp_path / "problem.pddl"
    plain_problem.write_text(str(problem))            # plado reads one define per file
    # plado 0.1 crashes on an action whose effect is empty (the tower rules' blocking rule): it
    # gets the domain without those, and they are left out of the comparison
    noop = {a.name for a in domain.actions if a.effect == AndEffect(())}
    plado_domain = tmp_path / "domain.pddl"
    plado_domain.write_text(str(replace(domain, actions=tuple(a for a in domain.actions if a.name not in noop))))
    ref = Plado(plado_domain, plain_problem)
    task = Task(domain, problem)
    rng = np.random.default_rng(3)
    state = task.initial_state
    compared = 0
    ground = {Atom(a.name, args) for a in domain.actions if a.name not in noop for args in task.groundings(a.name)}
    for _ in range(25):
        ours = {g for g in ground if task.applicable(state, g)}
        assert {_low(g) for g in ours} == ref.applicable(_fluent(task, state))     # plado lower-cases names
        if not ours:                                  # dead end: walk again from the start
            state = task.initial_state
            continue
        for g in sorted(ours):
            mine: dict = {}
            for s in task.outcomes(state, g):
                key = (_fluent(task, s.state), round(s.reward, 9))
                mine[key] = mine.get(key, 0.0) + s.prob
            theirs = ref.successors(_fluent(task, state), g)
            assert mine.keys() == theirs.keys(), g
            for k in mine:
                assert mine[k] == pytest.approx(theirs[k], abs=1e-12), g
            compared += 1
        g = sorted(ours)[int(rng.integers(len(ours)))]
        dist = task.outcomes(state, g)
        state = dist[int(rng.choice(len(dist), p=np.array([d.prob for d in dist])))].state
    assert compared >= 10


def test_hand_computed_exploding_put_down():
    # IPPC-2006 exploding blocksworld: put-down detonates a block that has not detonated with 2/5
    domain, problem = load(DATA / "ippc2006/ex-blocksworld/domain.pddl", DATA / "ippc2006/ex-blocksworld/p01.pddl")
    s = frozenset(map(parse_atom, ["(holding b1)", "(no-destroyed-table)", "(no-detonated b1)", "(clear b2)"]))
    dist = successor_distribution(domain, problem, s, parse_atom("(put-down b1)"))
    base = frozenset(parse_atom(x) for x in ["(emptyhand)", "(on-table b1)", "(clear b2)"])
    got = {st: p for p, st, _ in dist}
    intact = base | {parse_atom("(no-destroyed-table)"), parse_atom("(no-detonated b1)")}
    assert got == {intact: pytest.approx(0.6), base: pytest.approx(0.4)}
    # a detonated block cannot detonate again: one outcome
    s2 = s - {parse_atom("(no-detonated b1)")}
    assert [p for p, _, _ in successor_distribution(domain, problem, s2, parse_atom("(put-down b1)"))] == [1.0]
    # not applicable: empty distribution
    assert successor_distribution(domain, problem, frozenset(), parse_atom("(put-down b1)")) == []


def test_tower_reference_by_hand():
    domain, problem = load(REF / "tower/domain.ppddl", REF / "tower/p01.ppddl")
    task = Task(domain, problem)
    s = frozenset(map(parse_atom, ["(on o1 o2)", "(clear o1)", "(ontable o2)", "(ontable o3)", "(clear o3)"]))
    grasp = task.distribution(s, parse_atom("(closeHandAround o1)"))
    assert [x.prob for x in grasp] == pytest.approx([0.9, 0.1]) or [x.prob for x in grasp] == pytest.approx([0.1, 0.9])
    held = next(x.state for x in grasp if x.prob == pytest.approx(0.9))
    assert held == frozenset(map(parse_atom, ["(inhand o1)", "(clear o1)", "(clear o2)", "(ontable o2)",
                                              "(ontable o3)", "(clear o3)"]))
    assert task.distribution(s, parse_atom("(closeHandAround o2)")) == []        # covered
    assert task.probability(s, parse_atom("(closeHandAround o2)"), s) == 1.0     # ... nothing changes
    drop = {x.state: x.prob for x in task.distribution(held, parse_atom("(openHandOver o3)"))}
    on3 = held - {parse_atom("(inhand o1)"), parse_atom("(clear o3)")} | {parse_atom("(on o1 o3)")}
    table = held - {parse_atom("(inhand o1)")} | {parse_atom("(ontable o1)")}
    assert drop == {on3: pytest.approx(0.8), table: pytest.approx(0.2)}
    assert task.distribution(held, parse_atom("(closeHandAround o3)")) == []     # hand is full


def test_simulated_traces_follow_the_documented_semantics():
    domain, problem = load(DATA / "ippc2008/triangle-tireworld/p01.pddl")
    task = Task(domain, problem)
    ds = simulate_traces(task, 30, 15, np.random.default_rng(0), inapplicable=0.3)
    again = simulate_traces(task, 30, 15, np.random.default_rng(0), inapplicable=0.3)
    assert [t.actions for t in ds.traces] == [t.actions for t in again.traces]
    assert ds.predicates["location"] == 1 and ds.primitives == {"changetire": 0, "loadtire": 1, "move-car": 2}
    tried_inapplicable = changed = 0
    for tr in ds.traces:
        for t, (s, a, s2) in enumerate(tr.transitions()):
            assert parse_atom("(location l-1-1)") in s                     # type atoms are written
            plain = task.strip_types(s)
            expect = task.goal_reward if task.goal_holds(plain) else 0.0
            assert tr.rewards[t] == expect                                  # no reward effects here
            if not task.is_applicable(plain, a):
                tried_inapplicable += 1
                assert s2 == s
            else:
                changed += 1
                assert task.probability(s, a, s2) > 0
        last = task.strip_types(tr.states[-1])
        if len(tr) < 15:                                                    # stopped early: dead end
            assert not any(task.is_applicable(last, a) for a in task.primitive_actions())
    share = tried_inapplicable / (tried_inapplicable + changed)
    assert 0.2 < share < 0.4
    assert any(len(tr) < 15 for tr in ds.traces)                            # flat tire, no spare: dead end


def test_reward_effects_and_goal_reward(tmp_path):
    # IPPC-2008 blocksworld p02: every action costs (decrease reward 1) or more; goal reward 1
    domain, problem = load(DATA / "ippc2008/blocksworld/p02.pddl")
    task = Task(domain, problem)
    s = task.initial_state
    pick = next(a for a in task.primitive_actions() if a.predicate == "pick-up" and task.is_applicable(s, a))
    assert {x.reward for x in task.distribution(s, pick)} == {-1.0}
    out = tmp_path / "t.json"
    assert main(["simulate", "--domain", str(DATA / "ippc2008/blocksworld/p02.pddl"), "--traces", "3",
                 "--length", "10", "--seed", "4", "-o", str(out)]) == 0
    ds = read_symbolic_traces(out)
    costly = {"pick-up", "pick-up-from-table"}                    # the actions with (decrease reward 1)
    for tr in ds.traces:
        for t, a in enumerate(tr.actions):
            goal = 20.0 if task.goal_holds(task.strip_types(tr.states[t])) else 0.0
            assert tr.rewards[t] == goal - (a.predicate in costly)
    assert any(r == -1.0 for tr in ds.traces for r in tr.rewards)
    assert json.loads(out.read_text())["meta"]["provenance"]["seed"] == 4


def test_simulate_cli_is_deterministic_and_rejects_bad_input(tmp_path, capsys):
    args = ["simulate", "--domain", str(REF / "blocksworld/domain.ppddl"), "--problem",
            str(REF / "blocksworld/p01.ppddl"), "--traces", "4", "--length", "12", "--seed", "9",
            "--inapplicable", "0.25"]
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    assert main(args + ["-o", str(a)]) == 0 and main(args + ["-o", str(b)]) == 0
    da, db = json.loads(a.read_text()), json.loads(b.read_text())
    assert da["traces"] == db["traces"] and da["meta"]["provenance"]["seed"] == 9
    bad = tmp_path / "bad.ppddl"
    bad.write_text("(define (domain d) (:predicates (p)) (:action a :parameters () :effect (q)))")
    capsys.readouterr()
    assert main(["simulate", "--domain", str(bad), "--problem", str(REF / "blocksworld/p01.ppddl"),
                 "-o", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "bad.ppddl:1:" in err and "unknown predicate 'q'" in err
