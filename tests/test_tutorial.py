"""docs/tutorial.md runs: every command of its ```sh blocks, in order, at small sizes.

The tutorial's sizes are shell variables with defaults (``${EVALS:-100000}``); the test sets the
small values the tutorial itself lists for a quick pass and runs each command in a temporary
folder holding a link to ``domains/``, as the tutorial's reader works. ``groundsym`` commands run
in-process through :func:`groundsym.cli.main` (the function the installed command calls), other
commands (``cat``) through bash. Each must exit 0 and leave the files it names (``-o``,
``--render-dir``, ``--plot``). Part 1 (the blocks world) is in the fast suite but for its harder
problem (FF-Replan calls Fast Downward many times); the whole page (part 2, the tower cell:
physics, symbol search, rendering) is slow.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
from pathlib import Path

import pytest

from groundsym.cli import main

ROOT = Path(__file__).parent.parent
TUTORIAL = ROOT / "docs" / "tutorial.md"
_VAR = re.compile(r"\$\{(\w+):-([^}]*)\}|\$(\w+)")
_OUTPUTS = ("-o", "--output", "--render-dir", "--plot")


def small_sizes(text: str) -> dict[str, str]:
    """The tutorial's own quick-pass line: ``export BW_TRACES=10 EPISODES=2 ...``."""
    m = re.search(r"^export ((?:\w+=\S+ ?)+)$", text, re.M)
    assert m, "docs/tutorial.md: no 'export NAME=VALUE ...' line of small sizes"
    return dict(kv.split("=", 1) for kv in m.group(1).split())


def commands(text: str) -> list[tuple[str, str, str]]:
    """(part heading, section heading, command) for every command of the ```sh blocks,
    continuation lines joined."""
    out = []
    part = section = ""
    in_block = False
    pending = ""
    for line in text.splitlines():
        if line.startswith("## "):
            part, section = line[3:], ""
        if line.startswith("### "):
            section = line[4:]
        if line.strip() == "```sh":
            in_block = True
            continue
        if in_block and line.strip() == "```":
            in_block = False
            continue
        if in_block:
            pending += line.rstrip("\\").strip() + " "
            if not line.endswith("\\"):
                if pending.strip() and not pending.lstrip().startswith("#"):
                    out.append((part, section, pending.strip()))
                pending = ""
    return out


def expand(command: str, env: dict[str, str]) -> str:
    def sub(m: re.Match) -> str:
        if m.group(3):
            return env[m.group(3)]
        return env.get(m.group(1), m.group(2))
    return _VAR.sub(sub, command)


PART1, PART2 = "Part 1: the noisy blocks world", "Part 2: the tower cell"
HARDER = "A harder problem: how far a planner looks"
TEXT = TUTORIAL.read_text()
SMALL = small_sizes(TEXT)
COMMANDS = commands(TEXT)


def test_the_tutorial_is_parsed_whole():
    """Every size variable the commands use has a small value and a row in the tutorial's table,
    and both parts have commands (a broken fence would silently drop some)."""
    used = {m.group(1) or m.group(3) for _, _, c in COMMANDS for m in _VAR.finditer(c)}
    assert used == set(SMALL)
    for name in used:
        assert f"| `{name}` |" in TEXT, name
    assert {p for p, _, _ in COMMANDS} == {PART1, PART2}
    assert any(s == HARDER for _, s, _ in COMMANDS)
    assert TEXT.count("```sh") == sum(1 for line in TEXT.splitlines() if line.strip() == "```sh")
    assert len(COMMANDS) >= 15


def _run(todo: list[str], workdir: Path, monkeypatch, capsys) -> None:
    if not (workdir / "domains").exists():
        (workdir / "domains").symlink_to(ROOT / "domains")
    monkeypatch.chdir(workdir)
    for raw in todo:
        argv = shlex.split(expand(raw, SMALL))
        if argv[0] == "groundsym":
            status = main(argv[1:])
            err = capsys.readouterr().err
        else:
            done = subprocess.run(argv, cwd=workdir, capture_output=True, text=True)
            status, err = done.returncode, done.stderr
        assert status == 0, f"{raw}\nexit {status}: {err[-2000:]}"
        for flag, value in zip(argv, argv[1:]):
            if flag in _OUTPUTS:
                assert (workdir / value).exists(), f"{raw}: wrote no {value}"


def test_part_1_the_blocks_world(tmp_path, monkeypatch, capsys):
    """Part 1 but its harder problem (Fast Downward replanning many times: in the slow test)."""
    _run([c for p, s, c in COMMANDS if p == PART1 and s != HARDER], tmp_path, monkeypatch, capsys)
    assert "rule 1: (pickup ?x1)" in (tmp_path / "bw-model" / "rules.txt").read_text()
    assert "(on a b)" in (tmp_path / "bw-export" / "problem.ppddl").read_text()


@pytest.mark.slow
def test_part_2_the_tower_cell(tmp_path, monkeypatch, capsys):
    """The whole page in one folder, in order, as a reader goes through it."""
    _run([c for _, _, c in COMMANDS], tmp_path, monkeypatch, capsys)
    html = (tmp_path / "report.html").read_text()
    assert all(f'<section id="{s}">' in html for s in ("symbols", "ground-truth", "rules", "episode"))
