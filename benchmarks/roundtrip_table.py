"""The round-trip table of docs/rddl.md: each export read back by another tool, checked against ours.

Rows: RDDL stepped by pyRDDLGym (groundsym/rddl/roundtrip.py: successor distributions and rewards
from the reachable states, Hoeffding + union bound at false-alarm rate ``--delta``) for the first
problem of each IPPC 2006/2008 domain in tests/data and for learned models (the blocks world and
the tower simulated from their reference PPDDL, as tests/test_export_cli.py learns them); every IPPC
test problem loaded and stepped once; FOND read by the ``pddl`` package (when installed) with the
outcome sets compared. Prints a markdown table; CPU seconds per row.

    nice -n 10 python benchmarks/roundtrip_table.py --states 10 --samples 200

(Not named bench_*: it measures agreement, not speed.)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from groundsym.export import ExportOptions, build_export  # noqa: E402
from groundsym.modeldir import load_model  # noqa: E402
from groundsym.ppddl.fond import fond_domain_text  # noqa: E402
from groundsym.ppddl.parser import load  # noqa: E402
from groundsym.ppddl.simulate import Task  # noqa: E402
from groundsym.rddl.roundtrip import PyRddlStepper, check  # noqa: E402
from groundsym.rddl.writer import RddlWriter  # noqa: E402

IPPC = ROOT / "tests" / "data" / "ippc"


def learned(tmp: Path) -> dict[str, Path]:
    from test_export_cli import _model
    for d in ("bw", "tower"):
        (tmp / d).mkdir(parents=True, exist_ok=True)
    return {"learned blocks world": _model(tmp / "bw", "blocksworld/domain.ppddl", "easy", 5),
            "learned tower (symbolic data)": _model(tmp / "tower", "tower/domain.ppddl", "tower/p02.ppddl", 2)}


def rddl_rows(args: argparse.Namespace, tmp: Path) -> list[str]:
    rows = []
    cases = [(f"IPPC {d.parent.name[4:]} {d.name} p01", *load(d / "domain.pddl", d / "p01.pddl"), None, ())
             for d in sorted(IPPC.glob("*/*"))]
    for name, path in learned(tmp).items():
        model = load_model(path)
        ex = build_export(model, ExportOptions())
        cases.append((name, ex.domain, ex.problem, ex.reward, model.rules.derived))
    for name, domain, problem, reward, derived in cases:
        start = time.process_time()
        r = check(domain, problem, tmp / "rddl", state_reward=reward, max_states=args.states, samples=args.samples,
                  delta=args.delta, seed=args.seed, derived=derived)
        rows.append(f"| RDDL -> pyRDDLGym | {name} | {r.states} states, {r.pairs} pairs, {r.outcomes} outcomes, "
                    f"{r.steps} steps | eps {r.eps:.3f}, worst {r.worst:.3f} | {'equal' if r.ok else 'DIFFER'} | "
                    f"{time.process_time() - start:.0f} |")
        print(rows[-1], flush=True)
    start = time.process_time()
    problems = sorted(IPPC.glob("*/*/p*.pddl"))
    stepped = 0
    for p in problems:
        domain, problem = load(p.parent / "domain.pddl", p)
        task = Task(domain, problem)
        s = task.initial_state
        prim = task.applicable_primitives(s)[0]
        after, _ = PyRddlStepper(RddlWriter(domain, problem), tmp / "load", args.seed).step(s, prim)
        stepped += any(x.state == after for x in task.distribution(s, prim))
    rows.append(f"| RDDL -> pyRDDLGym | every IPPC test problem | {len(problems)} problems loaded, one step each | "
                f"successor possible in ours | {stepped} of {len(problems)} | {time.process_time() - start:.0f} |")
    print(rows[-1], flush=True)
    return rows


def fond_rows(tmp: Path) -> list[str]:
    try:
        import pddl  # noqa: F401
    except ImportError:
        return ["| FOND -> pddl | (not run: the pddl package is not installed) | | | | |"]
    from groundsym.ppddl.fond_check import compare_fond
    domains = [(f"IPPC {d.parent.name[4:]} {d.name}", load(d / "domain.pddl", d / "p01.pddl")[0])
               for d in sorted(IPPC.glob("*/*"))]
    for name, path in learned(tmp / "fond").items():
        domains.append((name, build_export(load_model(path), ExportOptions()).domain))
    rows = []
    for name, domain in domains:
        start = time.process_time()
        (tmp / "domain.pddl").write_text(fond_domain_text(domain))
        problems = compare_fond(domain, tmp / "domain.pddl")
        rows.append(f"| FOND -> pddl | {name} | {len(domain.actions)} actions | outcome sets, parameters, "
                    f"preconditions | {'equal' if not problems else 'DIFFER: ' + problems[0]} | "
                    f"{time.process_time() - start:.1f} |")
        print(rows[-1], flush=True)
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=10, help="reachable states visited per problem")
    parser.add_argument("--samples", type=int, default=200, help="pyRDDLGym steps per state x primitive")
    parser.add_argument("--delta", type=float, default=1e-3, help="false-alarm rate of the whole check")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print("| export -> reader | model | what was compared | tolerance | result | CPU s |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory(prefix="groundsym-roundtrip-") as tmp:
        rows = fond_rows(Path(tmp)) + rddl_rows(args, Path(tmp))
    return 0 if all("DIFFER" not in r for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
