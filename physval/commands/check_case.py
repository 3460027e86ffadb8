"""`physval check-case FILE...`: try a family file before running it.

It loads and validates the family (every variant's scene, duration, dt, needs and
checks), runs every variant for one step on the reference and calls the observer on that
one-step trajectory (it must give a finite number for every check, whatever an engine
did), then prints each closed form with its tolerance and reason, and which engines would
run each variant or skip it and why. Exit 0 when the file is usable, 2 with the first
problem (one line naming the file and the family[variant]).

The file is first loaded and dry-run in worker processes (physval.core.dry_run), so an
exit, a crash or a hang in its code is that one line too, not the end of physval; the
same dry run checks every user family (`--cases-dir`) before any other command uses it.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from adapters import registry
from cases.family import CaseError
from physval.commands import options
from physval.core import dry_run
from physval.core.plan import leaves_out


def add_parser(sub) -> None:
    p = sub.add_parser("check-case", help="validate a case family file and dry-run it before a real run",
                       formatter_class=argparse.RawDescriptionHelpFormatter,
                       description=__doc__.split("\n\n", 1)[1],
                       epilog="example:\n  physval check-case my_cases/second_bounce.py")
    p.add_argument("files", nargs="+", metavar="FILE", help="family files (*.py defining FAMILY)")
    p.add_argument("--adapter", action="append", metavar="MODULE:CLASS", help="also show this engine")
    p.add_argument("--job-timeout", type=options.seconds_or_off, default=dry_run.DRY_RUN_TIMEOUT, metavar="S",
                   help=f"time limit of loading the file and of each variant's one-step run "
                        f"(default and at most {dry_run.DRY_RUN_TIMEOUT:g} s)")


def run(args) -> int:
    from cases.registry import builtin_families, load_file
    files = []
    for text in args.files:
        file = Path(text)
        if not options.is_a("check-case", text, Path.is_file) or file.suffix != ".py":
            raise options.UsageError(f"{text}: not a .py file")
        files.append((file.resolve(), text))
    from physval.core.executor import start_fork_server
    start_fork_server(reference=True)  # the dry run's workers start from it: it loads while the engines are imported here
    ctx = options.context_of(args)  # an --adapter is tried in a worker too
    engines = {}
    for name in registry.engine_names(ctx.adapters):
        try:
            engines[name] = registry.get(name, ctx.adapters)
        except registry.EngineError as exc:
            engines[name] = exc
    tried = dry_run.try_files(files, dry_run.execution_of(args))
    for t in tried:
        if t.problem:
            raise CaseError(t.problem)
        if t.family in builtin_families():
            raise CaseError(f"{t.file}: family {t.family!r} is already a built-in family: rename it")
    for (path, file), t in zip(files, tried):
        fam = load_file(path, file)  # in this process, now that it was tried
        print(f"{file}: family {fam.name}: {len(fam.variants)} variants"
              + (f" (+{len(fam.all_variants) - len(fam.variants)} with --full)" if fam.full_grid else "")
              + f"; {fam.summary}")
        print(f"  closed form: {fam.source}")
        for v in fam.all_variants:
            dt = fam.dt_for(v.params)
            scene = fam.scene(v.params)
            print(f"  [{v.id}]  dt {dt:g} s, {fam.duration(v.params):g} s, effects "
                  f"{','.join(sorted(scene.effects)) or 'none'}")
            for c in fam.expect(v.params, dt):
                got = t.observed.get(v.id, {}).get(c.metric)
                shown = f"{got:.6g}" if got is not None else "not run (the reference cannot represent the scene)"
                print(f"    {c.metric} = {c.expected:.6g} {c.unit} +- {c.tolerance:.3g} ({c.kind}): {c.why}"
                      f"  [one reference step: {shown}]")
            runs, skips = [], []
            for name, a in engines.items():
                if isinstance(a, Exception):
                    continue
                why = (a.capabilities.cannot_run(scene, fam.needs_of(v.params))
                       or leaves_out(a, fam.tags, scene, named=True))
                (skips.append(f"{name}: {why}") if why else runs.append(name))
            print(f"    runs on: {', '.join(runs) or 'none'}")
            for s in skips:
                print(f"    skips {s}")
        missing = [n for n, a in engines.items() if isinstance(a, Exception)]
        if missing:
            print(f"  not installed: {', '.join(missing)}")
    return 0
