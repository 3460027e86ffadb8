"""`physval parity ENGINE PORT`: the same scenes on an engine and its port (MuJoCo C and
MuJoCo Warp), check by check in units of the checks' tolerances and trajectory by
trajectory to the step where the two part (physval.readings.parity)."""
from __future__ import annotations

import argparse

from physval.commands import options

EPILOG = """examples:
  physval parity mujoco mujoco-warp --cases central_impact resting_blocks
  physval parity mujoco mujoco-warp --workers 2     (into reports/parity/mujoco-mujoco-warp)
exit codes: 0 completed (differences are a result); 2 bad input; 130 interrupted (finished
jobs kept in --out; the same command resumes)."""


OUT = "reports/parity/ENGINE-PORT"  # the default --out: one folder a pair, where `physval run` reads it


def add_parser(sub) -> None:
    p = sub.add_parser(
        "parity", help="an engine and its port on the same scenes: check and trajectory differences",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Run the selected families on ENGINE and PORT through the same job loop, saving every "
                    "trajectory, and report per family each check's difference (PORT minus ENGINE) in units of "
                    "the check's tolerance (at the narrower float width of the two), the verdicts that differ, and the step at which each pair of "
                    "trajectories parts (some state differs by more than --parted of the job's scale). Writes parity.md, parity.csv, parting.csv, the run's "
                    "results.csv and trajectories/ into --out; `physval run` puts each pair found in reports/parity/ "
                    "into its report.")
    p.add_argument("engine", metavar="ENGINE", help="the original engine (e.g. mujoco)")
    p.add_argument("port", metavar="PORT", help="its port (e.g. mujoco-warp)")
    p.add_argument("--cases", nargs="+", metavar="SPEC",
                   help="families or variants (the --cases grammar of `physval run`; default: every family)")
    p.add_argument("--cases-dir", action="append", metavar="DIR",
                   help="also load case families from *.py files in DIR (repeatable)")
    p.add_argument("--adapter", action="append", metavar="MODULE:CLASS",
                   help="also use this engine adapter (repeatable)")
    p.add_argument("--full", action="store_true", help="also the families' full grids")
    p.add_argument("--on-demand", action="store_true",
                   help="also the runs an engine declares too slow for a default run (Newton's solvers beyond "
                        "their core families: physval parity mujoco newton-mujoco --on-demand)")
    from physval.readings.parity import PARTED
    p.add_argument("--parted", type=options.positive_float, default=PARTED, metavar="FRACTION",
                   help=f"two trajectories part where a state differs by more than FRACTION of the job's scale "
                        f"(default {PARTED:g}: 1 mm on a scene of a metre, above float32 rounding)")
    options.add_execution(p, OUT)


def shared_scene(resolver, family: str, variant, engines: list[str]) -> bool:
    """Every one of `engines` can represent the variant's scene (by its capabilities)."""
    fam = resolver.family(family)
    scene, needs = fam.scene(variant.params), fam.needs_of(variant.params)
    return all(resolver.adapter(e).capabilities.cannot_run(scene, needs) is None for e in engines)


def run(args) -> int:
    import sys
    import time
    from pathlib import Path

    from physval.core import COLUMNS, run_jobs
    from physval.core.plan import plan
    from physval.core.store import KNOBS_FILE, RowStore, cache_keys
    from physval.core.trajectories import file_name, with_saving
    from physval.readings import parity
    from physval.readings.checks import frame
    ctx = options.context_of(args)
    resolver = ctx.resolver()
    chosen = options.cases_of(args, resolver, full=args.full)
    engines = [args.engine, args.port]
    for name in engines:
        options.engines_of(argparse.Namespace(engines=[name]), ctx)  # unknown, or outside its supported releases
        resolver.adapter(name)  # not installed: one line, exit 2, before any job
    if args.engine == args.port:
        raise options.UsageError(f"ENGINE and PORT are both {args.engine!r}: name two engines")
    if not any(shared_scene(resolver, f, v, engines) for f, vs in chosen.items() for v in vs):
        raise options.UsageError(f"{args.engine} and {args.port} share no scene among the selected cases: every "
                                 "variant is one that at most one of them can represent (`physval list` shows which "
                                 "engines run each variant)")
    out = options.held(args, options.output_folder(OUT.replace("ENGINE-PORT", f"{args.engine}-{args.port}")
                                                   if args.out == OUT else args.out))
    options.check_scheduler(args.scheduler)
    traj = out / "trajectories"
    from physval.readings import cost
    jobs, _ = plan(chosen, engines, resolver, True, on_demand=args.on_demand,
                   price=cost.pricer(resolver, cost.model_for(None)))
    jobs = [with_saving(j, traj) for j in jobs]
    keys = cache_keys(ctx, engines)
    store = RowStore(out / "results.csv", COLUMNS, knobs_file=out / KNOBS_FILE)
    store.load(keys.of_row)
    say = options.teller(args)
    say(f"{len(jobs)} runs ({len(chosen)} families x 2 engines) -> {out}/")
    started = time.monotonic()
    res = run_jobs(jobs, ctx, args.workers, args.scheduler, args.job_timeout, args.start_method, store=store,
                   cache_key=keys.of_job, progress=not args.quiet, label="parity")
    rows = store.finalize([j.key for j in jobs if j.key in res.rows])
    if not res.complete:
        print(f"physval: interrupted ({res.interrupted}): finished runs kept in {out / 'results.csv'}; run the "
              "same command again to finish", file=sys.stderr)
        return 130
    df = frame(rows, COLUMNS)
    threshold = args.parted
    by_variant = {}
    for j in jobs:
        by_variant.setdefault((j.family, j.variant.id), {})[j.engine] = traj / file_name(j)
    pairs = [(case, variant, Path(p[args.engine]), Path(p[args.port]))
             for (case, variant), p in by_variant.items() if len(p) == 2]
    table = parity.checks(df, args.engine, args.port)
    parts = parity.parting(pairs, threshold)
    versions = {e: resolver.adapter(e).version() for e in engines}
    written = parity.write(out, table, parts, args.engine, args.port, threshold, options.command_line(), versions)
    d = table.difference.abs()
    judged = (f"median |difference| {d.median():.3g} tolerances, {int((d > 1).sum())} beyond one" if d.notna().any()
              else "none judged on both")
    print(f"{len(table)} checks on both, {judged}, {int(table.verdicts_differ.sum())} verdicts differ; "
          f"{int(parts.parted_step.notna().sum())} of {int(parts.steps.notna().sum())} trajectory pairs part "
          f"({time.monotonic() - started:.1f} s)")
    print(f"wrote {', '.join(str(p) for p in written)}")
    return 0
