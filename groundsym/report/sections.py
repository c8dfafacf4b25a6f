"""The parts of a model report, each from what another command already computes.

Why reuse: the report must say exactly what ``show`` (symbols in words and their Fig. 3-style
plot, F1 against ground truth), ``rules.txt`` (rules and outcome probabilities) and
``export-domain`` (the PPDDL domain, its predicates' meanings, the reward in words) say, so a
person who reads the report and one who runs the commands see the same model.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from ..describe import describe
from ..export import Export, predicate_comments, reward_terms, reward_words
from ..figures import symbols_png
from ..grounding import Match, match_symbols, suggested_names
from ..modeldir import Model
from ..ppddl.rule_actions import rule_action_names
from ..rules.model import Rule
from ..symbols import dataset_arrays, share_true
from ..traces import Dataset
from .page import Section, esc, img, table

MAX_DOMAIN_LINES = 400      # longer domains are cut in the page (the export writes them whole)


def model_name(model: Model) -> str:
    """The model directory's own name (``-o .`` has none; no machine paths in a report)."""
    return model.path.resolve().name


def _code(text: object) -> str:
    return f"<code>{esc(text)}</code>"


def _pct(x: float) -> str:
    return f"{100 * x:.1f}%"


# ------------------------------------------------------------------------------ overview
def overview(model: Model, export: Export) -> Section:
    sds = model.symbolic_traces
    learned = model.symbols is not None
    rows = [("model", _code(model_name(model))),
            ("predicates", f"{len(model.predicates)} "
             + ("(RBF symbols learned from continuous data)" if learned else "(given with the symbolic data)")),
            ("primitives", ", ".join(_code(f"{p}/{n}") for p, n in sorted(_primitives(model).items()))),
            ("rules", f"{len(model.rules.rules)} (plus a default rule per primitive)"),
            ("reward terms", str(len(model.reward.features))),
            ("training transitions", str(sds.n_transitions) if sds is not None else "unknown"),
            ("PPDDL domain", f"{len(export.domain.actions)} actions over {len(export.objects)} objects"
             + (f"; {len(export.dropped)} rule(s) left out" if export.dropped else ""))]
    body = table(None, rows)
    body += ('<p class="note">Read from top to bottom: what each predicate means, how well it matches the '
             "simulator's ground truth, how the actions change the predicates (rules), what the reward "
             "pays for, and the planning domain a PPDDL planner reads.</p>")
    return Section("overview", "Overview", body)


def _primitives(model: Model) -> dict[str, int]:
    return model.primitives or {r.action.predicate: r.action.arity for r in model.rules.rules}


# ------------------------------------------------------------------------------ symbols
def symbol_data(model: Model, against: Dataset | None) -> tuple[np.ndarray, np.ndarray] | None:
    """(features, pairs) of the training traces, else of the ground-truth traces, else None."""
    ds = model.traces if model.traces is not None else against
    return dataset_arrays(ds) if ds is not None else None


def symbols_section(model: Model, data: tuple[np.ndarray, np.ndarray] | None) -> Section:
    symbols = model.symbols
    if symbols is None:
        return Section("symbols", "Symbols", _given_predicates(model))
    shares = share_true(symbols, *data) if data is not None else {}
    lines = describe(symbols, *(data or (None, None)))
    rows = []
    for s, line in zip(symbols.symbols, lines):
        words = line.split(": ", 1)[-1]
        share = _pct(shares[s.name]) + (" of objects" if s.arity == 1 else " of ordered pairs") \
            if s.name in shares else "-"
        rows.append((_code(f"{s.name}/{s.arity}"), esc(words), share))
    body = ('<p>Each symbol is a radial basis function over the objects\' features (one object) or '
            'the differences of two objects\' features (a pair); it holds where the function exceeds '
            "0.5. In words, naming only the dimensions that decide it on the data:</p>")
    body += table(("symbol", "holds when", "true for"), rows) if rows else "<p>No symbols: all were pruned.</p>"
    if data is not None and symbols.symbols:
        body += ("<p>Each panel: the data over the symbol's two most selective dimensions, red where "
                 "the symbol holds, and its boundary (the ellipse; other dimensions at the centre).</p>")
        body += img(symbols_png(symbols, *data), "the symbols' activation regions over the data")
    elif symbols.symbols:
        body += '<p class="note">No plot: the model directory holds no traces.json and no --against traces.</p>'
    return Section("symbols", "Symbols", body)


def _given_predicates(model: Model) -> str:
    sds = model.symbolic_traces
    counts: dict[str, int] = {}
    states = 0
    if sds is not None:
        for tr in sds.traces:
            for s in tr.states:
                states += 1
                for a in s:
                    counts[a.predicate] = counts.get(a.predicate, 0) + 1
    rows = [(_code(f"{p}/{n}"), f"{counts.get(p, 0) / states:.2f}" if states else "-")
            for p, n in sorted(model.predicates.items())]
    return ("<p>This model was learned from symbolic data: its predicates were given with the data, "
            "not learned from continuous features.</p>"
            + table(("predicate", "true atoms per state in the data (mean)"), rows, numeric=(1,)))


# ------------------------------------------------------------------------------ ground truth
def grounding_section(model: Model, against: Dataset | None, against_name: str | None) -> Section | None:
    """F1 of every symbol against the ground truth of ``against``; None when there is nothing to say."""
    symbols = model.symbols
    if symbols is None:
        return None
    if against is None:
        return Section("ground-truth", "Ground truth", '<p class="note">Not compared: give '
                       "<code>--against TRACES</code> (traces that carry the simulator's ground truth).</p>")
    matches = match_symbols(symbols, against)
    rows = [_match_row(m) for m in matches]
    body = (f"<p>Each symbol against the ground-truth relations in {_code(against_name)}, scored over "
            "every scene (unary: every object; binary: every ordered pair, in both argument orders).</p>")
    body += table(("symbol", "best match", "argument order", "precision", "recall", "F1", "its negation"),
                  rows, numeric=(3, 4, 5))
    names = suggested_names(matches)
    if names:
        body += ("<p>Suggested names: "
                 + _code(f"groundsym rename {model_name(model)} " + " ".join(f"{k}={v}" for k, v in names.items()))
                 + "</p>")
    return Section("ground-truth", "Ground truth", body)


def _match_row(m: Match) -> Sequence[str]:
    if m.best_match is None:
        return (_code(f"{m.symbol}/{m.arity}"), "none of this arity", "", "", "", "", "")
    neg = f"{esc(m.negation_of)} (F1 {m.negation_f1:.3f})" if m.negation_of is not None else ""
    return (_code(f"{m.symbol}/{m.arity}"), esc(m.best_match), esc(m.argument_order), f"{m.precision:.3f}",
            f"{m.recall:.3f}", f"<b>{m.f1:.3f}</b>", neg)


# ------------------------------------------------------------------------------ rules
def rules_section(model: Model, export: Export) -> Section:
    covers = (model.meta.get("covers") or [None] * len(model.rules.rules))
    cards = [_rule_card(rule, name, cov, name in export.dropped)
             for rule, name, cov in zip(model.rules.rules, rule_action_names(model.rules.rules), covers)]
    defaults = "".join(f"<li>{_code(name)}: no change {d.p_nochange:.3f}, noise {d.p_noise:.3g}</li>"
                       for name, d in model.rules.defaults)
    body = ("<p>A rule says what a primitive does where its context holds: each outcome's changes with "
            "its probability; noise is the share of changes the rule does not explain. Where no rule "
            "or several rules cover an action, the primitive's default rule applies. The card names "
            "the rule's action in the PPDDL domain below.</p>")
    body += f'<div class="cards">{"".join(cards)}</div>'
    body += f"<p>Default rules:</p><ul>{defaults}</ul>" if defaults else ""
    return Section("rules", "Rules", body)


def _rule_card(rule: Rule, name: str, covers: int | None, dropped: bool) -> str:
    tag = '<span class="tag">left out of the domain: never applies alone</span>' if dropped else ""
    context = " ".join(_code(l) for l in rule.context) if rule.context else "always"
    refs = (f"<div>references: {', '.join(_code(y) for y in rule.deictic)} (each must match exactly one "
            "object)</div>") if rule.deictic else ""
    cov = f"<div>covers {covers} training transition(s)</div>" if covers is not None else ""
    order = sorted(range(len(rule.outcomes)), key=lambda k: -rule.probs[k])
    outs = "".join(_outcome(rule.probs[k], str(rule.outcomes[k]), "") for k in order)
    outs += _outcome(rule.noise, "noise", " noise")
    return (f'<div class="card"><h3>{esc(name)}: {_code(rule.action)}{tag}</h3>'
            f"<div>when {context}</div>{refs}{cov}<div>outcomes:</div>{outs}</div>")


def _outcome(p: float, what: str, kind: str) -> str:
    width = max(0.0, min(1.0, p)) * 100
    return (f'<div class="outcome"><span>{p:.3f}</span><div class="bar{kind}" style="width:{width:.1f}%">'
            f"</div><code>{esc(what)}</code></div>")


# ------------------------------------------------------------------------------ reward
def reward_section(model: Model) -> Section:
    rm = model.reward
    rt = reward_terms(model)
    kept = {f for f, _ in rt.terms}
    rows = [("intercept", "(every state)", f"{rm.intercept:.6g}")]
    rows += [(_code(f), "yes" if f in kept else "no (below 1/1000 of the largest)", f"{w:.6g}")
             for f, w in zip(rm.features, rm.weights)]
    body = ("<p>The reward of a state is a constant plus a weight per count feature: a feature counts "
            "how many objects (or pairs of distinct objects) make its atoms true.</p>")
    body += table(("feature", "in the domain", "weight"), rows, numeric=(2,))
    body += "<p>As the PPDDL domain states it:</p><pre>" + esc("\n".join(reward_words(model))) + "</pre>"
    body += _fit(rm.fit)
    return Section("reward", "Reward model", body)


def _fit(fit: dict) -> str:
    parts = []
    if fit.get("note"):
        parts.append(esc(fit["note"]))
    for key, label in (("heldout", "held-out traces"), ("train", "training data")):
        s = fit.get(key)
        if isinstance(s, dict) and "r2" in s:
            parts.append(f"{label}: R&sup2; {s['r2']:.3f}, RMSE {s['rmse']:.4g} against {s['baseline_rmse']:.4g} "
                         f"for the mean ({s.get('n', '?')} states)")
    return f'<p class="note">Fit: {"; ".join(parts)}.</p>' if parts else ""


# ------------------------------------------------------------------------------ domain
def domain_section(model: Model, export: Export) -> Section:
    meanings = predicate_comments(model)
    rows = [(_code(f"({p.name} {' '.join(x.name for x in p.params)})".replace(" )", ")")),
             esc(meanings.get(p.name) or p.comment or "a given predicate"))
            for p in export.domain.predicates]
    goal = " ".join(_code(l) for l in export.goal) if export.goal else "none"
    body = ("<p>What <code>groundsym export-domain</code> writes: one PPDDL action per rule, "
            "probabilities to 4 decimals (the rest of the mass is no change), the reward as reward "
            "effects. Each predicate's meaning:</p>")
    body += table(("predicate", "meaning"), rows)
    body += (f"<p>The problem: objects {', '.join(_code(o) for o in export.objects)}; goal {goal} "
             f'<span class="note">({esc(export.goal_note)})</span>.</p>')
    body += _pre(str(export.domain), "domain.ppddl") + _pre(str(export.problem), "problem.ppddl")
    return Section("domain", "PPDDL domain", body)


def _pre(text: str, name: str) -> str:
    lines = text.splitlines()
    cut = ""
    if len(lines) > MAX_DOMAIN_LINES:
        cut = f"\n; ... {len(lines) - MAX_DOMAIN_LINES} more lines (groundsym export-domain writes them all)"
        lines = lines[:MAX_DOMAIN_LINES]
    return f"<p>{_code(name)}:</p><pre>{esc(chr(10).join(lines) + cut)}</pre>"


def against_name(path: str | Path | None) -> str | None:
    """The ground-truth file as the page names it: its file name (no machine paths in reports)."""
    return Path(path).name if path is not None else None
