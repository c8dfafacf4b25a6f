"""User-facing errors.

Anything the user can fix (a malformed file, an unknown name, a bad option) is raised as
:class:`UserError`. The CLI prints its message as one line and exits with status 2, without a
traceback. Programming errors stay ordinary exceptions.
"""

from __future__ import annotations


class UserError(Exception):
    """An error caused by user input; the message names the file, line or field."""

    exit_status = 2


def where(path: object, field: str | None = None) -> str:
    """Format a location prefix such as ``traces.json: traces[0].steps[3].features``."""
    return f"{path}: {field}" if field else f"{path}"


def interrupted(exc: BaseException) -> bool:
    """Is ``exc`` a Ctrl-C (or SIGTERM, SIGHUP: ``groundsym.stopping``)? See :func:`interrupt_in`."""
    return interrupt_in(exc) is not None


def interrupt_in(exc: BaseException | None) -> KeyboardInterrupt | None:
    """The KeyboardInterrupt ``exc`` is or was raised because of, else None. An error can be
    raised because one arrived inside compiled code: SIGINT's handler raises KeyboardInterrupt
    while a numba kernel runs, and the kernel's dispatcher then reports a SystemError ("returned a
    result with an exception set") or, while it converts the arguments, a TypeError ("can't
    unbox"), each with the KeyboardInterrupt as its cause or context."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        # ``raise ... from None`` says the error it was raised in is not its cause
        exc = exc.__cause__ or (None if exc.__suppress_context__ else exc.__context__)
    return None
