"""Learned symbols in words a person understands, e.g.
``b1(X,Y): X above Y, dz between 3.1 and 6.9 cm; |dx| under 1.8 cm; |dy| under 2.0 cm``.

A symbol holds where ``sum(((y - c) / w)^2) < ln 2``: along each feature dimension alone (the others
at the centre) that is the interval ``c +- w sqrt(ln 2)``. Dimensions whose interval covers all the
data are left out (they do not constrain the symbol). Lengths (features named x, y, z, size and
their differences) are printed in centimetres, since the simulations measure in metres.
"""

from __future__ import annotations

import math

import numpy as np

from .symbols import Symbol, SymbolSet

_LENGTHS = {"x", "y", "z", "size", "height", "width", "depth"}


def _is_length(name: str) -> bool:
    return name in _LENGTHS or (name.startswith("d") and name[1:] in _LENGTHS)


def _fmt(name: str, v: float) -> str:
    return f"{v * 100:.1f} cm" if _is_length(name) else f"{v:.3g}"


def _fmt_pair(name: str, lo: float, hi: float) -> str:
    if _is_length(name):
        return f"{lo * 100:.1f} and {hi * 100:.1f} cm"
    return f"{lo:.3g} and {hi:.3g}"


def intervals(symbol: Symbol) -> np.ndarray:
    """(n, 2): where the symbol can hold along each dimension alone."""
    r = symbol.widths * math.sqrt(math.log(2.0))
    return np.column_stack([symbol.centre - r, symbol.centre + r])


def describe_symbol(symbol: Symbol, names: tuple[str, ...], data: np.ndarray | None = None,
                    share: float | None = None) -> str:
    """One line for one symbol; ``data`` (N x n points of its feature space) drops unconstraining dims."""
    iv = intervals(symbol)
    parts = []
    lead = ""
    for d, name in enumerate(names):
        lo, hi = iv[d]
        if data is not None and len(data):
            dlo, dhi = np.percentile(data[:, d], [0.5, 99.5])
            if lo <= dlo and hi >= dhi:
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
