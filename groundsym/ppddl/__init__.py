"""PPDDL in both directions: parse (lark grammar), print, simulate, convert to and from NID rules,
determinise for classical planners. See docs/ppddl.md."""
