"""PPDDL parsing scales linearly in the number of actions (issue 15).

A generated domain of N probabilistic actions (each with parameters, a precondition and two
outcomes, about 130 bytes like IPPC actions) is parsed for several N. Prints the wall and CPU time
per N and the wall time per 1,000 actions, measured in this run, so linearity shows as a flat
column; the target is 20,000 actions in under 20 s and 100,000 in under 120 s (the duplicate-action
check was quadratic: 20,000 actions took 67 s). The machine's load average is printed, since a
shared machine moves wall times several-fold while CPU time moves less. ``--sizes`` changes the
list; ``--reference N`` also parses N actions with lark alone (``parse_text_lark``, the reference
the tokenizer-driven reader is tested against) and prints the ratio of the two in this run;
``--errors N`` times N actions whose last one has a syntax error (lark reads and words it) and
whose last one names an unknown predicate (the reader's walk finds it, one more scan locates it).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from groundsym.ppddl.parser import PPDDLError, parse_text, parse_text_lark  # noqa: E402


def domain_text(n: int) -> str:
    """A domain with ``n`` distinct actions over three predicates."""
    head = ("(define (domain many) (:requirements :strips :probabilistic-effects)\n"
            " (:predicates (p ?x) (q ?x ?y) (r))\n")
    action = (" (:action a{i} :parameters (?x ?y)\n"
              "  :precondition (and (p ?x) (not (q ?x ?y)))\n"
              "  :effect (probabilistic 0.7 (and (q ?x ?y) (not (p ?x))) 0.2 (r)))\n")
    return head + "".join(action.format(i=i) for i in range(n)) + ")\n"


def broken(n: int) -> dict[str, str]:
    """``n`` actions whose last one is wrong, by the kind of error."""
    body = domain_text(n - 1)[:-2]
    return {"a syntax error": body + " (:action last :parameters (?x) :effect (p ?x]))\n)\n",
            "an unknown predicate": body + " (:action last :parameters (?x) :effect (nosuch ?x))\n)\n"}


def time_errors(n: int) -> None:
    for what, text in broken(n).items():
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            parse_text(text, "big.ppddl")
        except PPDDLError as exc:
            message = str(exc)
        else:
            raise AssertionError(f"{what} was not refused")
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        print(f"{n} actions, {what} in the last: {wall:.2f} s ({cpu:.2f} CPU s): {message}", flush=True)


def timed(parse, text: str, n: int) -> tuple[float, float]:
    """(wall, CPU) seconds of one parse of ``text``, checked to hold its ``n`` actions."""
    wall, cpu = time.perf_counter(), time.process_time()
    domains, _ = parse(text, f"<{n} actions>")
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    assert len(domains[0].actions) == n
    return wall, cpu


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="5000,20000,100000", help="action counts, comma-separated")
    ap.add_argument("--reference", type=int, default=0, metavar="N",
                    help="also parse N actions with lark alone and print the ratio (0: not)")
    ap.add_argument("--errors", type=int, default=0, metavar="N",
                    help="also time N actions with an error in the last one (0: not)")
    args = ap.parse_args()
    print(f"load average at start: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"{'actions':>8} {'MB':>6} {'seconds':>8} {'CPU s':>7} {'s per 1k actions':>17}")
    for n in (int(x) for x in args.sizes.split(",")):
        text = domain_text(n)
        wall, cpu = timed(parse_text, text, n)
        print(f"{n:>8} {len(text) / 1e6:>6.1f} {wall:>8.2f} {cpu:>7.2f} {1000 * wall / n:>17.3f}", flush=True)
    if args.reference:
        text = domain_text(args.reference)
        fast, fast_cpu = timed(parse_text, text, args.reference)
        ref, ref_cpu = timed(parse_text_lark, text, args.reference)
        print(f"{args.reference} actions: lark alone {ref:.2f} s ({ref_cpu:.2f} CPU s), this reader {fast:.2f} s "
              f"({fast_cpu:.2f} CPU s): {ref / fast:.1f}x wall, {ref_cpu / fast_cpu:.1f}x CPU")
    if args.errors:
        time_errors(args.errors)
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
