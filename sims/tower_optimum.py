"""The best episode value of the tower cell in the deterministic world, by exhaustive search.

With the motor noise off, every grasp of a free cube succeeds and every cube let go over the top of
a tower stays there (the physics tests check this). The cell then behaves like blocks world with
sizes: a state is a set of towers (bottom to top) and the content of the hand; a cube's bottom is
as high as the sizes below it add up to; the reward is the mean of those heights over the cubes, a
held cube counting 0. This module searches over every sequence of ``episode_length`` primitives
(grasp the top of a tower, put the held cube on a tower or on the table, or a primitive that
changes nothing) by dynamic programming over states, which are identified up to renaming equal
cubes, and returns the plan of the highest discounted value ``sum_t gamma^(t-1) r_t``.

Balls do not count in the reward and nothing can stand on a ball, so they play no part in the
optimum. Cans (as tall as wide) stack and count as cubes of their size do.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

Towers = tuple[tuple[float, ...], ...]     # cube sizes per tower, bottom first, sorted canonically


@dataclass(frozen=True)
class Plan:
    """An optimal plan in size terms: ``("grasp", tower)`` / ``("put", tower)`` / ``("table",)``."""

    value: float
    moves: tuple[tuple, ...]
    rewards: tuple[float, ...]

    def __str__(self) -> str:
        return f"V* = {self.value:.6f} via {len(self.moves)} moves"


def _canon(towers: list[tuple[float, ...]]) -> Towers:
    return tuple(sorted(t for t in towers if t))


def _reward(towers: Towers, n_cubes: int) -> float:
    total = 0.0
    for t in towers:
        h = 0.0
        for size in t:
            total += h
            h += size
    return total / n_cubes


def _successors(towers: Towers, hand: float | None) -> list[tuple[tuple, Towers, float | None]]:
    """Every distinct outcome of one primitive from (towers, hand), with a label for the move."""
    out: list[tuple[tuple, Towers, float | None]] = [(("noop",), towers, hand)]
    seen = set()
    for k, t in enumerate(towers):
        if t in seen:
            continue
        seen.add(t)
        rest = list(towers[:k] + towers[k + 1:])
        if hand is None:
            out.append((("grasp", t), _canon(rest + [t[:-1]]), t[-1]))
        else:
            out.append((("put", t), _canon(rest + [t + (hand,)]), None))
    if hand is not None:
        out.append((("table",), _canon(list(towers) + [(hand,)]), None))
    return out


def best_plan(options: dict[str, Any], gamma: float, length: int) -> Plan:
    """Exhaustive dynamic programming over the size-labelled tower states (see module doc)."""
    n_cubes = options["cubes"] + options.get("cans", 0)          # cans stack and count as cubes do
    if n_cubes == 0:
        return Plan(0.0, (), (0.0,) * length)
    sizes = ([options["big_size"]] * options["big"] + [options["small_size"]] * (options["cubes"] - options["big"])
             + [options.get("can_size", 0.0)] * options.get("cans", 0))
    start = _canon([(s,) for s in sizes])

    @lru_cache(maxsize=None)
    def value(towers: Towers, hand: float | None, left: int) -> float:
        if left == 0:
            return 0.0
        best = float("-inf")
        for _, nxt, nhand in _successors(towers, hand):
            best = max(best, _reward(nxt, n_cubes) + gamma * value(nxt, nhand, left - 1))
        return best

    moves, rewards = [], []
    towers, hand = start, None
    for left in range(length, 0, -1):
        target = value(towers, hand, left)
        for move, nxt, nhand in _successors(towers, hand):
            r = _reward(nxt, n_cubes)
            if abs(r + gamma * value(nxt, nhand, left - 1) - target) < 1e-12:
                moves.append(move)
                rewards.append(r)
                towers, hand = nxt, nhand
                break
    return Plan(value(start, None, length), tuple(moves), tuple(rewards))


def ground_plan(plan: Plan, sizes: dict[str, float]) -> list[tuple[str, str]]:
    """The plan as primitives on named cubes (``sizes``: cube id -> edge), from all on the table.

    A move that changes nothing becomes a primitive that only moves the arm: ``openHandOver`` with
    an empty hand, ``closeHandAround`` of another cube with a full one.
    """
    towers = [[obj] for obj in sorted(sizes)]
    hand: str | None = None
    out: list[tuple[str, str]] = []

    def find(shape: tuple[float, ...]) -> list[str]:
        return next(t for t in towers if tuple(sizes[o] for o in t) == shape)

    for move in plan.moves:
        if move[0] == "grasp":
            tower = find(move[1])
            hand = tower.pop()
            out.append(("closeHandAround", hand))
        elif move[0] == "put":
            tower = find(move[1])
            out.append(("openHandOver", tower[-1]))
            tower.append(hand)
            hand = None
        elif move[0] == "table":
            out.append(("openHandOver", hand))
            towers.append([hand])
            hand = None
        else:
            other = next(t[-1] for t in towers if t)
            out.append(("closeHandAround", other) if hand else ("openHandOver", other))
        towers = [t for t in towers if t]
    return out
