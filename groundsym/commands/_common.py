"""Argument helpers shared by several subcommands."""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

from ..errors import UserError
from ..fileio import output_target
from ..limits import MAX_SEED
from ..options import split_key_values


class Count:
    """argparse ``type=`` for a count or size: a whole number from ``lo`` to ``hi`` (``unit`` names
    what is counted in the refusal: ``argument --steps: at most 10000 primitives, got 10000000``).
    Every count option has one, so an absurd value is one line, exit 2, before any work; the
    bounds and why each is where it is: :mod:`groundsym.limits`, docs/reliability.md."""

    def __init__(self, lo: int, hi: int, unit: str) -> None:
        self.lo, self.hi, self.unit = lo, hi, unit

    def __call__(self, text: str) -> int:
        v = (positive_int if self.lo >= 1 else nonneg_int)(text)
        if v > self.hi:
            raise argparse.ArgumentTypeError(f"at most {self.hi}{' ' * bool(self.unit)}{self.unit}, got {v}")
        return v

    def __repr__(self) -> str:           # argparse names the type in some messages
        return f"Count({self.lo}, {self.hi}, {self.unit!r})"


SEED = Count(0, MAX_SEED, "")


def positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {v}")
    return v


def nonneg_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"must be at least 0, got {v}")
    return v


def add_sim_args(p: argparse.ArgumentParser, required: bool = True) -> None:
    p.add_argument("--sim", required=required, help="simulation by name (tower, bowling, or a plug-in)")
    p.add_argument("--sim-opt", action="append", default=[], metavar="KEY=VALUE",
                   help="simulation option, repeatable (see docs/cli.md)")


def sim_options(args: argparse.Namespace) -> dict[str, str]:
    return split_key_values(args.sim_opt, "--sim-opt")


def output_path(text: str) -> Path:
    """argparse ``type=`` for an output file: a directory, FIFO or device is refused as a usage error
    (exit 2) before any work; a symbolic link is written through (fileio.output_target)."""
    try:
        output_target(text)
    except UserError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return Path(text)


def writable_output(text: str | Path) -> Path:
    """The path, once a file is known to be writable there, so a typo fails before minutes of work."""
    path = Path(text)
    target = output_target(path)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=target.parent):
            pass
    except OSError as exc:
        raise UserError(f"{path}: cannot write ({exc.strerror or exc})") from None
    if target.exists() and not os.access(target, os.W_OK):
        raise UserError(f"{path}: cannot write (the file is read-only)")
    return path
