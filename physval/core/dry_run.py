"""User code is tried in worker processes before physval's own process runs it.

A case family file (`--cases-dir`, `physval check-case`) and an ad-hoc adapter
(`--adapter`) are code physval did not write: an exception, an exit (sys.exit,
os._exit), a crash (a segfault) or a hang in it must cost one line, never physval's
process. So each is first run as calls of the executor (physval.core.session.map_calls:
every call in a worker process, crashes and time-outs isolated):

- a family file is imported and its grid checked (one call per file), then every
  variant, the full grid too, is built, run one step on the reference and observed (one
  call per variant: the dry run, so a problem names the family[variant]); the observer
  must give every check a finite number;
- an adapter is imported and made, and says its version (one call per --adapter).

Only what passed is then loaded in physval's own process and in every job's worker.
"""
from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

from adapters import registry
from adapters.base import Settings
from cases.family import OBSERVE_RULE, VARIANT_RULE, CaseError, CaseFamily, Variant, user_code
from cases.scene import Body, Scene, Sphere, ground
from physval.core.context import Context
from physval.core.executor import DEFAULT_JOB_TIMEOUT
from physval.core.jobs import Failed, number_of, run_scene
from physval.core.session import Execution, executor_of, map_calls
from physval.interrupts import sigterm_as_ctrl_c

DRY_RUN_ENGINE = "reference"
# s per call: a file's import, or one variant built and run one step. A command's shorter
# --job-timeout applies instead.
DRY_RUN_TIMEOUT = 60.0
# What a worker's death or a time-out means a user's code did, in its one-line error.
LOAD_DEATH_RULE = "a case file must import without ending the process, within the time limit"
DEATH_RULE = "a family's code must return or raise, never end the process, and finish within the time limit"
ADAPTER_DEATH_RULE = "an adapter's module must import, and its class be made, without ending the process"
VERSION_RULE = "an adapter's version() must return its engine's release as a string"


def execution_of(args) -> Execution:
    """Local workers for the dry run, as the command's --workers and --start-method ask;
    its time limit DRY_RUN_TIMEOUT or the command's shorter --job-timeout; no progress."""
    limit = getattr(args, "job_timeout", None) or DRY_RUN_TIMEOUT
    return Execution(workers=getattr(args, "workers", None) or os.cpu_count() or 1,
                     job_timeout=min(limit, DRY_RUN_TIMEOUT), start_method=getattr(args, "start_method", None),
                     progress=False)


# --- family files ---------------------------------------------------------------------------

@dataclass
class Tried:
    """What the dry run found of one family file."""
    file: str                 # as messages name it
    family: str = ""          # its FAMILY's name, once imported
    observed: dict[str, dict[str, float]] = field(default_factory=dict)  # variant id -> the one step's values
    problem: str = ""         # the first problem, one line naming the file ("" if usable)


def try_files(files: list[tuple[Path, str]], execution: Execution) -> list[Tried]:
    """Dry-run family files, each (path, name in messages), in workers: one Tried each."""
    tried = [Tried(shown) for _, shown in files]
    variants = []  # (Tried, path, variant id)
    # one set of workers for the three steps: the worker that loaded the reference for the
    # warm-up runs variants with it loaded (before: a pool a step, each loading it again, ~1 s)
    with sigterm_as_ctrl_c(), executor_of(Context(), execution) as ex:
        results = map_calls(_outline, [(str(path), shown) for path, shown in files], Context(), execution,
                            executor=ex)
        for t, (path, _), r in zip(tried, files, results):
            found = f"{t.file}: cannot be loaded: {r.error} ({LOAD_DEATH_RULE})" if r.error else r.value
            if isinstance(found, str):
                t.problem = found
                continue
            t.family, ids = found
            variants += [(t, path, vid) for vid in ids]
        if variants:  # the reference's first-run cost is physval's, not the user's code's: paid before the limit counts
            with ex.time_limit(DEFAULT_JOB_TIMEOUT):
                map_calls(warm, [DRY_RUN_ENGINE], Context(), execution, executor=ex)
        results = map_calls(_variant, [(str(path), t.file, vid) for t, path, vid in variants], Context(), execution,
                            executor=ex)
    for (t, _, vid), r in zip(variants, results):
        found = f"{t.file}: {t.family}[{vid}]: {r.error} ({DEATH_RULE})" if r.error else r.value
        if isinstance(found, str):
            t.problem = t.problem or found
        else:
            t.observed[vid] = found
    return tried


@functools.cache
def _family(path: str, shown: str) -> CaseFamily:
    """The file's family, imported once per worker process."""
    from cases.registry import load_file
    return load_file(Path(path), shown)


def _outline(item: tuple[str, str]) -> tuple[str, list[str]] | str:
    """In a worker: (family name, every variant id) of a family file, or its problem."""
    path, shown = item
    try:
        fam = _family(path, shown)
        try:
            fam.validate_grid(full=True)
        except CaseError as exc:
            raise CaseError(f"{shown}: {exc}") from None
        return fam.name, [v.id for v in fam.all_variants]
    except CaseError as exc:
        return str(exc)


def warm(engine: str) -> None:
    """In a worker: one step of a ball on a ground, so that the engine's compiled code (the
    reference's numba cache: minutes of compiling on a fresh install) is on disk before the
    user's variants run under the dry run's time limit, in workers that then only load it."""
    scene = Scene(bodies=(ground(), Body("ball", Sphere(0.1), mass=1.0, position=(0, 0, 0.1))))
    run_scene(registry.get(engine), scene, Settings(dt=1e-3), 1)


def _variant(item: tuple[str, str, str]) -> dict[str, float] | str:
    """In a worker: the dry run of one variant of a family file, or its problem."""
    path, shown, vid = item
    try:
        fam = _family(path, shown)
        (v,) = [v for v in fam.all_variants if v.id == vid]
        return dry_run(fam, v, shown)
    except CaseError as exc:
        return str(exc)


def dry_run(fam: CaseFamily, v: Variant, where: str) -> dict[str, float]:
    """Build the variant, run it one step on the reference and observe it: {metric: value}
    ({} if the reference cannot represent the scene). Raises CaseError naming `where`
    (the file), the family[variant] and what is allowed."""
    at = f"{where}: {v.test_id}"
    try:
        scene, dt, checks = fam.validate_variant(v)
    except CaseError as exc:
        raise CaseError(f"{where}: {exc}") from None
    with user_code(at, "its code raised", VARIANT_RULE):
        needs = fam.needs_of(v.params)
    try:
        run, _ = run_scene(registry.get(DRY_RUN_ENGINE), scene, Settings(dt=dt), 1, needs)
    except Failed as exc:
        if exc.status == "unsupported":
            return {}
        raise CaseError(f"{at}: one step on the reference failed: {exc.reason}") from None
    traj = run.trajectory
    with user_code(at, "observe() raised", f"{OBSERVE_RULE}, on a one-step run too"):
        values = fam.observe(traj, v.params)
    if not hasattr(values, "get"):
        raise CaseError(f"{at}: observe() returned {type(values).__name__}, not a dict of metrics")
    missing = [c.metric for c in checks if c.metric not in values]
    if missing:
        raise CaseError(f"{at}: observe() gives no {', '.join(missing)} (expect() checks it)")
    out = {}
    for c in checks:
        number = number_of(values[c.metric])
        if number is None or not math.isfinite(number):
            raise CaseError(f"{at}: observe() gave {c.metric} = {values[c.metric]!r} on a one-step run "
                            f"({OBSERVE_RULE}: the check then fails with a size)")
        out[c.metric] = number
    return out


# --- ad-hoc adapters ------------------------------------------------------------------------

def try_adapters(targets: tuple[str, ...], execution: Execution) -> None:
    """Import and make each `--adapter module:Class` and ask its version in a worker;
    EngineError naming the first that cannot be (or whose version() raises)."""
    for target, r in zip(targets, map_calls(_adapter, list(targets), Context(), execution)):
        problem = f"adapter {target!r}: {r.error} ({ADAPTER_DEATH_RULE})" if r.error else r.value
        if problem:
            raise registry.EngineError(problem)


def _adapter(target: str) -> str:
    """In a worker: '' if the adapter imports, is made and gives its version (every run's
    resume key and report name it), else why not."""
    try:
        adapter = registry.get(registry.adhoc(target).name, (target,))
        with user_code(f"adapter {target!r}", "version() raised", VERSION_RULE, error=registry.EngineError):
            version = adapter.version()
        if not isinstance(version, str):
            return f"adapter {target!r}: version() gave {version!r}, not a string ({VERSION_RULE})"
        return ""
    except registry.EngineError as exc:
        return str(exc)
