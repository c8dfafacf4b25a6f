"""Figures as PNG bytes: what a person would rather see than read.

Every figure is drawn with matplotlib's non-interactive Agg backend into bytes, so callers decide
where the picture goes (a file written atomically, a data URI in the HTML report). Drawing is
deterministic: the same inputs give the same bytes.
"""

from __future__ import annotations
