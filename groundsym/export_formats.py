"""The files of an export in each format ``export-domain --format`` offers (docs/rddl.md).

* ``ppddl``: the readable PPDDL of :mod:`groundsym.export` (``--determinize`` adds plain PDDL);
* ``rddl``: an RDDL domain and instance (:mod:`groundsym.rddl.writer`), the reward model written
  once as the reward expression, for pyRDDLGym and its planners (JaxPlan);
* ``fond``: FOND PDDL, ``oneof`` effects (:mod:`groundsym.ppddl.fond`), for FOND planners and the
  ``pddl`` package.

Why a module apart from the command: the report and the benchmarks write the same files; and why
not in :mod:`groundsym.export`: that module is the PPDDL export and its round trip, already long.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

from .errors import UserError
from .export import Export
from .ppddl.ast import Domain
from .ppddl.fond import fond_domain_text, fond_problem_text
from .rddl.writer import RddlOptions, rddl_files
from .rules.model import Derived

FORMATS = ("ppddl", "rddl", "fond")
RDDL_FILES = ("domain.rddl", "instance.rddl")


# the PPDDL header's lines that another format says otherwise (groundsym.export.build_export)
RDDL_HEADER = {
    "learned NID rules as PPDDL (groundsym export-domain): one action per rule":
        "learned NID rules as RDDL (groundsym export-domain --format rddl): one action fluent per primitive; "
        "its rules stand in the conditional probability functions, one Uniform draw picks a rule's outcome",
    "a precondition's last (and ...) lists the other rules of the action that must not apply":
        "a rule applies when its context holds and no other rule of the primitive covers (docs/rddl.md)",
    "(every action carries it as reward effects):": "(the reward expression below):",
}
FOND_HEADER = {
    "learned NID rules as PPDDL (groundsym export-domain): one action per rule":
        "learned NID rules as FOND PDDL (groundsym export-domain --format fond): one action per rule, its "
        "outcomes as oneof",
    "probabilities rounded to 4 decimals; the mass an outcome list leaves unassigned is":
        "the probabilities are dropped (FOND has none); the outcome (and), where a rule has noise, is",
    "reward of a step, read in the state the action is taken in (every action carries it as reward effects):":
        "reward (left out here, FOND has no rewards), read in the state the action is taken in:",
}


def _header(domain: Domain, lines: dict[str, str]) -> Domain:
    text = domain.comment.replace("\n", "\0")     # a PPDDL comment line may have been wrapped: match unwrapped
    for old, new in lines.items():
        text = text.replace(old, new)
    return replace(domain, comment=text.replace("\0", "\n"))


def check_format(fmt: str, determinize: str | None, horizon: int | None, axioms: bool = False,
                 strips: bool = False, operators: bool = False) -> None:
    """Refuse, in one line, an option that means nothing in ``fmt`` (before any work starts)."""
    if fmt not in FORMATS:
        raise UserError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
    if operators and fmt != "ppddl":
        raise UserError(f"--operators: only with --format ppddl (the typed one-operator-per-action form; {fmt} "
                        "writes the rules as they are)")
    if operators and axioms:
        raise UserError("--axioms: not with --operators (an operator per action has no derived predicates)")
    if axioms and fmt == "rddl":
        raise UserError("--axioms: not with --format rddl (RDDL always declares derived predicates once, as "
                        "interm fluents)")
    if axioms and strips:
        raise UserError("--axioms: not with --strips (STRIPS has no axioms; the STRIPS compilation writes them out)")
    if determinize and fmt != "ppddl":
        raise UserError(f"--determinize: only with --format ppddl ({fmt} keeps every outcome; "
                        "determinise the PPDDL export for a classical planner)")
    if horizon is not None and fmt != "rddl":
        raise UserError("--horizon: only with --format rddl (PPDDL and FOND have no horizon)")
    if horizon is not None and horizon < 1:
        raise UserError(f"--horizon: expected a positive number of steps, got {horizon}")


def format_files(ex: Export, fmt: str, horizon: int | None = None, derived: Sequence[Derived] = ()) -> dict[str, str]:
    """File name -> text of ``ex`` in ``fmt`` (FOND: no problem.pddl without a goal to reach;
    ``derived``: the rule set's derived predicates, RDDL declares them once)."""
    if fmt == "rddl":
        options = RddlOptions() if horizon is None else RddlOptions(horizon=horizon)
        return rddl_files(_header(ex.domain, RDDL_HEADER), ex.problem, ex.reward, options, derived)
    if fmt == "fond":
        files = {"domain.pddl": fond_domain_text(_header(ex.domain, FOND_HEADER))}
        if ex.problem.goal is not None:
            files["problem.pddl"] = fond_problem_text(ex.problem)
        return files
    return {"domain.ppddl": str(ex.domain), "problem.ppddl": str(ex.problem)}
