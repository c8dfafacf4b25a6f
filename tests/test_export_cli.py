"""``groundsym export-domain`` on a model learned from data simulated from the reference blocks world."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from groundsym.cli import main
from groundsym.logic import Atom, parse_atom
from groundsym.modeldir import learn_symbolic_model
from groundsym.ppddl.ast import And
from groundsym.ppddl.compare import context_key, rules_close
from groundsym.ppddl.determinize import primitive_plan, solve
from groundsym.ppddl.parser import load
from groundsym.ppddl.rule_actions import NOISE_PREDICATE
from groundsym.ppddl.simulate import Task, simulate_traces
from groundsym.ppddl.to_rules import action_to_rule, domain_to_rules
from groundsym.rules.io import read_rules
from groundsym.symbolic_traces import read_symbolic_traces, write_symbolic_traces

REF = Path(__file__).parent.parent / "domains" / "reference"


EASY = """(define (problem easy) (:domain noisy-blocksworld) (:objects a b c d)
  (:init (handempty) (clear a) (clear b) (clear c) (clear d) (ontable a) (ontable b) (ontable c) (ontable d))
  (:goal (on a b)) (:goal-reward 1))"""


def _model(tmp: Path, domain: str, problem: str, seed: int) -> Path:
    if problem == "easy":
        (tmp / "easy.ppddl").write_text(EASY)
    d, p = load(REF / domain, tmp / "easy.ppddl" if problem == "easy" else REF / problem)
    ds = simulate_traces(Task(d, p), 20, 15, np.random.default_rng(seed), inapplicable=0.25)
    write_symbolic_traces(tmp / "data.json", ds)
    learn_symbolic_model(ds, tmp / "model", seed=0, argv=["test"], progress=False)
    return tmp / "model"


@pytest.fixture(scope="module")
def bw_model(tmp_path_factory) -> Path:
    return _model(tmp_path_factory.mktemp("bw"), "blocksworld/domain.ppddl", "easy", 5)


@pytest.fixture(scope="module")
def tower_model(tmp_path_factory) -> Path:
    return _model(tmp_path_factory.mktemp("tower"), "tower/domain.ppddl", "tower/p02.ppddl", 2)


@pytest.fixture(scope="module")
def rbf_model(tmp_path_factory) -> Path:
    """Symbols learned as RBFs from the tower cell's continuous traces (a short search: its
    predicates carry the described-geometry comments a symbolic model has none of)."""
    out = tmp_path_factory.mktemp("rbf") / "model"
    data = Path(__file__).parent / "data" / "tower_small.json"
    assert main(["learn", str(data), "-o", str(out), "--evals", "120", "--restarts", "1", "--workers", "1",
                 "--quiet"]) == 0
    return out


def _numbered(rules):
    count: dict[str, int] = {}
    for r in rules:
        count[r.action.predicate] = count.get(r.action.predicate, 0) + 1
        yield f"{r.action.predicate}_r{count[r.action.predicate]}", r


@pytest.mark.parametrize("noise", ["no-change", "pessimistic"])
def test_export_parses_back_to_the_models_rules(bw_model, tower_model, tmp_path, noise):
    for model in (bw_model, tower_model):
        out = tmp_path / model.parent.name / noise
        assert main(["export-domain", str(model), "-o", str(out), "--noise", noise]) == 0
        domain, problem = load(out / "domain.ppddl", out / "problem.ppddl")
        rules, _ = read_rules(model / "rules.json")
        actions = {a.name: a for a in domain.actions}
        back = {context_key(r) for r in domain_to_rules(domain).rules}
        for name, r in _numbered(rules.rules):
            if name in actions:             # probabilities rounded to 4 decimals
                assert rules_close(r, action_to_rule(actions[name]), 1e-4 * (len(r.outcomes) + 1)), name
            else:                           # a rule that can never apply: read back as blocking
                assert context_key(r) in back, name
        assert (domain.predicate(NOISE_PREDICATE) is not None) == (noise == "pessimistic")
        first = read_symbolic_traces(model / "symbolic-traces.json").traces[0]
        assert frozenset(problem.init) == first.states[0]
        assert sorted(o.name for o in problem.objects) == sorted(first.objects)
        for f in ("domain.ppddl", "problem.ppddl"):
            text = (out / f).read_text()
            assert max(map(len, text.splitlines())) <= 100 and str(model.parent) not in text
            assert "/" not in "".join(l for l in text.splitlines() if ";" in l), f   # no paths in comments


def test_exported_domains_parse_in_plado_and_our_parser(bw_model, tower_model, rbf_model, tmp_path):
    """Several learned models (two from symbolic data, one with RBF symbols learned from continuous
    traces), both noise modes, ADL and STRIPS determinisations."""
    import plado.parser as pp
    from plado.semantics.task import Task as PladoTask

    runs = [(bw_model, ["--goal", "(on a b)", "--determinize", "all-outcomes"]),
            (bw_model, ["--noise", "pessimistic", "--determinize", "most-likely", "--strips"]),
            (tower_model, ["--goal", "(on o1 o2)", "--determinize", "all-outcomes"])]
    learned = json.loads((rbf_model / "symbols.json").read_text())["symbols"]
    assert learned and all("centre" in s for s in learned)
    # a goal over a learned symbol (the derived one depends on what the short search found)
    goal = f"({learned[0]['name']} o1{' o2' if learned[0]['arity'] == 2 else ''})"
    runs += [(rbf_model, ["--goal", goal, "--determinize", "all-outcomes"]),
             (rbf_model, ["--goal", goal, "--noise", "pessimistic", "--determinize", "all-outcomes", "--strips"])]
    for i, (model, extra) in enumerate(runs):
        out = tmp_path / str(i)
        assert main(["export-domain", str(model), "-o", str(out), *extra]) == 0
        for d, p in (("domain.ppddl", "problem.ppddl"), ("domain.pddl", "problem.pddl")):
            ours, problem = load(out / d, out / p)
            task = PladoTask(*pp.parse_and_normalize(str(out / d), str(out / p)))
            assert {a.name for a in task.actions} == {a.name.lower() for a in ours.actions}, (extra, d)
            assert len(problem.init) > 0 or model is rbf_model    # its first scene may hold no learned atom
        if model is rbf_model:              # the learned symbols' meanings reached the domain
            text = (out / "domain.ppddl").read_text()
            assert all(f"({s['name']} ?x1" in text for s in learned) and " cm" in text


def test_derived_goal_is_the_best_state_in_the_data(bw_model, tmp_path):
    assert main(["export-domain", str(bw_model), "-o", str(tmp_path)]) == 0
    _, problem = load(tmp_path / "domain.ppddl", tmp_path / "problem.ppddl")
    ds = read_symbolic_traces(bw_model / "symbolic-traces.json")
    best = max(r for tr in ds.traces for r in [*tr.rewards, tr.final_reward])
    assert best == 1.0                                            # the goal (on a b) was reached
    goal_atoms = set(problem.goal.args)
    assert parse_atom("(on a b)") in goal_atoms
    states = [s for tr in ds.traces for s, r in zip(tr.states, [*tr.rewards, tr.final_reward]) if r == best]
    assert any(goal_atoms <= s for s in states)
    text = (tmp_path / "problem.ppddl").read_text()
    assert "; goal: the highest-reward abstract state in the data" in text


def test_constant_reward_omits_the_goal_and_says_why(tower_model, tmp_path):
    assert main(["export-domain", str(tower_model), "-o", str(tmp_path)]) == 0
    text = (tmp_path / "problem.ppddl").read_text()
    assert "(:goal" not in text and "no goal: the reward is constant (0) in the data" in text


def _execute(domain, problem, plan):
    """The determinised task and the state a plan ends in (each step must be deterministic)."""
    task = Task(domain, problem)
    s = task.initial_state
    for step in plan:
        (succ,) = task.distribution(s, step)
        s = succ.state
    return task, s


def test_determinised_export_is_solved_by_fast_downward(tower_model, tmp_path):
    code = main(["export-domain", str(tower_model), "-o", str(tmp_path), "--goal", "(on o1 o2) (on o2 o3)",
                 "--determinize", "all-outcomes"])
    assert code == 0
    plain, plain_problem = load(tmp_path / "domain.pddl", tmp_path / "problem.pddl")
    plan = solve(plain, plain_problem)
    assert plan
    task, s = _execute(plain, plain_problem, plan)
    assert task.goal_holds(s)
    domain, _ = load(tmp_path / "domain.ppddl")
    prims = primitive_plan(domain, plan)
    assert {p.predicate for p in prims} <= {"closeHandAround", "openHandOver"} and all(p.arity == 1 for p in prims)


def test_scene_option_and_deterministic_output(bw_model, tmp_path):
    data = bw_model.parent / "data.json"
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        assert main(["export-domain", str(bw_model), "-o", str(out), "--scene", f"{data}:2:4"]) == 0
    assert (a / "domain.ppddl").read_bytes() == (b / "domain.ppddl").read_bytes()
    _, problem = load(a / "domain.ppddl", a / "problem.ppddl")
    assert frozenset(problem.init) == read_symbolic_traces(data).traces[2].states[4]


@pytest.mark.parametrize("extra,message", [
    (["--goal", "(on a b) (tower a)"], "--goal: unknown predicate 'tower'"),
    (["--goal", "(on a z)"], "names an object that is not in the scene"),
    (["--goal", "(on a)"], "--goal: on takes 2 argument(s)"),
    (["--scene", "nowhere.json:0"], "--scene: expected FILE:TRACE:STEP"),
    (["--scene", "{data}:99:0"], "no trace 99"),
])
def test_bad_input_is_one_line_and_status_2(bw_model, tmp_path, capsys, extra, message):
    extra = [x.replace("{data}", str(bw_model.parent / "data.json")) for x in extra]
    capsys.readouterr()
    assert main(["export-domain", str(bw_model), "-o", str(tmp_path / "o"), *extra]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "o").exists()


def test_learned_predicates_say_what_they_mean(bw_model, tmp_path):
    from groundsym.symbols import Symbol, SymbolSet, save_symbols

    symbols = SymbolSet((Symbol("clear", 1, np.array([0.1, 0.2, 0.3]), np.array([0.05, 0.05, 0.02])),
                         Symbol("on", 2, np.array([0.0, 0.0, 0.05]), np.array([0.02, 0.02, 0.01]))),
                        ("x", "y", "z"))
    model = tmp_path / "model"
    model.mkdir()
    for f in ("rules.json", "reward.json", "symbolic-traces.json"):
        (model / f).write_bytes((bw_model / f).read_bytes())
    save_symbols(model / "symbols.json", symbols, shares={"clear": 0.25, "on": 0.125})
    assert main(["export-domain", str(model), "-o", str(tmp_path / "o")]) == 0
    text = (tmp_path / "o" / "domain.ppddl").read_text()
    preds = re.sub(r"\n\s*; ", " ", text[text.index("(:predicates"):text.index("(:action")])  # wrapped comments
    assert "X above Y" in preds and "z between 28.3 and 31.7 cm" in preds      # groundsym.describe's words
    assert "25.0% of objects" in preds and "12.5% of ordered pairs" in preds
    assert "±" not in preds and "centre" not in preds                           # no raw numbers
    assert max(map(len, text.splitlines())) <= 100


def test_scene_from_continuous_traces_is_abstracted_with_the_symbols(bw_model, tmp_path):
    from groundsym.symbols import Symbol, SymbolSet, save_symbols
    from groundsym.traces import read_traces

    data = Path(__file__).parent / "data" / "tower_small.json"
    scene = read_traces(data).traces[1].scenes[3]
    model = tmp_path / "model"
    model.mkdir()
    for f in ("rules.json", "reward.json"):
        (model / f).write_bytes((bw_model / f).read_bytes())
    # a resting cube's centre height, whatever x, y and size, named after a unary predicate of the
    # rules ("clear"): load_model refuses symbols that are not predicates of the model's rules
    full = SymbolSet((Symbol("clear", 1, np.array([0.5, 0.5, 0.02, 0.04]), np.array([9.0, 9.0, 0.01, 9.0])),),
                     ("x", "y", "z", "size"))
    save_symbols(model / "symbols.json", full)
    assert main(["export-domain", str(model), "-o", str(tmp_path / "o"), "--scene", f"{data}:1:3"]) == 0
    _, problem = load(tmp_path / "o" / "domain.ppddl", tmp_path / "o" / "problem.ppddl")
    clear = full.symbols[0]
    want = {Atom("clear", (o,)) for o, y in zip(scene.objects, scene.features) if clear.holds(np.asarray(y))}
    assert want and {a for a in problem.init if a.predicate == "clear"} == want


def test_pyperplan_solves_the_strips_determinisation_of_a_learned_blocks_world(bw_model, tmp_path):
    """pyperplan (through unified-planning) takes STRIPS only; the plan must reach the goal when run
    in the compiled domain by our own simulator."""
    goal = "(on a b) (on b c)"
    assert main(["export-domain", str(bw_model), "-o", str(tmp_path), "--goal", goal,
                 "--determinize", "all-outcomes", "--strips"]) == 0
    plain, plain_problem = load(tmp_path / "domain.pddl", tmp_path / "problem.pddl")
    assert plain.requirements == (":strips",)
    text = (tmp_path / "domain.pddl").read_text()
    assert all("(not (" not in part.split(":effect")[0] for part in text.split("(:action")[1:])  # positive only
    assert "(=" not in text and "forall" not in text and "exists" not in text
    plan = solve(plain, plain_problem, planner="pyperplan")
    assert plan
    task, s = _execute(plain, plain_problem, plan)
    assert task.goal_holds(s) and {parse_atom("(on a b)"), parse_atom("(on b c)")} <= s


def test_unreachable_goal_warns_and_strict_refuses(tower_model, tmp_path, capsys):
    args = ["export-domain", str(tower_model), "-o", str(tmp_path / "o"), "--goal", "(on o1 o1)",
            "--determinize", "all-outcomes"]
    capsys.readouterr()
    assert main(args) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "warning: the goal cannot be reached" in err
    assert main([*args, "--strict", "-o", str(tmp_path / "s")]) == 2
    assert not (tmp_path / "s").exists()
    assert main([*args[:4], "--goal", "(on o1 o2)", "--determinize", "all-outcomes", "--strict"]) == 0


def test_determinisation_without_actions_warns(tmp_path, capsys):
    """Rules whose outcomes change nothing (a model trained with too small a budget)."""
    from groundsym.rules.io import write_rules
    from groundsym.rules.model import Outcome, Rule, RuleSet

    model = tmp_path / "m"
    model.mkdir()
    rs = RuleSet((Rule(parse_atom("(grab ?x)"), (), (Outcome(()),), (0.9,), 0.1),), ())
    write_rules(model / "rules.json", rs, predicates={"held": 1}, primitives={"grab": 1})
    from groundsym.symbolic_traces import SymbolicDataset, SymbolicTrace
    write_symbolic_traces(model / "symbolic-traces.json", SymbolicDataset(
        (SymbolicTrace(("o1",), (frozenset(), frozenset()), (parse_atom("(grab o1)"),), (0.0,)),),
        {"held": 1}, {"grab": 1}))
    capsys.readouterr()
    args = ["export-domain", str(model), "-o", str(tmp_path / "o"), "--goal", "(held o1)", "--determinize", "most-likely"]
    assert main(args) == 0
    out, err = capsys.readouterr()
    assert "warning: the most-likely determinisation has no actions" in err and "domain.pddl: 0 actions" in out
    assert main([*args, "--strict"]) == 2


@pytest.mark.parametrize("name", ["x) (:requirements", "9lives", "and", ""])
def test_bad_names_are_refused_in_one_line(bw_model, tmp_path, capsys, name):
    capsys.readouterr()
    assert main(["export-domain", str(bw_model), "-o", str(tmp_path / "o"), "--name", name]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--name" in err
    assert main(["export-domain", str(bw_model), "-o", str(tmp_path / "o"), "--rename", f"on={name}"]) == 2


def test_rename_model_and_export(bw_model, tmp_path, capsys):
    import shutil

    model = tmp_path / "model"
    shutil.copytree(bw_model, model)
    before = (model / "rules.json").read_text()
    assert main(["rename", str(model), "on=stacked", "holding=inhand"]) == 0
    rules, meta = read_rules(model / "rules.json")
    assert "stacked" in meta["predicates"] and "on" not in meta["predicates"]
    assert {l.atom.predicate for r in rules.rules for l in r.context} <= {"stacked", "inhand", "clear", "handempty",
                                                                          "ontable"}
    # renaming back gives the same rules document
    assert main(["rename", str(model), "stacked=on", "inhand=holding"]) == 0
    assert (model / "rules.json").read_text() == before
    # one export only: the model itself is unchanged
    assert main(["export-domain", str(model), "-o", str(tmp_path / "o"), "--rename", "on=stacked"]) == 0
    domain, problem = load(tmp_path / "o" / "domain.ppddl", tmp_path / "o" / "problem.ppddl")
    assert domain.predicate("stacked") is not None and domain.predicate("on") is None
    assert (model / "rules.json").read_text() == before
    capsys.readouterr()
    # unknown, taken by a predicate, an action, the name a derived predicate takes ("no-stacked-1"
    # from stacked, once on is stacked; "no-on-1" while on stays)
    for bad in (["nothere=x"], ["on=clear"], ["on=stack"], ["on=stacked", "clear=no-stacked-1"], ["clear=no-on-1"]):
        assert main(["rename", str(model), *bad]) == 2
        assert capsys.readouterr().err.count("\n") == 1
    assert (model / "rules.json").read_text() == before


def test_a_rule_that_is_all_noise_exports_pessimistically_as_a_dead_end(tmp_path):
    """A rule with no outcomes and noise 1 under ``--noise pessimistic``: its action leads to
    (noise-happened) with probability 1, as plado (an independent PPDDL implementation) computes
    from the text, and it reads back as the same rule; a rule with noise 0.2 next to it keeps its
    distribution (hand-computed below)."""
    from groundsym.logic import Literal
    from groundsym.rules.io import write_rules
    from groundsym.rules.model import Outcome, Rule, RuleSet
    from groundsym.symbolic_traces import SymbolicDataset, SymbolicTrace
    from test_ppddl_simulate import Plado

    held = parse_atom("(held ?x)")
    rs = RuleSet((Rule(parse_atom("(grab ?x)"), (Literal(held, False),), (), (), 1.0),
                  Rule(parse_atom("(drop ?x)"), (Literal(held, True),), (Outcome((Literal(held, False),)),), (0.8,), 0.2)),
                 ())
    model = tmp_path / "m"
    model.mkdir()
    write_rules(model / "rules.json", rs, predicates={"held": 1}, primitives={"grab": 1, "drop": 1})
    write_symbolic_traces(model / "symbolic-traces.json", SymbolicDataset(
        (SymbolicTrace(("o1",), (frozenset(), frozenset()), (parse_atom("(grab o1)"),), (0.0,)),),
        {"held": 1}, {"grab": 1, "drop": 1}))
    out = tmp_path / "o"
    assert main(["export-domain", str(model), "-o", str(out), "--goal", "(held o1)", "--noise", "pessimistic"]) == 0
    domain, _ = load(out / "domain.ppddl", out / "problem.ppddl")
    back = action_to_rule(domain.action("grab_r1"))
    assert (back.outcomes, back.noise) == ((), 1.0)
    ref = Plado(out / "domain.ppddl", out / "problem.ppddl")
    noise, h = parse_atom("(noise-happened)"), parse_atom("(held o1)")
    assert ref.successors(frozenset(), parse_atom("(grab_r1 o1)")) == {(frozenset({noise}), 0.0): 1.0}
    drop = ref.successors(frozenset({h}), parse_atom("(drop_r1 o1)"))
    assert drop.keys() == {(frozenset(), 0.0), (frozenset({h, noise}), 0.0)}
    assert drop[(frozenset(), 0.0)] == pytest.approx(0.8) and drop[(frozenset({h, noise}), 0.0)] == pytest.approx(0.2)
