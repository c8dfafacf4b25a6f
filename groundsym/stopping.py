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

A stop is never lost. Python runs a signal's handler in whatever Python code runs next, and an
exception raised in a ctypes callback, a ``__del__`` or a weakref callback is printed ("Exception
ignored in ...") and dropped (the Python docs, ``sys.unraisablehook``). llvmlite calls back into
Python while numba loads a kernel (``ExecutionEngine._raw_object_cache_notify``): a Ctrl-C early
in a short ``learn --workers 2`` was lost there in 3 of 30 runs, which then finished with status
0 and a complete model. While a command runs, :func:`install` puts in a hook that sends such a
dropped interrupt's signal again, so its handler raises it once more in the code that follows.
"""

from __future__ import annotations

import signal
import sys
import threading
from dataclasses import dataclass, field
from typing import Any, Callable, Union

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


@dataclass(eq=False)
class Installed:
    """What :func:`install` replaced: the handlers of the signals, and the unraisable hook."""

    handlers: dict[int, Handler] = field(default_factory=dict)
    hook: Callable | None = None


#: How long after an interrupt was dropped its signal is sent again: time for the code that
#: dropped it (the hook, the rest of the callback) to return, so the handler runs after it.
AGAIN_AFTER = 0.05


_installed: list[Installed] = []    # non-empty while a command installed here runs


def _send_again(signum: int) -> None:
    """Send ``signum`` to the main thread again, from another thread, a moment from now. Sent
    from the hook itself, the handler would raise at once, inside the hook, and Python would
    drop that too; if it lands in such code again, the hook sends it once more. A command that
    has finished by then (in-process: its handlers restored) is left alone."""
    main = threading.main_thread().ident

    def send() -> None:
        if _installed and main is not None:
            signal.pthread_kill(main, signum)

    timer = threading.Timer(AGAIN_AFTER, send)
    timer.daemon = True
    timer.start()


def install() -> Installed:
    """Raise :class:`Terminated` on SIGTERM and SIGHUP from now on, and never drop an interrupt
    (the module docstring says where Python would); returns what it replaced, for
    :func:`restore`. Signals ignored at the start are left ignored; outside the main thread
    (where Python cannot set handlers) nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        return Installed()
    handlers = {sig: signal.signal(sig, _raise) for sig in TERMINATING if signal.getsignal(sig) != signal.SIG_IGN}
    before = sys.unraisablehook

    def redeliver(unraisable: Any) -> None:
        """An interrupt Python would drop: its signal is sent again, and its handler raises it
        once more in the code that follows. Anything else goes to the hook before."""
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            _send_again(signal_of(unraisable.exc_value))
        else:
            before(unraisable)

    sys.unraisablehook = redeliver
    installed = Installed(handlers, before)
    _installed.append(installed)
    return installed


def restore(installed: Installed) -> None:
    """Put back the handlers and the unraisable hook :func:`install` replaced."""
    for sig, handler in installed.handlers.items():
        signal.signal(sig, signal.SIG_DFL if handler is None else handler)
    if installed.hook is not None:
        sys.unraisablehook = installed.hook
    if installed in _installed:
        _installed.remove(installed)


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


__all__ = ["TERMINATING", "Terminated", "Installed", "install", "restore", "signal_of", "exit_status", "word", "like"]
