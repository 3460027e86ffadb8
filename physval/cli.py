"""The `physval` command line: the parsers, the options every command shares, and the
checks of bad input that run before any job (each stops with one line and exit code 2)."""
from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
import time
from pathlib import Path

# A command's time counts from here (the interpreter's start is ~0.03 s earlier); main()
# sets it again for each command after a process's first (scripts, tests).
STARTED = time.monotonic()
_commands_run = 0

EPILOG = """examples:
  physval run                                   every case on every installed engine, report in reports/
  physval run --cases central_impact --engines reference,mujoco
  physval run --cases "incline_threshold[mu=0.5*]" --dt 5e-3 --out /tmp/incline
  physval run --cases-dir my_cases --cases second_bounce
  physval list                                  case families, variants, effects, engines
  physval list --engines                        engines, where each comes from, capabilities
  physval check-case my_cases/second_bounce.py  validate a family file before running it
exit codes: 0 the command completed (failing physics is a result, not a crash); 2 bad input;
130 interrupted (finished jobs are kept; the same command resumes); 141 the reader of the
output went away (e.g. `physval list | head`), as a shell reports SIGPIPE."""


class UsageError(ValueError):
    """Bad input on the command line: one line, exit code 2."""


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error: the message and where to find help. Options must be
    spelled out: with abbreviations, `physval known ENGINE --cases X` (known has no --cases)
    was read as --cases-dir X."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


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

def add_selection(p, cases_help: str, engines_help: str) -> None:
    p.add_argument("--cases", nargs="+", metavar="SPEC", help=cases_help)
    p.add_argument("--engines", nargs="+", metavar="NAME", help=engines_help)
    p.add_argument("--cases-dir", action="append", metavar="DIR",
                   help="also load case families from *.py files in DIR (repeatable)")
    p.add_argument("--adapter", action="append", metavar="MODULE:CLASS",
                   help="also use this engine adapter (an adapters.base.Adapter; 'module:Class' or "
                        "'path/file.py:Class'; repeatable)")
    p.add_argument("--known", action="append", metavar="FILE",
                   help="known deviations you expect (the format of adapters/xfails/*.txt; repeatable)")


def add_execution(p, out: str, workers: int | None = None) -> None:
    from physval.core.executor import DEFAULT_JOB_TIMEOUT, START_METHODS
    p.add_argument("--out", default=out, metavar="DIR", help=f"output folder (default: {out})")
    p.add_argument("--workers", type=positive_int, default=workers or os.cpu_count() or 1, metavar="N",
                   help="worker processes; every job runs in one, so a crash costs only that job "
                        f"(default: {workers or 'one per core'})")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the jobs on an existing Dask distributed cluster (e.g. tcp://127.0.0.1:8786)")
    p.add_argument("--job-timeout", type=seconds_or_off, default=DEFAULT_JOB_TIMEOUT, metavar="S",
                   help=f"stop a job that runs longer and record it as an error (default {DEFAULT_JOB_TIMEOUT:g} s; "
                        "0: no limit; local workers only)")
    p.add_argument("--start-method", choices=START_METHODS,
                   help="how local workers start (default: forkserver on Linux, else the platform's)")
    p.add_argument("--quiet", action="store_true", help="no progress")


# Each command's module adds its own parser. Only the named command's module is imported
# (the others import pandas or scipy at the top: 0.3 s that `physval run` would spend on them).
COMMANDS = {"run": "physval.validation", "sweep": "physval.readings.sweep", "stress": "physval.readings.robustness",
            "bench": "physval.bench", "known": "physval.known", "check-case": "physval.checkcase",
            "real": "physval.readings.real"}


def parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The command line; given argv that names a command, with that command's parser only."""
    import importlib
    words = sys.argv[1:] if argv is None else argv
    named = words[0] if words and words[0] in COMMANDS else None
    p = _Parser(
        prog="physval", formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Validate rigid-body contact physics: run analytic cases on physics engines and "
                    "report how far each is from the closed-form answer.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    ls = sub.add_parser("list", help="list case families and engines",
                        description="List case families (variants, effects, which engines can run them), "
                                    "or with --engines one engine per line: where it comes from, its version "
                                    "and capabilities.")
    ls.add_argument("--engines", action="store_true", help="list engines and their capabilities")
    ls.add_argument("--cases-dir", action="append", metavar="DIR", help="also load case families from DIR")
    ls.add_argument("--adapter", action="append", metavar="MODULE:CLASS", help="also list this adapter")
    ls.set_defaults(func=cmd_list)

    for command, module in COMMANDS.items():
        if named in (None, command):
            importlib.import_module(module).add_parser(sub)
    return p


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
    from physval import deviations
    deviations.load(ctx.known_files)  # a --known file that does not parse stops here
    return ctx


def output_folder(text: str) -> Path:
    """--out as a folder that exists and can be written to (made if missing)."""
    if not text or not text.strip():
        raise UsageError("--out '': must name a folder")
    out = Path(text)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {text}: exists and is not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".physval-write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise UsageError(f"--out {text}: cannot write there ({exc.strerror or exc})") from None
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


# --- list ---------------------------------------------------------------------------------

def cmd_list(args) -> int:
    from adapters import registry
    ctx = context_of(args)
    specs = registry.specs(ctx.adapters)
    if args.engines:
        for name, spec in specs.items():
            try:
                a = registry.get(name, ctx.adapters)
                print(f"{name}\t{a.version()}\t{spec.origin}\t{a.capabilities.describe()}")
            except registry.EngineError as exc:
                print(f"{name}\tnot installed\t{spec.origin}\t{exc}")
        return 0
    fams = ctx.resolver().families
    adapters = {}
    for name in specs:
        try:
            adapters[name] = registry.get(name, ctx.adapters)
        except registry.EngineError:
            pass
    for fam in fams.values():
        tags = f" [{', '.join(sorted(fam.tags))}]" if fam.tags else ""
        print(f"{fam.name}{tags}: {fam.summary}")
        print(f"  closed form: {fam.source}; default dt {fam.dt:g} s" if not callable(fam.dt) else
              f"  closed form: {fam.source}; dt per variant")
        for v in fam.variants:
            scene = fam.scene(v.params)
            can = [n for n, a in adapters.items() if a.capabilities.cannot_run(scene, fam.needs_of(v.params)) is None]
            print(f"  [{v.id}]  effects: {','.join(sorted(scene.effects))}  engines: {','.join(can) or 'none'}")
        if fam.full_grid:
            print(f"  (+{len(fam.all_variants) - len(fam.variants)} variants with --full)")
    return 0


def main(argv: list[str] | None = None) -> int:
    global STARTED, _commands_run
    if _commands_run:
        STARTED = time.monotonic()
    _commands_run += 1
    from adapters.base import SettingsError
    from adapters.registry import EngineError
    from cases.family import CaseError
    from cases.scene import SceneError
    from physval.core.selection import SelectionError
    from physval.core.store import StoreError
    from physval.deviations import DeviationFileError
    p = parser(argv)
    args = p.parse_args(argv)
    if args.command is None:
        p.print_help()
        return 0
    try:
        return args.func(args)
    except (UsageError, CaseError, SceneError, SettingsError, EngineError, SelectionError, StoreError,
            DeviationFileError) as exc:
        print(f"physval: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("physval: interrupted; files already written are complete", file=sys.stderr)
        return 130
    except BrokenPipeError:  # stdout's reader is gone: say nothing more there (Python's own advice)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
