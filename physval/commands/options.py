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


def positive_float(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(x) and x > 0):
        raise argparse.ArgumentTypeError(f"{text!r}: must be a finite number > 0")
    return x


def positive_int(text: str) -> int:
    try:
        x = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if x < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: must be >= 1")
    return x


def whole_number(text: str) -> int:
    try:
        x = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if x < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: must be >= 0")
    return x


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


def add_execution(p, out: str, workers: int | None = None, job_timeout: float | None = None) -> None:
    """--out, --workers, --scheduler, --job-timeout, --start-method, --quiet."""
    from physval.core.executor import DEFAULT_JOB_TIMEOUT, START_METHODS
    job_timeout = job_timeout or DEFAULT_JOB_TIMEOUT
    p.add_argument("--out", default=out, metavar="DIR", help=f"output folder (default: {out})")
    p.add_argument("--workers", type=positive_int, default=workers or os.cpu_count() or 1, metavar="N",
                   help="worker processes; every job runs in one, so a crash costs only that job "
                        f"(default: {workers or 'one per core'})")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the jobs on an existing Dask distributed cluster (e.g. tcp://127.0.0.1:8786)")
    p.add_argument("--job-timeout", type=seconds_or_off, default=job_timeout, metavar="S",
                   help=f"stop a job that runs longer and record it as an error (default {job_timeout:g} s; "
                        "0: no limit; local workers only)")
    p.add_argument("--start-method", choices=START_METHODS,
                   help="how local workers start (default: forkserver on Linux, else the platform's)")
    p.add_argument("--quiet", action="store_true", help="no progress")


# --- checks before any work ---------------------------------------------------------------

def context_of(args):
    """The run's Context from --cases-dir, --adapter and --known (each checked)."""
    from physval.core import Context
    for d in getattr(args, "cases_dir", None) or []:
        if not d or not Path(d).is_dir():
            raise UsageError(f"--cases-dir {d!r}: not a folder")
    for f in getattr(args, "known", None) or []:
        if not f or not Path(f).is_file():
            raise UsageError(f"--known {f!r}: not a file")
    ctx = Context(cases_dirs=tuple(str(Path(d).resolve()) for d in getattr(args, "cases_dir", None) or []),
                  adapters=tuple(getattr(args, "adapter", None) or []),
                  known_files=tuple(str(Path(f).resolve()) for f in getattr(args, "known", None) or []))
    from adapters import registry
    registry.specs(ctx.adapters)  # an ad-hoc adapter that does not load stops here
    from physval.core import deviations
    deviations.load(ctx.known_files)  # a --known file that does not parse stops here
    return ctx


def output_folder(text: str) -> Path:
    """--out as a folder that exists and can be written to (made if missing)."""
    return writable_folder(text, "--out")


def writable_folder(text: str, option: str) -> Path:
    """A folder option's value as a folder that exists and can be written to (made if
    missing); UsageError naming the option if it cannot be."""
    if not text or not text.strip():
        raise UsageError(f"{option} '': must name a folder")
    out = Path(text)
    if out.exists() and not out.is_dir():
        raise UsageError(f"{option} {text}: exists and is not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".physval-write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise UsageError(f"{option} {text}: cannot write there ({exc.strerror or exc})") from None
    return out


def check_scheduler(address: str | None) -> None:
    """Connect once to a Dask scheduler, so a bad address stops before any work."""
    if not address:
        return
    from physval.core.executor import DaskExecutor, ExecutorError
    try:
        DaskExecutor(address).close()
    except ExecutorError as exc:
        raise UsageError(str(exc)) from None


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
    return chosen


def _installed(ctx, engine: str) -> bool:
    """The engine's adapter can be made (made once per process: the resolver keeps it)."""
    try:
        ctx.resolver().adapter(engine)
        return True
    except Exception:
        return False


def fast_engines(ctx) -> list[str]:
    """The installed engines that do not step in pure Python (Adapter.slow): what sweeps,
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
