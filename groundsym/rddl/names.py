"""PPDDL names as RDDL identifiers: one map for a whole translation, so every name is spelt once.

Why: PPDDL allows ``-`` in names (``l-1-1``, ``?derived-z1``, ``pick-up``), which RDDL reads as a
minus; RDDL reserves words PPDDL does not (``if``, ``sum``, ``true``). The map replaces ``-`` by
``_`` and prefixes a reserved or clashing name, and refuses (one line) a domain where two PPDDL
names would become one identifier, rather than write a model that means something else.
"""

from __future__ import annotations

import re

from ..errors import UserError

# the words an identifier must not be (pyRDDLGym 2.7's reserved words, lower case, and the
# aggregations; compared in lower case, so ``Uniform`` and ``uniform`` are both kept free)
RESERVED = frozenset("""
domain instance horizon discount objects init-state requirements state-action-constraints
action-preconditions state-invariants types object int real bool true false neg-inf pos-inf
pvariables non-fluent non-fluents state-fluent interm-fluent derived-fluent observ-fluent action-fluent
param-fluent level default max-nondef-actions terminate-when terminal termination reward cpfs cdfs policy
if then else switch case otherwise forall exists sum prod avg minimum maximum argmin argmax enum
krondelta diracdelta uniform bernoulli discrete unnormdiscrete normal poisson exponential weibull gamma
binomial negativebinomial beta geometric pareto student gumbel laplace cauchy gompertz chisquare
kumaraswamy multivariatenormal multivariatestudent dirichlet multinomial det inverse pinverse cholesky
row col
""".split())
_VALID = re.compile(r"[A-Za-z][A-Za-z0-9_]*$")


class Identifiers:
    """PPDDL name -> RDDL identifier, for objects, predicates, actions and types alike (one
    namespace: RDDL's pvariables, types and objects must not clash either)."""

    def __init__(self, what: str) -> None:
        self.what = what
        self._of: dict[str, str] = {}
        self._taken: dict[str, str] = {}

    def __call__(self, name: str) -> str:
        """The identifier of ``name`` (made on first use)."""
        if name not in self._of:
            base = name.replace("-", "_")
            if not _VALID.match(base):
                base = "n_" + re.sub(r"[^A-Za-z0-9_]", "_", base)
            if base.lower() in RESERVED:
                base = "p_" + base
            if base in self._taken:
                raise UserError(f"{self.what}: {name!r} and {self._taken[base]!r} would both be written as "
                                f"the RDDL name {base!r}")
            self._of[name] = base
            self._taken[base] = name
        return self._of[name]

    def name_of(self, identifier: str) -> str | None:
        """The PPDDL name written as ``identifier`` (None: a name the writer added itself)."""
        owner = self._taken.get(identifier)
        return owner if owner is not None and self._of.get(owner) == identifier else None

    def reserve(self, name: str, owner: str) -> None:
        """Keep ``name`` for a fluent the writer adds itself (a draw, a derived fluent)."""
        if name in self._taken:
            raise UserError(f"{self.what}: {self._taken[name]!r} clashes with the RDDL name {name!r} "
                            f"the translation needs for {owner}")
        self._taken[name] = owner


def variable(name: str) -> str:
    """A PPDDL variable (``?derived-z1``) as an RDDL variable (``?derived_z1``)."""
    return "?" + re.sub(r"[^A-Za-z0-9_]", "_", name.lstrip("?"))
