import os
import signal
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
os.environ.setdefault("MPLBACKEND", "Agg")


def as_foreground_job() -> None:
    """``preexec_fn`` for a command a test interrupts as a terminal's Ctrl-C would: SIGINT's
    default action, even when the tests run where it is ignored (a background job of a
    non-interactive shell ignores SIGINT, a child inherits that, and Python then keeps ignoring
    it, so the command would run to its end)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def descendants(pid: int) -> set[int]:
    """Every descendant process of ``pid`` (from /proc; empty where there is no /proc)."""
    parent = {}
    for d in Path("/proc").iterdir() if Path("/proc").is_dir() else ():
        if d.name.isdigit():
            try:
                parent[int(d.name)] = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                pass
    found, grew = {pid}, True
    while grew:
        new = {c for c, p in parent.items() if p in found} - found
        found |= new
        grew = bool(new)
    return found - {pid}


def alive(pid: int) -> bool:
    """Is process ``pid`` running (a zombie, ended but not yet reaped, is not)?"""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def outliving(pids: set[int], wait: float = 10) -> set[int]:
    """Those of ``pids`` still running after up to ``wait`` seconds; they are killed then, so a
    failing test leaves nothing behind."""
    deadline = time.monotonic() + wait
    while any(alive(w) for w in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = {w for w in pids if alive(w)}
    for w in left:
        os.kill(w, signal.SIGKILL)
    return left


@pytest.fixture(scope="session")
def blocks_traces(tmp_path_factory) -> Path:
    """Symbolic traces from the reference blocks world (simulate is fast and needs no physics)."""
    from groundsym.cli import main

    blocks = ROOT / "domains" / "reference" / "blocksworld"
    path = tmp_path_factory.mktemp("blocks") / "bw.json"
    assert main(["simulate", "--domain", str(blocks / "domain.ppddl"), "--problem", str(blocks / "p01.ppddl"),
                 "--traces", "4", "--length", "8", "--seed", "1", "-o", str(path)]) == 0
    return path
