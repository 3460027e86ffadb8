"""`physval run`: the validation run. Every selected case variant on every selected engine,
judged; the engine-wide readings when the whole library runs (or when asked), whose jobs
share the workers with the run's; the report, with where the time went (its Cost section).
`--plan` predicts the cost before anything runs.

Rows stream to `results.csv` as jobs finish. Run the same command again after an
interrupt and no finished job is recomputed (after a crash of the machine, at most the
jobs of its last second: physval.core.store.SYNC_EVERY); a change of the code or of an
engine's version makes its jobs run again.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from physval.commands import options
from physval.core import COLUMNS
from physval.core.plan import plan, relation_jobs
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
    run.add_argument("--relations", default="auto", metavar="LIST",
                     help="the invariance battery: relations (cases.relations: rotate_vertical, translate_1000m, "
                          "mirror, scale_4, body_order, as_hull, threads, worlds, save_restore, ...) to apply, "
                          "comma-separated, or all, none, auto (default: all when no --cases are named, each on "
                          "its representative scenes; else none). With --cases, each named relation runs on every "
                          "selected variant")
    run.add_argument("--plan", action="store_true",
                     help="print what the run will cost, per engine and family, predicted from measured per-job costs "
                          "(the last run in --out, else physval's table), against the default run's budget, and exit "
                          "without running")
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


def relations_of(text: str, cases_named: bool) -> list[str]:
    """The relations --relations names (its help)."""
    from cases.relations import RELATIONS
    every = [r.name for r in RELATIONS]
    names = [x.strip() for x in text.split(",") if x.strip()]
    if names == ["auto"]:
        return [] if cases_named else every
    if names == ["all"]:
        return every
    if names == ["none"]:
        return []
    bad = [n for n in names if n not in every]
    if bad or not names:
        raise options.UsageError(f"--relations {text!r}: {bad[0] + ' is not a relation; ' if bad else ''}"
                                 f"choose from {', '.join(every)}, all, none, auto")
    return names


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
    relations = relations_of(args.relations, args.cases is not None)
    if not args.scheduler and not args.plan:
        from physval.core.executor import start_fork_server
        start_fork_server(args.start_method, reference=options.steps_the_reference(args))  # loads beside what follows
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
    from physval.readings import cost
    model = cost.model_for(out)  # before the store drops the rows of changed code: their times still count
    price = cost.pricer(resolver, model)  # a job measured over the per-job limit waits for --on-demand
    keys = cache_keys(ctx, engines)
    store = RowStore(out / "results.csv", COLUMNS, knobs_file=out / KNOBS_FILE)
    reused = store.load(keys.of_row, rewrite=not args.plan)
    finished = frozenset(store.rows) | frozenset(store.verdicts_stale)  # spared by the per-job limit
    jobs, later = plan(chosen, engines, resolver, args.engines is not None, args.dt, args.iterations, args.on_demand,
                       price, finished)
    battery = relation_jobs(relations, engines, resolver, args.engines is not None,
                            chosen if args.cases is not None else None, args.dt, args.iterations, args.on_demand, price,
                            finished)
    jobs += battery
    if traj_dir is not None:
        from physval.core.trajectories import with_saving
        jobs = [with_saving(j, traj_dir) for j in jobs]
    from physval.core.session import judge_again
    rejudged = store.rejudge(jobs, judge_again(ctx), keys.of_job, write=not args.plan)  # known deviations edited
    reused += rejudged
    # the engines users run, with the reference at its default formulation; its other
    # formulations (Adapter.slow) are read when named
    wide = engines if args.engines is not None else [e for e in engines if e in options.fast_engines(ctx)]
    if args.plan:
        return print_plan(jobs, store, resolver, out, args.workers, readings, wide, model, later)
    say = options.teller(args)
    todo = sum(j.key not in store.rows for j in jobs)
    say(f"{len(jobs)} runs ({len(chosen)} families x {len(engines)} engines"
        + (f", {len(battery)} of them the invariance battery's" if battery else "") + f"), {todo} to run"
        + (f", {len(jobs) - todo} finished before" if reused and todo < len(jobs) else "")
        + (f" ({rejudged} of them judged again: known deviations edited)" if rejudged else "")
        + (f"; {len(later)} on-demand runs left out (--on-demand)" if later else "") + f" -> {out}/"
        + (f"; beside them the engine-wide readings: {', '.join(readings)} (cached per engine version)"
           if readings else ""))
    from physval.core.executor import default_start_method
    import_report_meanwhile(args.start_method or default_start_method())
    from physval.core.session import Execution, Stream, run_streams
    from physval.readings import effective, laws
    todo_jobs = [j for j in jobs if j.key not in store.rows]
    main = Stream(cost.longest_first(todo_jobs, resolver, model) + [j for j in jobs if j.key in store.rows],
                  store, keys.of_job, "run")
    wide_readings = {name: {"effective": effective, "laws": laws}[name].stream(wide, ctx, families) for name in readings}
    t_jobs = time.monotonic()
    use = run_streams([main, *wide_readings.values()], ctx, Execution.of(args))
    res = main.results
    phases = cost.Phases(planning_s=t_jobs - started, ahead_s=use.ahead_s, pool_s=use.wall_s, workers=use.workers,
                         jobs=main.spent.jobs, job_s=main.spent.job_s, compile_s=main.spent.compile_s,
                         run_s=main.spent.run_s,
                         stepping_s=main.spent.stepping_s,
                         reading_jobs=sum(r.spent.jobs for r in wide_readings.values()),
                         reading_s=sum(r.spent.job_s for r in wide_readings.values()), worker_cpu_s=use.worker_cpu_s,
                         job_cpu_s=main.spent.cpu_s + sum(r.spent.cpu_s for r in wide_readings.values()),
                         later=tuple(later))
    finished = [j for j in jobs if j.key in res.rows]
    after.update(store=store, keys=[j.key for j in finished], out=out, families=families, planned=len(jobs))
    interrupted = res.interrupted or next((r.results.interrupted for r in wide_readings.values()
                                           if r.results.interrupted), "")
    if interrupted:
        return incomplete(after, interrupted)
    rows = store.finalize(after["keys"])
    from physval.readings import results
    engine_wide = {name: r.value for name, r in wide_readings.items()}
    from physval.readings import scorecard
    engine_wide["beside"] = scorecard.companions(out)  # what sweep, stress and real left in their folders under out
    for why in engine_wide["beside"].left_out:
        print(f"physval: left out {why}", file=sys.stderr)
    from physval.core.deviations import release_notes, stale_entries
    from physval.readings.checks import frame, status_counts
    df = frame(rows, COLUMNS)
    phases.report_started = time.monotonic()
    results.write_run_report(rows, out, families, command=options.command_line(), engine_wide=engine_wide,
                            stale=stale_entries(df, resolver), releases=release_notes(df, resolver), phases=phases,
                            draw=results.draw_beside)
    t_report = time.monotonic() - phases.report_started
    total = time.monotonic() - started
    print(f"{len(df)} checks: {status_counts(df)} ({res.ran} runs now, {res.reused} reused; {total:.1f} s: "
          f"{phases.planning_s:.1f} s planning, "
          + f"{use.wall_s:.1f} s jobs and readings on {use.workers} workers ("
          + (f"{use.ahead_s:.1f} worker-s of it compiling ahead; " if use.ahead_s else "")
          + f"{_overhead_ms(phases):.1f} ms a job outside jobs, {_overhead_cpu_ms(phases):.1f} ms of CPU), "
          f"{t_report:.1f} s report)")
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


def _overhead_ms(p) -> float:
    n = p.jobs + p.reading_jobs
    return 1e3 * p.outside_s / n if n else 0.0


def _overhead_cpu_ms(p) -> float:
    n = p.jobs + p.reading_jobs
    return 1e3 * (p.worker_cpu_s - p.job_cpu_s) / n if n else 0.0


def print_plan(jobs, store, resolver, out, workers: int, readings: list[str], wide: list[str], model,
               later=()) -> int:
    """physval run --plan: the run's predicted cost, nothing run, and the runs left for
    --on-demand with why."""
    from physval.readings import cost
    todo = [j for j in jobs if j.key not in store.rows]
    planned = cost.plan(todo, resolver, model)
    note = ""
    if len(todo) < len(jobs):
        note = f"{len(jobs) - len(todo)} of {len(jobs)} jobs finished before (in {out / 'results.csv'}): not run again"
    if readings:
        note += ("; " if note else "") + (f"engine-wide readings ({', '.join(readings)}) on {len(wide)} engines: "
                                          "cached per engine version, run beside the jobs where not cached")
    print(cost.plan_text(planned, workers, model, note))
    if later:
        print(f"\n{len(later)} runs wait for --on-demand:")
        print(cost.left_out_text(later))
    return 0


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
