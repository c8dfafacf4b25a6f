"""Provenance recorded in every file groundsym writes: version, command line, seed, data hash."""

from __future__ import annotations

import shlex
from typing import Any

from . import __version__


def provenance(argv: list[str] | None = None, **extra: Any) -> dict[str, Any]:
    out: dict[str, Any] = {"version": __version__}
    if argv:
        out["command"] = " ".join(shlex.quote(a) for a in argv)
    out.update({k: v for k, v in extra.items() if v is not None})
    return out
