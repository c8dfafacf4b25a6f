"""Names that go into PDDL files, and renaming predicates throughout a model directory.

Why here: a predicate or domain name is pasted into a PDDL file as is, so a name such as
``x) (:requirements`` would change the file's meaning. Every name a user gives (``--name``,
``--rename u1=inhand``, ``groundsym rename``) passes :func:`check_identifier` first.

Renaming works on the files' JSON documents (rules, reward, symbolic traces, symbols) and on the
readable ``rules.txt``, so every other field (provenance, fit statistics, covers) stays as it was.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path
from typing import Any, Mapping, Sequence

from ..errors import UserError
from ..identifiers import check_identifier
from ..fileio import atomic_write_json, atomic_write_text, read_json
from ..rules.model import Derived


def parse_renames(items: Sequence[str], what: str = "rename") -> dict[str, str]:
    """``["u1=inhand", "b1=on"]`` -> ``{"u1": "inhand", "b1": "on"}``, each side checked."""
    out: dict[str, str] = {}
    for item in items:
        old, sep, new = item.partition("=")
        if not sep:
            raise UserError(f"{what}: expected OLD=NEW, got {item!r}")
        check_identifier(old.strip(), f"{what} {item}")
        check_identifier(new.strip(), f"{what} {item}")
        old, new = old.strip(), new.strip()
        if old in out:
            raise UserError(f"{what}: {old} is renamed twice")
        out[old] = new
    return out


def check_renames(mapping: Mapping[str, str], predicates: Mapping[str, int], primitives: Sequence[str],
                  where: str, what: str = "rename") -> None:
    """Every old name is a predicate of the model; no new name is, to PDDL (which ignores case:
    :mod:`groundsym.identifiers`), a predicate that stays, another new name, a primitive (action)
    name or the name a derived predicate takes after the renaming (``on=stacked`` makes
    ``no-on-1`` ``no-stacked-1``; :func:`with_derived_names`)."""
    for old in mapping:
        if old not in predicates:
            raise UserError(f"{what}: {where} has no predicate {old!r} (predicates: {', '.join(sorted(predicates))})")
    after: dict[str, str] = {}                                       # lower-case name -> its predicate
    for p in sorted(predicates, key=lambda p: p in mapping):          # the new names last: they are named first
        name = mapping.get(p, p)
        first = after.setdefault(name.lower(), p)
        if first != p:
            other = mapping.get(first, first)
            pair = f"{name!r}" if other == name else f"{name!r} and {other!r}"
            raise UserError(f"{what}: two predicates would be called {pair}{_case_note(name, other)}")
    actions = {a.lower(): a for a in primitives}
    derived = {d.name.lower(): d for p, n in predicates.items() for d in Derived.for_predicates({mapping.get(p, p): n})}
    for new in mapping.values():
        if new.lower() in actions:
            raise UserError(f"{what}: {new!r} is the action {actions[new.lower()]!r} of {where}"
                            f"{_case_note(new, actions[new.lower()])}; choose another name")
        d = derived.get(new.lower())
        if d is not None:
            raise UserError(f"{what}: {new!r} is the predicate {d.name!r} derived from {d.base!r}"
                            f"{_case_note(new, d.name)}; choose another name")


def _case_note(name: str, other: str) -> str:
    return "" if name == other else " (one name in PDDL, which ignores case)"


def _pattern(mapping: Mapping[str, str]) -> re.Pattern:
    names = "|".join(re.escape(k) for k in sorted(mapping, key=len, reverse=True))
    return re.compile(rf"(?<=\()\s*({names})(?=[\s)])")


def rename_text(text: str, mapping: Mapping[str, str]) -> str:
    """Rename predicates in atom texts: ``(u1 ?x)`` -> ``(inhand ?x)``; other words are untouched."""
    if not mapping:
        return text
    return _pattern(mapping).sub(lambda m: mapping[m.group(1).strip()], text)


def _rename_doc(doc: Any, mapping: Mapping[str, str], keys: bool = False) -> Any:
    """Every atom text inside a JSON document renamed; ``predicates`` maps get renamed keys."""
    if isinstance(doc, str):
        return rename_text(doc, mapping) if "(" in doc else doc
    if isinstance(doc, list):
        return [_rename_doc(x, mapping) for x in doc]
    if isinstance(doc, dict):
        out = {}
        for k, v in doc.items():
            if k == "predicates" and isinstance(v, dict):
                out[k] = {mapping.get(p, p): n for p, n in v.items()}
            elif k == "provenance":
                out[k] = v                     # the command that made the file, as it was
            elif k == "derived" and isinstance(v, list):   # rules.json: a derived predicate's name is no atom text
                out[k] = [dict(_rename_doc(d, mapping), name=mapping.get(d["name"], d["name"]))
                          if isinstance(d, dict) and isinstance(d.get("name"), str) else _rename_doc(d, mapping)
                          for d in v]
            else:
                out[k] = _rename_doc(v, mapping)
        return out
    return doc


def _rename_symbols_doc(doc: Any, mapping: Mapping[str, str]) -> Any:
    if isinstance(doc, dict) and isinstance(doc.get("symbols"), list):
        doc = dict(doc)
        doc["symbols"] = [dict(s, name=mapping.get(s.get("name"), s.get("name"))) if isinstance(s, dict) else s
                          for s in doc["symbols"]]
    return doc


JSON_FILES = ("rules.json", "reward.json", "symbolic-traces.json")


def with_derived_names(mapping: Mapping[str, str]) -> dict[str, str]:
    """``mapping`` plus the derived predicates' names that follow their base predicate's
    (``on`` -> ``stacked``: ``no-on-1`` -> ``no-stacked-1``), named as :meth:`Derived.for_predicates`
    names them; the PPDDL export writes a derived literal through its base and reads it back under
    that name, so a renamed model must carry the renamed name."""
    out = dict(mapping)
    for old, new in mapping.items():
        for arity in (1, 2):
            for a, b in zip(Derived.for_predicates({old: arity}), Derived.for_predicates({new: arity})):
                out.setdefault(a.name, b.name)
    return out


def write_renamed(src: Path, dst: Path, mapping: Mapping[str, str]) -> None:
    """Copies of the model files of ``src`` in ``dst`` with predicates renamed (and the derived
    predicates named after them); files that hold no predicate names (``traces.json``, plots) are
    copied as they are."""
    mapping = with_derived_names(mapping)
    dst.mkdir(parents=True, exist_ok=True)
    for f in sorted(src.iterdir()):
        if f.is_dir() or f.name == "manifest.json":     # the manifest's checksums are of the old files
            continue
        if f.name in JSON_FILES:
            atomic_write_json(dst / f.name, _rename_doc(read_json(f), mapping),
                              indent=None if f.name == "symbolic-traces.json" else 1)
        elif f.name == "symbols.json":
            atomic_write_json(dst / f.name, _rename_symbols_doc(read_json(f), mapping), indent=1)
        elif f.name == "rules.txt":
            atomic_write_text(dst / f.name, rename_text(f.read_text(), mapping))
        else:
            shutil.copy2(f, dst / f.name)
