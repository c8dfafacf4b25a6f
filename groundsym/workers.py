"""Worker processes that a Ctrl-C can always stop: one pipe per worker, no shared locks.

Why not ``multiprocessing.Pool``: its ``terminate()`` waits for three helper threads and takes
queue locks that the workers share (an idle worker holds the task queue's read lock while it
waits for a task; a worker sending a result holds the result queue's write lock, and a worker
killed then never lets it go), so how soon it returns depends on what every process was doing
when the Ctrl-C came. Once, on a heavily loaded machine, an interrupted ``learn --workers 2`` did
not stop within 40 s of a SIGINT to its main process. Here each worker talks to the main
process over its own pipe, and stopping is SIGKILL then join, which waits on nothing a worker
could hold.

Workers ignore SIGINT: Ctrl-C reaches the whole process group, and only the main process acts on
it. SIGINT is held back while the workers are forked (a Ctrl-C landing in Python's fork handlers
was dropped, one in a half-started worker killed it); :func:`start` returns the signal mask to
restore, so the caller can let a held-back Ctrl-C in where it stops the workers.
"""

from __future__ import annotations

import signal
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Sequence


def _serve(conn: Connection, init: Callable[..., None], init_args: tuple,
           main_ends: Sequence[Connection] = ()) -> None:
    """A worker: ignore SIGINT, close the main process's pipe ends it inherited, initialise, then
    run ``(function, job)`` pairs until the pipe closes or brings None; each answer is
    ``(True, result)`` or ``(False, exception)``.

    The main process's ends are closed first because a forked worker holds copies of them: with
    its own copy of the other end open, the pipe never closes when the main process dies (``kill
    -9``, out of memory), and the worker would wait on it for ever."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})   # blocked by start() while forking
    for end in main_ends:
        end.close()
    init(*init_args)
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):       # the main process is gone
            return
        if task is None:
            return
        func, job = task
        try:
            answer: tuple[bool, Any] = (True, func(job))
        except Exception as exc:          # handed to the main process, which raises it
            answer = (False, exc)
        try:
            conn.send(answer)
        except OSError:                   # the main process is gone
            return
        except Exception as exc:          # e.g. an exception that does not pickle
            try:
                conn.send((False, RuntimeError(f"a worker's answer could not be sent: {exc!r}")))
            except OSError:
                return


class Workers:
    """``n`` forked worker processes, each initialised with ``init(*init_args)``."""

    def __init__(self, ctx: Any, n: int, init: Callable[..., None], init_args: tuple) -> None:
        self.procs: list[Any] = []
        self.conns: list[Connection] = []
        try:
            for _ in range(n):
                mine, theirs = ctx.Pipe()
                p = ctx.Process(target=_serve, args=(theirs, init, init_args, (mine, *self.conns)), daemon=True)
                p.start()
                theirs.close()
                self.procs.append(p)
                self.conns.append(mine)
        except BaseException:
            self.kill()
            raise

    def map(self, func: Callable[[Any], Any], jobs: Sequence[Any]) -> list[Any]:
        """``[func(job) for job in jobs]``, each job on whichever worker is free, in job order."""
        results: list[Any] = [None] * len(jobs)
        todo = list(range(len(jobs)))[::-1]
        busy: dict[Connection, int] = {}

        def hand_out(conn: Connection) -> None:
            if todo:
                i = todo.pop()
                conn.send((func, jobs[i]))
                busy[conn] = i

        for conn in self.conns:
            hand_out(conn)
        while busy:
            for conn in wait(list(busy)):
                try:
                    ok, value = conn.recv()
                except (EOFError, OSError):
                    raise RuntimeError("a worker process died (out of memory?)") from None
                if not ok:
                    raise value
                results[busy.pop(conn)] = value    # type: ignore[index]
                hand_out(conn)                     # type: ignore[arg-type]
        return results

    def kill(self) -> None:
        """Stop every worker now (SIGKILL: nothing it holds can keep the main process waiting)."""
        for p in self.procs:
            if p.exitcode is None:
                p.kill()
        for p in self.procs:
            p.join()
        self._close_pipes()

    def close(self) -> None:
        """Let the workers finish (they are idle between maps), or kill those that do not."""
        for conn in self.conns:
            try:
                conn.send(None)
            except OSError:
                pass
        for p in self.procs:
            p.join(timeout=5)
        self.kill()

    def _close_pipes(self) -> None:
        for conn in self.conns:
            conn.close()
        self.conns = []


def start(ctx: Any, n: int, init: Callable[..., None], init_args: tuple) -> tuple[Workers, Any]:
    """The workers, forked with SIGINT held back, and the signal mask to restore: the caller
    restores it inside the ``try`` whose handler kills the workers, so a Ctrl-C that came during
    the fork stops them like any other."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        return Workers(ctx, n, init, init_args), old
    except BaseException:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
        raise
