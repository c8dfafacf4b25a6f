"""Learned symbols in words a person understands, e.g.
``b1(X,Y): X above Y, dz between 3.1 and 6.9 cm; |dx| under 1.8 cm; |dy| under 2.0 cm``.

A symbol holds where ``sum(((y - c) / w)^2) < ln 2``: along each feature dimension alone (the others
at the centre) that is the interval ``c +- w sqrt(ln 2)``. Dimensions that do not decide the truth
on the data are left out: one at a time, the least deciding first, while the truth with their
terms replaced by constants still agrees with the symbol's on all but 0.1% of the points (the
intervals of the others then allow for those constants). (A dimension whose interval
alone covers the data may still decide jointly: a ball-like symbol whose size interval spans all
sizes, but whose ellipsoid with a low z keeps only the balls.) Lengths (features named x, y, z, size and
their differences) are printed in centimetres, since the simulations measure in metres.
"""

from __future__ import annotations

import math

import numpy as np

from .symbols import LN2, Symbol, SymbolSet

_LENGTHS = {"x", "y", "z", "size", "height", "width", "depth"}


def _is_length(name: str) -> bool:
    return name in _LENGTHS or (name.startswith("d") and name[1:] in _LENGTHS)


def _fmt(name: str, v: float) -> str:
    return f"{v * 100:.1f} cm" if _is_length(name) else f"{v:.3g}"


def _fmt_pair(name: str, lo: float, hi: float) -> str:
    if _is_length(name):
        return f"{lo * 100:.1f} and {hi * 100:.1f} cm"
    return f"{lo:.3g} and {hi:.3g}"


def deciding_dimensions(symbol: Symbol, data: np.ndarray, tol: float = 0.001) -> tuple[np.ndarray, float]:
    """Which dimensions decide the symbol's truth on ``data`` (N x n points), greedily, and the
    constant that the others add to the distance.

    A dimension is dropped when replacing its term of the distance by a constant (the one, among
    its quantiles over the data, that changes the fewest truths) changes the truth on at most
    ``tol`` of the points, with the dimensions dropped before replaced by theirs; the least deciding
    go first. A far centre with a wide width adds a near constant, which narrows the symbol along
    the other dimensions: the returned sum of the constants says how much.
    """
    terms = ((data - symbol.centre) / symbol.widths) ** 2          # (N, n)
    truth = terms.sum(1) < LN2
    options = np.quantile(terms, [0.0, 0.1, 0.25, 0.5, 0.75, 0.9], axis=0)   # (6, n)
    keep = np.ones(terms.shape[1], dtype=bool)
    const = np.zeros(terms.shape[1])
    while keep.any():
        base = terms[:, keep].sum(1) + const[~keep].sum()
        cols = np.flatnonzero(keep)
        # (N, kept, options): the truth with each kept dimension's term replaced by each constant
        replaced = (base[:, None, None] - terms[:, cols, None] + options[:, cols].T[None]) < LN2
        wrong = (replaced != truth[:, None, None]).mean(0)          # (kept, options)
        d, c = np.unravel_index(int(np.argmin(wrong)), wrong.shape)
        if wrong[d, c] > tol:
            break
        keep[cols[d]], const[cols[d]] = False, options[c, cols[d]]
    return keep, float(const[~keep].sum())


def intervals(symbol: Symbol, offset: float = 0.0) -> np.ndarray:
    """(n, 2): where the symbol can hold along each dimension alone, the others at the centre (or
    adding ``offset`` to the distance); a single point (lo = hi) where ``offset`` leaves no room."""
    r = symbol.widths * math.sqrt(max(LN2 - offset, 0.0))
    return np.column_stack([symbol.centre - r, symbol.centre + r])


def describe_symbol(symbol: Symbol, names: tuple[str, ...], data: np.ndarray | None = None,
                    share: float | None = None) -> str:
    """One line for one symbol; ``data`` (N x n points of its feature space) drops unconstraining dims."""
    keep, offset = (deciding_dimensions(symbol, data) if data is not None and len(data)
                    else (np.ones(len(names), bool), 0.0))
    iv = intervals(symbol, offset)
    parts = []
    lead = ""
    for d, name in enumerate(names):
        lo, hi = iv[d]
        if not keep[d]:
            continue
        if symbol.arity == 2 and name in ("dz", "dheight") and (lo > 0 or hi < 0):
            lead = "X above Y" if lo > 0 else "X below Y"
        if symbol.arity == 2 and name.startswith("d") and lo < 0 < hi:
            parts.append(f"|{name}| under {_fmt(name, max(-lo, hi))}" if abs(lo + hi) < 0.2 * (hi - lo)
                         else f"{name} between {_fmt_pair(name, lo, hi)}")
        else:
            parts.append(f"{name} between {_fmt_pair(name, lo, hi)}")
    args = "X" if symbol.arity == 1 else "X,Y"
    body = "; ".join(parts) if parts else "holds everywhere in the data"
    text = f"{symbol.name}({args}): " + (f"{lead}, " if lead else "") + body
    if share is not None:
        text += f"  [true for {100 * share:.1f}% of {'objects' if symbol.arity == 1 else 'ordered pairs'}]"
    return text


def describe(symbols: SymbolSet, features: np.ndarray | None = None, pairs: np.ndarray | None = None,
             shares: dict[str, float] | None = None) -> list[str]:
    """One line per symbol. ``features`` (S, M, n) and ``pairs`` (S, M, M, n') let unconstraining
    dimensions be left out."""
    lines = []
    unary_data = features.reshape(-1, features.shape[-1]) if features is not None else None
    pair_data = None
    if pairs is not None:
        m = pairs.shape[1]
        pair_data = pairs[:, ~np.eye(m, dtype=bool)].reshape(-1, pairs.shape[-1])
    for s in symbols.symbols:
        names = symbols.feature_names if s.arity == 1 else symbols.pair_names
        data = unary_data if s.arity == 1 else pair_data
        lines.append(describe_symbol(s, names, data, (shares or {}).get(s.name)))
    return lines
