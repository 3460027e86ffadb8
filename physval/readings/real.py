"""`physval real`: engines against 400 measured cube tosses (the real-world tier).

`physval real` asks how far each engine is from the real world once its contact
parameters are fitted as well as they can be. It replays 400 motion-captured tosses of
one acrylic cube onto one surface (the ContactNets data set, BSD 3-Clause, shipped in
`cases/data/cube_toss/`): each toss starts from its measured state just before the first
impact; every 3D engine fits its friction, restitution and (MuJoCo) contact time scale
on the even-numbered tosses; the odd-numbered ones are scored at the fitted and at the
data set's nominal parameters (mu 0.18, e 0.125). The errors are the distance between
simulated and measured centre in cube widths and the angle between the orientations in
degrees, 0.1 s and 0.5 s after the first impact and at the final rest pose, and whether
the cube ends on the same face; `reports/real/real_report.md` ranks the engines and sets
them against the noise floor of the data (the measurement against itself smoothed).
Read them as the reality gap for this one cube on this one surface, not as a property
of an engine in general: the tosses are chaotic (a small change before an impact can
change the face the cube ends on), the start state carries the capture's noise, and the
fitted parameters absorb whatever the cube and the surface do that no engine models.
`physval real --tosses FILE --params reports/real/params.json` scores your own tosses
(same columns) with the saved parameters; `--fit` fits them on your file instead.
`physval real --data elbow_toss` does all of this for a second data set, 541 tosses of an
articulated elbow (two boxes and a revolute joint, `cases.elbow_toss`), on the engines that
build revolute joints: the reading works on pose rows that each toss module defines
(TOSSES: the cube's centre and quaternion; the elbow's base link and hinge angle), and
reads every data-set-specific fact (scene, start state, corners, rest face) from it.

What it does, per engine (every registered 3D engine that is installed):
1. Each toss of the test split (odd toss ids, `cases.cube_toss`) is built as an
   engine-neutral scene from its start state (the free flight fitted up to the sample just
   before first contact) and simulated to the toss's last sample at dt = 1/148/7 s (seven
   steps per measured sample, so simulated states fall on the measured sample times). The
   simulation is the core's, as for every job: `physval.core.jobs.run_scene` builds the
   scene, steps and records it (`record.simulate`) and gives a failure the statuses every
   job gets (unsupported, unstable: NaN or a blow-up, or the cube beyond LOST; error: the
   engine raised, with `describe`'s reason). Tosses run in batches (`Batch`) as jobs of
   the core (`physval.core.jobs.Task`, `task`): each in a worker process of the command's
   one executor (`Runner`), or on a Dask cluster; a job whose worker dies (a segfault) or
   runs over --job-timeout becomes error rows for its tosses (`lost_batch`), and the run
   goes on. The batch carries the run's Context, so engines from `--adapter` and plug-ins
   resolve in the workers as in the main process.
2. Each simulated sample is compared with the measured one: the centre distance in cube
   widths, the geodesic angle between the orientations in degrees, and both together as
   the root mean square distance between corresponding corners, in cube widths
   (`cases.cube_toss.corner_error`). Errors are read at fixed horizons after the first
   measured contact (HORIZONS), at the final sample (the rest pose), and as whether the
   cube ends on the same face.
3. The engine's contact parameters are fitted on the training split (even ids): the
   neutral friction coefficient mu and restitution e (the scene's Material) and the
   adapter's own `tunables` (MuJoCo: the contact time scale `contact_steps`), at most
   three. The loss is the mean over tosses of each toss's mean corner error; the optimiser
   is scipy's differential evolution (bounded, seeded, a small stated budget; the loss is
   piecewise constant in the parameters at the rounding grid and discontinuous where a
   contact sequence changes, so a gradient method would stall). A generation's members
   go to the runner at once, batches of tosses as jobs, so the fit runs wherever jobs run
   (local workers, a Dask cluster), its simulations kept like any other.
   The parameters' uncertainty is a bootstrap over the training tosses: the training set
   is resampled with replacement BOOTSTRAP times, and each resample picks its best among
   the parameter sets the fit evaluated (their per-toss losses are kept), at no further
   simulation cost. An engine whose fit over the whole training split would cost more
   than `--fit-limit` CPU seconds (the reference formulations, DART) fits on
   an evenly spread subset of it; one that would need fewer than MIN_FIT_TOSSES tosses for
   that, or fails on most tosses, is scored at the nominal parameters only. Likewise an
   engine too slow for the whole test split (`--score-limit`) scores an even subset.
4. Both parameter sets (fitted, and the data set's nominal mu 0.18, e 0.125) are scored on
   the test split, with paired bootstrap intervals for the differences between them and
   between engines. Two floors go beside them, scored by the same code: the data's noise
   (the measured trajectory against itself smoothed), and each engine's sensitivity to
   its start state (its simulation from the fitted start against one from a start drawn
   from that fit's own uncertainty, `sensitivity`).

Finished jobs are kept in a row store per engine (physval.core.store.RowStore, in
--cache), as every command keeps its jobs: one row per toss with its scores, and for the
batches whose poses the report draws (`keep`) the poses too (float64, base64: a row of
7.4 kB for a MuJoCo toss of ~90 samples; read back at 2 ms of CPU a toss, measured over
160). A rerun, or an interrupted run run again, reads back every job whose
key (engine, parameters, tosses and their content, horizon, dt, start draw) and cache key
(the code's fingerprint, the engine's version, an outside adapter's source) are unchanged;
an edit to physval's, the cases' or the adapters' code simulates everything again.

The command (options, planning the fit, the progress lines) is physval/commands/real.py.
"""
from __future__ import annotations

import base64
import contextlib
import functools
import hashlib
import json
import math
import re
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from adapters import registry
from adapters.base import Settings, Tunable
from cases import cube_toss as ct
from cases import elbow_toss as et
from physval.core.context import Context
from physval.core.executor import make_executor
from physval.core.jobs import Failed, Task, run_scene
from physval.core.session import Execution, Stream, run_streams
from physval.core.store import RowStore, cache_keys
from physval.interrupts import Terminated

SUBSTEPS = 7                          # engine steps per measured sample
DT = ct.SAMPLE_PERIOD / SUBSTEPS      # 0.966 ms: the step the engines' own docs use for contact (~1 ms)
HORIZONS = (0.1, 0.5)                 # s after the first measured contact; plus the final sample
# Loss of a toss whose simulation blew up or raised: ten cube widths (elbow: bar lengths),
# beyond any real miss (the cubes travel at most ~5 widths, the elbows' misses are ~1 bar
# length), so a fit never prefers a failing parameter.
FAIL_LOSS = 10.0
# A simulated cube this far from the origin has left the scene (the tosses stay within 1 m).
LOST = 100.0                          # m
NEUTRAL = {
    "mu": Tunable(0.02, 1.0, ct.MU_NOMINAL, "Coulomb friction coefficient (scene Material.mu_s)"),
    "e": Tunable(0.0, 0.9, ct.E_NOMINAL, "coefficient of restitution (scene Material.e)"),
}
# The toss data sets the tier scores (--data), by family name: each module gives the same
# names (load, toss, split, fit_flight, scene, poses, read_poses, pose_error, same_rest,
# smoothed_poses, with_poses, UNIT, POSE_SIZE, NEEDS_JOINTS, the nominal mu and e).
TOSSES = {"cube_toss": ct, "elbow_toss": et}
NEUTRAL_GRID = 0.005                  # mu and e are rounded to this grid (far below their spread)
# The fit's budget: differential evolution with popsize * (number of parameters) members
# over GENERATIONS + 1 generations (the initial one included).
POPSIZE = 5
GENERATIONS = 8
BOOTSTRAP = 200                       # resamples of the training tosses for the parameters' spread
# Tosses per job. Measured (MuJoCo, CPU of the main process and its workers beyond the
# simulations' own, marginal over 128 tosses, 3 repeats): 4.6 ms a toss in jobs of 8, 5.6 ms
# in jobs of 1 (scoring, the row store's write, reading a kept toss back), against a toss's
# own 4-1800 ms (MuJoCo as shipped to Newton's XPBD). The fit's thousands of tosses run 8 to
# a job; a scored toss, whose poses the report keeps, is a job of its own, so an engine that
# crashes or hangs on it costs that toss alone.
BATCH = 8
SCORE_BATCH = 1
# CPU s per engine for its fit: an engine whose fit over the whole training split would cost
# more fits on an evenly spread subset (`_fit_plan`). CPU per toss measured: MuJoCo 0.017 s,
# PyBullet 0.034 s, DART 0.086 s, the reference (sequential impulses) 0.14 s, its PGS 0.23 s,
# so MuJoCo and PyBullet fit on all 209 training tosses and the others on a half to a fifth.
FIT_LIMIT = 900.0
MIN_FIT_TOSSES = 16                   # fewer training tosses would fit the noise of a few chaotic tosses
SCORE_LIMIT = 300.0                   # CPU s: an engine slower than this over the test split scores an even subset
DEFAULT_OUT = Path("reports/real")
PARAM_SETS = ("fitted", "nominal")

# --- engines and their parameters ---------------------------------------------------------

# Every function that names an engine takes the run's Context (physval.core.context): its
# --adapter specs make ad-hoc adapters and plug-ins resolvable here and in every worker.

def _adapter(engine: str, ctx: Context):
    return ctx.resolver().adapter(engine)  # made once per process and context


@functools.lru_cache(maxsize=None)
def engine_version(engine: str, ctx: Context = Context()) -> str:
    return _adapter(engine, ctx).version()


def parameter_space(engine: str, ctx: Context = Context(), family: str = "cube_toss") -> dict[str, Tunable]:
    """The fitted parameters: mu, e (at the data set's nominal values) and the adapter's
    tunables, by name."""
    ds = TOSSES[family]
    neutral = {"mu": replace(NEUTRAL["mu"], default=ds.MU_NOMINAL), "e": replace(NEUTRAL["e"], default=ds.E_NOMINAL)}
    return {**neutral, **dict(getattr(_adapter(engine, ctx), "tunables", {}) or {})}


def fitted_names(engine: str, ctx: Context = Context()) -> tuple[str, ...]:
    """The parameters a fit searches: those with a finite range. One whose range is
    unbounded (Rapier's and Box2D's push-out stiffness, whose default inf means no cap) stays
    at its default: differential evolution samples a box, and no box holds infinity."""
    return tuple(n for n, t in parameter_space(engine, ctx).items() if math.isfinite(t.low) and math.isfinite(t.high))


def nominal(engine: str, ctx: Context = Context(), family: str = "cube_toss") -> dict[str, float]:
    """The data set's mu and e, the adapter's defaults for the rest."""
    return {name: t.default for name, t in parameter_space(engine, ctx, family).items()}


def rounded(engine: str, params: dict, ctx: Context = Context(), family: str = "cube_toss") -> dict[str, float]:
    """Parameters on the fit's grid (mu, e: NEUTRAL_GRID; tunables: 3 significant digits);
    a parameter not given takes its default. The command checks given values first
    (physval/commands/real.py)."""
    out = {}
    for name, t in parameter_space(engine, ctx, family).items():
        v = float(params.get(name, t.default))
        v = round(v / NEUTRAL_GRID) * NEUTRAL_GRID if name in NEUTRAL else float(f"{v:.3g}")
        out[name] = round(v, 10)
    return out


def engines_3d(names: list[str] | None = None, ctx: Context = Context(),
               family: str = "cube_toss") -> tuple[list[str], dict[str, str]]:
    """(engines to score, {engine: why skipped}). Default: every registered engine (with
    the context's ad-hoc adapters) that is installed and takes 3D boxes on a plane (and
    revolute joints, for a data set of jointed bodies); an engine registered twice under
    two names (the same adapter class with the same settings) is scored once."""
    chosen = names or registry.engine_names(ctx.adapters)
    out, skipped, seen = [], {}, {}
    for name in chosen:
        try:
            adapter = _adapter(name, ctx)
        except registry.EngineError as exc:
            skipped[name] = str(exc)
            continue
        caps = adapter.capabilities
        if 3 not in caps.dimensions or not {"box", "plane"} <= caps.shapes:
            skipped[name] = "not a 3D engine with boxes and planes"
            continue
        if TOSSES[family].NEEDS_JOINTS and "revolute" not in caps.joints:
            skipped[name] = f"unsupported: builds no revolute joint (the {family.split('_')[0]}'s hinge)"
            continue
        same = (type(adapter), json.dumps({k: v for k, v in vars(adapter).items() if k != "name"},
                                          sort_keys=True, default=str))
        if same in seen and not names:
            skipped[name] = f"the same engine as {seen[same]}"
            continue
        seen[same] = name
        out.append(name)
    return out, skipped


# --- one toss ------------------------------------------------------------------------------

@functools.lru_cache(maxsize=2048)
def _flight(source: str | None, toss_id: int, family: str = "cube_toss"):
    """(the toss, its start state) of a data set (TOSSES)."""
    ds = TOSSES[family]
    tr = ds.toss(toss_id, source)
    return tr, ds.fit_flight(tr)


@functools.lru_cache(maxsize=4096)
def _toss_digest(source: str | None, toss_id: int, family: str = "cube_toss") -> str:
    """SHA-1 of a toss's measured samples: a batch's key carries it, so edited data is
    simulated again."""
    ds = TOSSES[family]
    tr = ds.toss(toss_id, source)
    h = hashlib.sha1()
    for a in (tr.t, ds.poses(tr)):
        h.update(np.ascontiguousarray(a, float).tobytes())
    return h.hexdigest()


def _samples(tr: ct.Toss, fit: ct.FlightFit, horizon: float | None, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Measured sample indices from the start sample on (up to `horizon` s after the
    start), and the engine step count at which each falls."""
    k = np.arange(fit.k0, len(tr))
    s = tr.t[k] - fit.t0
    if horizon is not None:
        k, s = k[s <= horizon + 1e-9], s[s <= horizon + 1e-9]
    return k, np.rint(s / dt).astype(int)


def _run(adapter, scene, dt: float, options: dict, steps_at: np.ndarray, family: str = "cube_toss") -> dict:
    """Build and step one scene through the core (physval.core.jobs.run_scene: the build,
    record.simulate and the statuses every job gets: unsupported, unstable, error), and
    read the pose rows (the data set's read_poses) at the given step counts. A failed
    simulation has no poses (NaN).
    `wall`: the core's stepping time (Run.wall_s); `cpu`: this thread's CPU time over the
    recorded run (Run.cpu_s); `elapsed`, `elapsed_cpu`: the same with the build."""
    ds = TOSSES[family]
    poses = np.full((len(steps_at), ds.POSE_SIZE), np.nan)
    out = {"status": "ok", "message": "", "wall": 0.0, "cpu": 0.0, "steps": 0}
    start, start_cpu = time.perf_counter(), time.thread_time()
    try:
        run, _ = run_scene(adapter, scene, Settings(dt=dt, options=options), int(steps_at[-1]))
    except Failed as f:
        out.update(status=f.status, message=f.reason)
    else:
        rows = ds.read_poses(run.trajectory.states, steps_at)
        far = ~(np.linalg.norm(rows[:, :3], axis=1) < LOST)  # NaN too
        if far.any():
            j = int(np.argmax(far))
            out.update(status="unstable", message=f"the body left the scene: pose {rows[j].tolist()} at step "
                                                   f"{int(steps_at[j])}")
        else:
            poses = rows
        out.update(wall=run.wall_s, cpu=run.cpu_s, steps=run.steps)
    out.update(poses=poses, elapsed=time.perf_counter() - start, elapsed_cpu=time.thread_time() - start_cpu)
    return out


def simulate_toss(engine: str, toss_id: int, params: dict, horizon: float | None = None, dt: float = DT,
                  source: str | None = None, perturb: int | None = None, ctx: Context = Context(),
                  family: str = "cube_toss") -> dict:
    """Simulate one toss from its start state, in this process; a pure function of
    picklable arguments (a batch's jobs call it in their workers).

    Returns the simulated pose rows at the measured sample times from the start sample on
    (`poses`: the data set's, the cube's centre and quaternion; NaN after a failure),
    `status` (ok, unstable, error, unsupported) and
    `message`, the stepping time (`wall`, and `cpu`: this thread's CPU time, which a
    shared machine's load does not inflate), the same with the build (`elapsed`,
    `elapsed_cpu`), and the per-sample errors against the measurement (`errors`).
    `perturb`: a seed; the start state is then drawn from its own uncertainty
    (`cases.cube_toss.FlightFit.perturbed`). `ctx`: the run's context (its ad-hoc adapters)."""
    tr, fit = _flight(source, int(toss_id), family)
    if perturb is not None:
        fit = fit.perturbed(perturb)
    params = rounded(engine, params, ctx, family)
    k, steps_at = _samples(tr, fit, horizon, dt)
    adapter = _adapter(engine, ctx)
    tunables = getattr(adapter, "tunables", {}) or {}
    options = {n: v for n, v in params.items() if n in tunables}
    sim = _run(adapter, TOSSES[family].scene(tr, params["mu"], params["e"], fit), dt, options, steps_at, family)
    return {"engine": engine, "toss": tr.id, "params": params, "t": tr.t[k] - fit.t0, **sim,
            **errors(tr, k, sim["poses"], family)}


def errors(tr, k: np.ndarray, poses: np.ndarray, family: str = "cube_toss") -> dict[str, np.ndarray]:
    """Per-sample errors of pose rows against the measured samples k: distance of the
    (base) body's centre (`pos_err`, in the data set's UNIT), geodesic angle of its
    orientation (`rot_err`, degrees), RMS distance of all corners (`corner_err`, UNIT)."""
    ds = TOSSES[family]
    meas = ds.poses(tr)[k]
    corner = np.full(len(poses), np.nan)
    ok = np.all(np.isfinite(poses), axis=1)
    if ok.any():
        corner[ok] = ds.pose_error(poses[ok], meas[ok])
    return {"pos_err": np.linalg.norm(poses[:, :3] - meas[:, :3], axis=1) / ds.UNIT,
            "rot_err": np.degrees(ct.angle_between(poses[:, 3:7], meas[:, 3:7])), "corner_err": corner}


# --- scores -------------------------------------------------------------------------------

def metric_names() -> list[str]:
    names = []
    for h in HORIZONS:
        names += [f"pos_{h:g}s", f"rot_{h:g}s"]
    return names + ["pos_final", "rot_final", "corner_mean"]


def score(tr, fit, t: np.ndarray, poses: np.ndarray, status: str = "ok", family: str = "cube_toss") -> dict:
    """One toss's scores from poses at the measured samples from fit.k0 on (len(t) of
    them): errors at HORIZONS after the first measured contact (NaN where the toss ends
    earlier), at the final sample (the rest pose), whether it ends on the same face (same_rest),
    and the fit's loss (the mean corner error). A failed simulation (status not ok) has no
    readings (NaN), does not end on the same face, and its loss is FAIL_LOSS."""
    k = np.arange(fit.k0, fit.k0 + len(t))
    e = errors(tr, k, poses, family)
    t_contact = tr.t[fit.contact] - fit.t0
    row = {}
    for h in HORIZONS:
        j = int(np.argmin(np.abs(t - (t_contact + h))))
        near = abs(t[j] - (t_contact + h)) <= 0.5 * ct.SAMPLE_PERIOD + 1e-9 and status == "ok"
        row[f"pos_{h:g}s"] = float(e["pos_err"][j]) if near else math.nan
        row[f"rot_{h:g}s"] = float(e["rot_err"][j]) if near else math.nan
    full = k[-1] == len(tr) - 1 and status == "ok"
    row["pos_final"] = float(e["pos_err"][-1]) if full else math.nan
    row["rot_final"] = float(e["rot_err"][-1]) if full else math.nan
    row["same_face"] = (TOSSES[family].same_rest(poses[-1], TOSSES[family].poses(tr)[-1]) if full
                        else (False if status != "ok" else None))
    row["corner_mean"] = float(np.mean(e["corner_err"])) if status == "ok" else math.nan
    row["loss"] = row["corner_mean"] if status == "ok" else FAIL_LOSS
    return row


# --- batches of tosses: jobs of the core ----------------------------------------------------

# The columns of a toss's row as the row store keeps it (`case`: the data set's family, which
# a row store's cache key reads): `poses` holds the simulated pose rows of a batch that keeps
# them (the data set's POSE_SIZE numbers per measured sample, float64, base64: the cube's
# x, y, z, qw, qx, qy, qz; the elbow's with its hinge angle after them).
STORED = ["engine", "case", "toss", "status", "message", "sim_time", "wall", "cpu", "elapsed", "elapsed_cpu",
          "steps", "params", *metric_names(), "same_face", "loss", "poses"]


@dataclass(frozen=True)
class Batch:
    """Some tosses of one engine at one parameter set: one job of the core (`task`).
    `ctx`: the run's context, which resolves the engine in the worker."""
    engine: str
    params: tuple[tuple[str, float], ...]
    tosses: tuple[int, ...]
    horizon: float | None = None
    dt: float = DT
    source: str | None = None
    keep: bool = False  # keep the simulated poses (reports), not only the scores
    perturb: bool = False  # start each toss from a start state drawn from its uncertainty (seed: the toss id)
    ctx: Context = Context()
    family: str = "cube_toss"  # the data set (TOSSES)

    @property
    def key(self) -> str:
        """The job's key: everything that changes what it computes beyond what the row
        store's cache key covers (the code, the engine's version, an outside adapter's
        source): parameters, tosses and their measured content, horizon, dt, start draw."""
        data = hashlib.sha1("".join(_toss_digest(self.source, i, self.family)
                                    for i in self.tosses).encode()).hexdigest()[:16]
        return (f"{self.family}[{','.join(map(str, self.tosses))}]-{self.engine}@"
                + ";".join(f"{n}={v!r}" for n, v in self.params)
                + f";horizon={self.horizon!r};dt={self.dt!r};data={data}"
                + (";perturbed" if self.perturb else "") + (";poses" if self.keep else ""))


def task(batch: Batch) -> Task:
    """The batch as a job of the core: run in a worker, its rows (one per toss) stored."""
    return Task(run_batch, batch, lost_batch, batch.engine, batch.key, batch.family)


def run_batch(batch: Batch) -> list[dict]:
    """The stored row of every toss of a batch (module-level and pure: a job's function)."""
    return [_row(batch, toss_id, simulate_toss(batch.engine, toss_id, dict(batch.params), batch.horizon, batch.dt,
                                               batch.source, toss_id if batch.perturb else None, batch.ctx,
                                               batch.family))
            for toss_id in batch.tosses]


def lost_batch(batch: Batch, why: str) -> list[dict]:
    """The rows of a batch whose job produced nothing (it raised, its worker died, or it
    ran over the time limit): each of its tosses failed with status error, `why` its message."""
    rows = []
    for toss_id in batch.tosses:
        tr, fit = _flight(batch.source, toss_id, batch.family)
        k, _ = _samples(tr, fit, batch.horizon, batch.dt)
        poses = np.full((len(k), TOSSES[batch.family].POSE_SIZE), np.nan)
        rows.append(_row(batch, toss_id, {
            "params": dict(batch.params), "t": tr.t[k] - fit.t0, "poses": poses, "status": "error",
            "message": why, "wall": 0.0, "cpu": 0.0, "elapsed": 0.0, "elapsed_cpu": 0.0, "steps": 0}))
    return rows


def _row(batch: Batch, toss_id: int, r: dict) -> dict:
    """A toss's stored row from its simulation (simulate_toss): its scores, and its poses
    if the batch keeps them."""
    tr, fit = _flight(batch.source, toss_id, batch.family)
    row = {"engine": batch.engine, "case": batch.family, "toss": toss_id, "status": r["status"], "message": r["message"],
           "sim_time": float(r["t"][-1]) if len(r["t"]) else 0.0, "wall": r["wall"], "cpu": r["cpu"],
           "elapsed": r["elapsed"], "elapsed_cpu": r["elapsed_cpu"], "steps": r["steps"],
           "params": json.dumps(r["params"], sort_keys=True)}
    if r["status"] != "unsupported":
        row.update(score(tr, fit, r["t"], r["poses"], r["status"], batch.family))
    if batch.keep and r["status"] == "ok":
        row["poses"] = base64.b64encode(r["poses"].astype("<f8").tobytes()).decode()
    return row


def _number(value) -> float:
    return math.nan if value is None or value == "" else float(value)


def _read(batch: Batch, row: dict, cached: bool) -> dict:
    """A toss's row as the reading uses it, from the row its job gave or the store kept
    (the same fields, there as text): numbers typed, `cached` (read back, not simulated by
    this call), and for a batch that keeps its poses the `trajectory` (sample times, poses
    and the per-sample errors against the measurement)."""
    out = {"engine": batch.engine, "toss": int(row["toss"]), "status": row["status"],
           "message": row.get("message") or "", "steps": int(row.get("steps") or 0), "cached": cached,
           "params": row.get("params") or json.dumps(dict(batch.params), sort_keys=True),
           **{k: _number(row.get(k)) for k in ("sim_time", "wall", "cpu", "elapsed", "elapsed_cpu")},
           "first_in_worker": _number(row.get("first_in_worker"))}  # NaN where the store read it back
    if out["status"] != "unsupported":
        out.update({m: _number(row.get(m)) for m in metric_names() + ["loss"]})
        face = row.get("same_face")
        out["same_face"] = None if face in (None, "") else face in (True, "True")
    if batch.keep:
        tr, fit = _flight(batch.source, out["toss"], batch.family)
        if batch.perturb:
            fit = fit.perturbed(out["toss"])
        k, _ = _samples(tr, fit, batch.horizon, batch.dt)
        size = TOSSES[batch.family].POSE_SIZE
        poses = (np.frombuffer(base64.b64decode(row["poses"]), "<f8").reshape(len(k), size).copy() if row.get("poses")
                 else np.full((len(k), size), np.nan))
        out["trajectory"] = {"t": tr.t[k] - fit.t0, "poses": poses, **errors(tr, k, poses, batch.family)}
    return out


class Runner:
    """Runs batches of tosses as jobs of the core (physval.core.jobs.Task) on one executor
    that lives as long as the runner: each job in a worker process (a crash or a time-out
    costs that batch only, its tosses then read as errors: `lost_batch`) or on a Dask
    cluster. With a `folder`, each engine's rows stream to a row store there
    (physval.core.store.RowStore, `<engine>.csv`), stamped with the fingerprint of the code
    and the engine's version: a rerun reads back what did not change, and an interrupted
    run keeps what finished. Call it with batches; it returns each batch's rows (`_read`).
    Use it as a context manager (its workers stop at the end)."""

    def __init__(self, ctx: Context = Context(), execution: Execution = Execution(progress=False),
                 folder: str | Path | None = None):
        self.ctx, self.execution = ctx, execution
        self.folder = Path(folder) if folder is not None else None
        self._stores: dict[str, RowStore] = {}
        self._keys = None
        self._executor = None
        self.worker_cpu_s = 0.0  # the local workers' CPU so far (user + system), as they reported it

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        if self._executor is not None:
            self._executor.close()
            self._executor = None

    def store(self, engine: str) -> RowStore | None:
        """The engine's row store, loaded on first use (None without a folder)."""
        if self.folder is None:
            return None
        if engine not in self._stores:
            if self._keys is None:
                self._keys = cache_keys(self.ctx)
            store = RowStore(self.folder / (re.sub(r"[^\w.+-]", "_", engine) + ".csv"), STORED)
            store.load(self._keys.of_row)
            self._stores[engine] = store
        return self._stores[engine]

    def __call__(self, batches) -> list[list[dict]]:
        batches = list(batches)
        if not batches:
            return []
        streams, held = {}, {}
        for b in batches:
            if b.engine not in streams:
                store = self.store(b.engine)
                held[b.engine] = set(store.rows) if store is not None else set()
                streams[b.engine] = Stream([], store, self._keys.of_job if store is not None else None, "real")
            streams[b.engine].plan.append(task(b))
        if self._executor is None:
            e = self.execution
            self._executor = make_executor(self.ctx, e.workers, e.scheduler, e.job_timeout, e.start_method)
        use = run_streams(list(streams.values()), self.ctx, self.execution, executor=self._executor)
        self.worker_cpu_s = max(self.worker_cpu_s, use.worker_cpu_s)  # (the executor's total: it lives on)
        stopped = next((s.results.interrupted for s in streams.values() if s.results.interrupted), "")
        if stopped:  # what finished is in the stores; the command stops as an interrupted one does
            self.close()
            raise Terminated() if stopped == "SIGTERM" else KeyboardInterrupt()
        return [[_read(b, r, b.key in held[b.engine]) for r in streams[b.engine].results.rows[b.key]]
                for b in batches]


def toss_cost(rows: list[dict]) -> float:
    """CPU seconds one toss costs an engine, from simulated tosses' rows: the median of those
    that were not their engine's first in their worker (a worker's first holds the engine's
    start: its import, its kernels compiled; Genesis' first toss took 17 CPU s where later
    ones took 2), else the least of them all."""
    later = [r["elapsed_cpu"] for r in rows if r.get("first_in_worker") == 0]
    return float(np.median(later)) if later else float(min(r["elapsed_cpu"] for r in rows))


def _chunks(ids, size: int) -> list[tuple[int, ...]]:
    ids = list(ids)
    return [tuple(ids[i:i + size]) for i in range(0, len(ids), size)]


def simulate_many(engine: str, params: dict, ids, *, runner: Runner | None = None, batch: int = SCORE_BATCH,
                  keep: bool = False, perturb: bool = False, ctx: Context = Context(), **common) -> list[dict]:
    """Score tosses `ids` of one engine at one parameter set, batches of `batch` tosses as
    jobs of `runner` (default: one of its own, one worker, no store)."""
    key = tuple(sorted(rounded(engine, params, ctx, common.get("family", "cube_toss")).items()))
    jobs = [Batch(engine, key, chunk, keep=keep, perturb=perturb, ctx=ctx, **common) for chunk in _chunks(ids, batch)]
    with contextlib.nullcontext(runner) if runner is not None else Runner(ctx) as run:
        return [row for rows in run(jobs) for row in rows]


# --- the fit ------------------------------------------------------------------------------

@dataclass
class FitResult:
    engine: str
    names: tuple[str, ...]
    params: dict[str, float]
    loss: float                    # mean corner error over the fit's tosses, cube widths
    nominal_loss: float
    evaluations: int               # distinct parameter sets simulated
    tosses: tuple[int, ...]
    seconds: float
    per_toss: dict[tuple, np.ndarray] = field(default_factory=dict)  # parameter set -> loss per toss
    cost: dict = field(default_factory=dict)  # simulations computed / read back from the row store, their CPU s

    def bootstrap(self, resamples: int = BOOTSTRAP, seed: int = 0) -> list[dict[str, float]]:
        """The best evaluated parameter set of each of `resamples` resamples (with
        replacement) of the fit's tosses."""
        keys = list(self.per_toss)
        L = np.array([self.per_toss[k] for k in keys])                  # (sets, tosses)
        picks = np.random.default_rng(seed).integers(0, L.shape[1], size=(resamples, L.shape[1]))
        best = np.argmin(L[:, picks].mean(axis=2), axis=0)              # per resample
        return [dict(keys[b]) for b in best.tolist()]


def fit(engine: str, ids, *, runner: Runner | None = None, popsize: int = POPSIZE, generations: int = GENERATIONS,
        seed: int = 0, batch: int = BATCH, names: tuple[str, ...] | None = None,
        fixed: dict | None = None, ctx: Context = Context(), **common) -> FitResult:
    """Fit an engine's contact parameters to tosses `ids` by differential evolution.

    The loss of a parameter set is the mean over the tosses of each toss's mean corner
    error (`score`). Each generation's members go to `runner` at once (DE's vectorised
    mode: jobs of the core, batches of `batch` tosses per member; default: a runner of its
    own, one worker, no store). `names` restricts the fitted parameters (the others stay at
    `fixed` or nominal). The nominal point is a member of the first generation."""
    if runner is None:
        with Runner(ctx) as own:
            return fit(engine, ids, runner=own, popsize=popsize, generations=generations, seed=seed, batch=batch,
                       names=names, fixed=fixed, ctx=ctx, **common)
    from scipy.optimize import differential_evolution

    start = time.perf_counter()
    family = common.get("family", "cube_toss")
    space = parameter_space(engine, ctx, family)
    names = tuple(names or fitted_names(engine, ctx))
    base = {**nominal(engine, ctx, family), **(fixed or {})}
    ids = tuple(sorted(int(i) for i in ids))
    memo: dict[tuple, np.ndarray] = {}
    cost = {"computed": 0, "cached": 0, "cpu": 0.0}

    def params_of(x) -> dict:
        return rounded(engine, {**base, **dict(zip(names, np.asarray(x, float).tolist()))}, ctx, family)

    def losses(candidates: list[dict]) -> list[float]:
        keys = [tuple(sorted(c.items())) for c in candidates]
        todo = list(dict.fromkeys(k for k in keys if k not in memo))
        jobs = [Batch(engine, k, chunk, ctx=ctx, **common) for k in todo for chunk in _chunks(ids, batch)]
        per_key: dict[tuple, list[float]] = {k: [] for k in todo}
        for job, rows in zip(jobs, runner(jobs)):
            per_key[job.params] += [r.get("loss", FAIL_LOSS) for r in rows]
            for r in rows:
                cost["cached" if r["cached"] else "computed"] += 1
                cost["cpu"] += r["elapsed_cpu"]
        for k, values in per_key.items():
            memo[k] = np.array(values)
        return [float(np.mean(memo[k])) for k in keys]

    def objective(X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, float)
        if X.ndim == 1:
            X = X[:, None]
        return np.array(losses([params_of(col) for col in X.T]))

    bounds = [(space[n].low, space[n].high) for n in names]
    x0 = np.clip([base[n] for n in names], [b[0] for b in bounds], [b[1] for b in bounds])
    result = differential_evolution(objective, bounds, x0=x0, popsize=popsize, maxiter=generations, seed=seed,
                                    polish=False, vectorized=True, updating="deferred", init="latinhypercube")
    best = params_of(result.x)
    nominal_loss = losses([rounded(engine, base, ctx, family)])[0]
    return FitResult(engine, names, best, losses([best])[0], nominal_loss, len(memo), ids,
                     time.perf_counter() - start, memo, cost)


# --- noise floor --------------------------------------------------------------------------

def noise_rows(ids, source: str | None = None, horizon: float | None = None, family: str = "cube_toss") -> list[dict]:
    """The measured trajectory against itself smoothed (cases.cube_toss.smoothed), scored
    exactly as a simulation (`score`), from the start sample on; plus the free-flight
    fit's residuals."""
    rows = []
    for toss_id in ids:
        tr, fit = _flight(source, toss_id, family)
        smooth = TOSSES[family].smoothed_poses(tr)
        k, _ = _samples(tr, fit, horizon, DT)
        t = tr.t[k] - fit.t0
        row = {"engine": "noise floor", "toss": toss_id, "status": "ok", "param_set": "data",
               **score(tr, fit, t, smooth[k], family=family),
               "flight_pos_mm": float(np.sqrt(np.mean(fit.residual_pos ** 2)) * 1e3),
               "flight_rot_deg": float(np.degrees(np.sqrt(np.mean(fit.residual_rot ** 2)))),
               "t_contact": float(tr.t[fit.contact] - fit.t0),
               "trajectory": {"t": t, **errors(tr, k, smooth[k], family)}}
        rows.append(row)
    return rows


def sensitivity(reference_rows: list[dict], shaken_rows: list[dict], source: str | None,
                family: str = "cube_toss") -> list[dict]:
    """Rows scoring simulations from perturbed start states (`shaken_rows`) against the
    same engine's simulations from the fitted start state (`reference_rows`, with their
    trajectories) by the same metrics as against the measurement: the engine's own
    sensitivity to the start state's uncertainty, a floor under its errors that no
    parameter can remove. Tosses whose reference simulation failed are left out."""
    base = {r["toss"]: r for r in reference_rows if r["status"] == "ok"}
    out = []
    for r in shaken_rows:
        ref = base.get(r["toss"])
        if ref is None:
            continue
        tr, fit = _flight(source, r["toss"], family)
        # the reference simulation in place of the measurement from the start sample on
        pseudo = TOSSES[family].with_poses(tr, fit.k0, ref["trajectory"]["poses"])
        keep = {k: r[k] for k in ("engine", "toss", "status", "message", "sim_time", "wall", "cpu", "elapsed",
                                  "elapsed_cpu", "steps", "cached", "params")}
        row = {**keep, "param_set": "start noise", "t_contact": ref["t_contact"], "split": "test"}
        if r["status"] == "ok":
            t, poses = r["trajectory"]["t"], r["trajectory"]["poses"]
            row.update(score(pseudo, fit, t, poses, family=family))
            row["trajectory"] = {"t": t, **errors(pseudo, np.arange(fit.k0, fit.k0 + len(t)), poses, family)}
        out.append(row)
    return out


def _cost(rows: list[dict]) -> dict:
    return {"computed": sum(not r["cached"] for r in rows), "cached": sum(bool(r["cached"]) for r in rows),
            "cpu": float(sum(r["elapsed_cpu"] for r in rows))}


def paired_difference(scores: pd.DataFrame, a: tuple[str, str], b: tuple[str, str], metric: str = "corner_mean",
                      resamples: int = 2000, seed: int = 0) -> tuple[float, float, float, int]:
    """Median over the tosses both ran of metric(a) - metric(b), with a 95 % bootstrap
    interval over tosses, and the number of tosses: (median, low, high, n)."""
    def values(engine, pset):
        g = scores[(scores.engine == engine) & (scores.param_set == pset) & (scores.status == "ok")]
        return g.set_index("toss")[metric].dropna()
    A, B = values(*a), values(*b)
    common = A.index.intersection(B.index)
    d = (A[common] - B[common]).to_numpy(float)
    if not len(d):
        return math.nan, math.nan, math.nan, 0
    picks = np.random.default_rng(seed).integers(0, len(d), size=(resamples, len(d)))
    lo, hi = np.percentile(np.median(d[picks], axis=1), [2.5, 97.5])
    return float(np.median(d)), float(lo), float(hi), len(d)


# --- summaries ----------------------------------------------------------------------------

def summary(scores: pd.DataFrame) -> pd.DataFrame:
    """Per engine and parameter set: tosses, failures, median / mean / 95th percentile of
    every metric over the tosses that ran, the fraction ending on the right face (failures
    count as wrong), and the speed (simulated seconds per wall second of stepping, and per
    CPU second of the recorded run: stepping and recording)."""
    out = []
    for (engine, pset), g in scores.groupby(["engine", "param_set"], sort=False):
        ok = g[g.status == "ok"]
        row = {"engine": engine, "param_set": pset, "tosses": len(g), "failed": int((g.status != "ok").sum())}
        for m in metric_names():
            v = ok[m].dropna().to_numpy(float)
            row[f"{m}_median"] = float(np.median(v)) if len(v) else math.nan
            row[f"{m}_mean"] = float(np.mean(v)) if len(v) else math.nan
            row[f"{m}_p95"] = float(np.percentile(v, 95)) if len(v) else math.nan
            row[f"{m}_n"] = len(v)
        face = g["same_face"].dropna() if "same_face" in g else pd.Series([], dtype=object)
        row["same_face"] = float(face.astype(bool).mean()) if len(face) else math.nan
        for name, column in (("speed", "wall"), ("speed_cpu", "cpu")):
            spent = g[column].sum() if column in g else 0.0
            row[name] = float(g["sim_time"].sum() / spent) if "sim_time" in g and spent > 0 else math.nan
        out.append(row)
    return pd.DataFrame(out)


# --- the report ---------------------------------------------------------------------------

def _fmt(x, digits=3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{digits}g}"


def _params_text(params: dict) -> str:
    return ", ".join(f"{k} {_fmt(v)}" for k, v in params.items())


def plot_horizons(trajectories: dict[tuple[str, str], list[dict]], noise: list[dict], path: Path,
                  psets=("fitted", "nominal"), title: str = "Test split: error against horizon",
                  unit: str = ct.UNIT_NAME) -> None:
    """Median position and orientation error against time after the first measured
    contact, one line per engine and parameter set in `psets` (the first solid, the
    second dashed), the data's noise floor in grey."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    colours = {}
    for (engine, pset), rows in sorted(trajectories.items()):
        if engine not in colours:
            colours[engine] = f"C{len(colours) % 10}"
        curve = _median_curve(rows) if pset in psets else None
        if curve is None:
            continue
        t, pos, rot = curve
        style = "-" if pset == psets[0] else "--"
        axes[0].plot(t, pos, style, color=colours[engine], label=f"{engine} ({pset})")
        axes[1].plot(t, rot, style, color=colours[engine])
    curve = _median_curve(noise)
    if curve is not None:
        axes[0].plot(curve[0], curve[1], color="0.5", lw=2, label="noise floor")
        axes[1].plot(curve[0], curve[2], color="0.5", lw=2)
    axes[0].set(xlabel="time after first contact (s)", ylabel=f"median centre error ({unit})", yscale="log")
    axes[1].set(xlabel="time after first contact (s)", ylabel="median orientation error (deg)", yscale="log")
    axes[0].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _median_curve(rows: list[dict]):
    """(t, median pos err, median rot err) on the sample grid after first contact, over
    the rows (each with 'trajectory' and 't_contact') that reach each time; None if empty."""
    by_offset: dict[int, list[tuple[float, float]]] = {}
    for r in rows:
        tr = r.get("trajectory")
        if not tr or r["status"] != "ok":
            continue
        offset = np.rint((tr["t"] - r["t_contact"]) / ct.SAMPLE_PERIOD).astype(int)
        for o, pe, re in zip(offset.tolist(), tr["pos_err"].tolist(), tr["rot_err"].tolist()):
            if o >= 0:
                by_offset.setdefault(o, []).append((pe, re))
    if not by_offset:
        return None
    # a point is drawn where at least a quarter of the tosses still run
    most = max(len(v) for v in by_offset.values())
    keys = sorted(o for o, v in by_offset.items() if len(v) >= most / 4)
    t = np.array(keys) * ct.SAMPLE_PERIOD
    pos = np.array([np.median([p for p, _ in by_offset[o]]) for o in keys])
    rot = np.array([np.median([r for _, r in by_offset[o]]) for o in keys])
    return t, pos, rot


def plot_overlays(engine: str, picks: dict[str, tuple[dict, dict | None]], source, path: Path,
                  family: str = "cube_toss") -> None:
    """Measured and simulated height of the centre above the surface and rotation since
    the start, against time, for the engine's typical and worst test tosses (fitted
    parameters solid, nominal dashed)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ds = TOSSES[family]
    fig, axes = plt.subplots(2, len(picks), figsize=(5.5 * len(picks), 6), squeeze=False)
    for col, (label, (row, nominal_row)) in enumerate(picks.items()):
        tr, fit = _flight(source, row["toss"], family)
        t_meas = tr.t[fit.k0:] - fit.t0
        q0 = tr.quat[fit.k0]
        axes[0, col].plot(t_meas, (tr.pos[fit.k0:, 2] - ds.SURFACE_Z) / ds.UNIT, "k.-", ms=3, label="measured")
        axes[1, col].plot(t_meas, np.degrees(ct.angle_between(tr.quat[fit.k0:], np.broadcast_to(q0, (len(t_meas), 4)))),
                          "k.-", ms=3)
        for r, style, name in ((row, "-", "fitted"), (nominal_row, "--", "nominal")):
            if r is None or not r.get("trajectory"):
                continue
            traj, quat = r["trajectory"], r["trajectory"]["poses"][:, 3:7]
            axes[0, col].plot(traj["t"], (traj["poses"][:, 2] - ds.SURFACE_Z) / ds.UNIT, style, color="C0" if
                              name == "fitted" else "C1", label=f"{engine} ({name})")
            axes[1, col].plot(traj["t"], np.degrees(ct.angle_between(quat, np.broadcast_to(q0, quat.shape))),
                              style, color="C0" if name == "fitted" else "C1")
        axes[0, col].set(title=f"{label}: toss {row['toss']} (mean corner error {_fmt(row['corner_mean'], 2)} {ds.UNIT_NAME})",
                         ylabel=f"centre height ({ds.UNIT_NAME})")
        axes[1, col].set(xlabel="time after start (s)", ylabel="rotation since start (deg)")
        axes[0, col].legend(fontsize=7)
    fig.suptitle(f"{engine}: measured and simulated tosses (test split)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _ci(stat: tuple[float, float, float, int]) -> str:
    med, lo, hi, n = stat
    return "-" if not n else f"{med:+.3f} [{lo:+.3f}, {hi:+.3f}] (n={n})"


def ranking(summ: pd.DataFrame) -> list[tuple[str, str, float]]:
    """(engine, parameter set, median mean corner error) in rank order: each engine at its
    fitted parameters, at the nominal ones where it was not fitted; an error that is not
    finite ranks last."""
    sets = {p: summ[summ.param_set == p].set_index("engine") for p in ("fitted", "nominal")}
    out = []
    for engine in dict.fromkeys(summ[summ.engine != "noise floor"].engine):
        which = "fitted" if engine in sets["fitted"].index else "nominal"
        out.append((engine, which, float(sets[which].loc[engine, "corner_mean_median"])))
    return sorted(out, key=lambda r: r[2] if math.isfinite(r[2]) else math.inf)


def section(summ: pd.DataFrame, fits: dict[str, dict], skipped: dict[str, str], notes: dict,
            scores: pd.DataFrame) -> str:
    """The report section in markdown: ranking, fitted against nominal parameters, fitted
    parameters, distributions, the noise floors, cost, skipped engines."""
    ds = TOSSES[notes.get("family", "cube_toss")]
    body = "cube" if ds is ct else "elbow"
    lines = [f"# Real-world tier: engines against measured {body} tosses", ""]
    lines += [notes.get("intro", ""), ""]
    fitted = summ[summ.param_set == "fitted"].set_index("engine")
    nom = summ[summ.param_set == "nominal"].set_index("engine")
    shaken = summ[summ.param_set == "start noise"].set_index("engine")
    floor = summ[summ.engine == "noise floor"]
    ranked = ranking(summ)
    order = [engine for engine, _, _ in ranked]
    ranked_at = {engine: which for engine, which, _ in ranked}

    def best(engine) -> str:
        return ranked_at[engine]

    def best_set(engine):
        return (fitted if best(engine) == "fitted" else nom).loc[engine]

    h1, h2 = (f"{h:g}s" for h in HORIZONS)
    lines += ["## Ranking (test split)", "",
              "Ranked by the median over test tosses of each toss's mean corner error (the RMS distance between "
              f"simulated and measured corners, averaged over the toss; {ds.UNIT_NAME}) at the engine's fitted "
              "parameters (nominal where it was not fitted). 'vs rank 1': the median over common tosses of the "
              "paired difference to the first engine, with its 95 % bootstrap interval (an interval containing 0: "
              "no measurable difference). 'start noise': the same error between the engine's own simulations "
              "from the fitted start state and from one drawn from that state's uncertainty (the flight fit's "
              "residuals): what the capture's noise alone costs this engine, a floor no parameter removes. Centre "
              f"errors in {ds.UNIT_NAME} ({ds.UNIT * 100:.2f} cm), angles in degrees, medians over the test tosses; "
              "'right face': the fraction of tosses that end on the measured face (failed simulations count as "
              "wrong). 'speed': simulated seconds per wall second of stepping, and per CPU second of the "
              "recorded run (stepping and recording every step, as every physval job records).", "",
              f"| rank | engine | parameters | mean corner err. | vs rank 1 | start noise | centre {h1} | angle {h1} | "
              f"centre {h2} | angle {h2} | centre final | angle final | right face | speed (sim s per wall s; "
              "per CPU s) |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for rank, engine in enumerate(order, 1):
        s = best_set(engine)
        which = ("nominal only" if best(engine) == "nominal" else
                 "fitted" if fits.get(engine, {}).get("loss") is not None else "given")
        params = fits.get(engine, {}).get("params") or notes.get("nominal", {}).get(engine, {})
        label = f"{engine} ({int(s['tosses'])} tosses)" if engine in notes.get("subsets", {}) else engine
        versus = "-" if rank == 1 else _ci(paired_difference(scores, (engine, best(engine)),
                                                            (order[0], best(order[0]))))
        noise = (f"{_fmt(shaken.loc[engine, 'corner_mean_median'])} ({_fmt(100 * shaken.loc[engine, 'same_face'], 3)} "
                 "% same face)" if engine in shaken.index else "-")
        lines.append(
            f"| {rank} | {label} | {which}: {_params_text(params)} | {_fmt(s['corner_mean_median'])} | {versus} | "
            f"{noise} | {_fmt(s[f'pos_{h1}_median'])} | {_fmt(s[f'rot_{h1}_median'])} | "
            f"{_fmt(s[f'pos_{h2}_median'])} | {_fmt(s[f'rot_{h2}_median'])} | {_fmt(s['pos_final_median'])} | "
            f"{_fmt(s['rot_final_median'])} | {_fmt(100 * s['same_face'], 3)} % | {_fmt(s['speed'])}; "
            f"{_fmt(s['speed_cpu'])} |")
    if len(floor):
        f = floor.iloc[0]
        lines.append(f"| - | noise floor (data vs smoothed) | - | {_fmt(f['corner_mean_median'])} | - | - | "
                     f"{_fmt(f[f'pos_{h1}_median'])} | {_fmt(f[f'rot_{h1}_median'])} | {_fmt(f[f'pos_{h2}_median'])} | "
                     f"{_fmt(f[f'rot_{h2}_median'])} | {_fmt(f['pos_final_median'])} | {_fmt(f['rot_final_median'])} "
                     "| - | - |")
    tied = [e for e in order[1:] if paired_difference(scores, (e, best(e)), (order[0], best(order[0])))[1] <= 0.0]
    lines += ["", f"Within the 95 % interval of rank 1 ({order[0]}): {', '.join(tied) or 'no other engine'}. "
              "'start noise' against 'mean corner err.' says how much of an engine's error the capture's noise "
              "in the start state could explain; its '% same face' how often that noise alone changes the face "
              f"the {body} ends on."] if order else []
    lines += ["", "![error against horizon](plots/horizons.png)", "",
              "![start noise against horizon](plots/start_noise.png)", ""]

    lines += ["## Fitted against nominal parameters (test split)", "",
              f"The data set's nominal parameters are mu {ds.MU_NOMINAL:g}, e {ds.E_NOMINAL:g} (and each adapter's "
              "defaults for the rest). "
              "'fitted - nominal': the median paired difference of the mean corner error over the test tosses, "
              "with its 95 % bootstrap interval (negative: the fit helps).", "",
              "| engine | nominal: corner err. | fitted: corner err. | fitted - nominal | nominal: right face | "
              "fitted: right face |", "|---|---|---|---|---|---|"]
    for engine in order:
        n = nom.loc[engine] if engine in nom.index else None
        f = fitted.loc[engine] if engine in fitted.index else None
        diff = _ci(paired_difference(scores, (engine, "fitted"), (engine, "nominal"))) if f is not None else "-"
        lines.append(f"| {engine} | {_fmt(n['corner_mean_median']) if n is not None else '-'} | "
                     f"{_fmt(f['corner_mean_median']) if f is not None else '-'} | {diff} | "
                     f"{_fmt(100 * n['same_face'], 3) + ' %' if n is not None else '-'} | "
                     f"{_fmt(100 * f['same_face'], 3) + ' %' if f is not None else '-'} |")

    lines += ["", "## Fitted parameters", "",
              notes.get("fit", ""), "",
              "| engine | fitted parameters | bootstrap over training tosses (mean +- sd; 5-95 %) | train loss (fitted) | "
              "train loss (nominal) | evaluations | fit wall time (s) |", "|---|---|---|---|---|---|---|"]
    for engine in order:
        f = fits.get(engine)
        if not f:
            lines.append(f"| {engine} | not fitted: {notes.get('not_fitted', {}).get(engine, 'parameters given')} "
                         "| - | - | - | - | - |")
            continue
        spread = "; ".join(
            f"{n} {_fmt(np.mean(v))} +- {_fmt(np.std(v))} ({_fmt(np.percentile(v, 5))}..{_fmt(np.percentile(v, 95))})"
            for n, v in ((n, [fp[n] for fp in f.get("spread", [])]) for n in f["names"]) if v) or "-"
        subset = f" (fitted on {f['subset']})" if f.get("subset") else ""
        lines.append(f"| {engine} | {_params_text(f['params'])}{subset} | {spread} | {_fmt(f.get('loss'))} | "
                     f"{_fmt(f.get('nominal_loss'))} | {f.get('evaluations', '-')} | {_fmt(f.get('seconds'), 3)} |")

    lines += ["", "## Error distributions (test split)", "",
              "Median / mean / 95th percentile over the test tosses that ran; n = tosses with that reading "
              "(a horizon past a toss's end has none).", "",
              "| engine | parameters | tosses | failed | " + " | ".join(metric_names()) + " |",
              "|---|---|---|---|" + "---|" * len(metric_names())]
    for engine in order + (["noise floor"] if len(floor) else []):
        for _, s in summ[summ.engine == engine].iterrows():
            cells = [f"{_fmt(s[f'{m}_median'])} / {_fmt(s[f'{m}_mean'])} / {_fmt(s[f'{m}_p95'])} (n={s[f'{m}_n']})"
                     for m in metric_names()]
            lines.append(f"| {engine} | {s['param_set']} | {s['tosses']} | {s['failed']} | " + " | ".join(cells) + " |")

    lines += ["", "## Noise floor", "", notes.get("noise", ""), ""]
    lines += ["## Typical and worst tosses", "",
              "Per engine, the test toss with the median and the one with the largest mean corner error at "
              "the fitted parameters: centre height above the surface and rotation since the start, measured "
              "(black) and simulated (fitted solid, nominal dashed).", ""]
    for engine in order:
        lines.append(f"![{engine}](plots/overlay_{engine}.png)")
    if notes.get("subsets"):
        lines += ["", "## Engines scored on part of the test split", ""] + [
            f"- {e}: {why}" for e, why in notes["subsets"].items()]
    if skipped:
        lines += ["", "## Engines not scored", ""] + [f"- {e}: {why}" for e, why in skipped.items()]
    if notes.get("failures"):
        lines += ["", "## Failed simulations", ""] + [f"- {t}" for t in notes["failures"]]
    lines += ["", "## Run", "", notes.get("run", ""), ""]
    return "\n".join(lines)


def write_report(out: Path, scores: pd.DataFrame, noise: list[dict], trajectories: dict, fits: dict,
                 skipped: dict, notes: dict, source) -> Path:
    """real_report.md, real_scores.csv (one row per engine, parameter set and toss),
    real_summary.csv, real_fits.csv, params.json and plots/ under `out`."""
    (out / "plots").mkdir(parents=True, exist_ok=True)
    noise_frame = pd.DataFrame([{k: v for k, v in r.items() if k != "trajectory"} for r in noise])
    both = pd.concat([scores, noise_frame], ignore_index=True)
    both.drop(columns=["trajectory"], errors="ignore").to_csv(out / "real_scores.csv", index=False, float_format="%.6g")
    summ = summary(both)
    summ.to_csv(out / "real_summary.csv", index=False, float_format="%.6g")
    fit_rows = []
    for engine, f in fits.items():
        fit_rows.append({"engine": engine, "sample": "fit", **f["params"], "loss": f.get("loss"),
                         "nominal_loss": f.get("nominal_loss"), "tosses": f.get("tosses"),
                         "evaluations": f.get("evaluations"), "seconds": f.get("seconds")})
        for j, fp in enumerate(f.get("spread", [])):
            fit_rows.append({"engine": engine, "sample": f"bootstrap {j}", **fp})
    pd.DataFrame(fit_rows).to_csv(out / "real_fits.csv", index=False, float_format="%.6g")
    (out / "params.json").write_text(json.dumps({e: f["params"] for e, f in fits.items()}, indent=2) + "\n")
    family = notes.get("family", "cube_toss")
    unit = TOSSES[family].UNIT_NAME
    plot_horizons(trajectories, noise, out / "plots" / "horizons.png", unit=unit)
    plot_horizons(trajectories, noise, out / "plots" / "start_noise.png", psets=("start noise",),
                  title="Test split: each engine against itself from a start state drawn from its uncertainty", unit=unit)
    for engine in dict.fromkeys(e for e, _ in trajectories):
        pset = "fitted" if (engine, "fitted") in trajectories else "nominal"
        rows = [r for r in trajectories[(engine, pset)] if r["status"] == "ok"]
        if not rows:
            continue
        rows.sort(key=lambda r: r["corner_mean"])
        nominal_by_toss = {r["toss"]: r for r in trajectories.get((engine, "nominal"), [])} if pset == "fitted" else {}
        typical, worst = rows[len(rows) // 2], rows[-1]
        picks = {"typical": (typical, nominal_by_toss.get(typical["toss"])),
                 "worst": (worst, nominal_by_toss.get(worst["toss"]))}
        plot_overlays(engine, picks, source, out / "plots" / f"overlay_{engine}.png", family)
    path = out / "real_report.md"
    path.write_text(section(summ, fits, skipped, notes, both))
    return path
