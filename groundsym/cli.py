"""The ``groundsym`` command.

Each subcommand is one module in :mod:`groundsym.commands` that defines ``NAME``, ``HELP``,
``add_arguments(parser)`` and ``run(args) -> int``; this file only finds and dispatches them, so a
new command is a new file. User errors (:class:`~groundsym.errors.UserError`) print one line and exit
with status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import signal
import sys
from types import ModuleType
from typing import Callable

from . import __version__
from . import commands as _commands_pkg
from . import stopping
from .errors import UserError, interrupt_in
from .workers import STOP_SIGNALS


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse's own status for usage errors)
        self.exit(2, f"{self.prog}: error: {message}\n")


def command_modules() -> list[ModuleType]:
    mods = []
    for info in sorted(pkgutil.iter_modules(_commands_pkg.__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        mods.append(importlib.import_module(f"{_commands_pkg.__name__}.{info.name}"))
    return sorted(mods, key=lambda m: getattr(m, "ORDER", 50))


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="groundsym", description="Learn grounded relational symbols from continuous "
                     "robot data and turn them into planning domains.")
    parser.add_argument("--version", action="version", version=f"groundsym {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for mod in command_modules():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=getattr(mod, "DESCRIPTION", mod.HELP))
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def _build_parser_uninterrupted() -> argparse.ArgumentParser:
    """The parser, with Ctrl-C, SIGTERM and SIGHUP held back while it imports every command (numpy,
    scipy, pybullet: a second or two). A SIGINT inside some extension's import code was swallowed
    (the command then ran to the end) or made Python kill itself at exit; held back, it arrives
    right after, here. The threads those imports start (OpenBLAS's) inherit the mask, so a signal
    sent to the process is never handed to one of them meanwhile."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        return build_parser()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def main(argv: list[str] | None = None) -> int:
    """Run one command. SIGTERM and SIGHUP stop it as Ctrl-C does (``groundsym.stopping``); run as
    the program (``argv`` None), every stopping signal is ignored once the command is over."""
    previous = stopping.install()
    try:
        return _main(argv, lambda: _settle(previous, argv is None))
    finally:
        _settle(previous, argv is None)


def _settle(previous: stopping.Installed, as_program: bool) -> None:
    """The command is over. Run as the program, Python would put back the default SIGINT action
    while it shuts down, so a Ctrl-C now would kill the exit silently with status 130, after the
    work was done and written (seen once in 20 interrupted runs of learn): it and the other
    stopping signals are ignored from here. Called in-process, the handlers before are restored."""
    if as_program:
        for sig in STOP_SIGNALS:
            signal.signal(sig, signal.SIG_IGN)
    else:
        stopping.restore(previous)


def _main(argv: list[str] | None, finished: Callable[[], None]) -> int:
    try:
        parser = _build_parser_uninterrupted()
        args = parser.parse_args(argv)
    except KeyboardInterrupt as stop:
        print(f"groundsym: {stopping.word(stop)}", file=sys.stderr)
        return stopping.exit_status(stop)
    if not getattr(args, "_run", None):
        parser.print_help(sys.stderr)
        return 2
    args.argv = list(sys.argv if argv is None else ["groundsym", *argv])
    try:
        status = int(args._run(args) or 0)
        finished()            # inside the try: a signal just before this still stops the command
        return status
    except UserError as exc:
        print(f"groundsym {args.command}: error: {exc}", file=sys.stderr)
        return exc.exit_status
    except BrokenPipeError:
        return 1
    except (KeyboardInterrupt, Exception) as exc:   # a command may say what was kept (a checkpoint);
        stop = interrupt_in(exc)                     # a Ctrl-C inside a compiled kernel comes wrapped
        if stop is None:
            raise
        detail = f"; {exc}" if isinstance(exc, KeyboardInterrupt) and str(exc) else ""
        fresh = "\r\x1b[K" if sys.stderr.isatty() else ""   # over a progress bar's unfinished line
        print(f"{fresh}groundsym {args.command}: {stopping.word(stop)}{detail}", file=sys.stderr)
        return stopping.exit_status(stop)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
