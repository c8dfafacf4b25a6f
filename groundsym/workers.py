"""The one local parallel runner: forked worker processes that a Ctrl-C can always stop.

``learn`` (annealing rounds: :meth:`Workers.map`, results in job order) and ``evaluate``
(evaluation units: :meth:`Workers.as_completed`, each saved as it finishes) both run their work
here, through ``groundsym.executors.ProcessExecutor``; :func:`running` starts the workers and
stops them, the one place that does.

Why not ``multiprocessing.Pool``: its ``terminate()`` waits for three helper threads and takes
queue locks that the workers share (an idle worker holds the task queue's read lock while it
waits for a task; a worker sending a result holds the result queue's write lock, and a worker
killed then never lets it go), so how soon it returns depends on what every process was doing
when the Ctrl-C came. Once, on a heavily loaded machine, an interrupted ``learn --workers 2`` did
not stop within 40 s of a SIGINT to its main process. Here each worker talks to the main
process over its own pipe, and stopping is SIGKILL then join, which waits on nothing a worker
could hold.

Workers ignore SIGINT, SIGTERM and SIGHUP (:data:`STOP_SIGNALS`): Ctrl-C reaches the whole
process group, a scheduler's SIGTERM often every process of the job, and only the main process
acts on them (the CLI turns SIGTERM and SIGHUP into Ctrl-C's exception, ``groundsym.stopping``).
They are held back while the workers are forked (a Ctrl-C landing in Python's fork handlers was
dropped, one in a half-started worker killed it); :func:`running` lets them in once every worker
is up, inside the block whose exit kills them.

Why fork, for ``evaluate`` too (it used to spawn, through ``concurrent.futures``; the choice came
with its first commit, f65b63f, and no reason was recorded). What a driver holds when it forks was
checked: the main thread and the idle threads of OpenBLAS (numpy's and scipy's; OpenBLAS stops
and restarts them around a fork, and ``learn`` has forked with them since its workers existed);
numba's kernels, compiled without threads (no ``parallel=True``), which forked workers inherit
loaded instead of each loading them again; pybullet imported, and a physics client only if a unit
ran in the driver before (``DIRECT`` clients simulate in the calling thread, and a forked copy
steps on its own: units forked from a driver holding two clients, a threadpoolctl controller and
a drawn Agg figure equalled spawned units byte for byte); matplotlib only with the Agg backend,
after all units. Even a driver running Ray (23 threads) forked workers that finished their units.
Every output of ``evaluate --workers 2`` (tools/same_outputs.py, and a 3-run tower evaluation with
learned symbols and all four planners) stayed what the spawned pool wrote, less wall times, and
the same as ``--workers 1``. Units start sooner: a spawned worker imports everything and loads the
kernels again (once, on a shared 2-core machine, 3 units on 2 workers took 9.0 s forked, 11.9 s
spawned). Where fork does not exist the platform's default start method is used (:data:`CONTEXT`).
"""

from __future__ import annotations

import ctypes
import multiprocessing as mp
import os
import signal
import sys
from contextlib import contextmanager
from multiprocessing.connection import Connection, wait
from typing import Any, Callable, Iterator, Sequence

#: How workers start: forked where the platform can (the module docstring says why).
CONTEXT = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else mp.get_context()

#: The signals only the main process acts on: held back while the workers fork, ignored by them.
#: Ctrl-C, and SIGTERM and SIGHUP, which the CLI raises as Ctrl-C's kin (``groundsym.stopping``):
#: a scheduler or ``systemctl stop`` may send SIGTERM to every process of the job, and a worker
#: killed by it would look to the main process like one that crashed.
STOP_SIGNALS = frozenset({signal.SIGINT, *(getattr(signal, n) for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n))})

#: prctl(2)'s request for a signal on the parent's death (linux/prctl.h).
_PR_SET_PDEATHSIG = 1


def no_init() -> None:
    """The initialiser of workers that need no per-process state."""


def _die_with_parent(parent: int | None) -> None:
    """On Linux, have the kernel SIGKILL this worker when the process that started it (``parent``)
    dies, however it dies.

    Workers ignore SIGTERM (the main process acts on it), so without this a main process killed
    outright (``kill -9``, out of memory, or a script that drives groundsym in-process and dies on
    SIGTERM's default action) left its workers computing their current job, which can be a whole
    annealing round of minutes, before they noticed the closed pipe. Elsewhere the closed pipe is
    the only sign, as before."""
    if parent is None or not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):     # no prctl here: the closed pipe still stops the worker
        return
    if os.getppid() != parent:            # the main process died before the request took hold
        os._exit(1)


def _serve(conn: Connection, init: Callable[..., None], init_args: tuple,
           main_ends: Sequence[Connection] = (), parent: int | None = None) -> None:
    """A worker: ignore the stopping signals, close the main process's pipe ends it inherited, initialise, then
    run ``(function, job)`` pairs until the pipe closes or brings None; each answer is
    ``(True, result)`` or ``(False, exception)``.

    The main process's ends are closed first because a forked worker holds copies of them: with
    its own copy of the other end open, the pipe never closes when the main process dies (``kill
    -9``, out of memory), and the worker would wait on it for ever. A closed pipe is only seen
    between jobs, though, so the worker also asks to die with the main process
    (:func:`_die_with_parent`): a job can be a whole annealing round."""
    _die_with_parent(parent)
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)   # blocked by running() while forking
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
    """``n`` worker processes, each initialised with ``init(*init_args)``, started from ``ctx``.

    Use them through :func:`running`, which holds Ctrl-C back while they start and kills them
    when the block it guards fails."""

    def __init__(self, n: int, init: Callable[..., None] = no_init, init_args: tuple = (), *,
                 ctx: Any = CONTEXT) -> None:
        self.procs: list[Any] = []
        self.conns: list[Connection] = []
        try:
            for _ in range(n):
                mine, theirs = ctx.Pipe()
                p = ctx.Process(target=_serve, args=(theirs, init, init_args, (mine, *self.conns), os.getpid()),
                                daemon=True)
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
        for i, value in self._answers(func, jobs):
            results[i] = value
        return results

    def as_completed(self, func: Callable[[Any], Any], jobs: Sequence[Any]) -> Iterator[Any]:
        """``func(job)`` for every job, each on whichever worker is free, yielded as each finishes."""
        for _, value in self._answers(func, jobs):
            yield value

    def _answers(self, func: Callable[[Any], Any], jobs: Sequence[Any]) -> Iterator[tuple[int, Any]]:
        """``(index, func(jobs[index]))`` as each job finishes; a worker's error is raised here."""
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
                i = busy.pop(conn)                 # type: ignore[arg-type]
                hand_out(conn)                     # type: ignore[arg-type]
                yield i, value

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


@contextmanager
def running(n: int, init: Callable[..., None] = no_init, init_args: tuple = (), *,
            ctx: Any = CONTEXT) -> Iterator[Workers]:
    """``n`` workers for the block: started with :data:`STOP_SIGNALS` held back, which are let in
    once every worker is up; killed at once when the block raises (Ctrl-C, an error, the consumer
    of :meth:`Workers.as_completed` going away), closed when it ends.

    The one place where workers start and stop. SIGTERM and SIGHUP stop them as Ctrl-C does
    because the CLI raises them as a KeyboardInterrupt (``groundsym.stopping``), which the block
    sees like any other."""
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        workers = Workers(n, init, init_args, ctx=ctx)
    except BaseException:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        raise
    try:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)    # a Ctrl-C held back while forking arrives here
        yield workers
    except BaseException:       # Ctrl-C or an error: stop the workers now
        workers.kill()
        raise
    workers.close()


def default_workers() -> int:
    """The cores this process may run on: ``learn``'s default worker count."""
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


__all__ = ["CONTEXT", "STOP_SIGNALS", "Workers", "running", "no_init", "default_workers"]
