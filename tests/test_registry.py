"""The registry's built-in tables and pyproject.toml's entry points name the same sims and planners.

A name only one of them lists works from a checkout but not from an installed package (or the
reverse): ``lrtdp`` was once registered as an entry point only, so ``--planner lrtdp`` failed on
an uninstalled checkout while its errors' lists of planners left it out.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from groundsym.errors import UserError
from groundsym.registry import BUILTIN_PLANNERS, BUILTIN_SIMS, get_planner_class, planner_names

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


@pytest.mark.parametrize("group, table", [("groundsym.sims", BUILTIN_SIMS),
                                          ("groundsym.planners", BUILTIN_PLANNERS)])
def test_pyproject_entry_points_are_the_builtin_table(group, table):
    entry_points = tomllib.loads(PYPROJECT.read_text())["project"]["entry-points"][group]
    assert entry_points == table


def test_every_builtin_planner_loads_under_its_own_name_and_is_listed():
    for name in BUILTIN_PLANNERS:
        assert get_planner_class(name).name == name
    assert set(BUILTIN_PLANNERS) <= set(planner_names())
    with pytest.raises(UserError, match="unknown planner") as refused:
        get_planner_class("nosuch")
    assert all(name in str(refused.value) for name in BUILTIN_PLANNERS)


def test_plan_help_names_every_builtin_planner(capsys):
    from groundsym.cli import main

    with pytest.raises(SystemExit):
        main(["plan", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name in BUILTIN_PLANNERS:
        assert name in text
