"""One self-contained HTML page: inline CSS, images as ``data:`` URIs, no scripts.

Why: a report is mailed, put on a course page or opened on a laptop without a network; it must
show the same thing wherever it is opened, so nothing is fetched at view time.
"""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass
from typing import Iterable, Sequence

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

CSS = """
:root { --ink: #1d2430; --muted: #5b6573; --line: #d9dee5; --card: #f6f8fa; --accent: #2f6db5; }
* { box-sizing: border-box; }
body { margin: 0; font: 15px/1.5 system-ui, -apple-system, "Segoe UI", sans-serif; color: var(--ink); }
header { padding: 1.2rem 2rem; background: #24364f; color: #fff; }
header h1 { margin: 0 0 .3rem; font-size: 1.5rem; }
header p { margin: 0; color: #d3dcea; }
nav { padding: .5rem 2rem; border-bottom: 1px solid var(--line); background: #fff; }
nav a { margin-right: 1.1rem; color: var(--accent); text-decoration: none; }
main { padding: 0 2rem 3rem; max-width: 1200px; }
section { margin-top: 2rem; }
h2 { border-bottom: 2px solid var(--line); padding-bottom: .2rem; }
table { border-collapse: collapse; margin: .6rem 0; }
th, td { border: 1px solid var(--line); padding: .25rem .6rem; text-align: left; vertical-align: top; }
th { background: var(--card); }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
code, pre { font: 13px/1.4 ui-monospace, "DejaVu Sans Mono", monospace; }
pre { background: var(--card); border: 1px solid var(--line); padding: .8rem; overflow: auto; max-height: 36rem; }
img { max-width: 100%; border: 1px solid var(--line); }
.note { color: var(--muted); }
.cards { display: grid; grid-template-columns: repeat(auto-fill, minmax(330px, 1fr)); gap: .9rem; }
.card { background: var(--card); border: 1px solid var(--line); border-radius: 6px; padding: .7rem .9rem; }
.card h3 { margin: 0 0 .4rem; font-size: 1rem; }
.card .tag { font-size: .75rem; background: #e6c65c; border-radius: 3px; padding: 0 .3rem; margin-left: .3rem; }
.outcome { display: grid; grid-template-columns: 4.2rem 6rem 1fr; gap: .5rem; align-items: center; }
.bar { height: .7rem; background: var(--accent); border-radius: 2px; }
.bar.noise { background: #b0b7c0; }
.strip { display: flex; flex-wrap: wrap; gap: .8rem; }
.strip figure { margin: 0; flex: 0 0 auto; width: 360px; }
.strip figcaption { font-size: .85rem; margin-top: .25rem; }
"""


@dataclass(frozen=True)
class Section:
    """One part of the page: an anchor id, a heading and its HTML body."""

    id: str
    title: str
    body: str


def esc(text: object) -> str:
    return html.escape(str(text), quote=True)


def png_uri(png: bytes) -> str:
    """A PNG as a ``data:`` URI (checked to be a PNG, so a stray file never breaks the page)."""
    if not png.startswith(PNG_MAGIC):
        raise ValueError("not a PNG image")
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def img(png: bytes, alt: str) -> str:
    return f'<img src="{png_uri(png)}" alt="{esc(alt)}">'


def table(header: Sequence[str] | None, rows: Iterable[Sequence[str]], numeric: Sequence[int] = ()) -> str:
    """An HTML table; ``rows`` hold HTML already escaped; columns in ``numeric`` align right; no
    header row when ``header`` is None."""
    head = "".join(f"<th>{esc(h)}</th>" for h in header or ())
    body = "".join("<tr>" + "".join(f'<td class="num">{c}</td>' if i in numeric else f"<td>{c}</td>"
                                    for i, c in enumerate(row)) + "</tr>" for row in rows)
    return f"<table>{f'<thead><tr>{head}</tr></thead>' if head else ''}<tbody>{body}</tbody></table>"


def page(title: str, subtitle: str, sections: Sequence[Section]) -> str:
    """The whole document. ``<link rel=icon href=data:,>`` keeps browsers from asking for a favicon."""
    nav = "".join(f'<a href="#{esc(s.id)}">{esc(s.title)}</a>' for s in sections)
    body = "\n".join(f'<section id="{esc(s.id)}">\n<h2>{esc(s.title)}</h2>\n{s.body}\n</section>' for s in sections)
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f'<link rel="icon" href="data:,">\n<title>{esc(title)}</title>\n<style>{CSS}</style>\n</head>\n'
            f'<body>\n<header><h1>{esc(title)}</h1><p>{esc(subtitle)}</p></header>\n'
            f"<nav>{nav}</nav>\n<main>\n{body}\n</main>\n</body>\n</html>\n")
