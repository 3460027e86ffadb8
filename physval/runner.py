"""Runs case variants on engines and turns what they did into verdict rows.

One job = one (family, variant, engine, settings). A job never raises: an engine that
cannot represent the scene, blows up or crashes becomes rows with status `unsupported`,
`unstable` or `error`, and the run goes on.
"""
from __future__ import annotations

import json
import math
import time
import traceback
from fnmatch import fnmatchcase
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass

import numpy as np

from adapters import registry
from adapters.base import Adapter, Settings, Simulation, Unsupported
from cases.family import CaseFamily, Check, Variant
from cases.registry import all_families
from cases.scene import Scene
from cases.trajectory import STATE_SIZE, Trajectory
from physval import deviations
from physval.metrics import errors, within

COLUMNS = ["case", "variant", "params", "engine", "engine_version", "dt", "iterations", "effects",
           "effects_simulated", "metric", "unit", "expected", "measured", "abs_error", "rel_error",
           "tolerance", "tolerance_kind", "tolerance_reason", "status", "reason", "known_deviation",
           "wall_s", "sim_s", "steps", "knobs"]


class Unstable(Exception):
    """The simulation produced NaN or infinity, or blew up."""


@dataclass(frozen=True)
class Job:
    family: str
    variant: Variant
    engine: str
    dt: float | None = None          # None: the family's default
    iterations: int | None = None    # None: the adapter's default

    @property
    def test_id(self) -> str:
        return f"{self.variant.test_id}-{self.engine}"


@dataclass
class Run:
    trajectory: Trajectory
    wall_s: float          # stepping only
    steps: int
    knobs: dict
    effects: frozenset
    iterations: int | None


def speed_limit(scene: Scene, duration: float) -> float:
    """A speed no body reaches unless the integration blew up: ten times what initial
    speed plus gravity acting for the whole run could give, and at least 100 m/s."""
    v0 = max(np.linalg.norm(b.velocity) + np.linalg.norm(b.angular_velocity) * 10 for b in scene.dynamic_bodies)
    return max(100.0, 10.0 * (v0 + np.linalg.norm(scene.gravity) * duration + 1.0))


def simulate(sim: Simulation, scene: Scene, dt: float, duration: float, warmup: int = 0) -> Run:
    """Step a built simulation for `duration`, recording every step; time the steps only,
    leaving the first `warmup` steps out of the timing (`Run.wall_s` covers the rest)."""
    names = [b.name for b in scene.dynamic_bodies]
    n = max(1, int(round(duration / dt)))
    states = np.empty((len(names), n + 1, STATE_SIZE))
    first = sim.states()
    for i, name in enumerate(names):
        states[i, 0] = first[name]
    forces: dict[tuple[str, str], np.ndarray] = {}
    v_max = speed_limit(scene, duration)
    wall = 0.0
    for k in range(1, n + 1):
        t0 = time.perf_counter()
        sim.step()
        if k > warmup:
            wall += time.perf_counter() - t0
        now = sim.states()
        for i, name in enumerate(names):
            states[i, k] = now[name]
        for pair, f in sim.contact_forces().items():
            if pair not in forces:
                forces[pair] = np.zeros(n + 1)
            forces[pair][k] = f
        row = states[:, k]
        if not np.all(np.isfinite(row)):
            raise Unstable(f"NaN or infinity in the state at t = {k * dt:.4g} s")
        speed = np.max(np.linalg.norm(row[:, 7:10], axis=1))
        if speed > v_max:
            raise Unstable(f"speed {speed:.3g} m/s at t = {k * dt:.4g} s exceeds {v_max:.3g} m/s: blew up")
    traj = Trajectory(dt=dt, t=np.arange(n + 1) * dt, states={nm: states[i] for i, nm in enumerate(names)},
                      forces=forces, effects=frozenset(sim.effects))
    return Run(traj, wall, n, dict(sim.knobs), frozenset(sim.effects), sim.iterations)


def _row(job: Job, family: CaseFamily, check: Check, **fields) -> dict:
    row = {c: "" for c in COLUMNS}
    row.update(case=family.name, variant=job.variant.id, params=job.variant.params_json, engine=job.engine,
               metric=check.metric, unit=check.unit, expected=check.expected, tolerance=check.tolerance,
               tolerance_kind=check.kind, tolerance_reason=check.why, measured=math.nan,
               abs_error=math.nan, rel_error=math.nan)
    row.update(fields)
    return row


def run_job(job: Job, family: CaseFamily, adapter: Adapter | None = None,
            known: list[deviations.Deviation] | None = None, warmup: int = 0) -> list[dict]:
    """All verdict rows of one job. Never raises. `wall_s` leaves out `warmup` steps."""
    dt = job.dt or family.dt_for(job.variant.params)
    params = job.variant.params
    checks = family.expect(params, dt)
    scene = family.scene(params)
    base = {"dt": dt, "effects": ",".join(sorted(scene.effects)), "iterations": job.iterations or ""}

    def rows_with(status: str, reason: str, **extra) -> list[dict]:
        return [_row(job, family, c, status=status, reason=reason, **base, **extra) for c in checks]

    try:
        adapter = adapter or registry.get(job.engine)
    except registry.EngineError as exc:
        return rows_with("unsupported", str(exc))
    base["engine_version"] = _version(adapter)
    why_not = adapter.capabilities.cannot_run(scene, family.needs_of(params))
    if why_not:
        return rows_with("unsupported", why_not)
    try:
        settings = Settings(dt=dt, iterations=job.iterations)
        sim = adapter.build(scene, settings)
    except Unsupported as exc:
        return rows_with("unsupported", str(exc))
    except Exception as exc:  # an engine crash while building: recorded, the run goes on
        return rows_with("error", _describe(exc))
    known = deviations.load(job.engine) if known is None else known
    try:
        with sim:
            run = simulate(sim, scene, dt, family.duration(params), warmup)
    except Unstable as exc:
        return rows_with("unstable", str(exc), knobs=json.dumps(getattr(sim, "knobs", {}), default=str))
    except Exception as exc:
        # an exception every check of which is a known deviation (e.g. a solver that
        # detects it cannot solve the scene) is that deviation; otherwise it is an error
        entries = [deviations.find(known, family.name, job.variant.id, c.metric) for c in checks]
        if all(entries):
            return [_row(job, family, c, status="deviation", known_deviation=e.reason,
                         reason=f"{e.reason} [{_describe(exc)}]", **base) for c, e in zip(checks, entries)]
        return rows_with("error", _describe(exc))
    timing = {"wall_s": run.wall_s, "sim_s": run.steps * dt, "steps": run.steps,
              "iterations": "" if run.iterations is None else run.iterations,
              "effects_simulated": ",".join(sorted(run.effects)),
              "knobs": json.dumps(run.knobs, sort_keys=True, default=str)}
    try:
        measured = family.observe(run.trajectory, params)
    except Exception as exc:
        return rows_with("error", "observing the trajectory failed: " + _describe(exc),
                         **{k: v for k, v in timing.items() if k != "iterations"})
    done = {**base, **timing}
    rows = []
    for c in checks:
        if c.metric not in measured:
            rows.append(_row(job, family, c, status="error", reason=f"observe() gave no {c.metric!r}", **done))
            continue
        entry = deviations.find(known, family.name, job.variant.id, c.metric)
        rows.append(_row(job, family, c, **judge(c, float(measured[c.metric]), entry), **done))
    return rows


def judge(c: Check, value: float, entry: deviations.Deviation | None) -> dict:
    """The verdict fields of one check: pass, fail, deviation (failing, but a known entry),
    or unstable (the measured value is not a number)."""
    abs_err, rel_err = errors(c.expected, value)
    fields = dict(measured=value, abs_error=abs_err, rel_error=rel_err,
                  known_deviation=entry.reason if entry else "")
    size = abs_err if c.kind == "abs" else rel_err
    if not math.isfinite(value):
        return dict(fields, status="unstable", reason=f"{c.metric} is {value}")
    if within(c, abs_err, rel_err):
        return dict(fields, status="pass")
    if entry:
        return dict(fields, status="deviation", reason=(
            f"{entry.reason} [measured {value:.6g} {c.unit}, expected {c.expected:.6g}: "
            f"{c.kind} error {size:.3g} > tolerance {c.tolerance:.3g}]"))
    return dict(fields, status="fail", reason=f"{c.kind} error {size:.3g} > tolerance {c.tolerance:.3g}")


def _version(adapter: Adapter) -> str:
    try:
        return adapter.version()
    except Exception:
        return "unknown"


def _describe(exc: BaseException) -> str:
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    loc = f" (at {where.filename.rsplit('/', 1)[-1]}:{where.lineno})" if where else ""
    return f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}{loc}"


# --- many jobs ----------------------------------------------------------------------------

def plan(families: dict[str, CaseFamily], engines: list[str], dt: float | None = None,
         iterations: int | None = None) -> list[Job]:
    return [Job(name, v, eng, dt, iterations) for name, fam in families.items()
            for v in fam.variants for eng in engines]


# The reference formulations other than the default run these families unless asked for
# more (they are pure Python: the whole case library on eight formulations would take an hour).
REFERENCE_VARIANT_FAMILIES = ("central_impact", "incline_threshold", "resting_blocks", "conformance")
# Runs that take minutes each (pure-Python pairwise impulses over a stack's corner contacts):
# left out of the default run and the default tests; name them to run them
# (`physval run --engines reference-newton-coulomb --cases resting_blocks`, `pytest -m slow`).
ON_DEMAND = (("reference-newton-coulomb", "resting_blocks", "n=[2-9]*"),)


def on_demand(job: Job) -> bool:
    return any(job.engine == e and job.family == f and fnmatchcase(job.variant.id, v) for e, f, v in ON_DEMAND)


def default_jobs(families: dict[str, CaseFamily], engines: list[str], dt: float | None = None,
                 iterations: int | None = None, include_on_demand: bool = False) -> list[Job]:
    """The jobs of a run whose cases were not named: every family on the engines, the
    reference formulations on REFERENCE_VARIANT_FAMILIES and on the compliant variants
    whose contact law they model, on-demand runs only if asked."""
    from adapters import registry
    jobs = []
    for job in plan(families, engines, dt, iterations):
        if job.engine.startswith("reference-") and job.family not in REFERENCE_VARIANT_FAMILIES:
            laws = families[job.family].scene(job.variant.params).contact_laws
            if not (laws and laws <= registry.get(job.engine).capabilities.contact_laws):
                continue
        if on_demand(job) and not include_on_demand:
            continue
        jobs.append(job)
    return jobs


def families(cases_dir=None) -> dict[str, CaseFamily]:
    """Every family physval runs: the built-in cases, a user's --cases-dir, and the
    adapter conformance battery."""
    from physval import conformance
    return {**all_families(cases_dir), conformance.FAMILY.name: conformance.FAMILY}


_WORKER_FAMILIES: dict[str, CaseFamily] = {}


def _init_worker(cases_dir):
    _WORKER_FAMILIES.update(families(cases_dir))


def _run_in_worker(job: Job) -> list[dict]:
    return run_job(job, _WORKER_FAMILIES[job.family])


def run_jobs(jobs: list[Job], families: dict[str, CaseFamily], workers: int = 1, cases_dir=None,
             progress: bool = True, on_rows=None) -> list[dict]:
    """Run every job; rows come back in job order. `on_rows(job, rows)` sees each job as it
    finishes (for streaming to disk). `progress` shows a bar with an ETA on stderr."""
    from tqdm import tqdm
    results: dict[int, list[dict]] = {}
    bar = tqdm(total=len(jobs), unit="run", disable=not progress, dynamic_ncols=True)
    try:
        if workers <= 1:
            adapters_cache: dict[str, Adapter] = {}
            known_cache: dict[str, list] = {}
            for i, job in enumerate(jobs):
                bar.set_description(job.test_id[:60])
                if job.engine not in adapters_cache:
                    try:
                        adapters_cache[job.engine] = registry.get(job.engine)
                    except registry.EngineError:
                        adapters_cache[job.engine] = None
                    known_cache[job.engine] = deviations.load(job.engine)
                results[i] = run_job(job, families[job.family], adapters_cache[job.engine], known_cache[job.engine])
                if on_rows:
                    on_rows(job, results[i])
                bar.update()
        else:
            with ProcessPoolExecutor(workers, initializer=_init_worker, initargs=(cases_dir,)) as pool:
                futures = {pool.submit(_run_in_worker, job): i for i, job in enumerate(jobs)}
                for fut in as_completed(futures):
                    i = futures[fut]
                    try:
                        results[i] = fut.result()
                    except Exception as exc:  # a worker that died (e.g. a segfaulting engine)
                        job = jobs[i]
                        fam = families[job.family]
                        results[i] = [_row(job, fam, c, status="error", reason="worker died: " + _describe(exc),
                                           dt=job.dt or fam.dt_for(job.variant.params))
                                      for c in fam.expect(job.variant.params, job.dt or fam.dt_for(job.variant.params))]
                    if on_rows:
                        on_rows(jobs[i], results[i])
                    bar.update()
    finally:
        bar.close()
    return [row for i in range(len(jobs)) for row in results.get(i, [])]
