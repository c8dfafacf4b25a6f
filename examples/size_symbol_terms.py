"""Why the loss prunes a size symbol in the tower cell: each term's price of adding `big`.

Planning needs cube size (docs/planning.md, "Vocabulary": PRADA on the true `inhand`, `on`, `big`
earns far more of V* than on `inhand`, `on`), yet symbol learning at 2 unary + 2 binary candidates
never keeps one. This script measures why, term by term, on the data symbol learning sees (160
random transitions, `collect --traces 16 --seed S`), in the 2 + 2 frame (literals of all four
candidates counted, as `groundsym learn --unary 2 --binary 2` counts them):

* ``inhand, on``: the RBF symbols the 1 + 1 search finds (seed 1001, 15,000 evaluations; their F1
  against the simulator's `inhand` and `on` on each seed's data is printed), the other two
  candidates switched off (never true: pruned);
* ``+ big``: the same with a size-only unary symbol, true exactly for the big cubes (F1 1.0),
  which ignores position (widths far above the spread, charged as ``width_cap``).

It prints the change of each term (docs/symbols.md, "The loss"). A static symbol changes no
literal, so with ``predict = changes`` it is never mispredicted; what it changes is the
*neighbours*: the leave-one-out classes of isomorphic states split by size, many transitions lose
their exact match and are predicted by a farther state, and the tie mixtures shrink. ``--backoff``
also prints the terms under a back-off of the neighbour classes (the classes of the symbols that
change, refined by the static ones only where the refined class still holds another member; Katz
1987's back-off for sparse counts, *Estimation of probabilities from sparse data*, IEEE TASSP 35):
how much of the price is the split itself, and what size is worth to the predictors on this data.
The back-off here is a numpy sketch for this measurement, not a loss option.

    python examples/size_symbol_terms.py --seeds 1001-1005 [--backoff]
    python examples/size_symbol_terms.py --seeds 1001-1005 --loss reward_model=linear --loss static=backoff --loss sigma_factor=0.1

The second line measures the loss settings that let a size symbol pay (docs/symbols.md, "Keeping a
size symbol"): ``static=backoff`` is the back-off above as a loss option.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from groundsym.collect import collect_traces  # noqa: E402
from groundsym.commands.learn import loss_config  # noqa: E402
from groundsym.grounding import match_symbols  # noqa: E402
from groundsym.loss import Loss, LossConfig, prepare  # noqa: E402
from groundsym.mixtures import mixture_ll, reward_entries, transition_entries  # noqa: E402
from groundsym.neighbourhood import group_rows  # noqa: E402
from groundsym.registry import make_sim  # noqa: E402
from groundsym.symbols import Symbol, SymbolSet  # noqa: E402
from tower_prada_diagnosis import seed_range  # noqa: E402

A = np.array
WIDE = 1e3          # a width far above every spread: the dimension is ignored (charged as width_cap)
INHAND = Symbol("u1", 1, A([0.382, -0.058, 0.412, -0.14]), A([0.101, 0.158, 0.105, 1.18]))
ON = Symbol("b1", 2, A([-0.0149, 0.0482, 0.0446, -0.0588]), A([0.113, 0.211, 0.0518, 0.0932]))
BIG = Symbol("u2", 1, A([0.4, 0.0, 0.4, 0.05]), A([WIDE, WIDE, WIDE, 0.006]))       # size 0.05 m, not 0.04
OFF_U = Symbol("u2", 1, np.full(4, WIDE), np.full(4, 1e-3))                        # never true: pruned
OFF_B = Symbol("b2", 2, np.full(4, WIDE), np.full(4, 1e-3))


def backoff_terms(loss: Loss, static: list[Symbol]) -> tuple[float, float]:
    """Transition and reward terms of INHAND, ON (+ ``static``) with back-off neighbour classes."""
    d, be, cfg = loss.data, loss.backend, loss.config
    u, b = loss._symbol(INHAND).truth[..., None], loss._symbol(ON).truth[..., None]
    up, bp = u[d.pre], b[d.pre]
    n, m = len(d.pre), u.shape[1]
    full_u = np.concatenate([up] + [loss._symbol(s).truth[d.pre][..., None] for s in static], -1)

    def refined(lock: np.ndarray, label: np.ndarray) -> np.ndarray:
        forms, _ = be.canonical_forms(full_u, bp, lock)
        return group_rows(np.concatenate([forms, label.astype(np.uint8)[:, None]], 1))[1]

    # reward: each member of a class predicted by the others of its refined class, when there are any
    nb = be.neighbours(up, bp, loss._no_lock, loss._no_label)
    item, other = reward_entries(nb)
    keep = _backoff(item, other, nb.cls, refined(loss._no_lock, loss._no_label))
    item, other = item[keep], other[keep]
    s2 = loss.sigma ** 2
    lp = -0.5 * math.log(2 * math.pi * s2) - (d.reward[item] - d.reward[other]) ** 2 / (2 * s2)
    reward = -mixture_ll(item, lp, np.ones(len(item)), n).sum()
    # transition: the same per partner (static literals never change: always right)
    nb = be.neighbours(up, bp, loss._lock, loss._label)
    idx = np.arange(n)[:, None]
    succ = np.concatenate([u[d.post][idx, nb.perms].reshape(n, -1),
                           b[d.post][idx[:, :, None], nb.perms[:, :, None], nb.perms[:, None, :]].reshape(n, -1)], 1)
    it, mis, w = transition_entries(u, b, d.pre, d.post, nb, True)
    sizes = np.bincount(nb.cls)
    lone = sizes[nb.cls[it]] == 1
    full = refined(loss._lock, loss._label)
    rows = [(it[lone], mis[lone], w[lone].astype(float))]
    for i in np.nonzero(sizes[nb.cls] > 1)[0]:
        others = np.nonzero((nb.cls == nb.cls[i]) & (np.arange(n) != i))[0]
        same = others[full[others] == full[i]]
        others = same if len(same) else others
        rows.append((np.full(len(others), i), (succ[others] != succ[i]).sum(1), np.ones(len(others))))
    it, mis, w = (np.concatenate(c) for c in zip(*rows))
    order = np.argsort(it, kind="stable")
    n_lit = m * 2 + m * (m - 1) * 2
    lp = mis[order] * math.log(cfg.noise) + (n_lit - mis[order]) * math.log1p(-cfg.noise)
    return float(-mixture_ll(it[order], lp, w[order], n).sum()), float(reward)


def _backoff(item: np.ndarray, other: np.ndarray, cls: np.ndarray, full: np.ndarray) -> np.ndarray:
    """Entries to keep: a class member's partners in its refined class if it has any there, else all;
    a lone item keeps its nearest classes."""
    keep = np.ones(len(item), dtype=bool)
    for i in np.unique(item):
        e = np.nonzero(item == i)[0]
        if cls[other[e[0]]] == cls[i]:
            same = full[other[e]] == full[i]
            if same.any():
                keep[e] = same
    return keep


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1001-1005", help="data seeds (collect --traces 16 --seed S)")
    ap.add_argument("--backoff", action="store_true", help="also the terms under back-off neighbour classes")
    ap.add_argument("--loss", action="append", default=[], metavar="KEY=VALUE",
                    help="a loss setting, as groundsym learn --loss takes it (repeatable), e.g. reward_model=linear")
    args = ap.parse_args()
    if args.backoff and args.loss:
        ap.error("--backoff sketches the back-off on the default loss; give --loss static=backoff instead")
    sim, cfg = make_sim("tower", {}), loss_config(args.loss)
    print("| seed | F1 inhand, on, big | effect | prediction | reward | regulariser | total |"
          + (" back-off: prediction | reward | total |" if args.backoff else ""))
    print("|---|---|---|---|---|---|---|" + ("---|---|---|" if args.backoff else ""))
    for seed in seed_range(args.seeds):
        ds = collect_traces(sim, 16, 10, seed, progress=False)
        loss = Loss(prepare(ds, cfg), cfg, kernels="numpy" if args.backoff else None)
        base, big = loss([INHAND, OFF_U, ON, OFF_B]), loss([INHAND, BIG, ON, OFF_B])
        f1 = {mt.symbol: mt.f1 for mt in match_symbols(SymbolSet.for_dataset([INHAND, BIG, ON], ds), ds)}
        line = (f"| {seed} | {f1['u1']:.2f}, {f1['b1']:.2f}, {f1['u2']:.2f} | {big.effect - base.effect:+.1f} | "
                f"{big.transition - base.transition:+.2f} | {big.reward - base.reward:+.2f} | "
                f"{big.regulariser - base.regulariser:+.2f} | {big.total - base.total:+.2f} |")
        if args.backoff:
            assert backoff_terms(loss, []) == (base.transition, base.reward)     # no static symbol: the loss itself
            t, r = backoff_terms(loss, [BIG])
            reg = big.regulariser - base.regulariser
            line += f" {t - base.transition:+.2f} | {r - base.reward:+.2f} | {t - base.transition + r - base.reward + reg:+.2f} |"
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
