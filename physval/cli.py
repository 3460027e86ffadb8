"""The `physval` command line: one dispatcher. Each command is one module of
physval.commands (COMMANDS below) with two public names: `add_parser(subparsers)` adds its
parser, `run(args) -> int` does the work. main() parses and calls the named command's run
itself, so no command can forget to register; the errors of bad input become one line and
exit code 2 here, for every command alike."""
from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import os
import sys
import time

from physval.interrupts import sigterm_as_ctrl_c

# A command's time counts from here (the interpreter's start is ~0.03 s earlier); main()
# sets it again for each command after a process's first (scripts, tests).
STARTED = time.monotonic()
_commands_run = 0

# command -> its module. Only the named command's module is imported (the others import
# pandas or scipy at the top: 0.3 s that `physval run` would spend on them).
COMMANDS = {"list": "physval.commands.list", "run": "physval.commands.run", "sweep": "physval.commands.sweep",
            "stress": "physval.commands.stress", "bench": "physval.commands.bench",
            "known": "physval.commands.known", "check-case": "physval.commands.check_case",
            "real": "physval.commands.real", "compare": "physval.commands.compare",
            "versions": "physval.commands.versions", "parity": "physval.commands.parity"}

EPILOG = """examples:
  physval run                                   every case on every installed engine, report in reports/
  physval run --cases central_impact --engines reference,mujoco
  physval run --cases "incline_threshold[mu=0.5*]" --dt 5e-3 --out /tmp/incline
  physval run --cases-dir my_cases --cases second_bounce
  physval list                                  case families, variants, effects, engines
  physval list --engines                        engines, where each comes from, capabilities
  physval check-case my_cases/second_bounce.py  validate a family file before running it
  physval compare before/ after/                what changed between two result folders (exit 1 if anything)
  physval versions mujoco 3.11.0 3.12.0         the same run on two releases, each in its own environment
  physval parity mujoco mujoco-warp             an engine and its port on the same scenes, check by check
  physval COMMAND --help                        each command's options
exit codes: 0 the command completed (failing physics is a result, not a crash); 1 (compare,
versions) something changed between the runs, (run) a check fell under --fail-on; 2 bad
input; 74 the disk is full or the file system refused a write (finished jobs are kept; the
same command resumes once it can write); 130 interrupted (finished jobs are kept; the same command resumes); 141 the reader
of the output went away (e.g. `physval list | head`), as a shell reports SIGPIPE."""
DISK_FULL = 74  # EX_IOERR of sysexits.h: an error while doing I/O on a file
# the file system's refusals mid-run (a read-only remount, a folder made unwritable, a failing
# disk): exit DISK_FULL too, one line, finished jobs kept
REFUSED = (errno.EROFS, errno.EIO, errno.EACCES, errno.EPERM)


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error: the message and where to find help. Options must be
    spelled out: with abbreviations, `physval known ENGINE --cases X` (known has no --cases)
    was read as --cases-dir X."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):
        from physval.commands.options import with_replacements
        self.exit(2, f"{self.prog}: error: {with_replacements(message)} (see '{self.prog} --help')\n")


def parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The command line; given argv that names a command, with that command's parser only."""
    from physval import __version__
    words = sys.argv[1:] if argv is None else argv
    named = words[0] if words and words[0] in COMMANDS else None
    p = _Parser(
        prog="physval", formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Validate rigid-body contact physics: run analytic cases on physics engines and "
                    "report how far each is from the closed-form answer.")
    p.add_argument("--version", action="version", version=f"physval {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for command, module in COMMANDS.items():
        if named in (None, command):
            importlib.import_module(module).add_parser(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    global STARTED, _commands_run
    if _commands_run:
        STARTED = time.monotonic()
        from physval.core.context import forget
        forget()
    _commands_run += 1
    p = parser(argv)
    try:
        args = p.parse_args(argv)
    except SystemExit as exc:  # --help, --version (0) or a malformed option (2, one line said)
        return exc.code if isinstance(exc.code, int) else 2
    if args.command is None:
        p.print_help()
        return 0
    args.started = STARTED
    # what the command holds until it ends, however it ends (its output folder's lock)
    args.held = contextlib.ExitStack()
    with args.held, sigterm_as_ctrl_c():
        try:
            return _run(args)
        except KeyboardInterrupt:  # Ctrl-C or SIGTERM (physval.interrupts), wherever it landed
            print("physval: interrupted; files already written are complete", file=sys.stderr)
            return 130


def _run(args) -> int:
    """The command's run(args), its bad input and the errors of the machine said in one line."""
    from adapters.base import SettingsError
    from adapters.registry import EngineError
    from cases.family import CaseError
    from cases.scene import SceneError
    from physval.commands.options import UsageError
    from physval.core.deviations import DeviationFileError
    from physval.core.selection import SelectionError
    from physval.core.store import StoreError
    try:
        return importlib.import_module(COMMANDS[args.command]).run(args)
    except (UsageError, CaseError, SceneError, SettingsError, EngineError, SelectionError, StoreError,
            DeviationFileError) as exc:
        print(f"physval: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # stdout's reader is gone: say nothing more there (Python's own advice)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as exc:
        if exc.errno not in (errno.ENOSPC, errno.EDQUOT) + REFUSED:
            raise
        # every finished job's rows were written before this one (each job is one write, and
        # a job cut short in its write is run again): nothing is lost but the time
        where = f" at {exc.filename}" if exc.filename else ""
        what, fix = (("the disk is full", "free space") if exc.errno not in REFUSED else
                     ("the file system refused a write", "make the folder writable again"))
        print(f"physval: error: {what} ({exc.strerror}{where}); the rows of finished jobs are kept: {fix} and run "
              "the same command again to resume", file=sys.stderr)
        return DISK_FULL
