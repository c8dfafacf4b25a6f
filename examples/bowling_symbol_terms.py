"""Why the loss prunes every binary symbol in bowling: each term's price of hand-made `sameColumn` and `behind`.

The paper learned 1 unary + 3 binary symbols in bowling ("upright", "same column", "behind and
15 cm to the left"); ``examples/bowling_symbols.py`` keeps `upright` and prunes every binary
symbol (docs/bowling.md). This script measures why, term by term (docs/symbols.md, "The loss"), on
the data symbol learning sees (40 random games of 2 throws in 5-pin worlds, ``collect --sim bowling
--sim-opt pins=5 --traces 40 --length 2 --seed S``), in the 1 + 3 frame (literals of all four
candidates counted, as ``learn --unary 1 --binary 3`` counts them). Hand-made RBF symbols, each
printed with its F1 against the simulator's relation on the same data:

* ``upright``: centre z = 9.5 cm, axis vertical (uz = 1); other dimensions ignored;
* ``sameColumn``: |dx| < 5 cm (pair features ``y_i - y_j``);
* ``behind``: X 8.7-51 cm further down the lane than Y (dy), the rack's rows.

Rows: ``upright`` alone, ``+ sameColumn``, ``+ behind``, ``+ both``, no symbol; columns: each term's
change against ``upright`` alone, unweighted (the prediction term's weight is applied in the total
only), with the loss's settings ``--loss KEY=VALUE``. Two diagnostic columns split the question
"what is a binary symbol worth": the prediction term counting the `upright` literals only (does
the binary symbol make *which pins fall* more predictable?), and the nearest-neighbour likelihood
of the pins a throw knocks down given the state and the throw (the neighbours of the prediction
term, a Gaussian of the loss's reward sigma around theirs; not a term of today's loss, whose reward
term predicts the reward of the state itself).

    python examples/bowling_symbol_terms.py TRAIN.json [TRAIN2.json ...] --loss transition_weight=0.15
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from groundsym.grounding import match_symbols  # noqa: E402
from groundsym.loss import Loss, LossConfig, prepare  # noqa: E402
from groundsym.mixtures import mixture_ll, reward_entries, transition_entries  # noqa: E402
from groundsym.options import split_key_values  # noqa: E402
from groundsym.symbols import Symbol, SymbolSet  # noqa: E402
from groundsym.traces import read_traces  # noqa: E402

A = np.array
WIDE = 1e3          # a width far above every spread: the dimension is ignored (charged as width_cap)
R = float(np.sqrt(np.log(2)))      # holds(y) <=> sum ((y - c) / w)^2 < ln 2: half-width = R * w
UPRIGHT = Symbol("u1", 1, A([0, 0, 0.095, 0, 0, 1.0]), A([WIDE, WIDE, 0.03 / R, WIDE, WIDE, 0.4 / R]))
SAME_COLUMN = Symbol("b1", 2, A([0, 0, 0, 0, 0, 0.0]), A([0.05 / R, WIDE, WIDE, WIDE, WIDE, WIDE]))
BEHIND = Symbol("b2", 2, A([0, 0.30, 0, 0, 0, 0.0]), A([WIDE, 0.213 / R, WIDE, WIDE, WIDE, WIDE]))


def off(name: str, arity: int, dims: int) -> Symbol:
    """A symbol that is never true on the data (pruned: its literals are counted, never mispredicted)."""
    return Symbol(name, arity, np.full(dims, WIDE), np.full(dims, 1e-3))


def diagnostics(loss: Loss, symbols: list[Symbol], scene_reward: np.ndarray) -> tuple[float, float]:
    """The prediction term counting unary literals only, and ``-sum log p(pins knocked | s_t, a_t)``."""
    d, cfg = loss.data, loss.config
    u = np.stack([loss._symbol(s).truth for s in symbols if s.arity == 1], -1)
    active = [loss._symbol(s).truth for s in symbols if s.arity == 2 and loss._symbol(s).active]
    m = u.shape[1]
    b = np.stack(active, -1) if active else np.zeros((len(u), m, m, 0), np.uint8)   # as the loss: active ones only
    nb = loss.backend.neighbours(u[d.pre], b[d.pre], loss._lock, loss._label)
    n_lit = m * u.shape[-1] + m * (m - 1) * sum(s.arity == 2 for s in symbols)
    item, mis, weight = transition_entries(u, np.zeros_like(b), d.pre, d.post, nb, cfg.predict == "changes")
    lp = mis * np.log(cfg.noise) + (n_lit - mis) * np.log1p(-cfg.noise)
    unary_only = -mixture_ll(item, lp, weight, len(d.pre)).sum()
    knocked = scene_reward[d.post] - scene_reward[d.pre]
    item, other = reward_entries(nb)
    s2 = loss.sigma ** 2
    lp = -0.5 * np.log(2 * np.pi * s2) - (knocked[item] - knocked[other]) ** 2 / (2 * s2)
    return float(unary_only), float(-mixture_ll(item, lp, np.ones(len(item)), len(d.pre)).sum())


def loss_config(items: list[str]) -> LossConfig:
    """``--loss KEY=VALUE`` items as a LossConfig (numbers as floats, the rest as text)."""
    given = split_key_values(items, "--loss") if items else {}
    kw = {}
    for k, v in given.items():
        try:
            kw[k] = float(v)
        except ValueError:
            kw[k] = v
    return LossConfig(**kw)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("traces", nargs="+", help="bowling traces (collect --sim bowling --sim-opt pins=5 ...)")
    ap.add_argument("--loss", action="append", default=[], metavar="KEY=VALUE", help="loss settings")
    args = ap.parse_args()
    cfg = loss_config(args.loss)
    unit = replace(cfg, transition_weight=1.0)
    print(f"loss: {cfg.to_doc()}")
    print("| data | vocabulary | F1 (upright, sameColumn, behind) | effect | prediction (x1) | reward | reg | "
          "total change (weighted) | total | prediction, upright literals only (x1) | knocked pins given s, a |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for path in args.traces:
        ds = read_traces(path)
        n_u, n_p = ds.traces[0].scenes[0].features.shape[-1], 6
        loss = Loss(prepare(ds, unit, path), unit)
        f1 = {m.symbol: m for m in match_symbols(SymbolSet.for_dataset([UPRIGHT, SAME_COLUMN, BEHIND], ds), ds)}
        f1_text = f"{f1['u1'].f1:.2f}, {f1['b1'].f1:.2f}, {f1['b2'].f1:.2f}"
        rows = {"upright": [UPRIGHT, off("b1", 2, n_p), off("b2", 2, n_p), off("b3", 2, n_p)],
                "+ sameColumn": [UPRIGHT, SAME_COLUMN, off("b2", 2, n_p), off("b3", 2, n_p)],
                "+ behind": [UPRIGHT, off("b1", 2, n_p), BEHIND, off("b3", 2, n_p)],
                "+ both": [UPRIGHT, SAME_COLUMN, BEHIND, off("b3", 2, n_p)],
                "none": [off("u1", 1, n_u), off("b1", 2, n_p), off("b2", 2, n_p), off("b3", 2, n_p)]}
        base = loss(rows["upright"])
        scene_reward = np.concatenate([[s.reward for s in tr.scenes] for tr in ds.traces])
        for name, symbols in rows.items():
            unary_only, knocked = diagnostics(loss, symbols, scene_reward) if name != "none" else (0.0, 0.0)
            t = loss(symbols)
            total = t.effect + cfg.transition_weight * t.transition + t.reward + t.regulariser
            ref = base.effect + cfg.transition_weight * base.transition + base.reward + base.regulariser
            print(f"| {Path(path).stem} | {name} | {f1_text} | {t.effect - base.effect:+.1f} | "
                  f"{t.transition - base.transition:+.1f} | {t.reward - base.reward:+.1f} | "
                  f"{t.regulariser - base.regulariser:+.2f} | {total - ref:+.1f} | {total:.1f} | "
                  + (f"{unary_only:.1f} | {knocked:.1f} |" if name != "none" else "- | - |"), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
