"""Does rule learning recover known dynamics? (docs/rules.md)

For each known domain, sample training data (random walks from all-on-the-table starts, 25 % of
steps an inapplicable action), learn NID rules with the default options, and compare on 2000
held-out transitions:

* the mean log-likelihood per transition of the learned rules against the true domain's
  (``gap = true - learned``, in nats; the target is < 0.1), at 200 and 1000 transitions;
* the contexts of the learned rules against those of the true operators, side by side.

The known domains are the PPDDL reference domains (``domains/reference/*/domain.ppddl``, sampled
from their problems with the PPDDL simulator and scored with their true dynamics) and two NID rule
sets written by hand (``tests/data/nid_*.rules.json``). Outputs go to ``--out``: ``recovery.md`` (tables and rules side by side), ``recovery.json`` and
``recovery.png``.

    python examples/rule_recovery.py --out results/rule-recovery
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import fields, replace
from itertools import permutations
from pathlib import Path

import numpy as np

from groundsym.logic import Atom
from groundsym.rules.evaluate import score_dataset, score_ruleset
from groundsym.rules.io import read_rules
from groundsym.rules.learner import LearnOptions, examples_from_dataset, learn_rules
from groundsym.rules.model import Rule, RuleSet
from groundsym.rules.sample import sample_traces
from groundsym.symbolic_traces import SymbolicDataset

ROOT = Path(__file__).resolve().parents[1]
KNOWN = {"blocks": ROOT / "tests" / "data" / "nid_blocks.rules.json",
         "tower": ROOT / "tests" / "data" / "nid_tower.rules.json"}
REFERENCE = ROOT / "domains" / "reference"
TRACE_LENGTH = 20


class NIDSource:
    """A hand-written NID rule set: sampled with :func:`sample_traces`, scored with its rules."""

    def __init__(self, path: Path):
        self.true, self.meta = read_rules(path)
        self.predicates = self.meta["predicates"]

    def sample(self, transitions: int, rng: np.random.Generator) -> SymbolicDataset:
        return simulate(self.true, self.meta, transitions, rng)

    def log_likelihood(self, ds: SymbolicDataset) -> float:
        return score_ruleset(self.true, ds).mean_log_likelihood

    def contexts(self) -> list:
        return sorted(canonical_context(r) for r in self.true.rules)


class PPDDLSource:
    """A PPDDL reference domain: random walks from its problems (alternating), true dynamics."""

    def __init__(self, folder: Path):
        from groundsym.ppddl.parser import load
        from groundsym.ppddl.simulate import Task, transition_model

        self.path = folder / "domain.ppddl"
        self.domain, _ = load(self.path)
        self.tasks = [Task(self.domain, load(self.path, p)[1]) for p in sorted(folder.glob("p*.ppddl"))]
        self.prob, _ = transition_model(self.path)
        self.predicates = None

    def sample(self, transitions: int, rng: np.random.Generator) -> SymbolicDataset:
        from groundsym.ppddl.simulate import simulate_traces

        parts = []
        n_traces = -(-transitions // TRACE_LENGTH)
        for k, task in enumerate(self.tasks):
            share = n_traces // len(self.tasks) + (k < n_traces % len(self.tasks))
            if share:
                parts.append(simulate_traces(task, share, TRACE_LENGTH, rng, inapplicable=0.25))
        ds = SymbolicDataset([t for p in parts for t in p.traces], {k: v for p in parts for k, v in p.predicates.items()},
                             {k: v for p in parts for k, v in p.primitives.items()})
        self.predicates = ds.predicates
        return trim(ds, transitions)

    def log_likelihood(self, ds: SymbolicDataset) -> float:
        return score_dataset(self.prob, ds).mean_log_likelihood

    def contexts(self) -> list:
        """The operators' contexts where the domain is in the rule subset, else their preconditions."""
        from groundsym.errors import UserError
        from groundsym.ppddl.ast import layout, to_sexp
        from groundsym.ppddl.to_rules import domain_to_rules

        try:
            return sorted(canonical_context(r) for r in domain_to_rules(self.domain).rules)
        except UserError:
            return sorted((f"({a.name})", (" ".join(layout(to_sexp(a.precondition)).split()),))
                      for a in self.domain.actions)


def sources() -> dict:
    out: dict = {f"{d.name} (PPDDL)": PPDDLSource(d) for d in sorted(REFERENCE.iterdir())
                 if (d / "domain.ppddl").exists()}
    out.update({f"{name} (NID)": NIDSource(path) for name, path in KNOWN.items()})
    return out


def table_starts(n: int, rng: np.random.Generator, predicates: dict[str, int],
                 n_objects: tuple[int, int] = (3, 5)) -> list[tuple[tuple[str, ...], frozenset]]:
    """All objects clear on the table, hand empty; a third are balls where the domain has balls."""
    out = []
    for _ in range(n):
        objs = tuple(f"o{i + 1}" for i in range(int(rng.integers(n_objects[0], n_objects[1] + 1))))
        s = {Atom("handempty")} | {Atom(p, (o,)) for o in objs for p in ("ontable", "clear")}
        if "ball" in predicates:
            s |= {Atom("ball", (o,)) for o in objs if rng.random() < 1 / 3}
        out.append((objs, frozenset(s)))
    return out


def simulate(true: RuleSet, meta: dict, transitions: int, rng: np.random.Generator) -> SymbolicDataset:
    n_traces = -(-transitions // TRACE_LENGTH)
    ds = sample_traces(true, table_starts(n_traces, rng, meta["predicates"]), meta["primitives"],
                       meta["predicates"], TRACE_LENGTH, rng, inapplicable=0.25)
    return trim(ds, transitions)


def trim(ds: SymbolicDataset, transitions: int) -> SymbolicDataset:
    """Cut the last traces so the dataset holds exactly ``transitions`` transitions."""
    excess = ds.n_transitions - transitions
    while excess > 0 and ds.traces:
        tr = ds.traces[-1]
        cut = min(excess, len(tr))
        del tr.states[len(tr.states) - cut:], tr.actions[len(tr.actions) - cut:], tr.rewards[len(tr.rewards) - cut:]
        if not tr.actions:
            ds.traces.pop()
        excess -= cut
    return ds


def canonical_context(rule: Rule) -> tuple[str, tuple[str, ...]]:
    """The action and context with action arguments renamed ?x1.. and deictic references ?y1.. in
    the order that sorts first, so equal contexts compare equal whatever the variable names."""
    acts = {v: f"?x{i + 1}" for i, v in enumerate(rule.action.args)}
    best = None
    for perm in permutations(rule.deictic):
        ren = {**acts, **{v: f"?y{i + 1}" for i, v in enumerate(perm)}}
        ctx = tuple(sorted(str(l.substitute(ren)) for l in rule.context))
        best = ctx if best is None or ctx < best else best
    return str(rule.action.substitute(acts)), best or ()


def parse_config(text: str) -> tuple[str, LearnOptions]:
    """``NAME:KEY=VALUE,...`` -> (NAME, LearnOptions with those fields)."""
    name, _, rest = text.partition(":")
    types = {f.name: f.type for f in fields(LearnOptions)}
    opts = LearnOptions()
    for item in filter(None, rest.split(",")):
        key, _, value = item.partition("=")
        if key not in types:
            raise SystemExit(f"--config {text}: {key} is not a LearnOptions field ({', '.join(types)})")
        cast = {"bool": lambda v: v.lower() in ("1", "true", "yes"), "int": int, "str": str}.get(str(types[key]), float)
        opts = replace(opts, **{key: cast(value)})
    return name, opts


def recover(source, n_train: int, seed: int, n_test: int = 2000, options: LearnOptions = LearnOptions()) -> dict:
    """Learn from ``n_train`` sampled transitions; held-out comparison with the true domain."""
    train = source.sample(n_train, np.random.default_rng(seed))
    test = source.sample(n_test, np.random.default_rng(seed + 10_000))
    t0 = time.perf_counter()
    learned, _ = learn_rules(examples_from_dataset(train), train.predicates, options, seed=seed, progress=False)
    seconds = time.perf_counter() - t0
    true_ll = source.log_likelihood(test)
    learned_ll = score_ruleset(learned, test).mean_log_likelihood
    true_ctx = source.contexts()
    learned_ctx = sorted(canonical_context(r) for r in learned.rules)
    return {"train": train.n_transitions, "seed": seed, "true_ll": true_ll, "learned_ll": learned_ll,
            "gap": true_ll - learned_ll, "same_contexts": true_ctx == learned_ctx, "seconds": seconds,
            "true_contexts": true_ctx, "learned_contexts": learned_ctx, "learned": learned}


def side_by_side(true_ctx: list, learned_ctx: list) -> list[str]:
    """Markdown rows: each true operator's context beside the learned rule with the same context,
    then the learned rules nothing matched (grouped by action name)."""
    rows = ["| action | true operator | learned rule |", "|---|---|---|"]
    learned = list(learned_ctx)
    for act, ctx in true_ctx:
        match = (act, ctx) in learned
        if match:
            learned.remove((act, ctx))
        rows.append(f"| {_name(act)} | {' '.join(ctx)} | {' '.join(ctx) if match else '-'} |")
    rows += [f"| {_name(act)} | - | {' '.join(ctx)} |" for act, ctx in learned]
    return rows


def _name(act: str) -> str:
    return act.strip("()").split()[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path("results/rule-recovery"))
    ap.add_argument("--sizes", type=int, nargs="+", default=[200, 1000])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--test", type=int, default=2000)
    ap.add_argument("--options", default="", help="learner options KEY=VALUE,... (LearnOptions fields)")
    args = ap.parse_args()
    _, options = parse_config(f"cli:{args.options}")
    args.out.mkdir(parents=True, exist_ok=True)
    results, md = [], ["# Rule recovery on known domains", "",
                       "gap = held-out log-likelihood per transition of the true domain minus that of the "
                       "learned rules (nats); 25 % of steps are inapplicable actions.", "",
                       "| domain | transitions | seed | true | learned | gap | same contexts | learn time (s) |",
                       "|---|---|---|---|---|---|---|---|"]
    sides = []
    for name, source in sources().items():
        for n in args.sizes:
            for seed in range(args.seeds):
                r = recover(source, n, seed, args.test, options)
                print(f"{name} n={n} seed={seed}: true {r['true_ll']:.4f} learned {r['learned_ll']:.4f} "
                      f"gap {r['gap']:.4f} same contexts {r['same_contexts']} ({r['seconds']:.2f} s)", flush=True)
                md.append(f"| {name} | {n} | {seed} | {r['true_ll']:.4f} | {r['learned_ll']:.4f} | "
                          f"{r['gap']:.4f} | {r['same_contexts']} | {r['seconds']:.2f} |")
                if seed == 0 and n == max(args.sizes):
                    sides += ["", f"## {name}: contexts, {n} transitions, seed 0", ""]
                    sides += side_by_side(r["true_contexts"], r["learned_contexts"])
                results.append({"domain": name, **{k: v for k, v in r.items() if k != "learned"}})
    (args.out / "recovery.md").write_text("\n".join(md + sides) + "\n")
    (args.out / "recovery.json").write_text(json.dumps(results, indent=1, default=list) + "\n")
    _plot(results, args.out / "recovery.png")
    print(f"wrote {args.out}/recovery.md, recovery.json, recovery.png")


def _plot(results: list[dict], path: Path) -> None:
    """Every run's gap (dots) and the median per size (line), on a symmetric log scale."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    names = sorted({r["domain"] for r in results})
    for k, name in enumerate(names):
        rs = [r for r in results if r["domain"] == name]
        sizes = sorted({r["train"] for r in rs})
        shift = 1 + 0.04 * (k - (len(names) - 1) / 2)
        for n in sizes:
            g = [r["gap"] for r in rs if r["train"] == n]
            ax.scatter([n * shift] * len(g), g, s=10, alpha=0.5, color=f"C{k}")
        med = [float(np.median([r["gap"] for r in rs if r["train"] == n])) for n in sizes]
        ax.plot([n * shift for n in sizes], med, marker="o", color=f"C{k}", label=f"{name} (median)")
    ax.axhline(0.1, color="grey", ls="--", lw=1, label="target 0.1 nats")
    ax.set_xscale("log")
    ax.set_yscale("symlog", linthresh=1e-3)
    ax.set_ylim(top=2 * max(r["gap"] for r in results))
    sizes = sorted({r["train"] for r in results})
    ax.set_xticks(sizes, [str(n) for n in sizes])
    ax.minorticks_off()
    ax.set_xlabel("training transitions (25 % inapplicable actions)")
    ax.set_ylabel("held-out gap to the true domain\n(nats per transition)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
