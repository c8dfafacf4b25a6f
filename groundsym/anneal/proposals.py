"""Where the search's new and moved symbols come from: centres drawn from the data, widths scaled
to a share of it, dimensions ignored, and small perturbations.

The proposals decide what the search can find at all: a relation that holds for 1% of the pairs is
almost never proposed by chance, so centres are drawn from the objects and pairs that primitives
acted on (:func:`proposal_points`), and widths are scaled so that a new symbol holds for a useful
share of the data (:func:`share_radius`).
"""

from __future__ import annotations

import numpy as np

from .. import compiled
from ..loss import LossData
from ..symbols import Symbol
from .config import AnnealConfig

_PROPOSAL_POINTS: dict[int, tuple] = {}


def proposal_points(data: LossData) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where new symbols centre (memoised for the last data): the object and distinct-pair feature
    vectors of all scenes; the objects a primitive moved (by more than the ``change_tol`` the data
    was prepared with, as a share of a feature's spread), before and after the move; and the
    ordered pairs of distinct objects a primitive *involved* (its arguments and the objects it
    moved), in the scene after it.

    Why those pairs: a relation that a primitive brings about holds between the objects it acted
    on and moved (``openHandOver(X)`` puts the held object on ``X``), and such pairs are rare among
    all pairs (``on`` holds for 1-2% of the tower's pairs, for 60-74% of these). Drawn from all
    pairs, or from every pair with a moved object, 0.03% to 0.13% of the binary proposals matched
    ``on`` or ``above`` (F1 >= 0.8); from these, 0.6% to 1.8% (``examples/proposal_rates.py``,
    docs/symbol-search.md).
    """
    hit = _PROPOSAL_POINTS.get(id(data))
    if hit is None or hit[0] is not data:
        m = data.features.shape[1]
        off = ~np.eye(m, dtype=bool)
        unary = data.features.reshape(-1, data.features.shape[-1])
        pairs = data.pairs[:, off].reshape(-1, data.pairs.shape[-1])
        moved = (np.abs(data.features[data.post] - data.features[data.pre]) / data.unary_scale).max(-1) \
            > data.change_tol                                                      # (T, M)
        scenes = np.concatenate([data.pre, data.post])
        mu = data.features[scenes][np.concatenate([moved, moved])]
        involved = moved | (data.lock != 0)                                        # (T, M)
        pair_inv = involved[:, :, None] & involved[:, None, :] & off[None]
        pi = data.pairs[data.post][pair_inv]
        _PROPOSAL_POINTS.clear()
        hit = _PROPOSAL_POINTS[id(data)] = (data, unary, pairs, mu if len(mu) else unary, pi if len(pi) else pairs)
    return hit[1], hit[2], hit[3], hit[4]


IGNORE_WIDTH = 100.0  # an ignored dimension's width, x the data's spread (the loss caps its cost)


def ignored_dimensions(rng: np.random.Generator, n: int, cfg: AnnealConfig) -> np.ndarray:
    """Which of ``n`` dimensions a new symbol ignores: each with probability ``p_ignore``
    (``looks="independent"``, never all), or all but a random subset whose size is uniform in 1..n
    (``looks="subset"``: symbols of one dimension, such as size or height alone, as often as any)."""
    if cfg.looks == "subset":
        ignore = np.ones(n, dtype=bool)
        ignore[rng.choice(n, int(rng.integers(1, n + 1)), replace=False)] = False
        return ignore
    ignore = rng.random(n) < cfg.p_ignore
    if ignore.all():
        ignore[int(rng.integers(n))] = False
    return ignore


def random_symbol(rng: np.random.Generator, arity: int, name: str, data: LossData, cfg: AnnealConfig) -> Symbol:
    """A centre drawn from the data (an object or an ordered pair of distinct objects; half of the
    time an object that a primitive moved, before or after the move, or a pair of objects that a
    primitive involved, after it, since symbols should reflect what primitives change:
    :func:`proposal_points`) and random widths. Some dimensions are ignored (a width far beyond the
    data's spread; which ones: :func:`ignored_dimensions`): symbols such as ``ball`` (by size, at
    any position) or "in the same stack" (any height difference) say nothing about some
    dimensions, and random widths almost never find that. The widths of the other dimensions are
    then scaled so that the symbol holds for a random share of the data (0.5% to 30%, log-uniform;
    :func:`share_radius`).

    Without the scaling most proposals are never or almost always true (random widths over several
    dimensions rarely fit the data), and a search wastes its re-seeds on them.
    """
    unary, pairs, moved_u, moved_p = proposal_points(data)
    pts = unary if arity == 1 else pairs
    pool = pts if rng.random() >= cfg.p_moved else (moved_u if arity == 1 else moved_p)
    centre = pool[int(rng.integers(len(pool)))]
    scale = data.unary_scale if arity == 1 else data.pair_scale
    lo, hi = np.log(cfg.width_range)
    widths = scale * np.exp(rng.uniform(lo, hi, len(scale)))
    ignore = ignored_dimensions(rng, len(scale), cfg)
    widths[ignore] = IGNORE_WIDTH * scale[ignore]
    share = float(np.exp(rng.uniform(np.log(cfg.share_range[0]), np.log(cfg.share_range[1]))))
    used = ~ignore             # the share is set by the dimensions the symbol looks at
    dist = scaled_distances(pts, centre, widths, used)
    radius = share_radius(dist, share)
    if radius > 0:
        widths[used] = widths[used] * radius / np.sqrt(np.log(2.0))
    return Symbol(name, arity, np.array(centre, dtype=float), widths)


_COLUMNS: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def scaled_distances(pts: np.ndarray, centre: np.ndarray, widths: np.ndarray, used: np.ndarray) -> np.ndarray:
    """Each point's distance from ``centre`` in widths over the ``used`` dimensions: numpy's sum,
    or the compiled kernel that takes the same float steps (fewer than 8 dimensions; about 3x
    faster on the 62,000 pairs of 40 objects' 16 traces, by not copying the columns each time)."""
    if not compiled.AVAILABLE or used.sum() >= 8:
        return np.sqrt((((pts[:, used] - centre[used]) / widths[used]) ** 2).sum(-1))
    hit = _COLUMNS.get(id(pts))
    if hit is None or hit[0] is not pts:
        if len(_COLUMNS) >= 4:
            _COLUMNS.clear()
        hit = _COLUMNS[id(pts)] = (pts, np.ascontiguousarray(pts.T))
    return compiled.scaled_distances_columns(hit[1], np.asarray(centre, dtype=float), widths, used)


def share_radius(dist: np.ndarray, share: float) -> float:
    """A radius that holds about ``share`` of the points at distances ``dist``, midway between the
    nearest point left out and the farthest one kept.

    Midway, not at a point: features such as size take a few values only, so many points lie at
    exactly the same distance (every ball at distance 0 of a ball's size); a radius on a point
    would leave them on the boundary, and a radius of 0 would make a symbol true nowhere.
    """
    k = min(max(int(np.ceil(share * len(dist))) - 1, 0), len(dist) - 1)
    inner = float(np.partition(dist, k)[k])
    outer = dist[dist > inner]
    return (inner + float(outer.min())) / 2 if len(outer) else inner * 1.0001


def perturb(rng: np.random.Generator, s: Symbol, cfg: AnnealConfig) -> Symbol:
    n = len(s.centre)
    dims = rng.random(n) < max(0.5, 1.0 / n)
    if not dims.any():
        dims[int(rng.integers(n))] = True
    centre = s.centre + dims * rng.normal(0, cfg.step, n) * s.widths
    widths = s.widths * np.exp(dims * rng.normal(0, cfg.step, n))
    return Symbol(s.name, s.arity, centre, widths)
