"""PPDDL parsing scales linearly in the number of actions (issue 15).

A generated domain of N probabilistic actions (each with parameters, a precondition and two
outcomes, about 130 bytes like IPPC actions) is parsed for several N. Prints the time per N and
the time per 1,000 actions, measured in this run, so linearity shows as a flat second column; the
target is 20,000 actions in under 20 s and 100,000 in under 120 s (the duplicate-action check was
quadratic: 20,000 actions took 67 s). ``--sizes`` changes the list.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from groundsym.ppddl.parser import parse_text  # noqa: E402


def domain_text(n: int) -> str:
    """A domain with ``n`` distinct actions over three predicates."""
    head = ("(define (domain many) (:requirements :strips :probabilistic-effects)\n"
            " (:predicates (p ?x) (q ?x ?y) (r))\n")
    action = (" (:action a{i} :parameters (?x ?y)\n"
              "  :precondition (and (p ?x) (not (q ?x ?y)))\n"
              "  :effect (probabilistic 0.7 (and (q ?x ?y) (not (p ?x))) 0.2 (r)))\n")
    return head + "".join(action.format(i=i) for i in range(n)) + ")\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="5000,20000,100000", help="action counts, comma-separated")
    args = ap.parse_args()
    print(f"{'actions':>8} {'MB':>6} {'seconds':>8} {'s per 1k actions':>17}")
    for n in (int(x) for x in args.sizes.split(",")):
        text = domain_text(n)
        t = time.perf_counter()
        domains, _ = parse_text(text, f"<{n} actions>")
        dt = time.perf_counter() - t
        assert len(domains[0].actions) == n
        print(f"{n:>8} {len(text) / 1e6:>6.1f} {dt:>8.2f} {1000 * dt / n:>17.3f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
