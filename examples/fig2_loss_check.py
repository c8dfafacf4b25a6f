"""Was the annealing budget of a `groundsym evaluate` run enough? Learned symbols against the intended ones.

For every finished unit of an evaluation folder, the unit's symbol data is collected again (same
seeds, so the same traces), and the paper's loss is evaluated for the symbols the task intends
(the simulator's relations written as RBF symbols, `groundsym.grounding.fit_relation_symbol`;
binary ones in either argument order, `on` or `above`, whichever the loss prefers) and for no
symbol at all. Two questions per unit:

* search: is the learned loss at most the intended symbols' loss? Then the budget sufficed to find
  what the loss asks for, and a poor grounding is the loss's choice, not the search's failure;
* loss: do the intended symbols beat no symbol? If not, no budget would find them on that data.

With ``--without REL`` a third question: do the intended symbols beat the same set without the
unary relation ``REL`` (does the loss pay for ``ball``)? ``--loss KEY=VALUE`` evaluates under
other loss settings than the defaults (the learned loss is then not comparable and not checked).

    python examples/fig2_loss_check.py results/fig2/cubes [--unary inhand] [--binary on,above]
    python examples/fig2_loss_check.py results/fig2/balls --unary inhand,ball --without ball [--loss predict=successor]
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.collect import collect_traces  # noqa: E402
from groundsym.commands.learn import loss_config  # noqa: E402
from groundsym.evaluation.config import EvalConfig  # noqa: E402
from groundsym.evaluation.protocol import unit_seeds  # noqa: E402
from groundsym.fileio import atomic_write_json, atomic_write_text, read_json  # noqa: E402
from groundsym.grounding import fit_relation_symbol  # noqa: E402
from groundsym.loss import Loss, LossConfig, prepare  # noqa: E402
from groundsym.registry import make_sim  # noqa: E402
from groundsym.symbols import Symbol, dataset_pair_names  # noqa: E402


def never(name: str, arity: int, n_features: int) -> Symbol:
    """A symbol that holds nowhere (pruned by the loss: its literals count as predicted right)."""
    return Symbol(name, arity, np.full(n_features, 1e3), np.full(n_features, 1e-3))


def binary_candidates(ds, binary: list[str]) -> list[tuple[Symbol, tuple[str, bool]]]:
    """Each relation of ``binary`` in both argument orders, fitted as a symbol ``b1`` (those that
    hold somewhere), with its (relation, swapped)."""
    fitted = [(fit_relation_symbol("b1", rel, ds, swapped=swapped), (rel, swapped))
              for rel, swapped in itertools.product(binary, (False, True))]
    return [(b, which) for b, which in fitted if b is not None]


def best_with(loss: Loss, unary_symbols: list[Symbol], candidates: list, rest: list[Symbol]):
    """The set ``unary_symbols + [b] + rest`` with the binary candidate ``b`` that scores lowest,
    and which relation that is; (None, None) without candidates."""
    sets = [([*unary_symbols, b, *rest], which) for b, which in candidates]
    return min(sets, key=lambda s: loss(s[0]).total, default=(None, None))


def intended_set(ds, loss: Loss, unary: list[str], binary: list[str], n_binary: int = 1):
    """The intended symbols (the unary relations fitted; of the binary ones, the relation and
    argument order whose fitted symbol scores lowest; further binary slots never true) and which
    binary relation that is, as (relation, swapped); (None, None) when none holds in ``ds``."""
    n, n2 = len(ds.feature_names), len(dataset_pair_names(ds))     # pair features may be fewer (point clouds)
    us = [fit_relation_symbol(f"u{i + 1}", r, ds) or never(f"u{i + 1}", 1, n) for i, r in enumerate(unary)]
    rest = [never(f"b{i + 1}", 2, n2) for i in range(1, n_binary)]
    return best_with(loss, us, binary_candidates(ds, binary), rest)


def intended_losses(ds, loss: Loss, unary: list[str], binary: list[str], n_binary: int,
                    without: str | None = None) -> dict[str, float]:
    """Loss of the intended symbol set (:func:`intended_set`), of no symbol and, with ``without``,
    of the intended set with that unary relation switched off."""
    n, n2 = len(ds.feature_names), len(dataset_pair_names(ds))
    us = [fit_relation_symbol(f"u{i + 1}", r, ds) or never(f"u{i + 1}", 1, n) for i, r in enumerate(unary)]
    empty_b = [never(f"b{i + 1}", 2, n2) for i in range(n_binary)]
    candidates = binary_candidates(ds, binary)

    def total(symbols: list[Symbol] | None) -> float:
        return math.inf if symbols is None else loss(symbols).total

    nothing = loss([never(f"u{i + 1}", 1, n) for i in range(len(unary))] + empty_b).total
    out = {"intended": total(intended_set(ds, loss, unary, binary, n_binary)[0]),
           "unary_only": loss([*us, *empty_b]).total, "nothing": nothing}
    if without:
        fewer = [never(s.name, 1, n) if r == without else s for r, s in zip(unary, us)]
        out["without"] = total(best_with(loss, fewer, candidates, empty_b[1:])[0])
    return out


def table(rows: list[dict], without: str | None) -> str:
    """One Markdown row per symbol-data size."""
    head = "| symbol data | units | learned loss <= intended | intended < no symbol |"
    if without:
        head += f" intended < without {without} |"
    head += " mean learned | mean intended | mean no symbol |"
    lines = [head, "|" + "---:|" * (head.count("|") - 1)]
    for N in sorted({r["N"] for r in rows}):
        rs = [r for r in rows if r["N"] == N]
        learned = [r["learned"] for r in rs if r["learned"] is not None]
        search = str(sum(v <= r["intended"] + 1e-6 for v, r in zip(learned, rs))) if learned else "-"
        cells = [str(N), str(len(rs)), search, str(sum(r["intended"] < r["nothing"] for r in rs))]
        if without:
            cells.append(str(sum(r["intended"] < r["without"] for r in rs)))
        cells += [f"{np.mean(learned):.1f}" if learned else "-", f"{np.mean([r['intended'] for r in rs]):.1f}",
                  f"{np.mean([r['nothing'] for r in rs]):.1f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path, help="an evaluation folder (config.json, runs/)")
    ap.add_argument("--unary", default="inhand", help="intended unary relations (default inhand)")
    ap.add_argument("--binary", default="on,above", help="candidate binary relations (default on,above)")
    ap.add_argument("--without", help="also the intended set without this unary relation (e.g. ball)")
    ap.add_argument("--loss", action="append", default=[], metavar="KEY=VALUE",
                    help="loss setting (as groundsym learn --loss); the learned loss is then not compared")
    ap.add_argument("--out", help="file name stem in FOLDER (default loss-check)", default="loss-check")
    ap.add_argument("--symbol-data", type=int, action="append", help="only the units of this symbol-data size (repeatable)")
    args = ap.parse_args()
    if args.without and args.without not in args.unary.split(","):
        ap.error(f"--without {args.without}: not among --unary {args.unary}")
    loss_cfg = loss_config(args.loss)
    cfg_doc = read_json(args.folder / "config.json")["config"]
    names = {f.name for f in dataclasses.fields(EvalConfig)}
    cfg = EvalConfig(**{k: tuple(v) if k in ("methods", "symbol_data", "model_traces", "truth_symbols") else v
                        for k, v in cfg_doc.items() if k in names})
    sim = make_sim(cfg.sim, dict(cfg.sim_options))
    # folders from before the loss had `predict` and `width_cap` were learned with the successor
    # copy and no cap; settings a folder does not record take those values, not today's defaults
    recorded = {"predict": "successor", "width_cap": 0.0, **(cfg_doc.get("loss") or {})}
    comparable = loss_cfg == LossConfig(**recorded)
    rows = []
    for path in sorted((args.folder / "runs").glob("N*-run*.json")):
        unit = read_json(path)
        if args.symbol_data and unit["symbol_data"] not in args.symbol_data:
            continue
        seeds = unit_seeds(cfg, unit["symbol_data"], unit["run"])
        ds = collect_traces(sim, max(1, math.ceil(unit["symbol_data"] / cfg.trace_length)), cfg.trace_length,
                            seeds["symbol_data"], progress=False)
        loss = Loss(prepare(ds, loss_cfg, str(path)), loss_cfg)
        got = intended_losses(ds, loss, args.unary.split(","), args.binary.split(","), cfg.binary, args.without)
        got.update(N=unit["symbol_data"], run=unit["run"],
                   learned=unit["report"]["loss"]["total"] if comparable else None)
        rows.append(got)
        extra = f", without {args.without} {got['without']:.1f}" if args.without else ""
        learned = f"learned {got['learned']:.1f}, " if comparable else ""
        print(f"{path.name}: {learned}intended {got['intended']:.1f}{extra}, "
              f"{'+'.join(args.unary.split(','))} alone {got['unary_only']:.1f}, no symbol {got['nothing']:.1f}",
              file=sys.stderr, flush=True)
    text = table(rows, args.without)
    print(text)
    doc = {"unary": args.unary, "binary": args.binary, "without": args.without,
           "loss": loss_cfg.to_doc(), "rows": rows}
    atomic_write_json(args.folder / f"{args.out}.json", doc)
    atomic_write_text(args.folder / f"{args.out}.md", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
