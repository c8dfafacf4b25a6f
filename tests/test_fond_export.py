"""FOND export (``--format fond``) read by the ``pddl`` package (PyPI) with the outcome sets we meant.

The independent reader is the ``pddl`` package's parser; both sides are brought to the all-outcomes
normal form of groundsym/ppddl/fond_check.py. The ``pddl`` package pins ``lark<1.2``, so it is the
optional extra ``fond-check``, not part of ``.[test]``; without it these tests skip.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from groundsym.cli import main
from groundsym.ppddl.fond import fond_domain_text, fond_problem_text
from groundsym.ppddl.parser import load

pytest.importorskip("pddl", reason="the pddl package is not installed (pip install -e '.[fond-check]'; it pins lark<1.2)")

from groundsym.ppddl.fond_check import compare_fond  # noqa: E402

from test_export_cli import bw_model, tower_model  # noqa: E402,F401  (the PPDDL export's learned models)

IPPC = Path(__file__).parent / "data" / "ippc"




@pytest.mark.parametrize("domain", sorted(IPPC.glob("*/*/domain.pddl")), ids=lambda p: f"{p.parent.parent.name}-{p.parent.name}")
def test_ippc_domains_read_back_with_identical_outcome_sets(domain, tmp_path):
    import pddl
    d, p = load(domain, domain.parent / "p01.pddl")
    (tmp_path / "domain.pddl").write_text(fond_domain_text(d))
    (tmp_path / "problem.pddl").write_text(fond_problem_text(p))
    assert compare_fond(d, tmp_path / "domain.pddl") == []
    problem = pddl.parse_problem(str(tmp_path / "problem.pddl"))
    assert {o.name for o in problem.objects} == {o.name for o in p.objects}


@pytest.mark.parametrize("noise", ["no-change", "pessimistic"])
def test_learned_models_read_back_with_identical_outcome_sets(bw_model, tower_model, tmp_path, noise):
    for model, goal in ((bw_model, []), (tower_model, ["--goal", "(on o1 o2)"])):
        out = tmp_path / model.parent.name
        assert main(["export-domain", str(model), "-o", str(out), "--format", "fond", "--noise", noise, *goal]) == 0
        assert main(["export-domain", str(model), "-o", str(out / "ppddl"), "--noise", noise, *goal]) == 0
        ours, _ = load(out / "ppddl" / "domain.ppddl", out / "ppddl" / "problem.ppddl")
        assert compare_fond(ours, out / "domain.pddl") == []
        text = (out / "domain.pddl").read_text()
        assert "oneof" in text and "probabilistic" not in text and "reward" not in text.split("(:requirements")[1]


def test_a_lost_outcome_is_noticed(tmp_path):
    """The check's power: the FOND text with one ``oneof`` branch taken out must differ."""
    d, _ = load(IPPC / "ippc2006" / "blocksworld" / "domain.pddl", IPPC / "ippc2006" / "blocksworld" / "p01.pddl")
    text = fond_domain_text(d)
    start = text.index("(oneof") + len("(oneof")
    branch_start = text.index("(and", start)
    depth, i = 0, branch_start
    while True:
        depth += {"(": 1, ")": -1}.get(text[i], 0)
        i += 1
        if depth == 0:
            break
    (tmp_path / "domain.pddl").write_text(text[:branch_start] + text[i:])
    assert any("outcome sets differ" in x for x in compare_fond(d, tmp_path / "domain.pddl"))


def test_no_goal_no_fond_problem(tower_model, tmp_path, capsys):
    assert main(["export-domain", str(tower_model), "-o", str(tmp_path), "--format", "fond"]) == 0
    assert (tmp_path / "domain.pddl").exists() and not (tmp_path / "problem.pddl").exists()
    assert "problem.pddl not written: no goal" in capsys.readouterr().err


def test_fond_with_axioms_reads_back_with_identical_outcome_sets(tower_model, tmp_path):
    """The pddl package reads ``(:derived ...)`` too: with ``--axioms`` the FOND export's outcome
    sets and preconditions (derived atoms named, not written out) still equal ours."""
    goal = ["--goal", "(on o1 o2)", "--axioms"]
    assert main(["export-domain", str(tower_model), "-o", str(tmp_path), "--format", "fond", *goal]) == 0
    assert main(["export-domain", str(tower_model), "-o", str(tmp_path / "ppddl"), *goal]) == 0
    text = (tmp_path / "domain.pddl").read_text()
    assert "(:derived (no-inhand)" in text and "oneof" in text
    from groundsym.export import ExportOptions, build_export
    from groundsym.modeldir import load_model
    ours = build_export(load_model(tower_model), ExportOptions(goal="(on o1 o2)", axioms=True)).domain
    assert compare_fond(ours, tmp_path / "domain.pddl") == []
