"""`physval check-case FILE...`: try a family file before running it.

It loads and validates the family (every variant's scene, duration, dt, needs and
checks), runs every variant for one step on the reference and calls the observer on that
one-step trajectory (it must give a value for every check, whatever an engine did), then
prints each closed form with its tolerance and reason, and which engines would run each
variant or skip it and why. Exit 0 when the file is usable, 2 with the first problem.

The same dry run (physval.core.dry_run) checks every user family (`--cases-dir`) before
`physval run` starts.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from adapters import registry
from cases.family import CaseError
from physval.commands import options
from physval.core.dry_run import dry_run


def add_parser(sub) -> None:
    p = sub.add_parser("check-case", help="validate a case family file and dry-run it before a real run",
                       formatter_class=argparse.RawDescriptionHelpFormatter,
                       description=__doc__.split("\n\n", 1)[1],
                       epilog="example:\n  physval check-case my_cases/second_bounce.py")
    p.add_argument("files", nargs="+", metavar="FILE", help="family files (*.py defining FAMILY)")
    p.add_argument("--adapter", action="append", metavar="MODULE:CLASS", help="also show this engine")


def run(args) -> int:
    from cases.registry import _families_in, _load_file, builtin_families, validate_family
    for text in args.files:
        file = Path(text)
        if not file.is_file() or file.suffix != ".py":
            raise options.UsageError(f"{text}: not a .py file")
        fams = _families_in(_load_file(file.resolve()), str(file))
        if not fams:
            raise CaseError(f"{file}: defines no FAMILY (a cases.family.CaseFamily)")
        for fam in fams:
            if fam.name in builtin_families():
                raise CaseError(f"{file}: family {fam.name!r} is already a built-in family: rename it")
            validate_family(fam, str(file), full=True)
            observed = dict(dry_run(fam, str(file), fam.all_variants))
            print(f"{file}: family {fam.name}: {len(fam.variants)} variants"
                  + (f" (+{len(fam.all_variants) - len(fam.variants)} with --full)" if fam.full_grid else "")
                  + f"; {fam.summary}")
            print(f"  closed form: {fam.source}")
            engines = {}
            for name in registry.engine_names(tuple(args.adapter or ())):
                try:
                    engines[name] = registry.get(name, tuple(args.adapter or ()))
                except registry.EngineError as exc:
                    engines[name] = exc
            for v in fam.all_variants:
                dt = fam.dt_for(v.params)
                scene = fam.scene(v.params)
                print(f"  [{v.id}]  dt {dt:g} s, {fam.duration(v.params):g} s, effects "
                      f"{','.join(sorted(scene.effects)) or 'none'}")
                for c in fam.expect(v.params, dt):
                    got = observed.get(v.id, {}).get(c.metric)
                    shown = f"{got:.6g}" if isinstance(got, (int, float)) and math.isfinite(got) else repr(got)
                    print(f"    {c.metric} = {c.expected:.6g} {c.unit} +- {c.tolerance:.3g} ({c.kind}): {c.why}"
                          f"  [one reference step: {shown}]")
                runs, skips = [], []
                for name, a in engines.items():
                    if isinstance(a, Exception):
                        continue
                    why = a.capabilities.cannot_run(scene, fam.needs_of(v.params)) or a.on_demand(scene)
                    (skips.append(f"{name}: {why}") if why else runs.append(name))
                print(f"    runs on: {', '.join(runs) or 'none'}")
                for s in skips:
                    print(f"    skips {s}")
            missing = [n for n, a in engines.items() if isinstance(a, Exception)]
            if missing:
                print(f"  not installed: {', '.join(missing)}")
    return 0
