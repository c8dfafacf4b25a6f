import os
import signal
import sys
from pathlib import Path

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
