"""Staging folders that name their owner, so the next writer can tell a leftover from work in progress.

``learn -o M`` builds the new model in a hidden sibling folder and swaps it in
(``groundsym.modeldir.model_transaction``); Ctrl-C, SIGTERM and errors remove that folder, but a
hard kill (SIGKILL, the out-of-memory killer, a power cut) cannot. Each folder's name therefore
records who made it: ``.M.new-MACHINE-PID-START-XXXXXXXX``, where MACHINE is a short hash of the
host name and the boot (``/proc/sys/kernel/random/boot_id``), PID the writer's process id and
START its start time (``/proc/PID/stat``, field 22, in clock ticks since boot). The next writer of
``M`` removes a folder of this machine and boot whose process has ended, or whose PID now belongs
to a process started at another time (the PID was reused). A folder of a live writer is never
touched; nor is one whose owner cannot be judged here (made on another machine sharing the
folder, before a reboot, or by an older version, whose names record no owner): those are left for
the user to remove (docs/reliability.md).
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import socket
import tempfile
from functools import lru_cache
from pathlib import Path

_OWNED = re.compile(r"(?P<machine>[0-9a-f]{8})-(?P<pid>\d+)-(?P<start>\d+)-[A-Za-z0-9_]+")


@lru_cache(maxsize=1)
def machine() -> str:
    """This host and boot, hashed to eight hex digits: a PID means nothing beyond them."""
    try:
        boot = Path("/proc/sys/kernel/random/boot_id").read_text().strip()
    except OSError:
        boot = ""
    return hashlib.sha256(f"{socket.gethostname()}\n{boot}".encode()).hexdigest()[:8]


def start_time(pid: int) -> int | None:
    """When process ``pid`` started (clock ticks since boot), 0 where there is no /proc to ask,
    None if there is no such process (or only its zombie, which will write nothing more)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return None if Path("/proc/self/stat").exists() else (0 if _exists(pid) else None)
    except OSError:
        return None
    fields = stat.rsplit(")", 1)[1].split()      # the name in (...) may hold spaces
    return None if fields[0] == "Z" else int(fields[19])   # a zombie writes nothing more; field 22


def _exists(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:        # someone else's process: it exists
        return True
    return True


def prefix(name: str) -> str:
    """The staging folder's name up to its random part, for the model directory ``name``."""
    pid = os.getpid()
    return f".{name}.new-{machine()}-{pid}-{start_time(pid) or 0}-"


def make(d: Path) -> Path:
    """A new staging folder beside the model directory ``d``, named after this process."""
    return Path(tempfile.mkdtemp(prefix=prefix(d.name), dir=d.parent))


def is_stale(folder_name: str, model_name: str) -> bool:
    """Was ``folder_name`` a staging folder of ``model_name`` whose writer is gone?"""
    head = f".{model_name}.new-"
    m = _OWNED.fullmatch(folder_name[len(head):]) if folder_name.startswith(head) else None
    if m is None or m["machine"] != machine():
        return False                  # not ours to judge
    pid, start = int(m["pid"]), int(m["start"])
    now = start_time(pid)
    return now is None or (start != 0 and now != start)


def remove_stale(d: Path) -> list[Path]:
    """Remove the staging folders of ``d`` that hard-killed writers left; returns them."""
    try:
        names = os.listdir(d.parent)
    except OSError:
        return []
    gone = [d.parent / n for n in names if is_stale(n, d.name)]
    for folder in gone:
        shutil.rmtree(folder, ignore_errors=True)
    return gone


__all__ = ["machine", "start_time", "prefix", "make", "is_stale", "remove_stale"]
