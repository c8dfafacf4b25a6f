"""``groundsym report MODEL -o report.html``: the model as one page a person opens in a browser."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import __version__
from ..errors import UserError
from ..export import ExportOptions, build_export
from ..fileio import atomic_write_text
from ..modeldir import load_model
from ..report.filmstrip import filmstrip_section, read_episode, read_frames
from ..report.page import page
from ..report.sections import (against_name, domain_section, grounding_section, model_name, overview,
                               reward_section, rules_section, symbol_data, symbols_section)
from ..traces import read_traces
from ..limits import MAX_EPISODES
from ._common import Count, output_path, writable_output

NAME = "report"
HELP = "write a learned model as one self-contained HTML page (symbols, F1, rules, reward, domain, episode)"
ORDER = 48
DESCRIPTION = """One HTML file that needs no network to view (images inlined, no scripts): the
symbols in words with their plots, their F1 against ground truth (--against), the rules as cards
with outcome probabilities, the reward model, the PPDDL domain export-domain writes with each
predicate's meaning, and a planned episode as a filmstrip (--episode, --frames)."""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("model", type=Path, help="model directory (groundsym learn -o)")
    p.add_argument("-o", "--output", type=output_path, required=True, help="the HTML file to write")
    p.add_argument("--against", type=Path, metavar="TRACES",
                   help="continuous traces with ground truth: each symbol's best match with precision/recall/F1")
    p.add_argument("--episode", type=Path, metavar="FILE", help="an episode file (groundsym plan -o) to show")
    p.add_argument("--episode-index", type=Count(0, MAX_EPISODES - 1, f"(plan writes at most {MAX_EPISODES} episodes)"),
                   default=0, metavar="K",
                   help="which episode of the file (default 0)")
    p.add_argument("--frames", type=Path, metavar="DIR", help="the episode's rendered frames (plan --render-dir)")


def run(args: argparse.Namespace) -> int:
    out = writable_output(args.output)
    if out.suffix.lower() not in (".html", ".htm"):
        raise UserError(f"{out}: report writes an HTML page; give a file name ending in .html")
    if args.frames is not None and args.episode is None:
        raise UserError("--frames: needs --episode FILE (the episode the frames show)")
    episode = read_episode(args.episode, args.episode_index) if args.episode else None
    frames = read_frames(args.frames, len(episode.steps), args.episode_index) if args.frames else None
    model = load_model(args.model)
    against = None
    if args.against is not None:
        if model.symbols is None:
            raise UserError(f"--against: {args.model} holds no learned symbols (no symbols.json) to compare")
        against = read_traces(args.against)
        model.symbols.check_features(against.feature_names, f"{args.against}: meta")
    if model.symbols is not None and model.traces is not None:
        model.symbols.check_features(model.traces.feature_names, f"{args.model / 'traces.json'}: meta")
    export = build_export(model, ExportOptions(), args.model)
    sections = [overview(model, export), symbols_section(model, symbol_data(model, against))]
    grounding = grounding_section(model, against, against_name(args.against))
    sections += [grounding] if grounding is not None else []
    sections += [rules_section(model, export), reward_section(model), domain_section(model, export)]
    if episode is not None:
        sections.append(filmstrip_section(episode, frames, args.episode.name))
    subtitle = (f"{len(model.predicates)} predicates, {len(model.rules.rules)} rules, "
                f"{len(model.reward.features)} reward terms; groundsym {__version__}")
    html = page(f"Model report: {model_name(model)}", subtitle, sections)
    atomic_write_text(out, html)
    print(f"{out}: wrote the report ({len(html) // 1024} KB; {', '.join(s.title for s in sections)})",
          file=sys.stderr)
    return 0
