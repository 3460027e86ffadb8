"""One job: a case variant on an engine at given settings, built, stepped, recorded and
judged by one function, `execute`. Every command (run, sweep, stress, bench, the
engine-wide readings) is a selection of jobs run through it.

`execute` never raises: an engine that cannot represent the scene, blows up or crashes
gives rows with status `unsupported`, `unstable` or `error`, with the reason, and the
caller goes on. A crash that kills the process (a segfault) is caught one level up, by
the executor, which runs every job in a worker process.
"""
from __future__ import annotations

import importlib
import json
import math
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from adapters.base import Settings, SettingsError, Unsupported
from cases.family import CaseFamily, Check, Variant, users_frame
from cases.trajectory import TrajectoryError
from cases import relations
from physval.core import deviations, invariance
from physval.core.context import Resolver
from physval.core.record import Run, Unstable, simulate
from physval.core.verdicts import blank_row, judge


@dataclass(frozen=True)
class Job:
    """What to run. `dt` None: the family's; `iterations` None: the adapter's default;
    `options`: engine-specific settings (Settings.options) as sorted (name, value) pairs;
    `probe`: "module:function" of a reading taken in the worker while the job runs
    (function(job) -> Probe), with `probe_args` as sorted (name, value) pairs; `relation`:
    the name of an invariance relation of cases.relations, which makes the job that relation's
    verdict on the variant instead of the family's checks (physval.core.invariance)."""
    family: str
    variant: Variant
    engine: str
    dt: float | None = None
    iterations: int | None = None
    options: tuple = ()
    probe: str | None = None
    probe_args: tuple = ()
    warmup: int = 0  # steps left out of the timing
    relation: str = ""

    @property
    def test_id(self) -> str:
        return f"{self.variant.test_id}-{self.engine}" + (f"-{self.relation}" if self.relation else "")

    @property
    def key(self) -> str:
        """Unique per job: the case, engine and every setting that changes what is measured."""
        parts = [f"dt={self.dt:.6g}" if self.dt else "dt=default",
                 f"it={self.iterations}" if self.iterations else "it=default"]
        parts += [f"{k}={v}" for k, v in self.options]
        if self.probe:
            parts.append(f"probe={self.probe.rsplit(':', 1)[-1]}" + "".join(f",{k}={v}" for k, v in self.probe_args))
        if self.warmup:
            parts.append(f"warmup={self.warmup}")
        return f"{self.test_id}@{';'.join(parts)}"


@dataclass(frozen=True)
class Call:
    """A plain call, fn(arg), run like a job: in a worker process (crashes and time-outs
    isolated) or on a Dask cluster. fn must be importable by name (a module's function) and
    arg picklable: a value with no rows to store (trying a user's file before use,
    physval.core.dry_run). Work that gives rows is a Job or a Task."""
    fn: Callable
    arg: object
    tag: int = 0  # the caller's number for it (results come back as they finish)

    @property
    def test_id(self) -> str:
        return getattr(self.fn, "__name__", "call")


@dataclass(frozen=True)
class Task:
    """A job of a non-family kind (a batch of measured tosses, physval real's): `fn(arg)`
    gives its rows, `lost(arg, reason)` the rows of one that gave none (it raised, its
    worker died or it ran over the time limit). With a `key` and an `engine` as a Job has,
    it runs in the same workers as every job (crashes and time-outs isolated), its rows
    stream to a row store and are resumed from it. `family`: what its rows' `case` column
    says (a store's cache key reads it). fn and lost must be importable by name, arg picklable."""
    fn: Callable
    arg: object
    lost: Callable
    engine: str
    key: str
    family: str = ""

    @property
    def test_id(self) -> str:
        return self.key


@dataclass(frozen=True)
class Timing:
    """Where a task's worker spent its time: `wall_s` and `cpu_s` (this process's CPU, user
    and system, all threads) performing it, `waited_s` idle before it arrived (0 when it
    was already there), `process_cpu_s` the process's CPU since it started, at the end."""
    wall_s: float
    cpu_s: float
    waited_s: float = 0.0
    process_cpu_s: float = 0.0


@dataclass
class CallResult:
    call: Call
    value: object = None
    error: str = ""  # why there is no value (the call raised, or its worker died)
    timing: Timing | None = None  # None: it did not finish in a worker (lost)


def compiling_s() -> float:
    """Seconds this process has spent getting the reference's compiled code ready
    (reference_impl.compiled.compiling_seconds; 0 where the reference was never imported)."""
    compiled = sys.modules.get("reference_impl.compiled")
    return compiled.compiling_seconds() if compiled is not None else 0.0


# the engines whose jobs this process has run (perform): a job of one not in it pays the engine's start
_engines_started: set[str] = set()


def perform(task, resolver: Resolver, waited_s: float = 0.0):
    """Run a Job or a Task (-> Outcome) or a Call (-> CallResult) in this process, with its Timing;
    a Job's rows get its time, `job_s`, of it numba's compiling of the reference's code,
    `compile_s`, and `first_in_worker` (1: the first job of its engine this process ran, whose
    time holds the engine's start: its imports, a kernel cache's load or compile; 0 otherwise).
    Never raises but on Ctrl-C: whatever else the
    code it runs raises, an exit (SystemExit) included, is the task's error (a Job's rows
    say it), so a worker lives on to take the next task."""
    engine = getattr(task, "engine", None)
    first = engine is not None and engine not in _engines_started
    wall0, cpu0, compile0 = time.perf_counter(), time.process_time(), compiling_s()
    try:
        if isinstance(task, Job):
            result = execute(task, resolver)
        elif isinstance(task, Task):
            result = Outcome(task, task.fn(task.arg))
        else:
            result = CallResult(task, task.fn(task.arg))
    except KeyboardInterrupt:
        raise
    except BaseException as exc:
        result = lost(task, resolver, describe(exc))
    cpu1 = time.process_time()
    result.timing = Timing(time.perf_counter() - wall0, cpu1 - cpu0, waited_s, cpu1)
    if isinstance(result, Outcome):
        compiled = compiling_s() - compile0
        for r in result.rows:
            r["job_s"], r["compile_s"], r["first_in_worker"] = result.timing.wall_s, compiled, int(first)
    if engine is not None:
        _engines_started.add(engine)
    return result


def lost(task, resolver: Resolver, reason: str):
    """The result of a task that produced nothing (its worker died, or it timed out)."""
    if isinstance(task, Job):
        return failed(task, resolver, "error", reason)
    if isinstance(task, Task):
        try:
            return Outcome(task, task.lost(task.arg, reason))
        except Exception as exc:  # its own lost() fails: one row says both
            return Outcome(task, [{"engine": task.engine, "case": task.family, "status": "error",
                                   "message": f"{reason}; and its lost() raised {describe(exc)}"}])
    return CallResult(task, error=reason)


@dataclass
class Outcome:
    job: Job
    rows: list[dict]
    extra: dict = field(default_factory=dict)  # what the job's probe read
    exception: str | None = None               # the exception type the engine raised, if any
    timing: Timing | None = None               # None: it did not finish in a worker (lost)
    run_s: float = 0.0                         # its run's whole wall time (Run.whole_s: stepping, recording)


class Probe:
    """A reading taken in the worker while a job runs (physics-law residuals, timing
    repeats, a final-state hash, ...). `forces`: read contact forces every step."""
    forces = False

    def on_step(self, sim, k: int) -> None:
        """At the start (k = 0) and after each step k (called only if a subclass defines it)."""

    def after(self, run: Run, sim, rebuild) -> dict:
        """Values to return once the run is done; `rebuild()` builds the same scene again."""
        return {}


# --- settings ------------------------------------------------------------------------------

def time_step(job: Job, family: CaseFamily) -> float:
    """The job's time step: its own, else the family's for the variant."""
    return job.dt or family.dt_for(job.variant.params)


def steps_of(job: Job, family: CaseFamily) -> int:
    return max(1, int(round(family.duration(job.variant.params) / time_step(job, family))))


def settings_of(job: Job, family: CaseFamily) -> Settings:
    return Settings(dt=time_step(job, family), iterations=job.iterations, options=dict(job.options))


def at_recorded_settings(job: Job, family: CaseFamily) -> bool:
    """Known-deviation bands are recorded at the family's dt and default iterations."""
    return (job.dt is None or job.dt == family.dt_for(job.variant.params)) and job.iterations is None \
        and not job.options


# --- rows ----------------------------------------------------------------------------------

def describe(exc: BaseException) -> str:
    """'Type: first line of the message (at file:line)': the innermost frame of the user's
    own code (a family of --cases-dir, an --adapter file; cases.family.users_frame) where
    one is on the traceback, with the innermost frame beside it where that is another
    (a helper the user's code called); else the innermost frame's file name."""
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    inner = f"{where.filename.rsplit('/', 1)[-1]}:{where.lineno}" if where else ""
    user = users_frame(exc)
    if user is None:
        loc = f" (at {inner})" if where else ""
    elif (Path(user[0]).name, user[1]) == (Path(where.filename).name, where.lineno):
        loc = f" (at {user[0]}:{user[1]})"
    else:
        loc = f" (at {user[0]}:{user[1]}, in {inner})"
    text = str(exc).splitlines()[0] if str(exc) else ""
    return f"{type(exc).__name__}: {text}{loc}"


def checks_of(job: Job, family: CaseFamily) -> list[Check]:
    """The job's checks: the family's closed forms, or its relation's verdict (at float64:
    the tolerance at the engine's own width is set once its run is known)."""
    if job.relation:
        return [invariance.check(relations.by_name(job.relation), scene_of(family, job.variant),
                                 steps_of(job, family))]
    return expected(family, job.variant, time_step(job, family))


_EXPECTED: dict[tuple, tuple[Check, ...]] = {}  # (the family's expect, a variant's params, dt) -> its checks


def expected(family: CaseFamily, variant: Variant, dt: float) -> list[Check]:
    """The family's closed forms for the variant at time step dt, computed once per
    process: they depend on nothing else, every engine's job of the variant asks for the
    same, and some cost (free_rigid_body's integrates Euler's equations for its
    tolerances: 0.3 s a call, asked by 23 engines). Keyed by the expect function itself, so
    two families of one name (a user's, a test's) never share an entry."""
    key = (family.expect, variant.params_json, dt)
    if key not in _EXPECTED:
        _EXPECTED[key] = tuple(family.expect(variant.params, dt))
    return list(_EXPECTED[key])


_SCENES: dict[tuple, object] = {}  # (the family's scene function, a variant's params) -> its Scene


def scene_of(family: CaseFamily, variant: Variant):
    """The variant's scene, built once per process as `expected`'s checks are: a scene is
    frozen data of its params alone, and every engine's job of the variant builds the same
    (a narrow_phase scene costs 46 ms of CPU to build, asked by 28 engines). What the
    family's code raises is raised each time, never kept."""
    key = (family.scene, variant.params_json)
    if key not in _SCENES:
        _SCENES[key] = family.scene(variant.params)
    return _SCENES[key]


_NEEDS: dict[tuple, frozenset] = {}  # (the family's needs, a variant's params) -> what the variant needs


def needs_of(family: CaseFamily, variant: Variant) -> frozenset:
    """The variant's needs (CaseFamily.needs_of), found once per process as its scene is:
    some families work them out from the closed forms (oblique_landing's law_matters:
    8.5 ms of CPU a call, asked by ~23 engines)."""
    if not callable(family.needs):  # a declared set: nothing to work out
        return family.needs_of(variant.params)
    key = (family.needs, variant.params_json)
    if key not in _NEEDS:
        _NEEDS[key] = family.needs_of(variant.params)
    return _NEEDS[key]


def job_rows(job: Job, family: CaseFamily, status: str, reason: str, checks=None, **fields) -> list[dict]:
    """Rows of every check of a job that did not get as far as a measurement."""
    dt = time_step(job, family)
    base = {"dt": dt, "iterations": job.iterations or "", "status": status, "reason": reason}
    return [blank_row(family.name, job.variant, job.engine, c, **{**base, **fields})
            for c in (checks if checks is not None else checks_of(job, family))]


def failed(job: Job, resolver: Resolver, status: str, reason: str) -> Outcome:
    """The outcome of a job that produced nothing (e.g. its worker process died)."""
    family = resolver.family(job.family)
    try:
        rows = job_rows(job, family, status, reason)
    except Exception as exc:  # the family's own expect() fails: one row says so
        rows = [{"case": job.family, "variant": job.variant.id, "engine": job.engine, "metric": "-",
                 "status": "error", "reason": f"{reason}; and expect() raised {describe(exc)}"}]
    return Outcome(job, rows)


# --- building and stepping one scene -------------------------------------------------------

class Failed(Exception):
    """A scene that gave no run: `status` unsupported, unstable or error, with the reason;
    `stage` "build" or "run"; `exception` the type name of what the engine raised, and
    `cause` the exception itself; `knobs` the engine's knobs of an unstable run."""

    def __init__(self, status: str, reason: str, stage: str = "build", cause: BaseException | None = None,
                 knobs: dict | None = None):
        super().__init__(reason)
        self.status, self.reason, self.stage, self.cause = status, reason, stage, cause
        self.exception = type(cause).__name__ if cause is not None else None
        self.knobs = dict(knobs or {})


def run_scene(adapter, scene, settings: Settings, steps: int, needs: frozenset = frozenset(),
              make_probe: Callable[[], Probe] = Probe, warmup: int = 0) -> tuple[Run, dict]:
    """Build `scene` on `adapter`, step and record it `steps` times (record.simulate) and
    take the probe's reading: (Run, what the probe read). The one build-and-step of every
    job (`execute`) and of the readings that make their own scenes (physval real's tosses).
    Raises Failed: unsupported (the engine cannot represent the scene, or its build says
    so), error (the build or a step raised: `describe`d), unstable (the state blew up)."""
    why_not = adapter.capabilities.cannot_run(scene, needs)
    if why_not:
        raise Failed("unsupported", why_not)
    probe = make_probe()
    try:
        sim = adapter.build(scene, settings)
    except Unsupported as exc:
        raise Failed("unsupported", str(exc)) from None
    except Exception as exc:  # an engine crash while building: recorded, the run goes on
        raise Failed("error", "the engine failed to build the scene: " + describe(exc), cause=exc) from None
    try:
        with sim:
            run = simulate(sim, scene, settings.dt, steps, forces="contact_forces" in needs or probe.forces,
                           warmup=warmup, on_step=probe.on_step if type(probe).on_step is not Probe.on_step else None,
                           points=bool({"contact_points", "contact_geometry"} & needs))
            return run, probe.after(run, sim, lambda: adapter.build(scene, settings))
    except Unstable as exc:
        raise Failed("unstable", str(exc), "run", knobs=getattr(sim, "knobs", {})) from None
    except Exception as exc:
        raise Failed("error", "the engine raised " + describe(exc), "run", cause=exc) from None


# --- executing one job ---------------------------------------------------------------------

def execute(job: Job, resolver: Resolver) -> Outcome:
    """Build, step, record and judge one job. Never raises."""
    family = resolver.family(job.family)
    params = job.variant.params
    where = f"{family.module_file} ({family.name}[{job.variant.id}])"
    try:
        settings = settings_of(job, family)
        checks = checks_of(job, family)
        scene = scene_of(family, job.variant)
        needs = needs_of(family, job.variant)
    except SettingsError as exc:
        return Outcome(job, job_rows(job, family, "error", str(exc)))
    except Exception as exc:  # the case's own code
        return failed(job, resolver, "error", f"the case's code raised {describe(exc)} in {where}")
    base = {"effects": ",".join(sorted(scene.effects))}

    def rows_with(status: str, reason: str, **extra) -> list[dict]:
        return job_rows(job, family, status, reason, checks, **base, **extra)

    try:
        adapter = resolver.adapter(job.engine)
    except Exception as exc:  # unknown or not installed
        return Outcome(job, rows_with("unsupported", str(exc)))
    base["engine_version"] = resolver.version(job.engine)
    try:
        known = resolver.known(job.engine)
    except deviations.DeviationFileError as exc:  # a worker must not die of a bad file: its rows say why
        return Outcome(job, rows_with("error", f"the known-deviation file does not parse: {exc}"))
    if job.relation:
        return Outcome(job, related(job, family, adapter, known, scene, settings, base))
    try:
        run, extra = run_scene(adapter, scene, settings, steps_of(job, family), needs=needs,
                               make_probe=lambda: _probe(job), warmup=job.warmup)
    except Failed as f:
        if f.status == "error" and f.stage == "run":  # judged against the bands of a known exception
            return Outcome(job, _raised(job, family, checks, known, f.cause, base), exception=f.exception)
        knobs = {"knobs": _knobs(f.knobs)} if f.status == "unstable" else {}
        return Outcome(job, rows_with(f.status, f.reason, **knobs), exception=f.exception)
    timing = {"wall_s": run.wall_s, "sim_s": run.steps * settings.dt, "steps": run.steps,
              "iterations": "" if run.iterations is None else run.iterations,
              "effects_simulated": ",".join(sorted(run.effects)), "knobs": _knobs(run.knobs)}
    try:
        measured = family.observe(run.trajectory, params)
        if not hasattr(measured, "get"):
            raise TypeError(f"observe() returned {type(measured).__name__}, not a dict of metrics")
    except TrajectoryError as exc:
        return Outcome(job, rows_with("error", f"observe() in {where}: {exc}", **timing), extra)
    except Exception as exc:
        return Outcome(job, rows_with("error", f"observe() in {where} raised {describe(exc)}", **timing), extra)
    bands_apply = at_recorded_settings(job, family)
    rows = []
    for c in adapter.capabilities.judged(checks, run.iterations):
        fields = {**base, **timing}
        value = measured.get(c.metric)
        if c.metric not in measured:
            rows.append(blank_row(family.name, job.variant, job.engine, c, status="error", dt=settings.dt,
                                  reason=f"observe() in {where} gave no {c.metric!r}", **fields))
            continue
        number = number_of(value)
        if number is None or not math.isfinite(number):
            rows.append(blank_row(family.name, job.variant, job.engine, c, status="error", dt=settings.dt,
                                  reason=f"observe() in {where} gave {c.metric} = {value!r}: not a finite number",
                                  **fields))
            continue
        entry = deviations.find(known, family.name, job.variant.id, c.metric)
        rows.append(blank_row(family.name, job.variant, job.engine, c, dt=settings.dt,
                              **fields, **judge(c, number, job.engine, job.variant.id, entry, bands_apply)))
    return Outcome(job, rows, extra, run_s=run.whole_s)


def rejudge(job: Job, rows: list[dict], resolver: Resolver) -> list[dict] | None:
    """A finished job's stored rows with their verdicts judged again against the engine's
    known deviations of now (an edited band moves verdicts, not measurements), or None
    where the rows cannot say what a run would (the job runs again): an invariance
    relation's row (its reason carries the comparison), an error (a run the engine aborted
    is judged by the bands of its exception: `_raised`), a known deviation without a
    measured value. Each check is judged as `execute` judges it, from the values the row
    holds: the check (expected, tolerance at the engine's width, kind) and the measured
    value, written to the store exactly (repr)."""
    if job.relation:
        return None
    family = resolver.family(job.family)
    try:
        known = resolver.known(job.engine)
    except deviations.DeviationFileError:
        return None
    bands_apply = at_recorded_settings(job, family)
    out = []
    for r in rows:
        if r["status"] in ("unsupported", "unstable"):  # no measurement, no band: as stored
            out.append(r)
            continue
        try:
            measured = float(r["measured"])
            c = Check(metric=r["metric"], unit=r["unit"], expected=float(r["expected"]),
                      tolerance=float(r["tolerance"]), kind=r["tolerance_kind"], why=r["tolerance_reason"] or "-",
                      measures=r["measures"] or "physics")
        except (KeyError, TypeError, ValueError):
            return None
        if r["status"] not in ("pass", "fail", "deviation") or not math.isfinite(measured):
            return None
        entry = deviations.find(known, family.name, job.variant.id, c.metric)
        out.append({**r, "reason": "", **judge(c, measured, job.engine, job.variant.id, entry, bands_apply)})
    return out


def related(job: Job, family: CaseFamily, adapter, known, scene, settings: Settings, base: dict) -> list[dict]:
    """The row of a job's invariance relation: the scene run as given and through the
    relation, the second run mapped back and compared (physval.core.invariance)."""
    relation = relations.by_name(job.relation)
    steps = steps_of(job, family)
    plain = invariance.check(relation, scene, steps)
    why_not = relation.applies(scene) or adapter.capabilities.cannot_run_as(relation.needs)
    if why_not:
        return job_rows(job, family, "unsupported", f"{relation.name}: {why_not}", [plain], **base)
    try:
        other, again = relation.transform(scene), invariance.settings_for(relation, settings)
    except Exception as exc:  # the relation cannot make the scene another way (SceneError, a shape it cannot scale)
        return job_rows(job, family, "unsupported", f"{relation.name}: {describe(exc)}", [plain], **base)
    why_not = adapter.capabilities.cannot_run(other)
    if why_not:
        return job_rows(job, family, "unsupported", f"{relation.name}: {why_not}", [plain], **base)
    try:
        first, _ = run_scene(adapter, scene, settings, steps)
    except Failed as f:
        return job_rows(job, family, f.status, f.reason, [plain], **base)
    try:
        if relation.restart:
            half = steps // 2
            before, saved = run_scene(adapter, other, again, half, make_probe=invariance.Saving)
            after, _ = run_scene(adapter, other, again, steps - half,
                                 make_probe=lambda: invariance.Restoring(saved["state"]))
            second = invariance.joined(before.trajectory, after.trajectory)
        else:
            second = run_scene(adapter, other, again, steps)[0].trajectory
    except Failed as f:
        return job_rows(job, family, f.status, f"the {relation.name} run: {f.reason}", [plain], **base)
    caps = adapter.capabilities
    substeps = first.iterations if caps.substeps and first.iterations else 1
    c = invariance.check(relation, scene, steps, caps.float_bits, substeps)
    parting = invariance.compare(first.trajectory, relation.map_back(second, scene), c.tolerance)
    entry = deviations.find(known, family.name, job.variant.id, c.metric)
    verdict = judge(c, parting.largest, job.engine, job.variant.id, entry, at_recorded_settings(job, family))
    said = parting.text(c.tolerance)
    verdict["reason"] = f"{verdict['reason']}; {said}" if verdict.get("reason") else said
    return [blank_row(family.name, job.variant, job.engine, c, dt=settings.dt, **base, **verdict)]


def _raised(job, family, checks, known, exc, base) -> list[dict]:
    """Rows of a run the engine aborted with an exception: each check whose recorded band
    says the run raises exactly this is that known deviation; otherwise all are errors."""
    name = type(exc).__name__
    entries = [deviations.find(known, family.name, job.variant.id, c.metric) for c in checks]
    bands = [e.band(job.engine, job.variant.id, c.metric) if e else None for e, c in zip(entries, checks)]
    if all(b is not None and b.holds(exception=name) for b in bands):
        return [blank_row(family.name, job.variant, job.engine, c, status="deviation", dt=time_step(job, family),
                          known_deviation=e.cause, band=b.describe(), iterations=job.iterations or "",
                          reason=f"{e.cause} [{describe(exc)}]", **base)
                for c, e, b in zip(checks, entries, bands)]
    return job_rows(job, family, "error", "the engine raised " + describe(exc), checks, **base)


def number_of(value) -> float | None:
    """The float a metric's value stands for; None for a bool or what is no number."""
    if isinstance(value, bool):
        return None
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


PER_ITEM_KNOBS = 12  # a knob section with more entries (one per body or pair) is grouped


def _knobs(knobs: dict) -> str:
    """The engine's knobs as JSON, one line per result row. A section keyed by body or
    pair (MuJoCo's `pair`, `geom`, ...) grows with the scene: 23,000 pairs of a 216-ball
    pile made 7.7 MB a row. Past PER_ITEM_KNOBS entries, entries alike once their own
    names are left out are written once, under "<n> like <first key>"."""
    return json.dumps({k: _grouped(v) if isinstance(v, dict) and len(v) > PER_ITEM_KNOBS else v
                       for k, v in knobs.items()}, sort_keys=True, default=str)


def _grouped(section: dict) -> dict:
    groups: dict[str, tuple[str, int, object]] = {}
    for key, value in section.items():
        names = set(str(key).split("|"))
        if isinstance(value, dict):
            value = {k: v for k, v in value.items() if not (isinstance(v, str) and v in names)}
        text = json.dumps(value, sort_keys=True, default=str)
        first, n, _ = groups.get(text, (key, 0, value))
        groups[text] = (first, n + 1, value)
    return {(first if n == 1 else f"{n} like {first}"): value for first, n, value in groups.values()}


def _probe(job: Job) -> Probe:
    if not job.probe:
        return Probe()
    module, name = job.probe.split(":")
    return getattr(importlib.import_module(module), name)(job)
