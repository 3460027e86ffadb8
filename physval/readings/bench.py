"""`physval bench`: speed measured side by side in one run, reported as ratios (this
machine is noisy; absolute times are for orientation only). Never a pass/fail test.

- `overhead`: per engine and scene (one body, two bodies, a 5-box stack), the time per
  step of the core's full recorded step (physval.core.record.simulate: stepping, reading
  the states, contact forces where the case reads them) against a bare loop of
  `Simulation.step()`, as a ratio;
- `step`: wall time per step of the same scenes on every engine, as ratios to MuJoCo's
  (a 5-box stack and a 55-box, 10-layer pyramid);
- `compile`: the reference formulations' numba compilation: each formulation's run in a
  fresh worker process with an empty numba cache (cold: compiling) and again with that
  cache filled (cached: loading), beside its step compiled and uncompiled;
- `sweep-workers`: the same small sweep with 1 and with 2 local workers (throughput ratio);
- `pgs`: the reference's projected Gauss-Seidel, cost of one sweep against the number of
  contacts (doubling the contacts should at most about double the time);
- `narrow`: narrow-phase queries per second on the narrow-phase family's catalogue of
  convex pairs: the reference's compiled GJK/EPA against python-fcl and the engines'
  collision routines that can be called alone (PyBullet's getClosestPoints, MuJoCo's
  mj_geomDistance and mj_collision), as ratios to the fastest;
- `faults`: not a speed: the suite's own power. Each fault of physval/faults.py planted in
  each engine it is written for, every family's default variants run on it, and the
  detection matrix written: failing checks per fault and family;
- `oracle` (only when named: it needs Pinocchio, the `oracle` extra): the reference's contact
  problems of a few steps of its own scenes solved by its Lemke, PGS and SPOOK and by
  Pinocchio's ADMM and PGS: where the solutions agree, and residual against CPU time
  (physval.readings.oracle);
- `run` (only when named: two whole default runs): `physval run` as a user runs it, in a
  fresh process, cold (empty physval and numba caches) and then warm (the caches filled),
  each timed whole, with where its time went (the run's Cost section: planning, the
  engines' steps, the rest of the jobs, the readings, the workers' overhead per job, the
  report, CPU) and each engine's worker-seconds, against the default run's budget.

Every measurement but `run` and `oracle` (the reference's solvers timed in this process) runs
as a job of the core (physval.core), one worker at a time, so engines are timed side by side
in the same conditions.
"""
from __future__ import annotations

import importlib.util
import math
import time
from pathlib import Path

import numpy as np
import pandas as pd

from cases.family import Variant
from physval.core import Context, Job, Probe, run_jobs, simulate
from physval.core.session import Execution
from physval.readings import oracle
from physval.report import first_clause, md_table, write_atomic

WHAT = ("overhead", "step", "compile", "sweep-workers", "pgs", "narrow", "faults", "oracle", "run")
# not in `physval bench` without names: `run` takes minutes of a whole default run, twice;
# `oracle` needs Pinocchio (the `oracle` extra)
ON_DEMAND = ("oracle", "run")


# --- overhead: the core's recorded step against a bare step ----------------------------------

# (label, family, variant params per dimension): one body, two bodies, a 5-box stack.
OVERHEAD_SCENES = (
    ("one body (ball dropped on the ground)", "central_impact", {3: {"setup": "drop", "e": 0.5, "h": 1.0, "dim": 3},
                                                                  2: {"setup": "drop", "e": 0.5, "h": 1.0, "dim": 2}}),
    ("two bodies (head-on spheres)", "central_impact", {3: {"setup": "spheres", "e": 0.5, "m": "1:3", "dim": 3},
                                                         2: {"setup": "spheres", "e": 0.5, "m": "1:3", "dim": 2}}),
    ("5-box stack (contact forces read)", "resting_blocks", {3: {"n": 5, "dim": 3}, 2: {"n": 5, "dim": 2}}),
)
OVERHEAD_STEPS = 2000
OVERHEAD_ROUNDS = 5


class Overhead(Probe):
    """Alternating rounds of a bare step loop and the core's recorded run of the same
    scene (each freshly built), the minimum per step of each."""

    def __init__(self, job: Job):
        from physval.core.context import Context
        self.family = Context().resolver().family(job.family)
        self.params = job.variant.params
        self.steps = int(dict(job.probe_args).get("steps", OVERHEAD_STEPS))

    def after(self, run, sim, rebuild) -> dict:
        scene = self.family.scene(self.params)
        forces = "contact_forces" in self.family.needs_of(self.params)
        bare = read = core = math.inf
        for _ in range(OVERHEAD_ROUNDS):
            with rebuild() as s:
                step = s.step
                t0 = time.perf_counter()
                for _ in range(self.steps):
                    step()
                bare = min(bare, (time.perf_counter() - t0) / self.steps)
            with rebuild() as s:
                read = min(read, _stepped_and_read(s, self.steps, forces))
            with rebuild() as s:
                t0 = time.perf_counter()
                simulate(s, scene, run.trajectory.dt, self.steps, forces=forces)
                core = min(core, (time.perf_counter() - t0) / self.steps)
        return {"bare_us": bare * 1e6, "read_us": read * 1e6, "core_us": core * 1e6}


def _stepped_and_read(sim, steps: int, forces: bool) -> float:
    """Seconds per step of the least any recorder must do through the engine's API: step,
    copy the raw state into a preallocated row (or the engine's own block recorder), read
    the contact forces where the case uses them; no decoding, no checks."""
    raw = np.empty((steps + 1, sim.state_size()))
    if sim.run is not None and not forces:
        t0 = time.perf_counter()
        sim.run(steps, raw[1:])
        return (time.perf_counter() - t0) / steps
    step, write, read_forces = sim.step, sim.write_state, sim.contact_forces
    t0 = time.perf_counter()
    for k in range(1, steps + 1):
        step()
        write(raw[k])
        if forces:
            read_forces()
    return (time.perf_counter() - t0) / steps


def overhead(engines: list[str], ctx: Context, execution: Execution) -> pd.DataFrame:
    resolver = ctx.resolver()
    jobs = []
    for label, family, by_dim in OVERHEAD_SCENES:
        fam = resolver.family(family)
        for e in engines:
            try:
                dim = 3 if 3 in resolver.adapter(e).capabilities.dimensions else 2
            except Exception:
                continue
            params = by_dim[dim]
            v = Variant(fam.name, fam.variant_id(params), params)
            jobs.append((label, dim, Job(family, v, e, probe=f"{__name__}:Overhead",
                                         probe_args=(("steps", OVERHEAD_STEPS),))))
    res = run_jobs([j for _, _, j in jobs], ctx, 1, execution.scheduler, execution.job_timeout,
                   execution.start_method, progress=execution.progress, label="bench overhead")
    out = []
    for label, dim, job in jobs:
        first = (res.rows.get(job.key) or [{}])[0]
        bare, read, core = (first.get(k, math.nan) for k in ("bare_us", "read_us", "core_us"))
        out.append({"engine": job.engine, "scene": f"{label}, {dim}D", "bare step us": bare,
                    "step + API read us": read, "recorded step us": core,
                    "recorded / bare": core / bare if bare else math.nan,
                    "recorded / (step + API read)": core / read if read else math.nan,
                    "note": "" if "bare_us" in first
                    else f"{first.get('status', '')}: {first_clause(first.get('reason', ''))}"})
    return pd.DataFrame(out)


OVERHEAD_NOTE = (
    f"Minimum over {OVERHEAD_ROUNDS} alternating rounds of {OVERHEAD_STEPS} steps at the family's dt, each on a "
    "freshly built scene. `bare step`: a loop of `Simulation.step()` alone. `step + API read`: the least any "
    "recorder must do through the engine's own API: step, copy the raw state into a preallocated row (or the "
    "engine's own block recorder), and read the contact forces where the case uses them (the stack). `recorded "
    "step`: the core's `simulate()`, which adds decoding in blocks of 256 steps and the blow-up check. Targets "
    "of the execution-core issue: recorded / bare <= 1.5 on one body, <= 1.1 on the stack. On one body they "
    "hold where the engine hands its state over in one call (MuJoCo's rollout, Drake's "
    "GetPositionsAndVelocities, the reference). Elsewhere the engine's own per-body read calls cost more than "
    "half its step (PyBullet: getBasePositionAndOrientation and getBaseVelocity; Pymunk: four Chipmunk getters; "
    "DART: getPositions and getVelocities per skeleton; Rapier and Box2D: four property reads per body), so no "
    "recorder that keeps every step can meet the target there. On the stack every engine but the reference "
    "reads its contact forces contact by contact in Python (Box2D: rebuilt by the adapter from the bodies' "
    "momentum changes, as pyb2d3 exposes no per-step contact data). What the core itself adds is the last "
    "column, recorded / (step + API read).")


# --- step time side by side ----------------------------------------------------------------

STEP_SCENES = (("5-box stack", {"structure": "stack", "n": 5}), ("10-layer pyramid (55 boxes)", {"structure": "pyramid", "n": 10}))


def steps_side_by_side(engines: list[str], ctx: Context, execution: Execution, steps: int = 20) -> pd.DataFrame:
    """Minimum over 2 repeats of the wall time per step over `steps` steps at dt = 1e-3
    after 10 warm-up steps, on robustness_stacks' scenes, one row an installed engine;
    ratios to STEP_BASELINE's step."""
    from physval.readings.sweep import Timing  # noqa: F401  (the probe the jobs name)
    resolver = ctx.resolver()
    fam = resolver.family("robustness_stacks")
    jobs = {}
    for label, p in STEP_SCENES:
        for e in engines:
            try:
                dim = 3 if 3 in resolver.adapter(e).capabilities.dimensions else 2
            except Exception:
                continue
            params = {**p, "dim": dim, "T": (steps + 10) * 1e-3}
            v = Variant(fam.name, fam.variant_id(params), params)
            jobs[(label, e)] = Job(fam.name, v, e, 1e-3, probe="physval.readings.sweep:Timing",
                                   probe_args=(("repeats", 2),), warmup=10)
    res = run_jobs(list(jobs.values()), ctx, 1, execution.scheduler, execution.job_timeout, execution.start_method,
                   progress=execution.progress, label="bench step")
    us, why = {}, {}
    for key, job in jobs.items():
        first = (res.rows.get(job.key) or [{}])[0]
        timed = first.get("wall_per_sim_s") not in (None, "")
        us[key] = float(first["wall_per_sim_s"]) * 1e-3 * 1e6 if timed else math.nan
        if not timed:  # the run's own verdict says why it has no time
            why[key] = f"{first.get('status', 'error')}: {first_clause(first.get('reason', 'no row'))}"
    out = []
    for e in engines:  # one row an engine: its step on each scene and that step in baseline steps
        if not any((label, e) in jobs for label, _ in STEP_SCENES):
            continue  # not installed
        row = {"engine": e}
        for label, _ in STEP_SCENES:
            mine, base = us.get((label, e), math.nan), us.get((label, STEP_BASELINE), math.nan)
            row[f"{label} us/step"] = mine
            row[f"{label} / {STEP_BASELINE}"] = mine / base
        row["no time because"] = "; ".join(f"{label}: {why[(label, e)]}" for label, _ in STEP_SCENES
                                           if (label, e) in why)
        out.append(row)
    return pd.DataFrame(out)


# the engine every other's step is set against: the fastest widely used engine that runs every
# scene here (the ratios the reference formulations' targets are stated in)
STEP_BASELINE = "mujoco"


# --- compilation: the reference formulations' numba cache, cold and warm ------------------------

# the scene each formulation is timed on: the 5-box stack, else (a formulation without
# friction or impulses) the first Newton's cradle variant it represents
COMPILE_SCENES = (("robustness_stacks", {"structure": "stack", "n": 5, "dim": 3, "T": 0.1}), ("newtons_cradle", None))


class StepTimes(Probe):
    """The run's stepping time, then the same scene rebuilt and stepped again in the same
    process. In a fresh process numba compiles (or loads from its cache) a function at its
    first call, in whichever step first calls it (a contact's first step, say): the first
    run pays it, the second does not. `extra_s`: first minus second; `step_s`: the second
    run's mean step."""

    def __init__(self, job: Job):
        pass

    def after(self, run, sim, rebuild) -> dict:
        with rebuild() as again:
            t0 = time.perf_counter()
            for _ in range(run.steps):
                again.step()
            warm = time.perf_counter() - t0
        return {"extra_s": run.wall_s - warm, "step_s": warm / run.steps}


def compile_cost(engines: list[str], ctx: Context, execution: Execution) -> pd.DataFrame:
    """Per reference formulation in `engines`: one run in a fresh worker process (spawned,
    so nothing is compiled or imported beforehand) with an empty numba cache (cold), then
    one with the cache that run filled (cached), each less the same run repeated in its
    process (StepTimes); and the repeated run's mean step compiled and with
    NUMBA_DISABLE_JIT=1 (the same code as Python)."""
    import tempfile
    from physval.readings.cost import is_reference
    resolver = ctx.resolver()
    out = []
    for e in engines:
        if not is_reference(e):
            continue  # numba compiles the reference's formulations only
        job = _compile_job(e, resolver.adapter(e), resolver)
        if job is None:
            continue
        with tempfile.TemporaryDirectory(prefix="physval-numba-") as cache:
            cold, cached = (_in_fresh_worker(job, ctx, execution, {"NUMBA_CACHE_DIR": cache}) for _ in range(2))
        plain = _in_fresh_worker(job, ctx, execution, {"NUMBA_DISABLE_JIT": "1"})
        out.append({"formulation": e, "scene": job.variant.test_id, "compiling s": cold["extra_s"],
                    "loading the cache s": cached["extra_s"], "compiled ms/step": cached["step_s"] * 1e3,
                    "plain Python ms/step": plain["step_s"] * 1e3,
                    "plain / compiled": plain["step_s"] / cached["step_s"]})
    return pd.DataFrame(out)


def _in_fresh_worker(job: Job, ctx: Context, execution: Execution, env: dict[str, str]) -> dict[str, float]:
    """StepTimes' readings of `job` run in a newly spawned worker that sees `env` in its
    environment (NaN where the job gave none)."""
    import os
    from unittest import mock
    with mock.patch.dict(os.environ, env):  # the spawned worker inherits it; restored after
        res = run_jobs([job], ctx, 1, None, execution.job_timeout, "spawn", progress=False, label="bench compile")
    first = (res.rows.get(job.key) or [{}])[0]
    return {k: float(first.get(k) or math.nan) for k in ("extra_s", "step_s")}


def _compile_job(engine: str, adapter, resolver) -> Job | None:
    """The job on the first of COMPILE_SCENES the formulation builds (a formulation refuses
    what it cannot represent when it builds the world; building steps nothing)."""
    from adapters.base import Settings, Unsupported
    for name, params in COMPILE_SCENES:
        fam = resolver.family(name)
        for v in ([Variant(fam.name, fam.variant_id(params), params)] if params else fam.variants):
            dt = 1e-3 if params else fam.dt_for(v.params)
            try:
                adapter.build(fam.scene(v.params), Settings(dt=dt)).close()
            except Unsupported:
                continue
            return Job(fam.name, v, engine, dt, probe="physval.readings.bench:StepTimes")
    return None


# --- sweep throughput ---------------------------------------------------------------------

def sweep_workers(engines: list[str], ctx: Context) -> pd.DataFrame:
    """One small sweep (central_impact's sweep variants) run with 1 and then 2 workers,
    each into a fresh store, so neither reuses the other's points."""
    from physval.readings.sweep import points, sweep_variants
    resolver = ctx.resolver()
    jobs = points(sweep_variants(resolver.families, ["central_impact"]), engines, resolver, repeats=1)
    out = []
    for workers in (1, 2):
        t0 = time.perf_counter()
        run_jobs(jobs, ctx, workers, progress=False)
        wall = time.perf_counter() - t0
        out.append({"workers": workers, "points": len(jobs), "wall_s": wall, "points_per_s": len(jobs) / wall})
    df = pd.DataFrame(out)
    df["throughput_vs_1_worker"] = df.points_per_s / df.points_per_s.iloc[0]
    return df


# --- faults: the detection matrix ---------------------------------------------------------

FAULTS_NOTE = ("Each fault of physval/faults.py, one thing changed in what the engine is given or reports (`none`: "
               "the wrapper alone), planted in each engine and run on every family's default variants (the robustness "
               "battery left out) at the family's dt, judged as the engine itself with its recorded known-deviation "
               "bands. A cell counts the checks that `fail`; `families flagging` counts the families with at least "
               "one; `not measured` names the families where checks came out `error` or `unstable` instead (an "
               "observer that could not measure: a fault should give a sized fail). Engines: reference, mujoco and "
               "pybullet unless --engines names others; a fault that needs an engine-internal change (a square "
               "friction cone, a damping, a restitution threshold) runs only on engines whose adapter makes it "
               "(adapters/planting.py).")


def faults_note() -> str:
    from physval import faults
    return FAULTS_NOTE + "\n\n" + "\n".join(f"- `{f.name}`: {f.summary}" for f in faults.FAULTS)


def fault_matrix(engines: list[str], ctx: Context, execution: Execution,
                 families: dict[str, list] | None = None) -> pd.DataFrame:
    """Fault x family detection counts for every installed engine of `engines`, over
    `families` (name -> variants; default: the default variants of every family but the
    robustness ones). Each fault's jobs run in worker processes that build the engine with
    the fault planted (physval.faults.verdicts: adapters.planting's hook), under the
    engine's own name, so its bands judge it."""
    from physval import faults
    resolver = ctx.resolver()
    if families is None:
        families = {n: f.variants for n, f in resolver.families.items() if "robustness" not in f.tags}
    adapters = {}
    for engine in engines:
        try:
            adapters[engine] = resolver.adapter(engine)
        except Exception:
            continue  # not installed
    out = []
    for fault in (faults.NONE, *faults.FAULTS):
        # the engines it can be planted in (MuJoCo's adapter makes no restitution threshold: it has no e)
        mine = [e for e, adapter in adapters.items() if faults.why_not(adapter, fault) is None]
        rows = faults.verdicts(fault, [j for e in mine for j in faults.jobs_of(families, e)], execution, ctx)
        for engine in mine:
            row = {"engine": engine, "fault": fault.name}
            broken = {}
            for name in families:
                found = [r for r in rows if r["case"] == name and r["engine"] == engine]
                row[name] = sum(r["status"] == "fail" for r in found)
                n = sum(r["status"] in ("error", "unstable") for r in found)
                if n:
                    broken[name] = n
            row["families flagging"] = sum(row[name] > 0 for name in families)
            row["total fails"] = sum(row[name] for name in families)
            row["checks"] = sum(r["engine"] == engine for r in rows)
            row["not measured (error/unstable)"] = ", ".join(f"{k}: {v}" for k, v in broken.items())
            out.append(row)
    order = {e: i for i, e in enumerate(adapters)}
    return pd.DataFrame(out).sort_values("engine", key=lambda c: c.map(order), kind="stable")


# --- report and command ---------------------------------------------------------------------

def write(out: Path, sections: dict[str, pd.DataFrame]) -> None:
    """bench.md and one CSV per benchmark run now; a benchmark not run now whose CSV an
    earlier run left in `out` keeps its section, marked as such."""
    out = Path(out)
    lines = ["# physval benchmarks", "",
             "Each section is measured side by side in one run on this machine; read the ratios, not the "
             "absolute times.", ""]
    for name in WHAT:
        path = out / f"bench_{name}.csv"
        if name in sections:
            df, note = sections[name], _note(name)
            write_atomic(path, df.to_csv(index=False))
        elif path.exists():
            df = pd.read_csv(path, keep_default_na=False)
            note = f"(From an earlier `physval bench {name}`, kept in {path.name}.) " + _note(name)
        else:
            continue
        lines += [f"## {name}", "", note, "", md_table(df.round(4), missing=""), ""]  # no figure: an empty cell
    write_atomic(out / "bench.md", "\n".join(lines))


def _note(name: str) -> str:
    if name == "faults":
        return faults_note()
    return {"overhead": OVERHEAD_NOTE, "step": STEP_NOTE, "compile": COMPILE_NOTE, "sweep-workers": SWEEP_WORKERS_NOTE,
            "pgs": PGS_NOTE, "narrow": NARROW_NOTE, "oracle": oracle.NOTE, "run": RUN_NOTE}[name]


STEP_NOTE = ("Minimum over 2 repeats of the mean wall time per step over 20 steps at dt = 1e-3 (10 warm-up "
             "steps; the 55-box pyramid costs up to 0.5 s a step (DART)); each engine at its own default "
             f"iterations (the reference's: up to 200 sweeps, to 1e-10 m/s). `/ {STEP_BASELINE}` is how many "
             f"times {STEP_BASELINE}'s step the engine's takes. An empty cell: the run's verdict says why (`no time "
             "because`): the engine cannot represent the scene (friction, for the force formulation and compliant "
             "contact; contact forces, which the stack's checks read), it blew up, or it outlasted the job's time "
             "limit (Lemke's dense tableau on the pyramid: over 200 s for 30 steps). An engine that runs 2D scenes only "
             "(Pymunk, Box2D) steps the in-plane stack and pyramid, so its ratio is not like for like.")
COMPILE_NOTE = ("Each reference formulation run in a freshly spawned worker process, first with an empty numba "
                "cache (`compiling s`: the run's stepping time less that of the same run repeated in the same "
                "process, i.e. numba compiling each function at its first call) and then with the cache that run "
                "left (`loading the cache s`, the same measure), beside the repeated run's mean step compiled "
                "and as plain Python (NUMBA_DISABLE_JIT=1: the same functions, uncompiled). Scene: the 5-box stack at dt = 1e-3 for "
                "0.1 s, or the first Newton's cradle variant for a formulation that cannot represent it "
                "(friction). A run in a process that has already compiled or loaded a function pays neither.")
SWEEP_WORKERS_NOTE = ("central_impact's sweep points on reference, pybullet and mujoco, one timing repeat each; "
                      "throughput relative to one worker.")


# --- PGS sweep cost -----------------------------------------------------------------------

PGS_NOTE = ("Projected Gauss-Seidel (reference_impl/pgs.py) on a chain of k + 1 particles, each touching the "
            "next, with friction (3 rows per contact). `ms per sweep` is the cost of one sweep alone: "
            "(T(1 + n sweeps) - T(1 sweep)) / n with n = 10; `setup ms` is the rest of one call (the rows' "
            "M^-1 J^T and the conversion to the sweep's lists), once per solve. CPU time of this process, "
            "sizes timed round-robin, least of 9 rounds, garbage collector paused while timing (as timeit does), so that a "
            "collection of the Python heap is not billed to whichever size triggers it. With per-body velocity "
            "sums (note 000) a sweep is O(contacts): `T(k) / T(k/2)` should stay at about 2 (O(contacts^2) "
            "would give 4).")
PGS_EXTRA_SWEEPS = 10


def pgs_chain(k: int):
    """k contacts: particles 0..k in a row along x, each touching the next, the first moving in."""
    import numpy as np
    from reference_impl import lcp
    bodies = lcp.Bodies(np.ones(k + 1), np.zeros((k + 1, 3, 3)))
    x = np.array([1.0, 0.0, 0.0])
    contacts = [lcp.Contact(i + 1, i, np.zeros(3), np.zeros(3), x, 0.0, 0.5) for i in range(k)]
    u = np.zeros((k + 1, 6))
    u[0, 0] = 1.0
    return bodies, contacts, u


def pgs_call_time(problem, sweeps: int) -> float:
    """CPU time of one projected_gauss_seidel call doing exactly `sweeps` sweeps on
    `problem` (rows, bodies, b), garbage collector paused."""
    import gc
    from reference_impl import pgs
    rows, bodies, b = problem
    settings = pgs.PGSSettings(iterations=sweeps, tolerance=0.0)
    gc.disable()
    try:
        start = time.process_time()
        pgs.projected_gauss_seidel(rows, bodies, b, settings)
        return time.process_time() - start
    finally:
        gc.enable()


def pgs_scaling(sizes=(250, 500, 1000, 2000, 4000, 8000), repeats: int = 9) -> pd.DataFrame:
    """Sizes are timed round-robin, `repeats` rounds, least time per size: a burst of load
    from other processes then slows every size of one round, not one size of all rounds."""
    from reference_impl import lcp
    problems = {}
    for k in sizes:
        bodies, contacts, u = pgs_chain(k)
        rows = lcp.build_rows(contacts, u)
        problems[k] = (rows, bodies, lcp.impact_rhs(rows, u))
    one = dict.fromkeys(sizes, math.inf)
    many = dict.fromkeys(sizes, math.inf)
    for _ in range(repeats):
        for k in sizes:
            one[k] = min(one[k], pgs_call_time(problems[k], 1))
            many[k] = min(many[k], pgs_call_time(problems[k], 1 + PGS_EXTRA_SWEEPS))
    sweep = {k: (many[k] - one[k]) / PGS_EXTRA_SWEEPS for k in sizes}
    out = [{"contacts k": k, "rows": 3 * k, "ms per sweep": sweep[k] * 1e3, "us per row": sweep[k] * 1e6 / (3 * k),
            "T(k) / T(k/2)": sweep[k] / sweep[k // 2] if k // 2 in sweep else math.nan,
            "setup ms": (one[k] - sweep[k]) * 1e3}
           for k in sizes]
    return pd.DataFrame(out)


# --- narrow phase: queries per second on the narrow-phase family's catalogue ------------------

NARROW_BASE = "reference"  # the rows' ratios are to the fastest routine; this one is the one judged
NARROW_WITHIN = 20.0       # the aim: the reference within 20x of the fastest routine on every pair
NARROW_QUERIES = 2000      # calls per timing
NARROW_ROUNDS = 7          # rounds of every routine on every pair in turn; the least time per call kept
NARROW_NOTE = ("Queries per second of each routine on the pairs of the narrow-phase family (cases/narrow_phase.py, "
               "the poses the engines are judged on and the reference's GJK is tested on), each called alone "
               "from Python once per query, as a user of the library calls it: `reference` the reference's "
               "compiled narrow phase (reference_impl.geometry.narrow_phase: closed forms for spheres and boxes, "
               "GJK and EPA with clipping for capsules, cylinders and hulls), `fcl` python-fcl's collide with "
               "contacts (FCL's primitive routines, libccd's GJK/EPA for convex meshes), `pybullet` "
               "getClosestPoints on the two bodies (shaped as its adapter shapes them, margins cleared), `mujoco` "
               "mj_geomDistance on the two geoms of a model of the pair (MuJoCo's narrow phase for the pair alone: a distance and its "
               "two witness points, no manifold), `mujoco mj_collision` its whole collision phase on that model (the "
               "pair's contacts, a manifold for a face or a line). All routines "
               f"timed round-robin, {NARROW_ROUNDS} rounds of {NARROW_QUERIES} calls, the least CPU time per call "
               "of this process, garbage collector paused. `depth` columns: the overlap each reported (a check "
               f"that it did the work: the exact depth is the pair's); `reference / fastest`: how many times the "
               f"fastest routine's time the reference's takes (the aim: within {NARROW_WITHIN:g}x). Engines whose "
               "collision routine cannot be called alone from Python are not timed (the others build and step a "
               "world to collide).")


def _reference_query(pair):
    """A call of the reference's compiled narrow phase on the pair, and the depth it finds."""
    from reference_impl import geometry as g
    from reference_impl.compiled import int_dict
    from reference_impl.rigid_body import RigidBody, new_bodies, stack

    def shape(s):
        return {"sphere": lambda: g.Sphere(s.radius), "capsule": lambda: g.Capsule(s.radius, s.half_length),
                "cylinder": lambda: g.Cylinder(s.radius, s.half_length), "box": lambda: g.Box(tuple(s.half_extents)),
                "hull": lambda: g.Hull(tuple(map(tuple, s.vertices)))}[s.kind]()
    base = RigidBody("base", shape(pair.base.shape), x=pair.base.position, q=pair.base.orientation, static=True)
    top = RigidBody("top", shape(pair.top.shape), pair.top.mass, pair.top.principal_inertia, x=pair.top.position,
                    q=pair.top.orientation)
    bodies, out, features = new_bodies(stack([base, top])), g.new_points(g.MAX_PAIR_POINTS), int_dict(4)

    def query():
        return g.narrow_phase(bodies, 0, 1, 1e-9, features, out, 0)
    count = query()[2]
    return query, max(float(out.depth[t]) for t in range(count)) if count else math.nan


def fcl_objects(pair):
    """python-fcl's collision objects of a narrow-phase pair (cases/narrow_phase.py), its base
    and its top: FCL's primitives for spheres, capsules, cylinders and boxes (a capsule's and a
    cylinder's axis on z, as the scene's), a hull as a convex mesh of its corners (libccd's GJK
    and EPA). The reference's GJK test compares with the same objects."""
    import fcl
    from scipy.spatial import ConvexHull

    def geometry(s):
        kind = s.kind
        if kind == "sphere":
            return fcl.Sphere(s.radius)
        if kind == "capsule":
            return fcl.Capsule(s.radius, 2 * s.half_length)
        if kind == "cylinder":
            return fcl.Cylinder(s.radius, 2 * s.half_length)
        if kind == "box":
            return fcl.Box(*(2 * h for h in s.half_extents))
        V = np.asarray(s.vertices, float)
        tri = ConvexHull(V).simplices
        return fcl.Convex(V, len(tri), np.column_stack([np.full(len(tri), 3), tri]).ravel())

    return tuple(fcl.CollisionObject(geometry(body.shape), fcl.Transform(np.asarray(body.orientation, float),
                                                                         np.asarray(body.position, float)))
                 for body in (pair.base, pair.top))


def _fcl_query(pair):
    """A call of python-fcl's collide (with contacts) on the pair, and the depth it finds."""
    import fcl
    a, b = fcl_objects(pair)
    request = fcl.CollisionRequest(enable_contact=True, num_max_contacts=8)

    def query():
        result = fcl.CollisionResult()
        fcl.collide(a, b, request, result)
        return result
    contacts = query().contacts
    return query, max(c.penetration_depth for c in contacts) if contacts else math.nan


# The engines' worlds are built here through their own public APIs, shape by shape as their
# adapters map them (a capsule's and a cylinder's axis on the body's z, a hull as a convex mesh
# of its corners, no collision margin): an adapter's built world is private to it.

def _pybullet_query(pair):
    """getClosestPoints on the pair's two bodies in a pybullet world of their shapes."""
    import pybullet as p
    client = p.connect(p.DIRECT)

    def body(b):
        s = b.shape
        kw = {"sphere": dict(shapeType=p.GEOM_SPHERE, radius=getattr(s, "radius", 0.0)),
              "capsule": dict(shapeType=p.GEOM_CAPSULE, radius=getattr(s, "radius", 0.0),
                              height=2 * getattr(s, "half_length", 0.0)),
              "cylinder": dict(shapeType=p.GEOM_CYLINDER, radius=getattr(s, "radius", 0.0),
                               height=2 * getattr(s, "half_length", 0.0)),
              "box": dict(shapeType=p.GEOM_BOX, halfExtents=list(getattr(s, "half_extents", ()))),
              "hull": dict(shapeType=p.GEOM_MESH, vertices=[list(v) for v in getattr(s, "vertices", ())])}[s.kind]
        w, x, y, z = b.orientation
        uid = p.createMultiBody(0.0 if b.static else b.mass, p.createCollisionShape(physicsClientId=client, **kw),
                                basePosition=list(b.position), baseOrientation=[x, y, z, w], physicsClientId=client)
        if s.kind in ("cylinder", "hull"):  # Bullet's margin lies outside these: cleared, as the adapter does
            p.changeDynamics(uid, -1, collisionMargin=0.0, physicsClientId=client)
        return uid
    a, b = body(pair.base), body(pair.top)

    def query():
        return p.getClosestPoints(a, b, 0.0, physicsClientId=client)
    rows = query()
    return query, (max(-r[8] for r in rows) if rows else math.nan)


def _mujoco_model(pair):
    """MuJoCo's model and data of the pair: a geom per body (a hull a mesh of its corners),
    the top on a free joint, the two in an explicit contact pair."""
    import mujoco

    def geom(b):
        s = b.shape
        size = {"sphere": lambda: [s.radius], "capsule": lambda: [s.radius, s.half_length],
                "cylinder": lambda: [s.radius, s.half_length], "box": lambda: list(s.half_extents),
                "hull": lambda: None}[s.kind]()
        shape = (f'type="mesh" mesh="{b.name}"' if size is None
                 else f'type="{s.kind}" size="{" ".join(map(repr, size))}"')
        return f'<geom name="{b.name}" {shape}/>'
    meshes = "".join(f'<mesh name="{b.name}" vertex="{" ".join(repr(float(c)) for v in b.shape.vertices for c in v)}"/>'
                     for b in (pair.base, pair.top) if b.shape.kind == "hull")
    bodies = "".join(f'<body name="{b.name}" pos="{" ".join(map(repr, b.position))}" '
                     f'quat="{" ".join(map(repr, b.orientation))}">{"" if b.static else "<freejoint/>"}{geom(b)}</body>'
                     for b in (pair.base, pair.top))
    m = mujoco.MjModel.from_xml_string(f'<mujoco><asset>{meshes}</asset><worldbody>{bodies}</worldbody>'
                                       '<contact><pair geom1="base" geom2="top"/></contact></mujoco>')
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    return m, d


def _mujoco_query(pair):
    """mj_geomDistance on the pair's two geoms: MuJoCo's narrow phase for the pair alone."""
    import mujoco
    m, d = _mujoco_model(pair)
    g1, g2 = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name) for name in ("base", "top"))
    fromto = np.zeros(6)

    def query():
        return mujoco.mj_geomDistance(m, d, g1, g2, 1.0, fromto)
    return query, -float(query())


def _mujoco_contacts_query(pair):
    """mj_collision on the pair's model: MuJoCo's whole collision phase for the one pair (the
    contacts, a manifold of up to 4 points for a face, written into mjData)."""
    import mujoco
    m, d = _mujoco_model(pair)

    def query():
        return mujoco.mj_collision(m, d)
    query()
    return query, (-float(min(d.contact.dist[:d.ncon])) if d.ncon else math.nan)


def _call_time(query, calls: int) -> float:
    """CPU time per call of `calls` calls of query(), garbage collector paused."""
    import gc
    gc.disable()
    try:
        start = time.process_time()
        for _ in range(calls):
            query()
        return (time.process_time() - start) / calls
    finally:
        gc.enable()


def narrow_phase_rate(engines: list[str], queries: int | None = None,
                      rounds: int | None = None) -> pd.DataFrame:
    """Queries per second of the reference's narrow phase, python-fcl and the engines'
    collision routines callable alone, on every pair of the narrow-phase catalogue, timed
    round-robin (every routine on every pair in turn, each round), least time per call."""
    from cases.narrow_phase import CATALOGUE
    queries, rounds = queries or NARROW_QUERIES, rounds or NARROW_ROUNDS
    makers = {"reference": _reference_query}
    if importlib.util.find_spec("fcl"):  # python-fcl: the test extra
        makers["fcl"] = _fcl_query
    for routine, engine, make in (("pybullet", "pybullet", _pybullet_query), ("mujoco", "mujoco", _mujoco_query),
                                  ("mujoco mj_collision", "mujoco", _mujoco_contacts_query)):
        if engine in engines and importlib.util.find_spec(engine):
            makers[routine] = make
    queries_of, depth = {}, {}
    for name, pair in CATALOGUE.items():
        for routine, make in makers.items():
            queries_of[name, routine], depth[name, routine] = make(pair)
    best = dict.fromkeys(queries_of, math.inf)
    for _ in range(rounds):
        for key, query in queries_of.items():
            best[key] = min(best[key], _call_time(query, queries))
    rows = []
    for name, pair in CATALOGUE.items():
        row = {"pair": name, "exact depth m": pair.depth}
        for routine in makers:
            row[f"{routine} queries/s"] = 1.0 / best[name, routine]
        for routine in makers:
            row[f"{routine} depth m"] = depth[name, routine]
        fastest = min(best[name, routine] for routine in makers)
        row["fastest"] = min(makers, key=lambda r: best[name, r])
        row[f"{NARROW_BASE} / fastest"] = best[name, NARROW_BASE] / fastest
        row[f"within {NARROW_WITHIN:g}x"] = "yes" if best[name, NARROW_BASE] <= NARROW_WITHIN * fastest else "no"
        rows.append(row)
    return pd.DataFrame(rows)


# --- the default run, cold and warm ---------------------------------------------------------

STATES = ("cold", "warm")


def default_run(workers: int, out: Path, args: tuple[str, ...] = ()) -> pd.DataFrame:
    """`physval run` with `args` (none: the default run) on `workers` workers, in a fresh
    process, twice: cold (empty physval and numba caches: PHYSVAL_CACHE_DIR and
    NUMBA_CACHE_DIR in a new temporary folder) and warm (the caches the cold run filled, a
    new --out). One row per part of the run's time (its cost.csv: phases, CPU, engines),
    the two states side by side, and the whole command's wall time and budget. The warm
    run's per-family costs are written to `out`/costs.csv with the shipped table's variants
    priced apart measured again after it (a run leaves them for --on-demand, so without
    this their first price stayed for good: physval's shipped cost table,
    physval/readings/costs.csv, is a copy of it)."""
    import os
    import subprocess
    import sys
    import tempfile
    from physval.readings import cost
    parts: dict[str, pd.DataFrame] = {}
    wall: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="physval-bench-run-") as tmp:
        env = {**os.environ, "PHYSVAL_CACHE_DIR": f"{tmp}/physval-cache", "NUMBA_CACHE_DIR": f"{tmp}/numba-cache"}
        for state in STATES:
            folder = Path(tmp) / state
            t0 = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "physval", "run", *args, "--workers", str(workers),
                                   "--quiet", "--out", str(folder)], env=env, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True)
            wall[state] = time.perf_counter() - t0
            if done.returncode not in (0, 1) or not (folder / "cost.csv").is_file():
                raise RuntimeError(f"physval run ({state}) exited {done.returncode}: {done.stderr.strip()[-400:]}")
            part = pd.read_csv(folder / "cost.csv")
            parts[state] = part[part.kind != "later"]  # its times, not the runs it left for --on-demand
            if state == "warm":
                from physval.core.store import read_results
                measured = cost.priceable(cost.per_job(read_results(folder / "results.csv")).dropna(subset=["job_s"]))
                # the shipped table's variants priced apart on the engines and families measured:
                # the run left them for --on-demand (over the per-job limit), so they run here, warm
                shipped = cost.load_table()
                apart = shipped[(shipped.variant != "") & shipped.engine.isin(set(measured.engine))
                                & shipped.case.isin(set(measured.case))]
                again = measured_apart(apart, workers, Path(tmp) / "apart", env)
                cost.write_table(cost.merged(pd.concat([measured, again], ignore_index=True), apart),
                                 Path(out) / "costs.csv")
    return run_table(parts, wall, workers)


def measured_apart(apart: pd.DataFrame, workers: int, folder: Path, env: dict) -> pd.DataFrame:
    """The variants of `apart` (a cost table's rows priced apart) run again with --on-demand,
    an engine's at a time on `workers` workers in the caches of `env`, to price them afresh
    (a job under half the per-job limit then runs in the default run again): each job's
    time less numba's part (a fresh worker's first job of a formulation loads its compiled
    code: 0.1-0.3 s), which would otherwise leave the one job of a variant unpriced. A run
    that fails leaves its variants at their earlier price."""
    import subprocess
    import sys
    from physval.core.store import read_results
    from physval.readings import cost
    found = []
    for engine, rows in apart.groupby("engine", sort=False):
        out = folder / engine
        cases = [f"{c}[{v}]" for c, v in zip(rows.case, rows.variant)]
        done = subprocess.run([sys.executable, "-m", "physval", "run", "--engines", engine, "--cases", *cases,
                               "--on-demand", "--workers", str(workers), "--quiet", "--out", str(out)],
                              env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if done.returncode in (0, 1) and (out / "results.csv").is_file():
            jobs = cost.per_job(read_results(out / "results.csv")).dropna(subset=["job_s"])
            jobs = jobs.assign(job_s=jobs.job_s - jobs.compile_s.fillna(0.0), compile_s=0.0)
            asked = set(zip(rows.case, rows.variant))
            found.append(jobs[[(c, v) in asked for c, v in zip(jobs.case, jobs.variant)]])
    return pd.concat(found, ignore_index=True) if found else cost.per_job([])


def run_table(parts: dict[str, pd.DataFrame], wall: dict[str, float], workers: int) -> pd.DataFrame:
    """The states' cost rows side by side, with the whole command and the budget first."""
    from physval.readings.cost import BUDGET_S, BUDGET_WORKERS
    keys: list[tuple[str, str]] = []
    for df in parts.values():
        keys += [k for k in zip(df.kind, df.name) if k not in keys]
    rows = [{"kind": "whole", "name": f"physval run on {workers} workers (budget {BUDGET_S:.0f} s on "
                                      f"{BUDGET_WORKERS} cores)", "of": "wall",
             **{f"{st} s": wall.get(st, math.nan) for st in parts}, "note": ""}]
    for kind, name in keys:
        row = {"kind": kind, "name": name}
        for st, df in parts.items():
            hit = df[(df.kind == kind) & (df.name == name)]
            row["of"] = hit["of"].iloc[0] if len(hit) else row.get("of", "")
            row[f"{st} s"] = float(hit.seconds.iloc[0]) if len(hit) else math.nan
            if kind == "phase" and name == "overhead" and len(hit):
                row[f"{st} ms per job"] = 1e3 * float(hit.seconds.iloc[0]) / float(hit.jobs.iloc[0]) \
                    if float(hit.jobs.iloc[0] or 0) else math.nan
            if kind == "engine" and len(hit):
                row["note"] = f"{int(hit.jobs.iloc[0])} jobs"
        rows.append(row)
    return pd.DataFrame(rows)


RUN_NOTE = ("`physval run` (the default run: every family on every installed engine, the engine-wide readings, the "
            "report) started as a user starts it, in a fresh process, first with empty caches (`cold`: physval's "
            "cache folder, where the readings keep their jobs, and numba's, where the reference's compiled "
            "functions are kept) and then again with the caches that run filled (`warm`, into a new folder). "
            "`whole`: the command's wall time from outside. The other rows are the run's own Cost section "
            "(`cost.csv`): wall-clock phases; within the jobs' phase the workers' time in the engines' steps, in "
            "the rest of each job and in the readings' jobs, and outside any job (`overhead`, also per job); the "
            "CPU time of the workers and of the main process; each engine's worker-seconds. Wall and worker "
            "times need a quiet machine; the CPU rows and the shares hold on a loaded one.")
