"""Rule files: ``rules.json`` (``groundsym.rules/1``, read and written) and the readable ``rules.txt``.

The JSON file is the model; the text file is for people (one block per rule: action, context,
outcomes with probabilities, noise). Reading validates everything a planner relies on (atoms
parse, variables are bound, probabilities are in [0, 1] and sum to 1) and names the file and the
field in its one-line error.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from ..docreader import DocReader
from ..fileio import atomic_write_json, atomic_write_text, read_json
from ..identifiers import check_names
from ..logic import is_variable, parse_atom
from ..ppddl.compare import same_rule_key
from .model import DefaultRule, Derived, Outcome, Rule, RuleSet

SCHEMA = "groundsym.rules/1"
SUM_TOL = 1e-6


def rules_to_doc(rs: RuleSet, *, predicates: Mapping[str, int] | None = None,
                 primitives: Mapping[str, int] | None = None, covers: Mapping[int, int] | None = None,
                 options: Mapping[str, Any] | None = None, provenance: Mapping[str, Any] | None = None
                 ) -> dict[str, Any]:
    """The JSON document of a rule set; ``covers[i]`` = training transitions rule ``i`` covers."""
    doc: dict[str, Any] = {"schema": SCHEMA}
    if provenance:
        doc["provenance"] = dict(provenance)
    if predicates is not None:
        doc["predicates"] = dict(sorted(predicates.items()))
    if primitives is not None:
        doc["primitives"] = dict(sorted(primitives.items()))
    doc["p_min"] = rs.p_min
    doc["p_min_default"] = rs.p_min_default
    doc["injective"] = rs.injective
    if rs.derived:       # "(on ?x _)": holds for ?x when no such atom does (an atom text: rename renames it)
        doc["derived"] = [{"name": d.name, "holds_when_no": _derived_text(d)} for d in rs.derived]
    if options:
        doc["options"] = dict(options)
    doc["defaults"] = [{"action": a, "p_noise": d.p_noise} for a, d in rs.defaults]
    rules = []
    for i, r in enumerate(rs.rules):
        rd: dict[str, Any] = {"action": str(r.action), "context": [str(l) for l in r.context],
                              "outcomes": [{"probability": p, "changes": [str(c) for c in o.changes]}
                                           for o, p in zip(r.outcomes, r.probs)],
                              "noise": r.noise, "noise_changes": r.noise_changes}
        if covers is not None:
            rd["covers"] = int(covers.get(i, 0))
        rules.append(rd)
    doc["rules"] = rules
    return doc


def write_rules(path: str | Path, rs: RuleSet, **kw: Any) -> None:
    atomic_write_json(path, rules_to_doc(rs, **kw))


def doc_to_rules(doc: Any, path: str | Path = "<rules>") -> tuple[RuleSet, dict[str, Any]]:
    """Parse and validate a rules document; returns the rule set and the rest (meta) of the file."""
    f = DocReader(path)
    if not isinstance(doc, dict):
        raise f.fail("document", "expected a JSON object")
    schema = f.get(doc, "schema", "", str)
    if schema != SCHEMA:
        raise f.fail("schema", f"expected {SCHEMA!r}, got {schema!r}")
    preds = f.arities(doc, "predicates", default=None)
    prims = f.arities(doc, "primitives", default=None)
    p_min = f.prob(f.get(doc, "p_min", "", (int, float)), "p_min")
    p_min_def = f.prob(f.get(doc, "p_min_default", "", (int, float)), "p_min_default")
    injective = f.get(doc, "injective", "", bool, True)
    derived = tuple(_derived(f, d, f"derived[{i}]", preds) for i, d in enumerate(f.get(doc, "derived", "", list, [])))
    check_names([d.name for d in derived], f"{path}: derived")
    _check_actions_are_no_predicates(f, prims, preds)
    if preds is not None:
        preds = {**preds, **{d.name: d.arity for d in derived}}
    defaults = []
    for i, d in enumerate(f.get(doc, "defaults", "", list)):
        name = f.get(d, "action", f"defaults[{i}]", str)
        defaults.append((name, DefaultRule(f.prob(f.get(d, "p_noise", f"defaults[{i}]", (int, float)),
                                                  f"defaults[{i}].p_noise"))))
    rules = tuple(_rule(f, rd, f"rules[{i}]", preds, prims) for i, rd in enumerate(f.get(doc, "rules", "", list)))
    _check_no_duplicates(f, rules)
    meta = {k: v for k, v in doc.items() if k not in ("schema", "rules", "defaults")}
    meta["covers"] = [rd.get("covers") for rd in doc["rules"]]
    return RuleSet(rules, tuple(defaults), p_min, p_min_def, injective, derived), meta


def _check_actions_are_no_predicates(f: DocReader, prims: Mapping[str, int] | None,
                                     preds: Mapping[str, int] | None) -> None:
    """An action named as a predicate, up to case, is refused as ``rename`` refuses it: an
    exported domain would give one PDDL name two meanings."""
    folded = {p.lower(): p for p in preds or ()}
    for a in prims or ():
        if a.lower() in folded:
            raise f.fail("primitives", f"{a!r} is also the predicate {folded[a.lower()]!r}"
                                       f"{'' if a == folded[a.lower()] else ' (one name in PDDL, which ignores case)'}")


def _check_no_duplicates(f: DocReader, rules: tuple[Rule, ...]) -> None:
    """A rule given twice (up to its variables' names) is refused: both copies cover the same
    states, so neither covers any, and the model's score silently falls (docs/reliability.md)."""
    first: dict[tuple, int] = {}
    for k, rule in enumerate(rules):
        j = first.setdefault(same_rule_key(rule), k)
        if j != k:
            raise f.fail(f"rules[{k}]", f"the same rule as rules[{j}] (action, context and outcomes, up to the "
                                        "names of variables): neither would cover any state; remove one")


def _derived_text(d: Derived) -> str:
    """The base atom a derived predicate denies, ``?x`` at the kept position: ``(on ?x _)``."""
    args = ["?x" if i in d.keep else "_" for i in range(d.base_arity)]
    return f"({d.base} {' '.join(args)})"


def _derived(f: DocReader, d: Any, field: str, preds: Mapping[str, int] | None) -> Derived:
    name = f.get(d, "name", field, str)
    text = f.get(d, "holds_when_no", field, str)
    try:
        atom = parse_atom(text)
    except ValueError as exc:
        raise f.fail(f"{field}.holds_when_no", str(exc)) from None
    keep = tuple(i for i, a in enumerate(atom.args) if a == "?x")
    if any(a not in ("?x", "_") for a in atom.args) or len(keep) > 1 or not atom.args:
        raise f.fail(f"{field}.holds_when_no", f"expected an atom over ?x (at most once) and _, got {text!r}")
    if preds is not None and preds.get(atom.predicate) != atom.arity:
        raise f.fail(f"{field}.holds_when_no", f"{atom.predicate!r} is not a declared predicate of arity {atom.arity}")
    if preds is not None and name in preds:
        raise f.fail(f"{field}.name", f"{name!r} is a declared predicate")
    check_names([name], f"{f.path}: {field}.name", taken=preds or ())
    return Derived(name, atom.predicate, atom.arity, keep)


def _rule(f: DocReader, rd: Any, field: str, preds: Mapping[str, int] | None,
          prims: Mapping[str, int] | None) -> Rule:
    text = f.get(rd, "action", field, str)
    try:
        action = parse_atom(text)
    except ValueError as exc:
        raise f.fail(f"{field}.action", str(exc)) from None
    f.check_arity(action, f"{field}.action", prims)
    if not all(map(is_variable, action.args)) or len(set(action.args)) != len(action.args):
        raise f.fail(f"{field}.action", f"expected distinct ?variables as arguments, got {text}")
    context = tuple(f.literal(t, f"{field}.context[{k}]", preds)
                    for k, t in enumerate(f.get(rd, "context", field, list)))
    variables = set(action.args) | {a for l in context for a in l.atom.args}
    outs, probs = [], []
    for k, od in enumerate(f.get(rd, "outcomes", field, list)):
        of = f"{field}.outcomes[{k}]"
        probs.append(f.prob(f.get(od, "probability", of, (int, float)), f"{of}.probability"))
        changes = tuple(f.literal(t, f"{of}.changes[{j}]", preds) for j, t in enumerate(f.get(od, "changes", of, list)))
        for j, c in enumerate(changes):
            unbound = [a for a in c.atom.args if a not in variables]
            if unbound:
                raise f.fail(f"{of}.changes[{j}]", f"{unbound[0]} is neither an action argument nor in the context")
        outs.append(Outcome(changes))
    noise = f.prob(f.get(rd, "noise", field, (int, float)), f"{field}.noise")
    total = sum(probs) + noise
    if abs(total - 1.0) > SUM_TOL:
        raise f.fail(f"{field}.outcomes", f"probabilities and noise sum to {total:.6g}, not 1")
    nc = f.get(rd, "noise_changes", field, (int, float), 0.0)
    return Rule(action, context, tuple(outs), tuple(probs), noise, float(nc))


def read_rules(path: str | Path) -> tuple[RuleSet, dict[str, Any]]:
    return doc_to_rules(read_json(path), path)


def _fmt_p(p: float) -> str:
    return f"{p:.3f}" if p >= 1e-3 else f"{p:.1e}"


def rules_to_text(rs: RuleSet, covers: Mapping[int, int] | None = None, title: str = "") -> str:
    """Readable rules: one block per rule (action, context, outcomes with probabilities, noise)."""
    lines = [f"# {title or 'NID rules'}: {len(rs.rules)} rules; p_min {rs.p_min:g}, "
             f"default rule p_min {rs.p_min_default:g}", ""]
    for d in rs.derived:
        head = f"({d.name} ?x)" if d.keep else f"({d.name})"
        lines.append(f"derived: {head} holds when no {_derived_text(d)} does")
    if rs.derived:
        lines.append("")
    for i, r in enumerate(rs.rules):
        cov = f"    ({covers.get(i, 0)} training transitions)" if covers is not None else ""
        lines.append(f"rule {i + 1}: {r.action}{cov}")
        if covers is not None and not covers.get(i, 0):
            lines.append("  exception: in the training data it covers only where another rule of this action "
                         "covers too;\n  there neither applies and the default rule does")
        lines.append(f"  context:  {' '.join(str(l) for l in r.context) if r.context else '(always)'}")
        if r.deictic:
            lines.append(f"  references: {', '.join(r.deictic)} (each must match exactly one object)")
        lines.append("  outcomes:")
        order = sorted(range(len(r.outcomes)), key=lambda k: -r.probs[k])
        for k in order:
            lines.append(f"    {_fmt_p(r.probs[k]):>8}  {r.outcomes[k]}")
        lines.append(f"    {_fmt_p(r.noise):>8}  noise (mean {r.noise_changes:.2f} atoms changed when it happened)")
        lines.append("")
    for name, d in rs.defaults:
        lines.append(f"default rule for {name}: no change {_fmt_p(d.p_nochange)}, noise {_fmt_p(d.p_noise)}")
    return "\n".join(lines).rstrip() + "\n"


def write_rules_text(path: str | Path, rs: RuleSet, covers: Mapping[int, int] | None = None, title: str = "") -> None:
    atomic_write_text(path, rules_to_text(rs, covers, title))
