"""Where independent pieces of work run: local worker processes (the default) or a Ray cluster.

The numbers never depend on where work runs: every evaluation unit and every annealing restart
draws its random numbers from its own seed and is a pure function of its arguments. So the
executor is a deployment choice, never part of an evaluation's fingerprint, and a results folder
started on one executor can be finished on another.

Work is shipped as ``fn(*job)`` with module-level functions, and results come back to the driver
as values: a task never writes into the results folder (on a cluster it runs on another machine),
the driver alone writes, atomically. A Ray task whose worker process dies is run again by Ray
(``max_retries``); since a task only returns a value, a retried task is neither lost nor counted
twice.

``ray`` is an optional dependency (``pip install 'groundsym[ray]'``), imported only when asked for.
"""

from __future__ import annotations

import logging
import os
import shutil
import socket
import tempfile
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Sequence

from .errors import UserError
from .workers import running

EXECUTORS = ("processes", "ray")
MAX_RETRIES = 3          # runs of a Ray task whose worker process died, beyond the first
CONNECT_TIMEOUT = 5.0    # seconds to reach a cluster's address before it counts as unreachable
SHIPPED_PACKAGES = ("groundsym", "sims", "planners")   # the project's code, sent to a cluster's workers

Job = Sequence[Any]
Mapper = Callable[[Callable[[Any], Any], list], list]


class ProcessExecutor:
    """``workers`` local worker processes (``groundsym.workers``: forked, stopped at once by
    Ctrl-C), or the calling process for one."""

    def __init__(self, workers: int = 1) -> None:
        self.workers = max(1, int(workers))
        self.description = f"{self.workers} worker process(es)" if self.workers > 1 else "this process"

    @property
    def in_process(self) -> bool:
        """Does every job run in the calling process (nothing to share with workers)?"""
        return self.workers <= 1

    def as_completed(self, fn: Callable[..., Any], jobs: Iterable[Job]) -> Iterator[Any]:
        """``fn(*job)`` for every job, yielded as each finishes (any order)."""
        jobs = list(jobs)
        if self.in_process or len(jobs) <= 1:
            for job in jobs:
                yield fn(*job)
            return
        with running(min(self.workers, len(jobs))) as pool:
            yield from pool.as_completed(_call, [(fn, job) for job in jobs])

    @contextmanager
    def mapper(self, init: Callable[..., None], initargs: tuple) -> Iterator[Mapper]:
        """``map(fn, jobs)`` for the block, in the jobs' order: on ``workers`` processes, each
        initialised once with ``init(*initargs)``, or in this process, initialised here."""
        if self.in_process:
            init(*initargs)
            yield lambda fn, jobs: [fn(job) for job in jobs]
            return
        with running(self.workers, init, initargs) as pool:
            yield pool.map

    def close(self) -> None:
        pass

    def __enter__(self) -> "ProcessExecutor":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _call(task: tuple[Callable[..., Any], Job]) -> Any:
    """A worker's job for :meth:`ProcessExecutor.as_completed`: ``fn(*job)``."""
    fn, job = task
    return fn(*job)


class RayExecutor:
    """Tasks on a Ray cluster: the one at ``address``, or a private local one with ``cpus`` CPUs.

    A local instance lives in a temporary directory, without the dashboard, and is shut down (and
    its directory removed) on :meth:`close`. A Ray instance this process already runs (a test or a
    notebook that called ``ray.init``) is used as it is and left running.
    """

    def __init__(self, address: str | None = None, cpus: int | None = None, *,
                 ship_code: bool | None = None, max_retries: int = MAX_RETRIES) -> None:
        self.ray = import_ray()
        self.max_retries = max_retries
        self._temp_dir: str | None = None
        self._owned = False
        if self.ray.is_initialized():
            where = "the running Ray instance"
        elif address:
            check_reachable(address)
            where = f"the Ray cluster at {address}"
            self._init(address=address, runtime_env=code_runtime_env() if ship_code in (None, True) else None)
        else:
            self._temp_dir = tempfile.mkdtemp(prefix="groundsym-ray-")
            where = "a local Ray instance"
            # worker_niceness: Ray runs its workers 15 steps nicer than the command by default;
            # like the process pool's, they run at the command's priority (on a shared machine
            # they would otherwise get almost no CPU while other work runs)
            self._init(num_cpus=max(1, int(cpus or os.cpu_count() or 1)), _temp_dir=self._temp_dir,
                       runtime_env=code_runtime_env() if ship_code else None,
                       _system_config={"worker_niceness": 0})
        cpus_now = int(self.ray.cluster_resources().get("CPU", 0))
        nodes = sum(1 for n in self.ray.nodes() if n.get("Alive"))
        self.description = f"{where} ({cpus_now} CPU(s) on {nodes} node(s))"

    def _init(self, **kwargs: Any) -> None:
        kwargs = {k: v for k, v in kwargs.items() if v is not None}
        try:
            self.ray.init(include_dashboard=False, log_to_driver=False, logging_level=logging.ERROR, **kwargs)
        except Exception as exc:     # Ray raises many kinds here; all of them mean "fix the address/setup"
            self._remove_temp_dir()
            raise UserError(f"--ray-address {kwargs.get('address', '(none: local Ray)')}: cannot start or join "
                            f"Ray ({_reason(exc)})") from None
        self._owned = True

    def as_completed(self, fn: Callable[..., Any], jobs: Iterable[Job]) -> Iterator[Any]:
        """Every job as a Ray task (retried if its worker dies), yielded as each finishes."""
        remote = self.ray.remote(max_retries=self.max_retries)(fn)
        pending = [remote.remote(*job) for job in jobs]
        try:
            while pending:
                ready, pending = self.ray.wait(pending, num_returns=1)
                yield self._get(ready[0])
        finally:
            for ref in pending:        # an interrupted driver: nothing left running on the cluster
                self.ray.cancel(ref, force=True)

    in_process = False

    @contextmanager
    def mapper(self, init: Callable[..., None], initargs: tuple) -> Iterator[Mapper]:
        """``map(fn, jobs)`` as Ray tasks for the block, in the jobs' order; each worker process
        runs ``init(*initargs)`` once before its first job (``initargs`` go to the object store once)."""
        ref = self.ray.put(initargs)
        key = uuid.uuid4().hex
        remote = self.ray.remote(max_retries=self.max_retries)(_call_initialised)

        def run(fn: Callable[[Any], Any], jobs: list) -> list:
            refs = [remote.remote(key, init, ref, fn, job) for job in jobs]
            try:
                return [self._get(r) for r in refs]
            except BaseException:
                for r in refs:
                    self.ray.cancel(r, force=True)
                raise
        yield run

    def _get(self, ref: Any) -> Any:
        """The task's value; a user error raised inside a task is raised here as itself."""
        try:
            return self.ray.get(ref)
        except self.ray.exceptions.RayTaskError as exc:
            if isinstance(exc.cause, UserError):
                raise UserError(str(exc.cause)) from None
            raise

    def close(self) -> None:
        if self._owned and self.ray.is_initialized():
            self.ray.shutdown()
        self._owned = False
        self._remove_temp_dir()

    def _remove_temp_dir(self) -> None:
        if self._temp_dir:
            shutil.rmtree(self._temp_dir, ignore_errors=True)
            self._temp_dir = None

    def __enter__(self) -> "RayExecutor":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _reason(exc: BaseException) -> str:
    """One line for a failed ``ray.init``; a missing token (Ray's default on new clusters) named."""
    chain, e = [], exc
    while e is not None and len(chain) < 10:
        chain.append(e)
        e = e.__cause__ or e.__context__
    if any("AuthToken" in str(e) or type(e).__name__ == "AuthenticationError" for e in chain):
        return ("the cluster asks for its authentication token: set RAY_AUTH_MODE=token and RAY_AUTH_TOKEN "
                "(or ~/.ray/auth_token) as on the cluster, docs/scale.md")
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


_INITIALISED: dict[str, str] = {}


def _call_initialised(key: str, init: Callable[..., None], initargs: tuple, fn: Callable[[Any], Any],
                      job: Any) -> Any:
    """A Ray task: ``fn(job)`` after ``init(*initargs)``, run once per worker process and key."""
    if _INITIALISED.get("key") != key:
        init(*initargs)
        _INITIALISED["key"] = key
    return fn(job)


def import_ray() -> Any:
    """The ``ray`` module, or one line saying how to install it."""
    try:
        import ray      # optional, and seconds to import: only when asked for
    except ImportError:
        raise UserError("--executor ray: Ray is not installed (pip install 'groundsym[ray]')") from None
    return ray


def check_reachable(address: str) -> None:
    """Fail in seconds, in one line, on an address nothing listens at (Ray itself would keep
    retrying for minutes). ``auto`` (the cluster this machine belongs to) is left to Ray."""
    if address == "auto":
        return
    hostport = address.split("://", 1)[1] if "://" in address else address
    host, sep, port = hostport.rpartition(":")
    if not sep or not host or not port.isdigit():
        if "://" in address and port and not sep:       # ray://host: the client port's default
            host, port = port, "10001"
        else:
            raise UserError(f"--ray-address {address}: expected HOST:PORT (e.g. 10.0.0.5:6379), "
                            "ray://HOST:PORT or auto")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT):
            pass
    except OSError as exc:
        raise UserError(f"--ray-address {address}: unreachable ({exc.strerror or exc}); is the cluster "
                        "running (ray start --head) and the port open?") from None


def code_runtime_env() -> dict[str, Any]:
    """Ray's ``runtime_env`` that sends this checkout's packages to every worker, so a cluster runs
    the driver's exact code (its other dependencies must be installed on the nodes)."""
    root = Path(__file__).resolve().parent.parent      # the checkout holding groundsym/
    mods = [str(root / name) for name in SHIPPED_PACKAGES if (root / name / "__init__.py").exists()]
    return {"py_modules": mods, "excludes": ["__pycache__", "*.pyc"]}


def check_executor_options(name: str, address: str | None) -> None:
    """``--executor``/``--ray-address`` checked before any work: Ray installed, the address reachable."""
    if name not in EXECUTORS:
        raise UserError(f"--executor {name}: unknown (choose from {', '.join(EXECUTORS)})")
    if name == "processes" and address:
        raise UserError("--ray-address: only with --executor ray")
    if name == "ray":
        import_ray()
        if address:
            check_reachable(address)


def make_executor(name: str, *, workers: int = 1, address: str | None = None) -> ProcessExecutor | RayExecutor:
    """The executor ``--executor NAME`` asks for; ``--ray-address`` only goes with ``ray``."""
    check_executor_options(name, None if name == "ray" else address)
    if name == "processes":
        return ProcessExecutor(workers)
    return RayExecutor(address, cpus=workers)


def add_executor_args(p: Any, workers_help: str) -> None:
    """``--executor``/``--ray-address`` for a command that also has ``--workers``."""
    p.add_argument("--executor", choices=EXECUTORS, default="processes",
                   help="where the work runs: local worker processes (default) or Ray tasks; the results "
                        "do not depend on it (docs/scale.md). " + workers_help)
    p.add_argument("--ray-address", default=None, metavar="HOST:PORT",
                   help="with --executor ray: join this running cluster (HOST:PORT, ray://HOST:PORT or auto) "
                        "instead of starting Ray on this machine")


__all__ = ["EXECUTORS", "ProcessExecutor", "RayExecutor", "make_executor", "add_executor_args",
           "check_executor_options",
           "check_reachable", "code_runtime_env", "import_ray"]
