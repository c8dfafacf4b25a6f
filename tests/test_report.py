"""``groundsym report``: one self-contained HTML page of a model, checked in its text and in a real
headless browser (Chromium from the operating system, driven by Playwright).

Truth used: the fixture world's intended symbols (``inhand`` as u1, ``on`` as b1) match the
traces' ground truth exactly (F1 1); the page's rules, reward weights and PPDDL text must be those
of ``rules.json``, ``reward.json`` and what ``export-domain`` writes; its filmstrip must hold the
very frames ``plan --render-dir`` rendered, in order, captioned with the episode file's actions.
"""

from __future__ import annotations

import base64
import json
import os
import re
import shutil
from html.parser import HTMLParser
from pathlib import Path

import pytest

from groundsym.cli import main
from groundsym.modeldir import learn_symbolic_model, write_manifest
from groundsym.report.page import PNG_MAGIC
from groundsym.rules.io import read_rules
from groundsym.symbols import SymbolSet, save_symbols
from groundsym.traces import read_traces, write_traces
from tests.test_loss import intended_symbols, kinematic_tower

SECTIONS = ("overview", "symbols", "ground-truth", "rules", "reward", "domain", "episode")


class _Page(HTMLParser):
    """Sections, images, figures and every URL-valued attribute of a page."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.sections: dict[str, str] = {}
        self.images: list[tuple[str, str]] = []      # (section, src)
        self.urls: list[str] = []
        self.tags: set[str] = set()
        self.captions: list[str] = []
        self._section = ""
        self._caption: list[str] | None = None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.add(tag)
        if tag == "section":
            self._section = a["id"]
            self.sections[self._section] = ""
        if tag == "img":
            self.images.append((self._section, a["src"]))
        if tag == "figcaption":
            self._caption = []
        self.urls += [v for k, v in attrs if k in ("src", "href", "action", "data") and v]

    def handle_endtag(self, tag):
        if tag == "figcaption" and self._caption is not None:
            self.captions.append("".join(self._caption))
            self._caption = None

    def handle_data(self, data):
        if self._section:
            self.sections[self._section] += data
        if self._caption is not None:
            self._caption.append(data)


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> dict[str, Path]:
    """A model of the fixture world with the intended symbols (rules and reward learned from its
    abstraction), its traces, and an episode PRADA planned with it in the tower cell, rendered."""
    tmp = tmp_path_factory.mktemp("report")
    ds = kinematic_tower(5, seed=8)
    traces = tmp / "traces.json"
    write_traces(traces, ds)
    symbols = SymbolSet(tuple(intended_symbols()), ("x", "y", "z", "size"))
    symbolic = tmp / "symbolic-model"          # a model of given predicates: no symbols.json
    learn_symbolic_model(symbols.to_symbolic_dataset(ds), symbolic, seed=0, argv=["test"], progress=False)
    model = tmp / "model"
    shutil.copytree(symbolic, model)
    save_symbols(model / "symbols.json", symbols)
    write_traces(model / "traces.json", ds)
    write_manifest(model)
    assert main(["plan", "--sim", "tower", "--sim-opt", "cubes=4", "--model", str(model), "--planner", "prada",
                 "--planner-opt", "samples=30", "--planner-opt", "horizon=2", "--steps", "2", "--seed", "0",
                 "--quiet", "--render-dir", str(tmp / "frames"), "-o", str(tmp / "episode.json")]) == 0
    report = tmp / "report.html"
    assert main(["report", str(model), "-o", str(report), "--against", str(traces),
                 "--episode", str(tmp / "episode.json"), "--frames", str(tmp / "frames")]) == 0
    return {"tmp": tmp, "traces": traces, "model": model, "symbolic": symbolic, "report": report,
            "episode": tmp / "episode.json", "frames": tmp / "frames"}


def test_the_page_is_self_contained(world):
    text = world["report"].read_text()
    page = _Page(text)
    assert tuple(page.sections) == SECTIONS
    assert "script" not in page.tags and "iframe" not in page.tags and "@import" not in text
    assert not [u for u in page.urls if not (u.startswith("#") or u.startswith("data:"))]
    assert [s for s, _ in page.images] == ["symbols"] + ["episode"] * 3
    for _, src in page.images:
        head, data = src.split(",", 1)
        assert head == "data:image/png;base64" and base64.b64decode(data).startswith(PNG_MAGIC)
    assert str(world["tmp"]) not in text                    # no machine paths in a report


def test_ground_truth_f1_of_the_intended_symbols(world):
    rows = _table_rows(world["report"].read_text(), "ground-truth")
    assert [r[:3] + r[5:6] for r in rows] == [["u1/1", "inhand", "same", "1.000"], ["b1/2", "on", "same", "1.000"]]
    section = _Page(world["report"].read_text()).sections["ground-truth"]
    assert "groundsym rename model b1=on u1=inhand" in section and "traces.json" in section


def test_rules_reward_and_domain_are_the_models(world, tmp_path, capsys):
    text = world["report"].read_text()
    model = world["model"]
    rules, meta = read_rules(model / "rules.json")
    cards = re.findall(r'<div class="card">(.*?)</div></div>(?=<div class="card">|</div>)', text, re.S)
    assert len(cards) == len(rules.rules)
    for card, rule, covers in zip(cards, rules.rules, meta["covers"]):
        shown = sorted(float(p) for p in re.findall(r'<div class="outcome"><span>([\d.]+)</span>', card))
        assert shown == pytest.approx(sorted([*rule.probs, rule.noise]), abs=5e-4)
        assert f"covers {covers} training" in card
    reward = json.loads((model / "reward.json").read_text())
    weights = [float(r[2]) for r in _table_rows(text, "reward")]
    assert weights == pytest.approx([reward["intercept"]] + [t["weight"] for t in reward["terms"]], rel=1e-5)
    assert main(["export-domain", str(model), "-o", str(tmp_path / "export")]) == 0
    pres = re.findall(r"<pre>(.*?)</pre>", _section_html(text, "domain"), re.S)
    import html
    assert [html.unescape(p) for p in pres] == [(tmp_path / "export" / f).read_text().rstrip("\n")
                                                for f in ("domain.ppddl", "problem.ppddl")]
    meanings = dict((r[0], r[1]) for r in _table_rows(text, "domain"))
    assert meanings["(u1 ?x1)"].startswith("z between") and meanings["(b1 ?x1 ?x2)"].startswith("X above Y")


def test_the_filmstrip_is_the_rendered_episode(world):
    page = _Page(world["report"].read_text())
    doc = json.loads(world["episode"].read_text())["episodes"][0]
    frames = [base64.b64decode(src.split(",", 1)[1]) for s, src in page.images if s == "episode"]
    assert frames == [(world["frames"] / f"frame-{k:03d}.png").read_bytes() for k in range(len(doc["steps"]) + 1)]
    for k, (cap, step) in enumerate(zip(page.captions, doc["steps"])):
        assert cap.startswith(f"step {k}: {step['action']}") and f"expected value {step['expected_value']:.4g}" in cap
    assert page.captions[-1].startswith("end: after 2 step(s)")


def test_a_model_of_given_predicates(world, tmp_path):
    """Without learned symbols: the predicates as given, no ground-truth section, and the filmstrip
    of an episode without frames shows each step's abstract state."""
    out = tmp_path / "r.html"
    assert main(["report", str(world["symbolic"]), "-o", str(out), "--episode", str(world["episode"])]) == 0
    page = _Page(out.read_text())
    assert tuple(page.sections) == ("overview", "symbols", "rules", "reward", "domain", "episode")
    assert "predicates were given with the data" in page.sections["symbols"] and not page.images
    doc = json.loads(world["episode"].read_text())["episodes"][0]
    assert " ".join(doc["steps"][0]["state"]) in page.sections["episode"]


def _one_line_error(capsys, argv, *needles):
    capsys.readouterr()
    try:
        status = main(argv)
    except SystemExit as exc:            # argparse's usage errors (an output that is a directory)
        status = exc.code
    assert status == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in err, err


def test_bad_input_is_one_line_and_leaves_the_old_report(world, tmp_path, capsys):
    model, ep = str(world["model"]), world["episode"]
    out = tmp_path / "r.html"
    out.write_text("old")
    doc = json.loads(ep.read_text())
    del doc["episodes"][0]["steps"][1]["action"]
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    _one_line_error(capsys, ["report", model, "-o", str(out), "--episode", str(tmp_path / "bad.json")],
                    "bad.json: episodes[0].steps[1].action: expected a string")
    frames = tmp_path / "frames"
    shutil.copytree(world["frames"], frames)
    (frames / "frame-002.png").unlink()
    _one_line_error(capsys, ["report", model, "-o", str(out), "--episode", str(ep), "--frames", str(frames)],
                    "frame-002.png: missing")
    (frames / "frame-002.png").write_text("not a picture")
    _one_line_error(capsys, ["report", model, "-o", str(out), "--episode", str(ep), "--frames", str(frames)],
                    "frame-002.png: not a PNG")
    _one_line_error(capsys, ["report", model, "-o", str(out), "--episode", str(ep), "--episode-index", "3"],
                    "no episode 3")
    _one_line_error(capsys, ["report", model, "-o", str(out), "--frames", str(frames)], "--frames: needs --episode")
    _one_line_error(capsys, ["report", str(world["symbolic"]), "-o", str(out), "--against", str(world["traces"])],
                    "--against", "no learned symbols")
    _one_line_error(capsys, ["report", str(tmp_path), "-o", str(out)], "not a model directory")
    _one_line_error(capsys, ["report", model, "-o", str(tmp_path / "r.txt")], "r.txt", "ending in .html")
    _one_line_error(capsys, ["report", model, "-o", str(tmp_path)], "is a directory")
    assert out.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["bad.json", "frames", "r.html"]


# ------------------------------------------------------------------------------ in a real browser
def _chromium() -> str | None:
    return os.environ.get("GROUNDSYM_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")


def test_the_page_in_headless_chromium(world, tmp_path):
    """Loads from file:// with no console error or failed request, every section visible, every
    image decoded, and a screenshot written."""
    sync_api = pytest.importorskip("playwright.sync_api", reason="Playwright for Python is not installed "
                                   "(pip install playwright; the browser is the system's Chromium)")
    exe = _chromium()
    if exe is None:
        pytest.skip("no Chromium on this machine (apt-get install -y chromium; or set GROUNDSYM_CHROMIUM)")
    problems: list[str] = []
    shot = tmp_path / "report.png"
    with sync_api.sync_playwright() as pw:
        try:
            browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"] if os.geteuid() == 0 else [])
        except sync_api.Error as exc:    # e.g. a snap stub for chromium in a container
            pytest.skip(f"Chromium at {exe} does not start: {str(exc).splitlines()[0]}")
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 900})
            page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}") if m.type == "error" else None)
            page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
            page.on("requestfailed", lambda r: problems.append(f"request failed: {r.url[:80]}"))
            page.goto(world["report"].resolve().as_uri(), wait_until="load")
            for sid in SECTIONS:
                sec = page.locator(f"section#{sid}")
                sec.scroll_into_view_if_needed()
                assert sec.is_visible() and sec.bounding_box()["height"] > 50, sid
            widths = page.eval_on_selector_all("img", "els => els.map(e => e.complete ? e.naturalWidth : 0)")
            assert len(widths) == 4 and min(widths) > 100
            page.screenshot(path=str(shot), full_page=True)
        finally:
            browser.close()
    assert problems == []
    assert shot.read_bytes().startswith(PNG_MAGIC)
    keep = os.environ.get("GROUNDSYM_REPORT_SCREENSHOT")
    if keep:
        shutil.copyfile(shot, keep)


# ------------------------------------------------------------------------------ helpers
def _section_html(text: str, sid: str) -> str:
    m = re.search(rf'<section id="{sid}">(.*?)</section>', text, re.S)
    assert m, sid
    return m.group(1)


def _table_rows(text: str, sid: str) -> list[list[str]]:
    """The cells (as text) of the first table of a section."""
    import html
    body = re.search(r"<tbody>(.*?)</tbody>", _section_html(text, sid), re.S).group(1)
    return [[html.unescape(re.sub(r"<[^>]+>", "", c)) for c in re.findall(r"<td[^>]*>(.*?)</td>", row, re.S)]
            for row in re.findall(r"<tr>(.*?)</tr>", body, re.S)]
