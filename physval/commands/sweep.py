"""`physval sweep`: what accuracy costs. Error against cost as the time step and the solver
iterations vary (physval.readings.sweep)."""
from __future__ import annotations

import argparse
import sys

from physval.core.session import Execution, run_stored
from physval.readings.sweep import REPEATS, SWEEP_COLUMNS, points, sweep_variants, write_report
from physval.commands import options


# --- the command --------------------------------------------------------------------------

def add_parser(sub) -> None:
    sw = sub.add_parser(
        "sweep", help="error against cost as the time step and solver iterations vary",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="For each case family (its sweep variants) and engine, vary dt over 1/60 .. 1e-4 s and solver "
                    "iterations over 1 .. 50; record every check's error and the wall time of stepping per simulated "
                    "second. Writes sweep.csv (streamed: re-running with the same arguments skips finished points), "
                    "sweep_points.csv, sweep_summary.csv, sweep_report.md and plots/ into --out.",
        epilog="examples:\n"
               "  physval sweep                                   core families, installed engines, local workers\n"
               "  physval sweep --cases incline_threshold --engines reference,mujoco --workers 2\n"
               "  physval sweep --scheduler tcp://127.0.0.1:8786  on a running Dask cluster")
    options.add_selection(sw, "case families or variants (default: the families tagged core)",
                      "engines (default: every installed engine but the reference's slower formulations; name "
                      "reference-pgs, reference-spook, ... to sweep those)")
    sw.add_argument("--full", action="store_true", help="the whole dt x iterations grid instead of two axes")
    sw.add_argument("--repeats", type=options.positive_int, default=REPEATS, metavar="N",
                    help=f"timing repeats per point; the minimum counts (default {REPEATS})")
    options.add_execution(sw, "reports/sweep")


def run(args) -> int:
    ctx = options.context_of(args)
    resolver = ctx.resolver()
    fams = resolver.families
    chosen = options.cases_of(args, resolver)  # without --cases every family (a broken user file stops it)
    if args.cases is None:
        chosen = sweep_variants(fams, [n for n in chosen if "core" in fams[n].tags])
    else:
        chosen = {n: [v for v in vs if v.id in (fams[n].sweep_variants or (fams[n].variants[0].id,))] or vs
                  for n, vs in chosen.items()}
    engines = options.engines_of(args, ctx, options.fast_engines(ctx))
    out = options.held(args, options.output_folder(args.out))
    options.check_scheduler(args.scheduler)
    # engines named with --engines sweep every chosen variant, those run only on demand included
    jobs = points(chosen, engines, resolver, full=args.full, repeats=args.repeats, named=args.engines is not None)
    if not jobs:
        raise options.UsageError(f"the selection has no sweep point: no selected engine ({', '.join(engines)}) can run "
                             f"the selected variants ({', '.join(chosen)})")
    say = options.teller(args, "physval sweep")
    say(f"{len(jobs)} points ({len(chosen)} families x {len(engines)} engines) -> {out}/")
    res, store = run_stored(jobs, ctx, out / "sweep.csv", SWEEP_COLUMNS, Execution.of(args), label="sweep")
    say(f"{res.ran} points run, {res.reused} finished before")
    finished = [j for j in jobs if j.key in res.rows]
    rows = store.finalize([j.key for j in finished])
    write_report(rows, fams, out, command=options.command_line(), complete=res.complete)
    if not res.complete:
        print(f"physval sweep: interrupted ({res.interrupted}); run the same command again to finish", file=sys.stderr)
        return 130
    print(f"wrote {out / 'sweep.csv'}, {out / 'sweep_report.md'}, {out / 'plots'}/")
    return 0
