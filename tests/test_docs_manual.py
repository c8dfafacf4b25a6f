"""The manual's rules, checked where a program can check them.

docs/ is a user's manual that stands alone: every page ends with a "Measured" section (what was
measured, the command, the figure, the version), no page names a machine's paths outside the
repository or the history of the project (dates, issue numbers), and every link and every
``docs/...`` file a page or the README names exists in the repository.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.glob("*.md"))
TEXTS = PAGES + [ROOT / "README.md"]
#: Code and data files: their docstrings and comments cite papers or docs/ pages, never notes that
#: live outside the repository. This file is left out (it spells the patterns it looks for).
CODE = sorted(p for d in ("groundsym", "sims", "planners", "tests", "examples", "benchmarks", "domains", "tools")
              for p in (ROOT / d).rglob("*") if p.suffix in (".py", ".ppddl", ".pddl", ".lark", ".md", ".yaml")
              and p.is_file() and p.name != Path(__file__).name)

LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
DOCS_PATH = re.compile(r"(?<![\w/.-])docs/[\w./-]*\w")
OUTSIDE = re.compile(r"(?<![\w.-])/work\b|\.\./shared\b|/shared/|ALGORITHMS\.md|DESIGN\.md")
MONTH = ("January|February|March|April|May|June|July|August|September|October|November|December")
HISTORY = re.compile(rf"\b(?:{MONTH})\s+20\d\d\b|\b20\d\d-\d\d-\d\d\b|\bissue\s+#?\d+|\bthis session\b",
                     re.IGNORECASE)
FENCE = re.compile(r"^(```|~~~)")


def rel(path: Path) -> str:
    return str(path.relative_to(ROOT))


def prose_lines(path: Path) -> list[tuple[int, str]]:
    """The page's lines outside fenced code blocks, numbered from 1."""
    out, fenced = [], False
    for no, line in enumerate(path.read_text().splitlines(), 1):
        if FENCE.match(line.strip()):
            fenced = not fenced
            continue
        if not fenced:
            out.append((no, line))
    return out


def test_the_manual_has_pages():
    assert len(PAGES) >= 10 and (DOCS / "README.md") in PAGES


@pytest.mark.parametrize("page", PAGES, ids=rel)
def test_every_page_ends_with_a_measured_section(page):
    headings = [line for _, line in prose_lines(page) if line.startswith("## ")]
    assert headings, f"{rel(page)}: no section"
    assert headings[-1].startswith("## Measured"), f"{rel(page)}: the last section is {headings[-1]!r}"
    tail = page.read_text().split(headings[-1], 1)[1]
    assert len(tail.split()) >= 20, f"{rel(page)}: the Measured section says next to nothing"


@pytest.mark.parametrize("page", TEXTS, ids=rel)
def test_no_paths_outside_the_repository_and_no_history(page):
    for no, line in enumerate(page.read_text().splitlines(), 1):
        assert not OUTSIDE.search(line), f"{rel(page)}:{no}: points outside the repository: {line.strip()}"
        assert not HISTORY.search(line), f"{rel(page)}:{no}: a date or project history: {line.strip()}"


def test_code_cites_nothing_outside_the_repository():
    bad = [f"{rel(p)}:{no}: {line.strip()}" for p in CODE
           for no, line in enumerate(p.read_text(errors="replace").splitlines(), 1) if OUTSIDE.search(line)]
    assert len(CODE) > 100 and not bad, "\n".join(bad)


@pytest.mark.parametrize("page", TEXTS, ids=rel)
def test_relative_links_and_named_docs_files_exist(page):
    for no, line in prose_lines(page):
        for target in LINK.findall(line):
            if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
                continue                     # a URL or an anchor on the same page
            path = (page.parent / target.split("#", 1)[0]).resolve()
            assert path.is_relative_to(ROOT), f"{rel(page)}:{no}: link {target} leaves the repository"
            assert path.exists(), f"{rel(page)}:{no}: link {target} names no file"
        for name in DOCS_PATH.findall(line):
            if "*" in name or name.endswith("/"):
                continue
            assert (ROOT / name).exists(), f"{rel(page)}:{no}: {name} names no file"


def test_the_checks_catch_what_they_are_for(tmp_path):
    """The patterns on hand-written lines: they must fire on these and stay quiet on the rest."""
    assert OUTSIDE.search("see /work/shared/DESIGN.md") and OUTSIDE.search("../shared/paper")
    assert not OUTSIDE.search("mkdir -p work && cd work") and not OUTSIDE.search("examples/work.py")
    assert HISTORY.search("measured in December 2026") and HISTORY.search("as issue 13 asked")
    assert HISTORY.search("on 2026-12-02") and not HISTORY.search("1e5 evaluations, 2,000 steps")
    assert LINK.findall("a [page](tower.md#speed) and ![plot](fig.png)") == ["tower.md#speed", "fig.png"]
    assert DOCS_PATH.findall("see docs/tower.md, or `docs/results/x.json`.") == ["docs/tower.md",
                                                                                  "docs/results/x.json"]
    page = tmp_path / "p.md"
    page.write_text("# P\n\n## A\n\n```\n## not a heading\n```\n\n## Measured\n")
    assert [line for _, line in prose_lines(page) if line.startswith("## ")] == ["## A", "## Measured"]
