"""Stopping a command: SIGTERM and SIGHUP end it the way Ctrl-C does.

Schedulers stop a job with SIGTERM (Slurm at its time limit, Kubernetes and systemd when a
service stops, CI runners on a timeout) and a closed terminal sends SIGHUP. By default either
kills the process where it stands: no cleanup runs, forked workers are left running (re-parented
to PID 1) and a half-built model stays in its hidden staging folder. Here both are raised in the
main thread as :class:`Terminated`, a ``KeyboardInterrupt``, so every path that already cleans up
after Ctrl-C runs for them too (workers killed by ``groundsym.workers.running``, the staging folder
removed by ``groundsym.modeldir.model_transaction``, the checkpoint kept). The CLI prints one line
and exits with 128 + the signal's number (143, 129), the status a shell reports for a process the
signal killed, so a scheduler sees what it expects (docs/reliability.md).

A signal the command was started with ignored (``nohup`` ignores SIGHUP) stays ignored.
"""

from __future__ import annotations

import signal
import threading
from typing import Callable, Union

#: The signals that stop a command as Ctrl-C does, besides SIGINT itself (SIGHUP is POSIX only).
TERMINATING = tuple(s for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)) if s)

#: The word the CLI's one line uses for each stopping signal.
WORDS = {signal.SIGINT: "interrupted", **{s: w for s, w in zip(TERMINATING, ("terminated", "hung up"))}}

Handler = Union[Callable, int, None]


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP arrived (``signum``); the message, if any, says what was kept."""

    def __init__(self, signum: int, detail: str = "") -> None:
        super().__init__(detail)
        self.signum = signum

    def __reduce__(self) -> tuple:   # pickles with its signal, not as KeyboardInterrupt's (detail,)
        return (type(self), (self.signum, str(self)))


def _raise(signum: int, frame: object) -> None:
    raise Terminated(signum)


def install() -> dict[int, Handler]:
    """Raise :class:`Terminated` on SIGTERM and SIGHUP from now on; returns the handlers replaced
    (for :func:`restore`). Signals ignored at the start are left ignored; outside the main thread
    (where Python cannot set handlers) nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    previous: dict[int, Handler] = {}
    for sig in TERMINATING:
        if signal.getsignal(sig) != signal.SIG_IGN:
            previous[sig] = signal.signal(sig, _raise)
    return previous


def restore(previous: dict[int, Handler]) -> None:
    """Put back the handlers :func:`install` replaced."""
    for sig, handler in previous.items():
        signal.signal(sig, signal.SIG_DFL if handler is None else handler)


def signal_of(stop: KeyboardInterrupt) -> int:
    """The signal behind an interrupt: SIGINT for Ctrl-C's KeyboardInterrupt."""
    return stop.signum if isinstance(stop, Terminated) else signal.SIGINT


def exit_status(stop: KeyboardInterrupt) -> int:
    """128 + the signal's number: 130 for Ctrl-C, 143 for SIGTERM, 129 for SIGHUP."""
    return 128 + int(signal_of(stop))


def word(stop: KeyboardInterrupt) -> str:
    """``interrupted``, ``terminated`` or ``hung up``: what the CLI's line says happened."""
    return WORDS.get(signal_of(stop), "stopped")


def like(stop: KeyboardInterrupt, detail: str) -> KeyboardInterrupt:
    """An interrupt of the same signal as ``stop`` that says ``detail`` (what the command kept)."""
    return Terminated(stop.signum, detail) if isinstance(stop, Terminated) else KeyboardInterrupt(detail)


__all__ = ["TERMINATING", "Terminated", "install", "restore", "signal_of", "exit_status", "word", "like"]
