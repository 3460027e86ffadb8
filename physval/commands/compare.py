"""`physval compare A B`: what changed between two result folders (physval.readings.compare),
and, when both runs saved their trajectories, where each job's two runs part
(physval.readings.divergence)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from physval.commands import options

EPILOG = """examples:
  physval compare reports/versions/3.11.0 reports/versions/3.12.0
  physval compare before/ after/ --threshold 0.1 --out diff
exit codes: 0 nothing changed; 1 something changed (a status, a move above the threshold,
a check in one run only); 2 bad input (a folder without results.csv, a table without
physval's columns)."""


def add_parser(sub) -> None:
    cp = sub.add_parser(
        "compare", help="what changed between two result folders (exit 1 if anything did)",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Join the results.csv of two runs check by check: checks whose status changed, checks whose "
                    "error moved by more than --threshold tolerances, checks in one run only; per family and "
                    "engine, the largest moves first. Writes compare.md, compare.csv and compare.png into --out. "
                    "With trajectories saved by both runs (`physval run --save-trajectories`), also the step at "
                    "which each job's two runs part, and the worst drawn side by side.")
    cp.add_argument("a", metavar="A", help="the first run's folder (or its results.csv)")
    cp.add_argument("b", metavar="B", help="the second run's folder (or its results.csv)")
    add_options(cp)
    cp.add_argument("--trajectories", nargs=2, metavar=("DIR_A", "DIR_B"),
                    help="trajectory folders of the two runs (default: A/trajectories and B/trajectories when "
                         "both exist)")
    cp.add_argument("--out", default="reports/compare", metavar="DIR", help="output folder (default: reports/compare)")


def add_options(p) -> None:
    """--threshold, shared with `physval versions`."""
    from physval.readings.compare import THRESHOLD
    p.add_argument("--threshold", type=options.nonnegative_float, default=THRESHOLD, metavar="TOL",
                   help=f"a check moved when its error moved by more than TOL of its tolerance (default {THRESHOLD:g}; "
                        "0: any move)")


def trajectory_folders(a, b, named) -> tuple[Path, Path] | None:
    """The two runs' trajectory folders: named (each must be a folder), else A/trajectories
    and B/trajectories when both exist, else None."""
    if named:
        for d in named:
            if not options.is_a("--trajectories", d, Path.is_dir):
                raise options.UsageError(f"--trajectories {d!r}: not a folder")
        return Path(named[0]), Path(named[1])
    found = Path(a) / "trajectories", Path(b) / "trajectories"
    try:
        return found if all(d.is_dir() for d in found) else None
    except OSError:  # A or B cannot be read: comparing their results says so
        return None


def compare_runs(a, b, out: str, threshold: float, trajectories=None, command: str = "", args=None):
    """Compare run folders a and b into folder `out` (made once both are read, and held by
    the command of `args` if given: options.held): (the joined
    table of physval.readings.compare, where the trajectories part (physval.readings.divergence;
    None without trajectories), the files written). CompareError (bad input) becomes UsageError."""
    from physval.readings import compare, divergence
    try:
        left, right = compare.load(a), compare.load(b)
    except compare.CompareError as exc:
        raise options.UsageError(str(exc)) from None
    folder = options.output_folder(out)
    if args is not None:
        options.held(args, folder)
    table = compare.compare(left, right, threshold)
    names = (str(a), str(b))
    extra, parts, written = [], None, [folder / "compare.md", folder / "compare.csv", folder / "compare.png"]
    if trajectories:
        parts = divergence.measure(*trajectories)
        unreadable = parts.note.fillna("").str.startswith(divergence.UNREADABLE)
        if unreadable.any():
            print(f"physval: {int(unreadable.sum())} jobs left out of the trajectories' comparison: a saved file "
                  f"cannot be read (first: {parts[unreadable].job.iloc[0]}, {parts[unreadable].note.iloc[0]}); "
                  "trajectories.csv names them all", file=sys.stderr)
        from physval.report import write_csv
        write_csv(parts, folder / "trajectories.csv")
        written.append(folder / "trajectories.csv")
        drawn = divergence.plot(parts, *trajectories, folder / "trajectories.png", names)
        written += [folder / "trajectories.png"] if drawn else []
        extra = divergence.section(parts, "trajectories.png" if drawn else None)
    compare.write(table, left, right, folder, names, threshold, command, extra)
    return table, parts, written


def run(args) -> int:
    from physval.readings.compare import changed, summary_line
    trajectories = trajectory_folders(args.a, args.b, args.trajectories)
    table, _, written = compare_runs(args.a, args.b, args.out, args.threshold, trajectories, options.command_line(),
                                     args)
    print(f"{'changed' if changed(table) else 'nothing changed'}: {summary_line(table, args.threshold)}")
    print(f"wrote {', '.join(str(p) for p in written)}")
    return 1 if changed(table) else 0
