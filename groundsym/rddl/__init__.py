"""RDDL (Sanner 2010, "Relational Dynamic Influence Diagram Language") from PPDDL domains.

:mod:`.names` maps PPDDL names onto RDDL identifiers, :mod:`.expressions` writes formulas and
effect conditions as RDDL expressions, :mod:`.writer` writes a domain and an instance
(docs/rddl.md says which tools read them and how the translation is checked).
"""
