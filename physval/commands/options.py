"""What every command shares: its options (the same names, grammar, defaults and checks in
every command), the checks of bad input that run before any job (each raises UsageError:
one line, exit code 2), and how a command talks to the terminal."""
from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
from pathlib import Path


class UsageError(ValueError):
    """Bad input on the command line: one line, exit code 2."""


# Options that were removed -> (what replaces them, what the replacement takes). Every
# command's parser (physval.cli) names the replacement instead of only "unrecognized".
READINGS_TAKES = "--readings takes effective, laws, all, none or auto"
REMOVED = {
    "--no-effective": ("physval run --readings laws (or none)", READINGS_TAKES),
    "--no-laws": ("physval run --readings effective (or none)", READINGS_TAKES),
}


def with_replacements(message: str) -> str:
    """argparse's error message, with the replacement of each removed option it names."""
    if not message.startswith("unrecognized arguments:"):
        return message
    given = dict.fromkeys(a.split("=", 1)[0] for a in message.split(":", 1)[1].split())
    removed = [o for o in given if o in REMOVED]
    uses = [f"{o} was removed: use {REMOVED[o][0]}" for o in removed]
    return "; ".join([message, *uses, *dict.fromkeys(REMOVED[o][1] for o in removed)])


def _float_above(text: str, low: float, inclusive: bool) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(x) and (x >= low if inclusive else x > low)):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number {'>=' if inclusive else '>'} {low:g}")
    return x


def positive_float(text: str) -> float:
    return _float_above(text, 0, inclusive=False)


def nonnegative_float(text: str) -> float:
    return _float_above(text, 0, inclusive=True)


def _int_at_least(text: str, low: int) -> int:
    try:
        x = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if x < low:
        raise argparse.ArgumentTypeError(f"{text!r}: must be >= {low}")
    return x


def positive_int(text: str) -> int:
    return _int_at_least(text, 1)


def whole_number(text: str) -> int:
    return _int_at_least(text, 0)


def seconds_or_off(text: str) -> float:
    """A time limit in s; 0 turns it off."""
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (math.isfinite(x) and x >= 0):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number of seconds >= 0 (0: no limit)")
    return x


# --- options every command that runs jobs shares -----------------------------------------

def add_engines(p, engines_help: str) -> None:
    """--engines (names or globs) and --adapter."""
    p.add_argument("--engines", nargs="+", metavar="NAME", help=engines_help)
    p.add_argument("--adapter", action="append", metavar="MODULE:CLASS",
                   help="also use this engine adapter (an adapters.base.Adapter; 'module:Class' or "
                        "'path/file.py:Class'; repeatable)")


def add_selection(p, cases_help: str, engines_help: str) -> None:
    """--cases and --engines, and what extends them: --cases-dir, --adapter, --known."""
    p.add_argument("--cases", nargs="+", metavar="SPEC", help=cases_help)
    add_engines(p, engines_help)
    p.add_argument("--cases-dir", action="append", metavar="DIR",
                   help="also load case families from *.py files in DIR (repeatable)")
    p.add_argument("--known", action="append", metavar="FILE",
                   help="known deviations you expect (the format of adapters/xfails/*.txt; repeatable)")


def add_execution(p, out: str, workers: int | None = None, job_timeout: float | None = None,
                  scheduler: bool = True) -> None:
    """--out, --workers, --scheduler (unless `scheduler` is False), --job-timeout, --start-method, --quiet."""
    from physval.core.executor import DEFAULT_JOB_TIMEOUT, START_METHODS
    job_timeout = job_timeout or DEFAULT_JOB_TIMEOUT
    p.add_argument("--out", default=out, metavar="DIR", help=f"output folder (default: {out})")
    p.add_argument("--workers", type=positive_int, default=workers or os.cpu_count() or 1, metavar="N",
                   help="worker processes; every job runs in one, so a crash costs only that job "
                        f"(default: {workers or 'one per core'})")
    if scheduler:
        p.add_argument("--scheduler", metavar="ADDRESS",
                       help="run the jobs on an existing Dask distributed cluster (e.g. tcp://127.0.0.1:8786)")
    p.add_argument("--job-timeout", type=seconds_or_off, default=job_timeout, metavar="S",
                   help=f"stop a job that runs longer and record it as an error (default {job_timeout:g} s; "
                        "0: no limit; local workers only)")
    p.add_argument("--start-method", choices=START_METHODS,
                   help="how local workers start (default: forkserver on Linux, else the platform's)")
    p.add_argument("--quiet", action="store_true", help="no progress")


# --- checks before any work ---------------------------------------------------------------

def is_a(option: str, text: str, kind) -> bool:
    """kind(Path(text)) (Path.is_dir, Path.is_file); a path the system refuses to look at (a
    folder on the way that cannot be searched, a name too long) is one line, UsageError."""
    try:
        return kind(Path(text))
    except OSError as exc:
        raise UsageError(f"{option} {text!r}: cannot be read ({exc.strerror or exc})") from None


def context_of(args):
    """The run's Context from --cases-dir, --adapter and --known (each checked). User code is
    tried in worker processes first (physval.core.dry_run): an --adapter that cannot be
    imported and made stops here; a family file that fails its dry run is left out of the
    Context (`broken`: not imported, here or by any worker) and stops only a selection
    that needs it (cases_of)."""
    from dataclasses import replace

    from physval.core import Context, dry_run
    for d in getattr(args, "cases_dir", None) or []:
        if not d or not is_a("--cases-dir", d, Path.is_dir):
            raise UsageError(f"--cases-dir {d!r}: not a folder")
        is_a("--cases-dir", d, lambda p: os.scandir(p).close())  # a folder it may not list: one line too
    for f in getattr(args, "known", None) or []:
        if not f or not is_a("--known", f, Path.is_file):
            raise UsageError(f"--known {f!r}: not a file")
    ctx = Context(cases_dirs=tuple(str(Path(d).resolve()) for d in getattr(args, "cases_dir", None) or []),
                  adapters=tuple(getattr(args, "adapter", None) or []),
                  known_files=tuple(str(Path(f).resolve()) for f in getattr(args, "known", None) or []))
    from adapters import registry
    from cases.registry import Problem, case_files
    if ctx.adapters:
        dry_run.try_adapters(ctx.adapters, dry_run.execution_of(args))
    registry.specs(ctx.adapters)  # an ad-hoc adapter that does not load stops here
    files = [f for d in ctx.cases_dirs for f in case_files(d)]
    if files:
        tried = dry_run.try_files([(f, str(f)) for f in files], dry_run.execution_of(args))
        ctx = replace(ctx, broken=tuple(Problem(t.file, t.family, t.problem) for t in tried if t.problem))
    if ctx.known_files:  # a --known file that does not parse, or names what does not exist, stops here
        from physval.core import deviations
        try:
            entries = deviations.load(ctx.known_files)
        except deviations.DeviationFileError as exc:
            raise UsageError(f"--known {exc}") from None
        unknown = deviations.unknown_names(entries, ctx.resolver().families, registry.engine_names(ctx.adapters))
        if unknown:
            raise UsageError(f"--known {unknown}")
    return ctx


def cases_of(args, resolver, families: dict | None = None, full: bool = False) -> dict:
    """The --cases selection among `families` (default: every family the resolver has):
    family name -> variants. A user's family file that cannot be used stops the command
    when the selection may need it (no --cases, or a spec naming it: its one line, exit 2);
    otherwise the command goes on without it and one line on stderr says why."""
    from physval.core.selection import select_variants
    every = resolver.families  # loading them completes resolver.broken
    chosen = select_variants(every if families is None else families, getattr(args, "cases", None), full=full,
                             unusable=list(resolver.broken.values()))
    for problem in resolver.broken.values():
        print(f"physval: left out {problem.message}", file=sys.stderr)
    return chosen


def output_folder(text: str, option: str = "--out") -> Path:
    """`option`'s value as a folder that exists and can be written to (made if missing)."""
    if not text or not text.strip():
        raise UsageError(f"{option} '': must name a folder")
    out = Path(text)
    try:  # exists() raises where a folder on the way cannot be searched, or a name is too long
        if out.exists() and not out.is_dir():
            raise UsageError(f"{option} {text}: exists and is not a folder")
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".physval-write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise UsageError(f"{option} {text}: cannot write there ({exc.strerror or exc})") from None
    return out


def held(args, folder: Path, option: str = "--out") -> Path:
    """`folder` held by this command until it ends (physval.files.folder_lock, released by
    the dispatcher however the command ends): another physval command writing there now
    stops this one with one line naming the folder and that command's process id."""
    from physval.files import FolderBusy, folder_lock
    try:
        args.held.enter_context(folder_lock(folder))
    except FolderBusy as exc:
        raise UsageError(f"{option} {folder}: another physval command (pid {exc.pid or 'unknown'}) is writing "
                         "there; wait for it to end, or choose another folder") from None
    except OSError as exc:
        raise UsageError(f"{option} {folder}: cannot write there ({exc.strerror or exc})") from None
    return folder


def output_file(text: str, option: str) -> Path:
    """A file to write at the end, checked now: a name, not a folder, in a folder that can be
    written to (made if missing)."""
    if not text or not text.strip():
        raise UsageError(f"{option} '': must name a file")
    path = Path(text)
    try:
        if path.is_dir():
            raise UsageError(f"{option} {text}: is a folder; name a file")
    except OSError as exc:
        raise UsageError(f"{option} {text}: cannot write there ({exc.strerror or exc})") from None
    output_folder(str(path.parent), option)
    return path


def check_scheduler(address: str | None) -> None:
    """Connect once to a Dask scheduler, so a bad address stops before any work."""
    if not address:
        return
    from physval.core.executor import DaskExecutor, ExecutorError
    try:
        DaskExecutor(address).close()
    except ExecutorError as exc:
        raise UsageError(str(exc)) from None


def steps_the_reference(args) -> bool:
    """Whether a run may step the reference: every engine (no --engines), a name or glob of
    --engines that matches a reference formulation, or user code the dry run tries on it
    (--cases-dir, --adapter)."""
    from fnmatch import fnmatchcase
    from adapters.registry import ENGINES
    if args.engines is None or getattr(args, "cases_dir", None) or getattr(args, "adapter", None):
        return True
    names = [w.strip() for v in args.engines for w in v.split(",") if w.strip()]
    return any(fnmatchcase(e, n) for n in names for e in ENGINES if e.startswith("reference"))


def engines_of(args, ctx, default: list[str] | None = None) -> list[str]:
    """--engines (names or globs), else `default`, else every installed engine."""
    from adapters import registry
    from physval.core.selection import select_engines
    known = registry.engine_names(ctx.adapters)
    if default is None and args.engines is None:  # only then: importing every engine takes ~1 s
        default = [e for e in known if _installed(ctx, e)]
    chosen = select_engines(args.engines, known, default or [])
    resolver = ctx.resolver()
    for e in chosen:
        resolver.known(e)  # an engine's own known-deviation file that does not parse stops here
    named = {w.strip() for v in args.engines or [] for w in v.split(",")}
    return supported_releases(chosen, ctx, named)


def supported_releases(engines: list[str], ctx, named: set[str]) -> list[str]:
    """The engines whose installed release lies in their adapter's supported range. One
    outside it stops the command if it was named by its name (UsageError), else (a glob, the
    default) is left out with one line on stderr; either way before any work. An engine
    not installed stays (its rows say so)."""
    from adapters import registry
    kept = []
    for e in engines:
        try:
            problem = registry.release_problem(ctx.resolver().adapter(e))  # the adapter this run already made
        except Exception:
            problem = None
        if problem and e in named:
            raise UsageError(f"--engines {e}: {problem}")
        if problem:
            print(f"physval: {e} left out: {problem}", file=sys.stderr)
            continue
        kept.append(e)
    return kept


def _installed(ctx, engine: str) -> bool:
    """The engine's adapter can be made (made once per process: the resolver keeps it)."""
    try:
        ctx.resolver().adapter(engine)
        return True
    except Exception:
        return False


def fast_engines(ctx) -> list[str]:
    """The installed engines but the slower reference formulations (Adapter.slow): what sweeps,
    the stress battery, benchmarks and engine-wide readings take unless engines are named."""
    from adapters import registry
    return [e for e in registry.engine_names(ctx.adapters) if _installed(ctx, e) and not ctx.resolver().adapter(e).slow]


def command_line() -> str:
    return "physval " + " ".join(shlex.quote(a) for a in sys.argv[1:])


def teller(args, who: str = "physval"):
    """say(text): a progress line on stderr, silent under --quiet."""
    if getattr(args, "quiet", False):
        return lambda text: None
    return lambda text: print(f"{who}: {text}", file=sys.stderr)
