"""PPDDL in both directions: parse (lark grammar), print, simulate, convert to and from NID rules,
determinise for classical planners. See docs/ppddl.md.

``transition_model`` (a domain file as the true ``P(s' | s, a)``, for ``groundsym score``) is
re-exported here.
"""

from .simulate import transition_model

__all__ = ["transition_model"]
