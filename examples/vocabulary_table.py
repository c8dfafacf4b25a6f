"""PRADA's share of V* per vocabulary, from finished `groundsym evaluate` folders (docs/planning.md,
"Vocabulary and rule data"): a Markdown table (mean over runs +- standard error, what each learned
symbol grounds, per run), a JSON with every run's figures and a PNG bar chart against the scripted
builders of docs/planning-results.md.

    python examples/vocabulary_table.py --out docs/results/tower-vocabulary-s7 \\
        "truth inhand,on,big=results/s7-truth-iob" "truth inhand,on=results/s7-truth-io" \\
        "learned 1+1=results/s7-learned-11" "learned 2+2=results/s7-learned-22"
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.fileio import atomic_write_bytes, atomic_write_json, read_json  # noqa: E402
from sims.tower import optimal_episode_value  # noqa: E402

BUILDERS = {"builder, true state": 0.909, "builder, size-blind": 0.715}    # docs/planning-results.md


def row(label: str, folder: Path, optimum: float) -> dict:
    """One vocabulary's runs: share of V* per run and episode, and each run's grounding."""
    runs = [read_json(p) for p in sorted((folder / "runs").glob("*.json"))]
    if not runs:
        sys.exit(f"{folder}: no finished runs")
    share = [float(np.mean(r["entries"][0]["values"]) / optimum) for r in runs]
    episodes = [v / optimum for r in runs for v in r["entries"][0]["values"]]
    ground = [[f"{g['symbol']}~{g['best_match']} {g['f1']:.2f}" for g in r["report"].get("grounding", [])]
              for r in runs]
    se = float(np.std(share, ddof=1) / np.sqrt(len(share))) if len(share) > 1 else 0.0
    return {"row": label, "runs": len(runs), "episodes": len(episodes), "share": float(np.mean(share)), "stderr": se,
            "full_episodes": float(np.mean(np.array(episodes) >= 0.98)), "run_shares": share,
            "pruned": [r["report"].get("pruned") for r in runs], "grounding": ground}


def chart(rows: list[dict], path: Path) -> None:
    """Bars of the share of V* (+- standard error), the builders as vertical lines."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.2))
    ax.barh([r["row"] for r in rows], [100 * r["share"] for r in rows], xerr=[100 * r["stderr"] for r in rows],
            color="#4477aa")
    for (name, v), style in zip(BUILDERS.items(), ("--", ":")):
        ax.axvline(100 * v, color="k", linestyle=style, label=f"{name} {100 * v:.1f}%")
    ax.set(xlabel="PRADA, share of V* (%)", xlim=(0, 100))
    ax.invert_yaxis()
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, tmp.read_bytes())
    tmp.unlink()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rows", nargs="+", metavar="LABEL=FOLDER")
    ap.add_argument("--out", type=Path, required=True, help="writes OUT.json and OUT.png")
    args = ap.parse_args()
    optimum = optimal_episode_value({})
    rows = [row(label, Path(folder), optimum) for label, _, folder in (r.partition("=") for r in args.rows)]
    print("| vocabulary | runs x starts | share of V* | full episodes | learned symbols (best match, F1), per run |")
    print("|---|---|---|---|---|")
    for r in rows:
        ground = "; ".join(", ".join(g) for g in r["grounding"] if g) or "(truth)"
        print(f"| {r['row']} | {r['runs']} x {r['episodes'] // r['runs']} | {100 * r['share']:.1f}% +- "
              f"{100 * r['stderr']:.1f}% | {r['full_episodes']:.2f} | {ground} |")
    atomic_write_json(args.out.with_suffix(".json"), {"optimum": optimum, "rows": rows})
    chart(rows, args.out.with_suffix(".png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
