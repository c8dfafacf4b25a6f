"""Reading and writing files safely.

Every output is written atomically (a temporary file in the same directory, then ``os.replace``),
so a crash or Ctrl-C never leaves half a file and never destroys what the user had.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import stat
import tempfile
from pathlib import Path
from typing import Any

from .errors import UserError


def output_target(path: str | Path) -> Path:
    """The regular file an output to ``path`` replaces, refusing any other kind of place.

    An existing FIFO, device, socket or directory is never replaced (``-o /dev/null`` must not turn
    the device into a JSON file): that is a :class:`UserError`. A symbolic link is written through:
    the file it points at is replaced and the link stays. A parent that is a file, or cannot be
    created, is refused here too, so callers can check an output before minutes of work.
    """
    path = Path(path)
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    try:
        st = os.stat(target)
    except (FileNotFoundError, NotADirectoryError):
        _check_parent(path, target.parent)
        return target
    except OSError as exc:
        raise UserError(f"{path}: cannot write ({exc.strerror or exc})") from None
    if stat.S_ISDIR(st.st_mode):
        raise UserError(f"{path}: is a directory, expected a file path")
    if not stat.S_ISREG(st.st_mode):
        raise UserError(f"{path}: exists and is not a regular file ({_kind(st.st_mode)}); refusing to replace it")
    return target


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "a special file"


def _check_parent(path: Path, parent: Path) -> None:
    """One line when the folder an output goes into cannot exist: an ancestor is a file."""
    for anc in (parent, *parent.parents):
        if anc.exists():
            if not anc.is_dir():
                raise UserError(f"{path}: cannot write ({anc} is a file, not a directory)")
            return


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically; raise UserError if the place is not writable."""
    shown = Path(path)
    path = output_target(shown)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise UserError(f"{shown}: cannot write ({exc.strerror or exc})") from None
    try:
        os.chmod(tmp, 0o666 & ~current_umask())  # mkstemp makes 0600; give the file the user's usual mode
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise UserError(f"{shown}: cannot write ({exc.strerror or exc})") from None
        raise


def current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_text(path: str | Path, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def _clean(obj: Any) -> Any:
    """Make numpy scalars/arrays JSON-serialisable; reject non-finite floats."""
    import numpy as np

    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    if isinstance(obj, np.generic):
        return _clean(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        raise ValueError(f"non-finite number {obj!r} cannot be written as JSON")
    return obj


def dumps_json(obj: Any, *, indent: int | None = 1) -> str:
    """Deterministic JSON text (sorted keys are *not* forced: documents keep their field order)."""
    return json.dumps(_clean(obj), indent=indent, allow_nan=False) + "\n"


def atomic_write_json(path: str | Path, obj: Any, *, indent: int | None = 1) -> None:
    atomic_write_text(path, dumps_json(obj, indent=indent))


def read_text(path: str | Path) -> str:
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UserError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise UserError(f"{path}: is a directory, expected a file") from None
    except UnicodeDecodeError:
        raise UserError(f"{path}: not UTF-8 text") from None
    except OSError as exc:
        raise UserError(f"{path}: cannot read ({exc.strerror or exc})") from None


def read_json(path: str | Path) -> Any:
    """Parse a JSON file; malformed or truncated files give one line with line and column."""
    text = read_text(path)
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise UserError(f"{path}: malformed JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
    except RecursionError:
        raise UserError(f"{path}: JSON nested too deeply to read") from None
    except ValueError as exc:   # an integer past Python's int-from-text limit
        what = "a number with too many digits to read" if "digits" in str(exc) else str(exc)
        raise UserError(f"{path}: unreadable JSON: {what}") from None


def file_sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
