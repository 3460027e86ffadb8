"""`physval run`: the validation run. Every selected case variant on every selected engine,
judged; the engine-wide readings when the whole library runs (or when asked); the report.

Rows stream to `results.csv` as jobs finish. Run the same command again after an
interrupt (or a crash of the machine) and no finished job is recomputed; a change of the
code or of an engine's version makes its jobs run again.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from physval.commands import options
from physval.core import COLUMNS, run_jobs
from physval.core.plan import plan
from physval.core.store import KNOBS_FILE, RowStore, cache_keys
from physval.interrupts import Terminated, held_off

READINGS = ("effective", "laws")

EPILOG = """examples:
  physval run                                   every case on every installed engine, report in reports/
  physval run --cases central_impact --engines reference,mujoco
  physval run --cases "incline_threshold[mu=0.5*]" --dt 5e-3 --out /tmp/incline
  physval run --cases-dir my_cases --cases second_bounce
  physval run --engines mujoco --junitxml physval.xml --fail-on fail,error,unstable,changed   an engine's CI gate
exit codes: 0 the run completed (failing physics is a result); 1 a check fell under --fail-on;
2 bad input; 74 the disk is full or read-only and 130 interrupted (finished jobs are kept
in both; the same command resumes)."""

HELP_CASES = ("case families or variants: NAME, a glob, or NAME[VARIANT] (an exact variant id or a glob), "
              "space- or comma-separated, e.g. 'central_impact[drop,e=0.5]' (default: every family)")
HELP_ENGINES = ("engines: names or globs, e.g. 'reference-*' (default: every installed engine; Drake's "
                "approximations other than 'drake' and MuJoCo Warp then run the core families only)")


def add_parser(sub) -> None:
    run = sub.add_parser(
        "run", help="run cases on engines and write results.csv, report.md, plots",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Run case variants on engines; write results.csv (streamed as jobs finish), report.md and "
                    "plots/ into --out. Failing physics is a result (exit 0). Running the same command again "
                    "resumes: finished jobs are not recomputed unless the code or an engine changed.")
    options.add_selection(run, HELP_CASES, HELP_ENGINES)
    run.add_argument("--dt", type=options.positive_float, metavar="DT", help="time step in s for every case (default: each family's own)")
    run.add_argument("--iterations", type=options.positive_int, metavar="N", help="solver iterations (default: each adapter's stated default)")
    run.add_argument("--full", action="store_true", help="also each family's full grid (long or many-body variants)")
    run.add_argument("--on-demand", action="store_true",
                     help="also the runs an engine declares too slow for a default run (minutes each)")
    run.add_argument("--readings", default="auto", metavar="LIST",
                     help="engine-wide readings: effective (asked-vs-measured restitution and friction), laws "
                          "(physics-law residuals of the contact forces), all, none, or auto (default: all when no "
                          "--cases are named, else none); cached per engine version and reused")
    run.add_argument("--save-trajectories", metavar="DIR",
                     help="also write each job's trajectory and contact forces (npz; physval.core.trajectories.load)")
    run.add_argument("--junitxml", metavar="FILE",
                     help="also write every check as a JUnit XML test case (fail: <failure>; error, unstable: <error>; "
                          "deviation, unsupported: <skipped>), for an engine's CI")
    run.add_argument("--fail-on", metavar="LIST", default="",
                     help="exit with 1 if any check is one of these (comma-separated): fail, error, unstable, "
                          "deviation, unsupported, changed (a known deviation that left its band), vanished (a known "
                          "deviation that now passes); default: none (exit 0 whatever the physics)")
    options.add_execution(run, "reports")


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
        raise options.UsageError(f"--readings {text!r}: choose from {', '.join(READINGS)}, all, none, auto")
    return names


def run(args) -> int:
    """The run; an interrupt (Ctrl-C or SIGTERM) once jobs have run, in them, in the
    engine-wide readings or in the report, keeps the finished rows and leaves the report
    marked incomplete (`incomplete`)."""
    after = {}  # what an interrupted run keeps: its store, its finished jobs, its folder
    try:
        return _run(args, after)
    except KeyboardInterrupt as exc:
        if not after:
            raise
        return incomplete(after, "SIGTERM" if isinstance(exc, Terminated) else "SIGINT")


def incomplete(after: dict, signal_name: str) -> int:
    """The finished rows and the report marked incomplete, written with further interrupts
    held off (a second Ctrl-C waits the second it takes); one line; exit code 130."""
    from physval.readings import results
    out, planned = after["out"], after["planned"]
    with held_off():
        rows = after["store"].finalize(after["keys"])
        results.write_run_report(rows, out, after["families"], command=options.command_line(), complete=False,
                                 planned=planned)
    print(f"physval: interrupted ({signal_name}): {len(after['keys'])} of {planned} runs kept in "
          f"{out / 'results.csv'}, the report marked incomplete; run the same command again to finish",
          file=sys.stderr)
    return 130


def _run(args, after: dict) -> int:
    started = args.started
    if not args.scheduler:
        from physval.core.executor import start_fork_server
        start_fork_server(args.start_method)  # loads in parallel with what follows
    ctx = options.context_of(args)  # user families dry-run in workers
    resolver = ctx.resolver()
    families = resolver.families
    chosen = options.cases_of(args, resolver, full=args.full)
    engines = options.engines_of(args, ctx)
    if args.dt is not None:
        from adapters.base import Settings
        Settings(dt=args.dt)  # validates the range once, with a message naming dt
    readings = readings_of(args.readings, args.cases is not None)
    fail_on = fail_on_of(args.fail_on)
    junit = options.output_file(args.junitxml, "--junitxml") if args.junitxml is not None else None
    out = options.held(args, options.output_folder(args.out))
    junit_beside(junit, out)
    traj_dir = None if args.save_trajectories is None else options.output_folder(args.save_trajectories,
                                                                                  "--save-trajectories")
    options.check_scheduler(args.scheduler)
    jobs, later = plan(chosen, engines, resolver, args.engines is not None, args.dt, args.iterations, args.on_demand)
    if traj_dir is not None:
        from physval.core.trajectories import with_saving
        jobs = [with_saving(j, traj_dir) for j in jobs]
    keys = cache_keys(ctx, engines)
    store = RowStore(out / "results.csv", COLUMNS, knobs_file=out / KNOBS_FILE)
    reused = store.load(keys.of_row)
    say = options.teller(args)
    todo = sum(j.key not in store.rows for j in jobs)
    say(f"{len(jobs)} runs ({len(chosen)} families x {len(engines)} engines), {todo} to run"
        + (f", {len(jobs) - todo} finished before" if reused and todo < len(jobs) else "")
        + (f"; {len(later)} on-demand runs left out (--on-demand)" if later else "") + f" -> {out}/")
    from physval.core.executor import default_start_method
    import_report_meanwhile(args.start_method or default_start_method())
    t_jobs = time.monotonic()
    res = run_jobs(jobs, ctx, args.workers, args.scheduler, args.job_timeout, args.start_method, store=store,
                   cache_key=keys.of_job, progress=not args.quiet, label="run")
    t_jobs = time.monotonic() - t_jobs
    finished = [j for j in jobs if j.key in res.rows]
    after.update(store=store, keys=[j.key for j in finished], out=out, families=families, planned=len(jobs))
    if not res.complete:
        return incomplete(after, res.interrupted)
    rows = store.finalize(after["keys"])
    from physval.readings import results
    engine_wide = {}
    from physval.core.session import Execution
    from physval.readings import effective, laws
    # the engines users run, with the reference at its default formulation; its other
    # formulations (Adapter.slow) are read when named
    wide = engines if args.engines is not None else [e for e in engines if e in options.fast_engines(ctx)]
    for name in readings:
        say(f"engine-wide reading: {name} (cached per engine version)")
        module = {"effective": effective, "laws": laws}[name]
        part = module.measure(wide, ctx, families, execution=Execution.of(args))
        if part is None:  # interrupted
            raise KeyboardInterrupt
        engine_wide[name] = part
    from physval.readings import scorecard
    engine_wide["beside"] = scorecard.companions(out)  # what sweep, stress and real left in their folders under out
    for why in engine_wide["beside"].left_out:
        print(f"physval: left out {why}", file=sys.stderr)
    from physval.core.deviations import stale_entries
    from physval.readings.checks import frame, status_counts
    df = frame(rows, COLUMNS)
    results.write_run_report(rows, out, families, command=options.command_line(), engine_wide=engine_wide,
                            stale=stale_entries(df, resolver))
    total = time.monotonic() - started
    print(f"{len(df)} checks: {status_counts(df)} ({res.ran} runs now, {res.reused} reused; {total:.1f} s, "
          f"of which {t_jobs:.1f} s ({t_jobs / total:.0%}) in the selected runs)")
    print(f"wrote {out / 'results.csv'}, {out / KNOBS_FILE}, {out / 'report.md'}, {out / 'report.html'}, {out / 'plots'}/")
    from physval.readings import junit as junit_report
    if junit is not None:
        print(f"wrote {junit_report.write(rows, junit)}")
    tripped = junit_report.gate(rows, fail_on)
    if tripped:
        print(f"physval: --fail-on {args.fail_on}: " + ", ".join(f"{n} {g}" for g, n in sorted(tripped.items())),
              file=sys.stderr)
        return 1
    return 0


def junit_beside(junit: Path | None, out: Path) -> None:
    """--junitxml inside --out must be a *.xml file: the run writes none, so it cannot be
    one of the run's own files (results.csv, the report), which it would overwrite after."""
    if junit is not None and junit.resolve().is_relative_to(out.resolve()) and junit.suffix != ".xml":
        raise options.UsageError(f"--junitxml {junit}: inside --out {out}, name a .xml file (e.g. {out / 'physval.xml'}): "
                                 "the run's own files are there")


def fail_on_of(text: str) -> set[str]:
    from physval.readings.junit import GATES
    names = {x.strip() for x in text.split(",") if x.strip()}
    if text.strip() and not names:
        raise options.UsageError(f"--fail-on {text!r}: names no category; choose from {', '.join(GATES)}")
    bad = sorted(names - set(GATES))
    if bad:
        raise options.UsageError(f"--fail-on {text!r}: {bad[0]!r} is not one of {', '.join(GATES)}")
    return names


def import_report_meanwhile(start_method: str) -> None:
    """Import the report's modules (pandas and matplotlib: ~0.55 s) in a thread while the
    jobs run, instead of after them. Not under the fork start method: a worker forked while
    the thread holds an import lock would inherit the lock held."""
    if start_method != "fork":
        import threading

        def load():
            from physval import report  # noqa: F401 (pandas)
            from physval.readings import results  # noqa: F401 (matplotlib's users)
            report.pyplot()
        threading.Thread(target=load, name="import the report's modules", daemon=True).start()
