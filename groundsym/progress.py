"""Progress on the terminal (stderr): done/total, rate, ETA, and a free-form status.

Quiet when stderr is not a terminal, except for occasional plain lines, so logs stay readable.
"""

from __future__ import annotations

import sys
import time


class Progress:
    def __init__(self, total: int, label: str = "", *, stream=None, min_interval: float = 0.2,
                 enabled: bool = True):
        self.total = max(int(total), 1)
        self.label = label
        self.stream = stream or sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.min_interval = min_interval if self.tty else 10.0
        self.enabled = enabled
        self.start = time.monotonic()
        self.last = 0.0
        self.done = 0

    def update(self, done: int, status: str = "", force: bool = False) -> None:
        self.done = done
        now = time.monotonic()
        if not self.enabled or (not force and now - self.last < self.min_interval and done < self.total):
            return
        self.last = now
        elapsed = now - self.start
        frac = min(done / self.total, 1.0)
        eta = (elapsed / frac - elapsed) if frac > 0 else float("nan")
        eta_s = "?" if eta != eta else _fmt(eta)
        width = 24
        bar = "#" * int(frac * width) + "-" * (width - int(frac * width))
        line = f"{self.label} [{bar}] {done}/{self.total} {_fmt(elapsed)} elapsed, ETA {eta_s}"
        if status:
            line += f" | {status}"
        if self.tty:
            self.stream.write("\r\x1b[K" + line)
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def close(self, status: str = "") -> None:
        if not self.enabled:
            return
        self.update(self.done, status, force=True)
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


def _fmt(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{(seconds % 3600) // 60:02d}m"
