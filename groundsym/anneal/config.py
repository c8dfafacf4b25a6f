"""The search's settings, and the shape of a candidate: one symbol per named slot."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from ..symbols import Symbol

LOOKS = ("independent", "subset")   # how a new symbol chooses the dimensions it ignores


@dataclass(frozen=True)
class AnnealConfig:
    """Search settings; ``evals`` is the total budget over all restarts (the paper used ~1e5)."""

    n_unary: int = 1
    n_binary: int = 1
    evals: int = 100_000
    restarts: int = 4
    population: int = 4
    t_start: float = 0.05        # initial temperature, nats per transition
    t_end: float = 0.0005        # final temperature, nats per transition
    p_reseed: float = 0.3        # 0.1 found inhand+on in 2 of 5 grounding seeds at 2e4 evals, 0.3 in 5
    p_swap: float = 0.1
    step: float = 0.3            # perturbation: centre moves ~ step x width, log-widths ~ step
    width_range: tuple[float, float] = (0.05, 2.0)  # shape of new widths, x the data's spread
    share_range: tuple[float, float] = (0.005, 0.3)  # a new symbol holds for this share of the data
    p_moved: float = 0.5         # share of new centres drawn from objects a primitive moved (pairs: involved)
    p_ignore: float = 0.25       # a new symbol ignores each feature dimension with this probability
    looks: str = "independent"   # or "subset": how many dimensions a new symbol looks at is uniform
    chunk: int = 500             # evaluations per restart between checkpoints
    hop_steps: int = 0           # >0: late re-seeds are basin hops, the new symbol settled this many steps
    hop_after: float = 0.5       # share of a restart's budget after which re-seeds hop (with hop_steps > 0)
    ladder: float = 3.0          # candidate k runs at ladder**k x the temperature (replica exchange;
                                 # 1: one temperature): at 88e004a cubes and balls 2 -> 5 of 10, the tower
                                 # 7 -> 8 (later runs: docs/symbols-results.md)
    p_exchange: float = 0.1      # with ladder > 1: per move, chance to offer neighbours' states a trade

    def __post_init__(self) -> None:
        if self.n_unary < 0 or self.n_binary < 0 or self.n_unary + self.n_binary == 0:
            raise ValueError("need at least one symbol to learn")
        if self.restarts < 1 or self.population < 1 or self.evals < self.restarts:
            raise ValueError("need at least one restart, one candidate and one evaluation per restart")
        if not 0 <= self.p_ignore < 1:
            raise ValueError(f"p_ignore must be in [0, 1), got {self.p_ignore}")
        if self.looks not in LOOKS:
            raise ValueError(f"looks must be one of {', '.join(LOOKS)}, got {self.looks!r}")
        for name in ("p_reseed", "p_swap", "p_moved"):
            if not 0 <= getattr(self, name) <= 1:
                raise ValueError(f"{name} must be in [0, 1], got {getattr(self, name)}")
        for name in ("t_start", "t_end", "step"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"{name} must be a finite number above 0, got {getattr(self, name)}")
        for name in ("width_range", "share_range"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                raise ValueError(f"{name} must be two finite numbers 0 < lo <= hi, got {lo},{hi}")
        if self.share_range[1] > 1:
            raise ValueError(f"share_range is a share of the data, at most 1, got {self.share_range[1]}")
        if self.chunk < 1:
            raise ValueError(f"chunk must be at least 1, got {self.chunk}")
        if self.hop_steps < 0:
            raise ValueError(f"hop_steps must be 0 (no hops) or more, got {self.hop_steps}")
        if not 0 <= self.hop_after <= 1:
            raise ValueError(f"hop_after must be in [0, 1], got {self.hop_after}")
        if not (math.isfinite(self.ladder) and self.ladder >= 1):
            raise ValueError(f"ladder must be a finite number of at least 1, got {self.ladder}")
        if not 0 <= self.p_exchange <= 1:
            raise ValueError(f"p_exchange must be in [0, 1], got {self.p_exchange}")

    def budget(self, restart: int) -> int:
        base, extra = divmod(self.evals, self.restarts)
        return base + (1 if restart < extra else 0)

    def to_doc(self) -> dict[str, Any]:
        d = asdict(self)
        d["width_range"] = list(self.width_range)
        d["share_range"] = list(self.share_range)
        return d


Candidate = list[Symbol]


def slot_name(arity: int, k: int) -> str:
    """The name of the k-th symbol of an arity: ``u1``, ``u2``, ... or ``b1``, ...."""
    return f"{'u' if arity == 1 else 'b'}{k + 1}"


def slots(cfg: AnnealConfig) -> list[tuple[int, str]]:
    """(arity, name) of each symbol a candidate holds."""
    return [(1, slot_name(1, k)) for k in range(cfg.n_unary)] + [(2, slot_name(2, k)) for k in range(cfg.n_binary)]
