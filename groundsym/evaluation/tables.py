"""results.md: an evaluation's results as Markdown tables (methods, then the grounding of the
learned symbols)."""

from __future__ import annotations

from typing import Any, Mapping

from .results import GOOD_F1


def markdown_table(results: Mapping[str, Any]) -> str:
    opt = results.get("optimum")
    lines = [f"Deterministic optimum: {opt:.4g}" if opt else "Deterministic optimum: not known for this sim", "",
             "| symbol data | model traces | method | mean value | stderr | runs | share of optimum |",
             "|---:|---:|---|---:|---:|---:|---:|"]
    for r in results["methods"]:
        se = f"{r['stderr']:.3g}" if r["stderr"] is not None else "-"
        share = f"{100 * r['share_of_optimum']:.1f}%" if r["share_of_optimum"] is not None else "-"
        lines.append(f"| {r['symbol_data']} | {r['model_traces']} | {r['method']} | {r['mean']:.4g} | {se} | "
                     f"{r['n']} | {share} |")
    return "\n".join(lines) + "\n" + grounding_table(results)


def grounding_table(results: Mapping[str, Any]) -> str:
    """Markdown: per symbol-data size, the runs in which each relation was learned (F1 >= GOOD_F1)."""
    summary = results.get("meta", {}).get("grounding") or {}
    if not summary:
        return ""
    rels = sorted({rel for v in summary.values() for rel in v.get("found", {})})
    lines = ["", f"Grounding of the learned symbols on each run's held-out model data: runs in which some "
             f"symbol matches the relation with F1 >= {GOOD_F1}", "",
             "| symbol data | runs | " + " | ".join(rels) + " |", "|---:|---:|" + "---:|" * len(rels)]
    for N in sorted(summary, key=int):
        v = summary[N]
        lines.append(f"| {N} | {v['runs']} | " + " | ".join(str(v.get("found", {}).get(r, 0)) for r in rels) + " |")
    return "\n".join(lines) + "\n"
