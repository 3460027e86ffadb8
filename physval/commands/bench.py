"""`physval bench`: speed side by side in one run, as ratios (physval.readings.bench)."""
from __future__ import annotations

import argparse
import os
from dataclasses import replace

from physval.core.executor import START_METHODS
from physval.core.selection import select_variants
from physval.core.session import Execution
from physval.readings import bench, oracle
from physval.readings.bench import (ON_DEMAND, WHAT, compile_cost, default_run, fault_matrix, narrow_phase_rate,
                                     overhead, pgs_scaling, steps_side_by_side, sweep_workers, write)
from adapters import registry
from physval.commands import options


def add_parser(sub) -> None:
    bn = sub.add_parser("bench", help="speed side by side in one run, as ratios (not a test)",
                        description=bench.__doc__.split("\n\n", 1)[1].split("\n\nEvery")[0],
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    bn.add_argument("what", nargs="*", metavar="WHAT",
                    help=f"{', '.join(WHAT)} (default: all but {', '.join(ON_DEMAND)}, which runs the whole default "
                         "run twice, cold and warm)")
    options.add_engines(bn, "engines: names or globs (default: all installed, the reference with its default "
                            "formulation)")
    bn.add_argument("--cases", nargs="+", metavar="SPEC",
                    help="faults and run only: these families or variants (the --cases grammar; default for "
                         "faults: every family but the robustness ones; for run: every family)")
    bn.add_argument("--out", default="reports/bench", metavar="DIR", help="output folder (default: reports/bench)")
    bn.add_argument("--workers", type=options.positive_int, default=os.cpu_count() or 1, metavar="N",
                    help="faults and run only: worker processes for the planted engines' jobs and for the "
                         "default run (default: one per core; the timings run one at a time)")
    bn.add_argument("--scheduler", metavar="ADDRESS", help=argparse.SUPPRESS)
    bn.add_argument("--job-timeout", type=options.seconds_or_off, default=1800.0, metavar="S",
                    help="per-job time limit (default 1800 s; the 55-box pyramid is slow on pure-Python engines)")
    bn.add_argument("--start-method", choices=START_METHODS, help="how local workers start")
    bn.add_argument("--quiet", action="store_true", help="no progress")


def run(args) -> int:
    ctx = options.context_of(args)
    engines = options.engines_of(args, ctx, options.fast_engines(ctx))
    what = args.what or [w for w in WHAT if w not in ON_DEMAND]
    unknown = [w for w in what if w not in WHAT]
    if unknown:
        raise options.UsageError(f"unknown benchmark {unknown[0]!r}: choose from {', '.join(WHAT)}")
    if "oracle" in what and not oracle.available():
        raise options.UsageError('benchmark \'oracle\' needs Pinocchio: pip install "physval[oracle]" (the pin package)')
    out = options.held(args, options.output_folder(args.out))
    execution = Execution(1, None, args.job_timeout, args.start_method, not args.quiet)
    say = options.teller(args, "physval bench")

    def faults():
        from physval.faults import ENGINES
        chosen = select_variants(ctx.resolver().families, args.cases) if args.cases else None
        return fault_matrix(engines if args.engines else [e for e in engines if e in ENGINES], ctx,
                            replace(execution, workers=args.workers), families=chosen)

    benchmarks = {
        "overhead": ("the core's recorded step against a bare step", lambda: overhead(engines, ctx, execution)),
        "step": ("step time side by side", lambda: steps_side_by_side(engines, ctx, execution)),
        "compile": ("the reference formulations' compilation, cold and cached", lambda: compile_cost(
            options.engines_of(args, ctx) if args.engines else registry.engine_names(ctx.adapters), ctx, execution)),
        "sweep-workers": ("the same sweep with 1 and with 2 workers", lambda: sweep_workers(
            [e for e in engines if e in ("reference", "pybullet", "mujoco")], ctx)),
        "pgs": ("PGS sweep cost against contact count", pgs_scaling),
        "narrow": ("narrow-phase queries per second on the narrow-phase catalogue",
                   lambda: narrow_phase_rate(engines)),
        "faults": ("planted faults: the detection matrix", faults),
        "oracle": ("the reference's contact solvers against Pinocchio's", lambda: oracle.measure(out)),
        "run": ("the default run, cold and then warm (minutes each)", lambda: default_run(
            args.workers, out, (*(("--engines", *args.engines) if args.engines else ()),
                                *(("--cases", *args.cases) if args.cases else ()),
                                *(x for a in args.adapter or () for x in ("--adapter", a))))),
    }
    sections = {}
    for name in WHAT:
        if name in what:
            say(benchmarks[name][0])
            sections[name] = benchmarks[name][1]()
            write(out, sections)  # after each: a later benchmark that fails keeps what was measured
    print(f"wrote {out / 'bench.md'}")
    return 0
