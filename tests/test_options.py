"""One option type and one parser for simulations and planners: the same errors for both.

An unknown name lists the known ones; a refused value says what was expected and why (the
parser's own reason, e.g. ``at most 100``), whether it was a ``--sim-opt`` or a ``--planner-opt``.
"""

from __future__ import annotations

import pytest

from groundsym.errors import UserError
from groundsym.options import Option, one_of, parse_bool, parse_options, positive, split_key_values

SPEC = (Option("size", positive(int, most=100), 4, "a size"), Option("flag", parse_bool, True, "a switch"),
        Option("mode", one_of("fast", "exact"), "fast", "a choice"))


@pytest.mark.parametrize("flag, kind", [("--sim-opt", "sim"), ("--planner-opt", "planner")])
def test_sims_and_planners_word_their_option_errors_alike(flag, kind):
    assert parse_options(flag, kind, "x", SPEC, {"size": "7", "flag": "off", "mode": "exact"}) == \
        {"size": 7, "flag": False, "mode": "exact"}
    assert parse_options(flag, kind, "x", SPEC, {}) == {"size": 4, "flag": True, "mode": "fast"}
    with pytest.raises(UserError, match=rf"^{flag} colour: unknown option for {kind} 'x' \(known: flag, mode, size\)$"):
        parse_options(flag, kind, "x", SPEC, {"colour": "red"})
    with pytest.raises(UserError, match=rf"^{flag} size=1000: expected positive int \(at most 100\)$"):
        parse_options(flag, kind, "x", SPEC, {"size": "1000"})
    with pytest.raises(UserError, match=rf"^{flag} flag=maybe: expected bool \(maybe\)$"):
        parse_options(flag, kind, "x", SPEC, {"flag": "maybe"})
    with pytest.raises(UserError, match=rf"^{flag} mode=slow: expected fast or exact \(no such choice\)$"):
        parse_options(flag, kind, "x", SPEC, {"mode": "slow"})
    assert one_of("a", "b", "c").__name__ == "one of a, b, c"


def test_key_values_split_on_spaces_and_refuse_a_bare_key():
    assert split_key_values(["a=1 b=x", "c=2=3"], "--sim-opt") == {"a": "1", "b": "x", "c": "2=3"}
    with pytest.raises(UserError, match="^--sim-opt cubes: expected key=value$"):
        split_key_values(["cubes"], "--sim-opt")
