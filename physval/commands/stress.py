"""`physval stress`: the robustness battery, the stability map and the determinism check
(physval.readings.robustness)."""
from __future__ import annotations

import argparse
import sys
import time

from physval.core import COLUMNS, Job
from physval.core.session import Execution, run_stored
from physval.readings.robustness import (MAP, QUICK_MAP, TAG, determinism, stability_map,
                                         write_stress_report)
from physval.readings.checks import status_counts
from physval.commands import options


# --- command line ----------------------------------------------------------------------------

EPILOG = """examples:
  physval stress                                    default grids, a 60 Hz stability map, determinism
  physval stress --long                             every robustness scene (minutes to hours) and the full map
  physval stress --engines mujoco,pybullet --cases 'robustness_stacks*'
  physval stress --cases 'robustness_pile[6^3*]' --long --out /tmp/pile
exit codes: 0 the battery completed (failing physics is a result); 2 bad input; 74 the disk is full;
130 interrupted."""


def add_parser(subparsers):
    p = subparsers.add_parser(
        "stress", help="robustness battery, stability maps and determinism; writes stress_results.csv and stress_report.md",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Run the robustness scenes (tall stacks, pyramids, mass ratios, warm starting, overlap "
                    "recovery, tunnelling, piles, Newton's cradle, tiny and far bodies, degenerate landings) on "
                    "engines, judged by invariants; map the tallest stack each engine keeps standing as the step "
                    "rate and solver iterations vary; check that each engine repeats a run exactly. Writes "
                    "stress_results.csv (the columns of results.csv), stress_report.md (with a Stability "
                    "section), stability_map.csv, determinism.csv and plots/ into --out.")
    options.add_selection(p, "robustness scenes: families or FAMILY[VARIANT] (globs allowed), e.g. "
                         "'robustness_stacks' or 'robustness_pile[6^3*]' (default: every robustness family)",
                      "engines (default: every installed engine but the reference's slower formulations, "
                      "which run when named)")
    p.add_argument("--long", action="store_true",
                   help="also run the long variants (the full grids: 60 s rest, 20-box stacks, 210-box pyramids, "
                        "the 216-ball pile, 20 s cradle) and the full stability map (60-240 Hz, 5-50 iterations, "
                        "stacks up to 20); minutes to hours")
    p.add_argument("--no-map", action="store_true", help="skip the stability map")
    options.add_execution(p, "reports/stress", workers=1)
    return p


def run(args) -> int:
    """Run the battery, the stability map and the determinism check; write the report."""
    say = options.teller(args, "physval stress")

    ctx = options.context_of(args)
    resolver = ctx.resolver()
    families = {n: f for n, f in resolver.families.items() if TAG in f.tags}
    chosen = options.cases_of(args, resolver, families, full=args.long)
    engines = options.engines_of(args, ctx, options.fast_engines(ctx))
    out = options.held(args, options.output_folder(args.out))
    options.check_scheduler(args.scheduler)
    execution = Execution.of(args)
    jobs = [Job(f, v, e) for f, vs in chosen.items() for v in vs for e in engines]
    say(f"{len(jobs)} runs ({len(chosen)} families x {len(engines)} engines) -> {out}/")
    t0 = time.perf_counter()
    res, store = run_stored(jobs, ctx, out / "stress_runs.csv", COLUMNS, execution, label="stress")
    rows = [r for j in jobs for r in res.rows.get(j.key, [])]
    smap = det = None
    if res.complete:
        say(f"battery done in {time.perf_counter() - t0:.0f} s")
        if not args.no_map:
            grid = MAP if args.long else QUICK_MAP
            say(f"stability map: stacks of {grid['heights']} at {[round(1 / d) for d in grid['dts']]} Hz, "
                f"iterations {grid['iterations']}")
            smap = stability_map(engines, ctx, out, **grid, execution=execution)
        if smap is not None or args.no_map:
            say("determinism")
            det = determinism(engines, ctx, out, execution=execution)
    complete = res.complete and (smap is not None or args.no_map) and det is not None
    df = write_stress_report(rows, smap, det, out, command=options.command_line(), complete=complete)
    if not complete:
        print("physval stress: interrupted; run the same command again to finish", file=sys.stderr)
        return 130
    print(f"{len(df)} checks: {status_counts(df)}")
    print(f"wrote {out / 'stress_results.csv'}, {out / 'stress_report.md'}")
    return 0
