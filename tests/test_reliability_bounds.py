"""Every count and size has an upper bound, checked before any work: an absurd value is one line
naming the flag, exit status 2 (``plan --steps``, ``learn --evals``, ``render --steps`` and
``learn --search population=`` ran past 60-90 s; ``collect --traces 99999999999999999999999`` and
``plan --episodes 99999999999999999999999`` ended in an ``OverflowError`` from numpy)."""

from __future__ import annotations

import argparse
import time
from dataclasses import fields

import pytest

from conftest import DATA
from groundsym.anneal import AnnealConfig
from groundsym.cli import build_parser
from groundsym.commands._common import Count, nonneg_int, positive_int
from groundsym.commands.learn import SEARCH_KEYS
from tests.test_reliability import cli, one_line_error

HUGE = "99999999999999999999999"


def whole_number_options() -> list[tuple[str, str, object]]:
    """(command, flag, type) of every option of every command whose value is a whole number."""
    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    out = []
    for name, sub in commands.items():
        for action in sub._actions:
            kind = action.type
            whole = kind in (int, positive_int, nonneg_int) or "int" in getattr(kind, "__name__", "")
            if whole or isinstance(kind, Count):
                out.append((name, action.option_strings[-1] if action.option_strings else action.dest, kind))
    return out


OPTIONS = whole_number_options()


def test_every_whole_number_option_has_an_upper_bound():
    unbounded = [f"{c} {f}" for c, f, kind in OPTIONS if not isinstance(kind, Count)]
    assert unbounded == [], "give these a bound (groundsym.limits, commands._common.Count): " + ", ".join(unbounded)
    flags = {(c, f) for c, f, _ in OPTIONS}
    assert {("plan", "--steps"), ("plan", "--episodes"), ("learn", "--evals"), ("learn", "--restarts"),
            ("learn", "--workers"), ("render", "--steps"), ("collect", "--traces"), ("collect", "--length"),
            ("simulate", "--traces"), ("evaluate", "--runs"), ("evaluate", "--starts")} <= flags
    assert len(OPTIONS) >= 25


@pytest.mark.parametrize("command, flag", [(c, f) for c, f, _ in OPTIONS])
def test_a_huge_count_is_one_line_before_any_work(tmp_path, capsys, command, flag):
    kind = dict(((c, f), k) for c, f, k in OPTIONS)[(command, flag)]
    start = time.monotonic()
    assert cli([command, flag, HUGE]) == 2
    one_line_error(capsys, f"groundsym {command}: error: argument {flag}: at most {kind.hi}", f"got {HUGE}")
    assert cli([command, flag, str(kind.hi + 1)]) == 2
    one_line_error(capsys, f"argument {flag}: at most {kind.hi}")
    assert time.monotonic() - start < 10
    assert kind(str(kind.hi)) == kind.hi and kind(str(kind.lo)) == kind.lo    # the bound itself is allowed


INT_SEARCH_KEYS = [f.name for f in fields(AnnealConfig) if f.name in SEARCH_KEYS and f.type in (int, "int")]


def test_the_search_settings_walked_are_the_whole_numbers():
    assert {"population", "chunk", "hop_steps"} <= set(INT_SEARCH_KEYS)


@pytest.mark.parametrize("key", INT_SEARCH_KEYS)
def test_a_huge_search_setting_is_one_line_before_any_work(tmp_path, capsys, key):
    out = tmp_path / "M"
    assert cli(["learn", str(DATA / "tower_small.json"), "-o", str(out), "--quiet", "--search", f"{key}={HUGE}"]) == 2
    one_line_error(capsys, f"--search {key}={HUGE}: at most ")
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("flag, value, message", [("--symbol-data", f"80,{HUGE}", "at most 1000000 transitions"),
                                                  ("--model-traces", HUGE, "at most 100000 traces")])
def test_evaluate_refuses_huge_sizes_before_writing_anything(tmp_path, capsys, flag, value, message):
    out = tmp_path / "E"
    assert cli(["evaluate", "--sim", "tower", "-o", str(out), "--runs", "1", flag, value]) == 2
    one_line_error(capsys, f"{flag} {value}: {message}")
    assert not out.exists()


def planner_and_sim_counts() -> list[tuple[str, str, str]]:
    """(kind, owner, option) of every whole-number ``--planner-opt`` and ``--sim-opt`` option."""
    from groundsym.registry import get_planner_class, get_sim_class, planner_names, sim_names
    out = []
    for owner in planner_names():
        for opt in getattr(get_planner_class(owner), "OPTIONS", ()):
            if opt.kind is int or getattr(opt.kind, "__name__", "") == "positive int":
                out.append(("planner", owner, opt.name))
    for owner in sim_names():
        for opt in getattr(get_sim_class(owner), "OPTIONS", ()):
            if opt.kind is int or getattr(opt.kind, "__name__", "") == "positive int":
                out.append(("sim", owner, opt.name))
    return out


@pytest.mark.parametrize("kind, owner, key", planner_and_sim_counts())
def test_every_planner_and_sim_count_has_an_upper_bound(kind, owner, key):
    """A planner's own bound (``positive(int, most=...)``) or the sim's check of its options
    (the tower: at most 10 objects) refuses a huge value in one line, before the physics starts."""
    from groundsym.errors import UserError
    from groundsym.options import parse_options
    from groundsym.registry import get_planner_class, make_sim
    with pytest.raises(UserError) as info:
        if kind == "planner":
            parse_options("--planner-opt", "planner", owner, get_planner_class(owner).OPTIONS, {key: HUGE})
        else:
            make_sim(owner, {key: HUGE})
    assert str(info.value).startswith(f"--{kind}-opt {key}={HUGE}: ") and "\n" not in str(info.value), str(info.value)


def test_the_planner_and_sim_counts_walked():
    walked = {(o, k) for _, o, k in planner_and_sim_counts()}
    assert {("prada", "samples"), ("prada", "horizon"), ("tower", "cubes"), ("bowling", "pins")} <= walked
