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

from typing import Sequence

from .errors import UserError
from .export import Export
from .ppddl.fond import fond_domain_text, fond_problem_text
from .rddl.writer import RddlOptions, rddl_files
from .rules.model import Derived

FORMATS = ("ppddl", "rddl", "fond")
RDDL_FILES = ("domain.rddl", "instance.rddl")


def check_format(fmt: str, determinize: str | None, horizon: int | None, axioms: bool = False,
                 strips: bool = False) -> None:
    """Refuse, in one line, an option that means nothing in ``fmt`` (before any work starts)."""
    if fmt not in FORMATS:
        raise UserError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
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
        return rddl_files(ex.domain, ex.problem, ex.reward, options, derived)
    if fmt == "fond":
        files = {"domain.pddl": fond_domain_text(ex.domain)}
        if ex.problem.goal is not None:
            files["problem.pddl"] = fond_problem_text(ex.problem)
        return files
    return {"domain.ppddl": str(ex.domain), "problem.ppddl": str(ex.problem)}
