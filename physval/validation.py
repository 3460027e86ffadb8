"""`physval run`: the validation run. Every selected case variant on every selected engine,
judged; the engine-wide readings when the whole library runs (or when asked); the report.

Rows stream to `results.csv` as jobs finish. Run the same command again after an
interrupt (or a crash of the machine) and no finished job is recomputed; a change of the
code or of an engine's version makes its jobs run again.
"""
from __future__ import annotations

import sys
import time

from physval import cli
from physval.core import COLUMNS, Job, run_jobs
from physval.core.selection import select_variants
from physval.core.store import RowStore, cache_keys

READINGS = ("effective", "laws")

HELP_CASES = ("case families or variants: NAME, a glob, or NAME[VARIANT] (an exact variant id or a glob), "
              "space- or comma-separated, e.g. 'central_impact[drop,e=0.5]' (default: every family)")
HELP_ENGINES = ("engines: names or globs, e.g. 'reference-*' (default: every installed engine; the slow "
                "pure-Python reference formulations then run the core families only)")


def add_parser(sub) -> None:
    run = sub.add_parser(
        "run", help="run cases on engines and write results.csv, report.md, plots",
        formatter_class=cli.argparse.RawDescriptionHelpFormatter, epilog=cli.EPILOG,
        description="Run case variants on engines; write results.csv (streamed as jobs finish), report.md and "
                    "plots/ into --out. Failing physics is a result (exit 0). Running the same command again "
                    "resumes: finished jobs are not recomputed unless the code or an engine changed.")
    cli.add_selection(run, HELP_CASES, HELP_ENGINES)
    run.add_argument("--dt", type=cli.positive_float, metavar="DT", help="time step in s for every case (default: each family's own)")
    run.add_argument("--iterations", type=cli.positive_int, metavar="N", help="solver iterations (default: each adapter's stated default)")
    run.add_argument("--full", action="store_true", help="also each family's full grid (long or many-body variants)")
    run.add_argument("--on-demand", action="store_true",
                     help="also the runs an engine declares too slow for a default run (minutes each)")
    run.add_argument("--readings", default="auto", metavar="LIST",
                     help="engine-wide readings: effective (asked-vs-measured restitution and friction), laws "
                          "(physics-law residuals of the contact forces), all, none, or auto (default: all when no "
                          "--cases are named, else none); cached per engine version and reused")
    run.add_argument("--save-trajectories", metavar="DIR",
                     help="also write each job's trajectory and contact forces (npz; physval.trajectories.load)")
    cli.add_execution(run, "reports")
    run.set_defaults(func=cmd_run)


def plan(chosen: dict, engines: list[str], resolver, engines_named: bool, dt=None, iterations=None,
         on_demand: bool = False) -> tuple[list[Job], list[Job]]:
    """(jobs to run, jobs left out as on demand). An engine with `default_tags` runs only
    families with one of those tags (and the variants whose compliant contact law it
    models), unless it was named; a job the adapter declares on demand runs only when asked."""
    jobs, later = [], []
    for name, variants in chosen.items():
        fam = resolver.family(name)
        for v in variants:
            scene = None
            for eng in engines:
                job = Job(name, v, eng, dt, iterations)
                try:
                    adapter = resolver.adapter(eng)
                except Exception:
                    jobs.append(job)  # not installed: its rows say so
                    continue
                if scene is None:
                    scene = fam.scene(v.params)
                if not engines_named and adapter.default_tags is not None and not (fam.tags & adapter.default_tags):
                    laws = scene.contact_laws
                    if not (laws and laws <= adapter.capabilities.contact_laws):
                        continue
                if not on_demand and adapter.on_demand(scene):
                    later.append(job)
                    continue
                jobs.append(job)
    return jobs, later


def readings_of(text: str, cases_named: bool) -> list[str]:
    names = [x.strip() for x in text.split(",") if x.strip()]
    if names == ["auto"]:
        return [] if cases_named else list(READINGS)
    if names == ["all"]:
        return list(READINGS)
    if names == ["none"]:
        return []
    bad = [n for n in names if n not in READINGS]
    if bad or not names:
        raise cli.UsageError(f"--readings {text!r}: choose from {', '.join(READINGS)}, all, none, auto")
    return names


def cmd_run(args) -> int:
    started = cli.STARTED
    if not args.scheduler:
        from physval.core.executor import start_fork_server
        start_fork_server(args.start_method)  # loads in parallel with what follows
    ctx = cli.context_of(args)
    resolver = ctx.resolver()
    families = resolver.families
    from physval.checkcase import dry_run_user_families
    dry_run_user_families(ctx)
    chosen = select_variants(families, args.cases, full=args.full)
    engines = cli.engines_of(args, ctx)
    if args.dt is not None:
        from adapters.base import Settings
        Settings(dt=args.dt)  # validates the range once, with a message naming dt
    readings = readings_of(args.readings, args.cases is not None)
    out = cli.output_folder(args.out)
    traj_dir = cli.output_folder(args.save_trajectories) if args.save_trajectories else None
    cli.check_scheduler(args.scheduler)
    jobs, later = plan(chosen, engines, resolver, args.engines is not None, args.dt, args.iterations, args.on_demand)
    if traj_dir is not None:
        from physval.trajectories import with_saving
        jobs = [with_saving(j, traj_dir) for j in jobs]
    keys = cache_keys(ctx, engines)
    store = RowStore(out / "results.csv", COLUMNS)
    reused = store.load(lambda row: keys.get(row["engine"], ""))
    say = (lambda text: None) if args.quiet else (lambda text: print(f"physval: {text}", file=sys.stderr))
    todo = sum(j.key not in store.rows for j in jobs)
    say(f"{len(jobs)} runs ({len(chosen)} families x {len(engines)} engines), {todo} to run"
        + (f", {len(jobs) - todo} finished before" if reused and todo < len(jobs) else "")
        + (f"; {len(later)} on-demand runs left out (--on-demand)" if later else "") + f" -> {out}/")
    from physval.core.executor import default_start_method
    import_report_meanwhile(args.start_method or default_start_method())
    t_jobs = time.monotonic()
    res = run_jobs(jobs, ctx, args.workers, args.scheduler, args.job_timeout, args.start_method, store=store,
                   cache_key=lambda e: keys[e], progress=not args.quiet, label="run")
    t_jobs = time.monotonic() - t_jobs
    finished = [j for j in jobs if j.key in res.rows]
    rows = store.finalize([j.key for j in finished])
    from physval import report
    if not res.complete:
        report.write_run_report(rows, out, families, command=cli.command_line(), complete=False,
                                planned=len(jobs))
        print(f"physval: interrupted ({res.interrupted}): {len(finished)} of {len(jobs)} runs kept in "
              f"{out / 'results.csv'}; run the same command again to finish", file=sys.stderr)
        return 130
    engine_wide = {}
    from physval.core.session import Execution
    from physval.readings import effective, laws
    # the engines users run, with the reference at its default formulation; the slow
    # pure-Python formulations (Adapter.slow) are read when named
    wide = engines if args.engines is not None else [e for e in engines if e in cli.fast_engines(ctx)]
    for name in readings:
        say(f"engine-wide reading: {name} (cached per engine version)")
        module = {"effective": effective, "laws": laws}[name]
        part = module.measure(wide, ctx, families, execution=Execution.of(args))
        if part is None:  # interrupted
            return 130
        engine_wide[name] = part
    from physval.known import stale_entries
    from physval.reportkit import frame, status_counts
    df = frame(rows, COLUMNS)
    report.write_run_report(rows, out, families, command=cli.command_line(), engine_wide=engine_wide,
                            stale=stale_entries(df, resolver))
    total = time.monotonic() - started
    print(f"{len(df)} checks: {status_counts(df)} ({res.ran} runs now, {res.reused} reused; {total:.1f} s, "
          f"of which {t_jobs:.1f} s ({t_jobs / total:.0%}) in the selected runs)")
    print(f"wrote {out / 'results.csv'}, {out / 'report.md'}, {out / 'plots'}/")
    return 0


def import_report_meanwhile(start_method: str) -> None:
    """Import the report's modules (pandas and matplotlib: ~0.55 s) in a thread while the
    jobs run, instead of after them. Not under the fork start method: a worker forked while
    the thread holds an import lock would inherit the lock held."""
    if start_method != "fork":
        import threading

        def load():
            from physval import report, reportkit  # noqa: F401 (pandas)
            reportkit.pyplot()
        threading.Thread(target=load, name="import the report's modules", daemon=True).start()
