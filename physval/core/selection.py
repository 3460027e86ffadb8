"""One grammar for choosing cases and engines, shared by every command.

Cases: `--cases SPEC ...`, each SPEC a family name or glob, optionally with a variant in
brackets: `central_impact`, `robustness_*`, `central_impact[drop,e=0.5]` (an exact variant
id, commas and all), `incline_threshold[mu=0.5*]` (a glob). Several specs go space- or
comma-separated; commas inside brackets belong to the variant.

Engines: `--engines NAME ...`, names or globs (`reference-*`), the same way.

A spec that selects nothing, or an option given with nothing in it, is an error naming
what there is to choose from; so is an unknown engine.
"""
from __future__ import annotations

import re
from fnmatch import fnmatchcase

from cases.family import CaseFamily, Variant


class SelectionError(ValueError):
    """A selection that names nothing or something unknown; one line with the choices."""


def split(values: list[str] | None) -> list[str]:
    """Items of space- or comma-separated lists; commas inside [...] belong to a variant."""
    return [x.strip() for v in values or [] for x in re.split(r",(?![^\[]*\])", v) if x.strip()]


def _matches(name: str, pattern: str) -> bool:
    return name == pattern or fnmatchcase(name, pattern)


def select_variants(families: dict[str, CaseFamily], values: list[str] | None, option: str = "--cases",
                    full: bool = False, unusable=()) -> dict[str, list[Variant]]:
    """Family name -> chosen variants. `values` None: every family, every variant (the
    grid; `full`: with the full grid). `unusable`: the user files that could not be loaded
    (cases.registry.Problem); a selection that may need one raises SelectionError with its
    line: every family, a spec naming its family, or one naming nothing (when the file
    failed before its family's name was known)."""
    def variants(fam):
        return list(fam.all_variants if full else fam.variants)

    if values is None:
        if unusable:
            raise SelectionError(unusable[0].message)
        return {n: variants(f) for n, f in families.items()}
    specs = split(values)
    if not specs:
        raise SelectionError(f"{option} {' '.join(values)!r} names no case: choose from {', '.join(families)}")
    chosen: dict[str, list[Variant]] = {}
    for spec in specs:
        m = re.fullmatch(r"([^\[\]]+)(?:\[(.*)\])?", spec)
        if not m:
            raise SelectionError(f"{option} {spec!r}: write FAMILY or FAMILY[VARIANT] (globs allowed)")
        named = [p for p in unusable if p.family and _matches(p.family, m[1])]
        if named:
            raise SelectionError(named[0].message)
        names = [n for n in families if _matches(n, m[1])]
        if not names:
            unnamed = "".join(f"; not loaded: {p.message}" for p in unusable if not p.family)
            raise SelectionError(f"unknown case {spec!r}: choose from {', '.join(families)}{unnamed}")
        for name in names:
            pool = variants(families[name])
            if m[2] is None:
                hits = pool
            else:
                exact = [v for v in pool if v.id == m[2]]
                hits = exact or [v for v in pool if fnmatchcase(v.id, m[2])]
            if not hits and len(names) == 1:
                raise SelectionError(f"{option} {spec!r}: no variant of {name} matches {m[2]!r} "
                                     f"(variants: {', '.join(v.id for v in pool)})")
            have = chosen.setdefault(name, [])
            have += [v for v in hits if v not in have]
        if not any(chosen.get(n) for n in names):
            raise SelectionError(f"{option} {spec!r}: selects no variant")
    return {n: vs for n, vs in chosen.items() if vs}


def select_engines(values: list[str] | None, known: list[str], default: list[str],
                   option: str = "--engines") -> list[str]:
    """Engine names: `default` when `values` is None, else the named ones (globs allowed)."""
    if values is None:
        return list(default)
    specs = split(values)
    if not specs:
        raise SelectionError(f"{option} {' '.join(values)!r} names no engine: choose from {', '.join(known)}")
    out: list[str] = []
    for spec in specs:
        hits = [e for e in known if _matches(e, spec)]
        if not hits:
            raise SelectionError(f"unknown engine {spec!r}: choose from {', '.join(known)}")
        out += [e for e in hits if e not in out]
    return out
