"""The `physval` command line."""
from __future__ import annotations

import argparse
import math
import os
import re
import shlex
import sys
from collections import Counter
from fnmatch import fnmatchcase
from pathlib import Path

EPILOG = """examples:
  physval run                                   every case on every engine, report in reports/
  physval run --cases central_impact --engines reference,mujoco
  physval run --cases "incline_threshold[mu=0.5*]" --dt 5e-3 --out /tmp/incline
  physval list                                  case families, variants, effects, engines
  physval list --engines                        engines and their capabilities
exit codes: 0 the run completed (failing physics is a result, not a crash); 2 bad input."""


class UsageError(ValueError):
    """Bad input on the command line: one line, exit code 2."""


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error: the message and where to find help."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _names(values: list[str] | None) -> list[str]:
    out = []
    for v in values or []:
        out += [x.strip() for x in v.split(",") if x.strip()]
    return out


def _positive_float(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(x) and x > 0):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number > 0")
    return x


def _positive_int(text: str) -> int:
    try:
        x = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if x < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: must be >= 1")
    return x


def parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="physval", formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Validate rigid-body contact physics: run analytic cases on physics engines and "
                    "report how far each is from the closed-form answer.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    ls = sub.add_parser("list", help="list case families and engines",
                        description="List case families (variants, effects, which engines can run them), "
                                    "or with --engines one engine per line with its capabilities.")
    ls.add_argument("--engines", action="store_true", help="list engines and their capabilities")
    ls.add_argument("--cases-dir", metavar="DIR", help="also load case families from *.py files in DIR")

    run = sub.add_parser("run", help="run cases on engines and write results.csv, report.md, plots",
                         formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
                         description="Run case variants on engines; write results.csv, report.md and "
                                     "plots/ into --out. Failing physics is a result (exit 0).")
    run.add_argument("--cases", nargs="+", metavar="NAME",
                     help="case families (default: all); NAME[VARIANT-GLOB] selects variants, "
                          "e.g. 'central_impact[drop*]'; comma-separated lists work too")
    run.add_argument("--engines", nargs="+", metavar="NAME", help="engines (default: all; see 'physval list --engines')")
    run.add_argument("--dt", type=_positive_float, metavar="DT", help="time step in s for every case (default: each family's own)")
    run.add_argument("--iterations", type=_positive_int, metavar="N", help="solver iterations (default: each adapter's stated default)")
    run.add_argument("--out", default="reports", metavar="DIR", help="output folder (default: reports)")
    run.add_argument("--cases-dir", metavar="DIR", help="also load case families from *.py files in DIR")
    run.add_argument("--workers", type=_positive_int, default=os.cpu_count() or 1, metavar="N",
                     help="parallel processes (default: one per core; use 1 for undisturbed wall_s timings, "
                          "or better, physval sweep / physval bench for cost)")
    run.add_argument("--no-effective", action="store_true",
                     help="skip measuring the restitution and friction each engine really produces")
    run.add_argument("--no-laws", action="store_true",
                     help="skip the physics-law residuals of each engine's contact forces (physval/laws.py)")
    run.add_argument("--quiet", action="store_true", help="no progress bar")

    sw = sub.add_parser("sweep", help="error against cost as the time step and solver iterations vary",
                        formatter_class=argparse.RawDescriptionHelpFormatter,
                        description="For each case family (its sweep variants) and engine, vary dt over "
                                    "1/60 .. 1e-4 s and solver iterations over 1 .. 50; record every check's "
                                    "error and the wall time of stepping per simulated second. Writes sweep.csv "
                                    "(streamed: re-running with the same arguments skips finished points), "
                                    "sweep_points.csv, sweep_summary.csv, sweep_report.md and plots/ into --out.",
                        epilog="examples:\n"
                               "  physval sweep                                   core families, all engines, local processes\n"
                               "  physval sweep --cases incline_threshold --engines reference,mujoco --workers 2\n"
                               "  physval sweep --scheduler tcp://127.0.0.1:8786  on a running Dask cluster")
    sw.add_argument("--cases", nargs="+", metavar="NAME",
                    help="case families (default: the core three: central_impact, incline_threshold, resting_blocks)")
    sw.add_argument("--engines", nargs="+", metavar="NAME",
                    help="engines (default: all installed, the reference with its default formulation; "
                         "name reference-pgs, reference-spook, ... to sweep the other formulations)")
    sw.add_argument("--workers", type=_positive_int, default=os.cpu_count() or 1, metavar="N",
                    help="local worker processes (default: one per core)")
    sw.add_argument("--scheduler", metavar="ADDRESS", help="run on an existing Dask distributed cluster instead")
    sw.add_argument("--full", action="store_true", help="the whole dt x iterations grid instead of two axes")
    sw.add_argument("--repeats", type=_positive_int, default=3, metavar="N",
                    help="timing repeats per point; the minimum counts (default 3)")
    sw.add_argument("--out", default="reports/sweep", metavar="DIR", help="output folder (default: reports/sweep)")
    sw.add_argument("--cases-dir", metavar="DIR", help="also load case families from *.py files in DIR")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")

    from physval import stress
    stress.add_parser(sub)

    bn = sub.add_parser("bench", help="speed side by side in one run, as ratios (not a test)",
                        description="Benchmarks measured side by side in one run: sweep throughput with 1 and "
                                    "2 workers; step time of a 5-box stack and a 10-layer pyramid on every "
                                    "engine against the reference; the reference PGS sweep cost against the "
                                    "number of contacts. Writes bench.md and bench_*.csv into --out.")
    bn.add_argument("what", nargs="*", metavar="WHAT", help="sweep-workers, step, pgs (default: all)")
    bn.add_argument("--engines", nargs="+", metavar="NAME",
                    help="engines (default: all installed, the reference with its default formulation)")
    bn.add_argument("--out", default="reports/bench", metavar="DIR", help="output folder (default: reports/bench)")
    return p


def select_cases(families: dict, specs: list[str]) -> tuple[dict, dict]:
    """(families, variant globs) for --cases specs; raises UsageError for unknown names."""
    if not specs:
        return families, {}
    chosen, globs = {}, {}
    for spec in specs:
        m = re.fullmatch(r"(\w+)(?:\[(.+)\])?", spec)
        if not m or m[1] not in families:
            raise UsageError(f"unknown case {spec!r}: choose from {', '.join(families)}")
        chosen[m[1]] = families[m[1]]
        if m[2]:
            globs.setdefault(m[1], []).append(m[2])
            if not any(fnmatchcase(v.id, m[2]) for v in families[m[1]].variants):
                raise UsageError(f"case {spec!r}: no variant of {m[1]} matches {m[2]!r} "
                                 f"(variants: {', '.join(v.id for v in families[m[1]].variants)})")
    return chosen, globs


def cmd_list(args) -> int:
    from adapters import registry
    from physval.runner import families as all_families
    if args.engines:
        for name in registry.engine_names():
            try:
                a = registry.get(name)
                print(f"{name}\t{a.version()}\t{a.capabilities.describe()}")
            except registry.EngineError as exc:
                print(f"{name}\tnot installed\t{exc}")
        return 0
    fams = all_families(args.cases_dir)
    adapters = {}
    for name in registry.engine_names():
        try:
            adapters[name] = registry.get(name)
        except registry.EngineError:
            pass
    for fam in fams.values():
        print(f"{fam.name}: {fam.summary}")
        print(f"  closed form: {fam.source}; default dt {fam.dt:g} s" if not callable(fam.dt) else
              f"  closed form: {fam.source}; dt per variant")
        for v in fam.variants:
            scene = fam.scene(v.params)
            can = [n for n, a in adapters.items() if a.capabilities.cannot_run(scene, fam.needs_of(v.params)) is None]
            print(f"  [{v.id}]  effects: {','.join(sorted(scene.effects))}  engines: {','.join(can) or 'none'}")
    return 0


def cmd_run(args) -> int:
    from adapters import registry
    from adapters.base import Settings
    from physval.report import write_report
    from physval.runner import default_jobs, families as all_families, plan, run_jobs

    families = all_families(args.cases_dir)
    families, globs = select_cases(families, _names(args.cases))
    engines = _names(args.engines) or registry.engine_names()
    for e in engines:
        if e not in registry.ENGINES:
            raise UsageError(f"unknown engine {e!r}: choose from {', '.join(registry.ENGINES)}")
    if args.dt is not None:
        Settings(dt=args.dt)  # validates the range once, with a message naming dt
    if args.cases:  # named cases run on every named engine
        jobs = [j for j in plan(families, engines, args.dt, args.iterations)
                if j.family not in globs or any(fnmatchcase(j.variant.id, g) for g in globs[j.family])]
    else:
        jobs = default_jobs(families, engines, args.dt, args.iterations)
    out = Path(args.out)
    print(f"physval: {len(jobs)} runs ({len(families)} families x {len(engines)} engines) -> {out}/", file=sys.stderr)
    rows = run_jobs(jobs, families, workers=args.workers, cases_dir=args.cases_dir,
                    progress=not args.quiet and sys.stderr.isatty())
    effective = []
    if not args.no_effective:
        from physval.effective import measure
        # the engines users run, with the reference at its default formulation; the other
        # formulations (pure Python, seconds per incline run) are measured when named
        measured = [e for e in engines if args.engines or not e.startswith("reference-")]
        for eng in measured:
            print(f"physval: measuring the restitution and friction {eng} really produces", file=sys.stderr)
            effective += measure(eng)
    law_rows = []
    if not args.no_laws:
        from physval import laws
        for eng in [e for e in engines if args.engines or not e.startswith("reference-")]:
            print(f"physval: physics-law residuals of {eng}'s contact forces", file=sys.stderr)
            law_rows += laws.measure(eng, families)
    command = "physval " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    write_report(rows, out, command=command, effective=effective, laws=law_rows,
                 cross_engine={n for n, f in families.items() if f.cross_engine})
    counts = Counter(r["status"] for r in rows)
    print(f"{len(rows)} checks: " + ", ".join(f"{n} {s}" for s, n in counts.most_common()))
    print(f"wrote {out / 'results.csv'}, {out / 'report.md'}, {out / 'plots'}/")
    return 0


CORE_FAMILIES = ("central_impact", "incline_threshold", "resting_blocks")


def cmd_sweep(args) -> int:
    from adapters import registry
    from physval.runner import families as all_families
    from physval.sweep import Store, run_sweep, sweep_points
    from physval.tradeoff import write_sweep_report
    import pandas as pd

    fams = all_families(args.cases_dir)
    names = _names(args.cases) or [n for n in CORE_FAMILIES if n in fams]
    for n in names:
        if n not in fams:
            raise UsageError(f"unknown case {n!r}: choose from {', '.join(fams)}")
    # default: every installed engine with the reference's default formulation; the other
    # formulations (pure Python, up to seconds a step at dt = 1e-4) are swept when named
    engines = _names(args.engines) or [e for e in registry.engine_names()
                                       if not e.startswith("reference-") and registry.available(e)]
    for e in engines:
        if e not in registry.ENGINES:
            raise UsageError(f"unknown engine {e!r}: choose from {', '.join(registry.ENGINES)}")
    chosen = {n: fams[n] for n in names}
    points = sweep_points(chosen, engines, full=args.full)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    store = Store(out / "sweep.csv", fams)
    print(f"physval sweep: {len(points)} points ({len(chosen)} families x {len(engines)} engines), "
          f"{len([p for p in points if p.key not in store.done])} to run -> {out}/", file=sys.stderr)
    run_sweep(points, fams, store, workers=args.workers, scheduler=args.scheduler, cases_dir=args.cases_dir,
              progress=not args.quiet and sys.stderr.isatty(), repeats=args.repeats)
    df = pd.read_csv(out / "sweep.csv", keep_default_na=False, na_values=["nan", "NaN", ""])
    df = df[df.point.isin({p.key for p in points})]
    command = "physval " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    write_sweep_report(df, fams, out, command=command)
    print(f"wrote {out / 'sweep.csv'}, {out / 'sweep_report.md'}, {out / 'plots'}/")
    return 0


def cmd_bench(args) -> int:
    from adapters import registry
    from physval import bench
    engines = _names(args.engines) or [e for e in registry.engine_names()
                                       if not e.startswith("reference-") and registry.available(e)]
    for e in engines:
        if e not in registry.ENGINES:
            raise UsageError(f"unknown engine {e!r}: choose from {', '.join(registry.ENGINES)}")
    what = args.what or ["sweep-workers", "step", "pgs"]
    unknown = [w for w in what if w not in ("sweep-workers", "step", "pgs")]
    if unknown:
        raise UsageError(f"unknown benchmark {unknown[0]!r}: choose from sweep-workers, step, pgs")
    sections, notes = {}, {}
    if "sweep-workers" in what:
        print("physval bench: the same sweep with 1 and with 2 workers", file=sys.stderr)
        sections["sweep-workers"] = bench.sweep_workers([e for e in engines if e in ("reference", "pybullet", "mujoco")])
        notes["sweep-workers"] = "central_impact's sweep points on reference, pybullet and mujoco; throughput relative to one worker."
    if "step" in what:
        print("physval bench: step time side by side", file=sys.stderr)
        sections["step"] = bench.steps_side_by_side(engines)
        notes["step"] = "Minimum over 2 repeats of the mean wall time per step over 20 steps at dt = 1e-3 (10 warm-up steps; the 55-box pyramid costs up to 0.8 s a step); `reference / X` is how many times slower the reference is."
    if "pgs" in what:
        print("physval bench: PGS sweep cost against contact count", file=sys.stderr)
        sections["pgs"] = bench.pgs_scaling()
        notes["pgs"] = bench.PGS_NOTE
    bench.write(Path(args.out), sections, notes)
    print(f"wrote {Path(args.out) / 'bench.md'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    from adapters.base import SettingsError
    from adapters.registry import EngineError
    from cases.family import CaseError
    from cases.scene import SceneError
    p = parser()
    args = p.parse_args(argv)
    if args.command is None:
        p.print_help()
        return 0
    try:
        if args.command == "stress":
            from physval import stress
            return stress.run(args)
        return {"list": cmd_list, "run": cmd_run, "sweep": cmd_sweep, "bench": cmd_bench}[args.command](args)
    except (UsageError, CaseError, SceneError, SettingsError, EngineError) as exc:
        print(f"physval: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("physval: interrupted; files already written are complete", file=sys.stderr)
        return 130
