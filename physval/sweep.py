"""`physval sweep`: what accuracy costs in time.

For each case family (its `sweep_variants`) and engine, vary the time step and, where the
engine has one, the solver iteration count; at each point record every check's error
exactly as in the case's verdicts and the honest cost: wall time of stepping only per
simulated second, scene construction and a warm-up excluded, the minimum over repeats.

Points are batched into tasks of at least about 100 ms and run on a local process pool or
on a Dask distributed cluster (`--scheduler`). Rows stream to `sweep.csv` as points
finish; re-running with the same arguments skips every finished point.
"""
from __future__ import annotations

import csv
import io
import json
import math
import os
import time
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

from adapters import registry
from adapters.base import Settings
from cases.family import CaseFamily
from physval.runner import COLUMNS, Job, families as all_families, on_demand, run_job

# Time steps from 1/60 s (games) down to 1e-4 s (six values, about log-spaced).
DTS = (1 / 60, 1 / 120, 1 / 240, 1e-3, 3e-4, 1e-4)
# Solver iterations from starved to generous; engines without the setting get one value.
ITERATIONS = (1, 2, 5, 10, 50)
REPEATS = 3
MIN_TASK_STEPS = 20_000  # ~100 ms of stepping at >= 5 us per step: scheduling overhead stays small

SWEEP_COLUMNS = COLUMNS + ["point", "iterations_asked", "warmup_steps", "repeat_wall_s", "wall_per_sim_s"]


@dataclass(frozen=True)
class Point:
    family: str
    variant: str
    engine: str
    dt: float
    iterations: int | None  # None: the adapter's default

    @property
    def key(self) -> str:
        it = "default" if self.iterations is None else str(self.iterations)
        return f"{self.family}[{self.variant}]-{self.engine}@dt={self.dt:.6g},it={it}"

    def steps(self, fam: CaseFamily) -> int:
        v = next(v for v in fam.variants if v.id == self.variant)
        return max(1, int(round(fam.duration(v.params) / self.dt)))


def sweep_points(fams: dict[str, CaseFamily], engines: list[str], full: bool = False,
                 dts=DTS, iterations=ITERATIONS) -> list[Point]:
    """Every point of the sweep. By default two axes through each engine's defaults: dt
    over `dts` at the default iterations, and iterations over `iterations` at the family's
    dt; `full` takes the whole dt x iterations grid."""
    points = []
    for name, fam in fams.items():
        variants = [v for v in fam.variants if v.id in (fam.sweep_variants or (fam.variants[0].id,))]
        for eng in engines:
            try:
                caps = registry.get(eng).capabilities
            except registry.EngineError:
                continue
            its = list(iterations) if caps.iterations else []
            for v in variants:
                if caps.cannot_run(fam.scene(v.params), fam.needs_of(v.params)):
                    continue  # e.g. a 3D variant on a 2D engine: not a point of this engine
                if on_demand(Job(name, v, eng)):
                    continue  # minutes a run even at the family's dt (runner.ON_DEMAND)
                vid = v.id
                grid = set((dt, None) for dt in dts)
                if full:
                    grid |= set((dt, it) for dt in dts for it in its)
                else:
                    grid |= set((fam.dt_for(v.params), it) for it in its)
                for dt, it in sorted(grid, key=lambda g: (-g[0], g[1] or 0)):
                    points.append(Point(name, vid, eng, dt, it))
    return points


def batches(points: list[Point], fams: dict[str, CaseFamily]) -> list[list[Point]]:
    """Consecutive points grouped until each task holds at least MIN_TASK_STEPS steps
    (times repeats), so every task runs for about 100 ms or more."""
    out, current, steps = [], [], 0
    for p in points:
        current.append(p)
        steps += p.steps(fams[p.family]) * (REPEATS + 1)
        if steps >= MIN_TASK_STEPS:
            out.append(current)
            current, steps = [], 0
    if current:
        out.append(current)
    return out


# --- one point ----------------------------------------------------------------------------

def warmup_steps(n: int) -> int:
    """Steps left out of the timing: the first 5 %, at least 10 (caches, lazy set-up)."""
    return min(n - 1, max(10, n // 20))


def time_stepping(adapter, fam: CaseFamily, params: dict, dt: float, iterations, warmup: int) -> float:
    """Wall time of stepping only, after `warmup` untimed steps; nothing is read back."""
    scene = fam.scene(params)
    n = max(1, int(round(fam.duration(params) / dt)))
    with adapter.build(scene, Settings(dt, iterations)) as sim:
        for _ in range(warmup):
            sim.step()
        t0 = time.perf_counter()
        for _ in range(n - warmup):
            sim.step()
        return time.perf_counter() - t0


def run_point(p: Point, fam: CaseFamily, adapter, repeats: int = REPEATS) -> list[dict]:
    """The verdict rows of one point, with the minimum stepping time over `repeats` runs
    (the recorded run is the first)."""
    variant = next(v for v in fam.variants if v.id == p.variant)
    n = p.steps(fam)
    warm = warmup_steps(n)
    rows = run_job(Job(p.family, variant, p.engine, p.dt, p.iterations), fam, adapter, warmup=warm)
    walls = []
    if rows and rows[0]["status"] not in ("unsupported", "error", "unstable"):
        walls.append(rows[0]["wall_s"])
        for _ in range(repeats - 1):
            try:
                walls.append(time_stepping(adapter, fam, variant.params, p.dt, p.iterations, warm))
            except Exception:  # a timing repeat that fails leaves the recorded run's time
                break
    best = min(walls) if walls else math.nan
    timed_sim_s = (n - warm) * p.dt
    for r in rows:
        r.update(point=p.key, iterations_asked="default" if p.iterations is None else p.iterations,
                 warmup_steps=warm, repeat_wall_s=json.dumps([round(w, 9) for w in walls]),
                 wall_per_sim_s=best / timed_sim_s if walls else math.nan)
    return rows


_CACHE: dict = {}


def run_batch(points: list[Point], cases_dir=None, repeats: int = REPEATS, fams=None) -> list[dict]:
    """A task: run its points in this process (families and adapters cached per process;
    a worker process finds the families by name, from the built-ins and `cases_dir`)."""
    if fams is None:
        if "families" not in _CACHE:
            _CACHE["families"] = all_families(cases_dir)
        fams = _CACHE["families"]
    adapters = _CACHE.setdefault("adapters", {})
    rows = []
    for p in points:
        if p.engine not in adapters:
            try:
                adapters[p.engine] = registry.get(p.engine)
            except registry.EngineError:
                adapters[p.engine] = None
        rows += run_point(p, fams[p.family], adapters[p.engine], repeats)
    return rows


# --- streaming store ----------------------------------------------------------------------

class Store:
    """`sweep.csv`, appended one finished point at a time; on start, the points already
    complete (every check of the point present) are known and skipped."""

    def __init__(self, path: Path, fams: dict[str, CaseFamily]):
        self.path = Path(path)
        self.fams = fams
        self.done: set[str] = set()
        self._load()

    def _expected_rows(self, family: str, variant: str, dt: float) -> int | None:
        fam = self.fams.get(family)
        v = next((v for v in fam.variants if v.id == variant), None) if fam else None
        return len(fam.expect(v.params, dt)) if v else None

    def _load(self) -> None:
        if not self.path.exists():
            return
        text = self.path.read_text()
        if text and not text.endswith("\n"):  # a write cut short by a kill: drop the tail
            text = text[:text.rfind("\n") + 1]
        rows = list(csv.DictReader(io.StringIO(text)))
        by_point = defaultdict(list)
        for r in rows:
            by_point[r["point"]].append(r)
        keep = []
        for key, rs in by_point.items():
            if len(rs) == self._expected_rows(rs[0]["case"], rs[0]["variant"], float(rs[0]["dt"])):
                self.done.add(key)
                keep += rs
        # rewrite without partial points, so the file holds each point once
        self._write_all(keep)

    def _write_all(self, rows: list[dict]) -> None:
        from physval.report import write_atomic
        buf = io.StringIO()
        w = csv.DictWriter(buf, SWEEP_COLUMNS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
        write_atomic(self.path, buf.getvalue())

    def append(self, rows: list[dict]) -> None:
        if not rows:
            return
        buf = io.StringIO()
        csv.DictWriter(buf, SWEEP_COLUMNS, extrasaction="ignore").writerows(rows)
        new = not self.path.exists()
        with open(self.path, "a", newline="") as fh:
            if new:
                csv.DictWriter(fh, SWEEP_COLUMNS).writeheader()
            fh.write(buf.getvalue())  # one write per point
            fh.flush()
            os.fsync(fh.fileno())
        self.done.update(r["point"] for r in rows)


# --- running ------------------------------------------------------------------------------

def run_sweep(points: list[Point], fams: dict[str, CaseFamily], store: Store, workers: int = 1,
              scheduler: str | None = None, cases_dir=None, progress: bool = True,
              repeats: int = REPEATS) -> int:
    """Run the points not yet in `store`; return how many were run."""
    from tqdm import tqdm
    todo = [p for p in points if p.key not in store.done]
    tasks = batches(todo, fams)
    bar = tqdm(total=len(todo), unit="point", disable=not progress, dynamic_ncols=True,
               desc=f"sweep ({len(points) - len(todo)} already done)")
    try:
        if scheduler:
            from distributed import Client, as_completed
            with Client(scheduler) as client:
                futures = [client.submit(run_batch, t, cases_dir, repeats, pure=False) for t in tasks]
                for fut in as_completed(futures):
                    rows = fut.result()
                    store.append(rows)
                    bar.update(len({r["point"] for r in rows}))
        elif workers <= 1:
            for t in tasks:
                for p in t:
                    store.append(run_batch([p], cases_dir, repeats, fams))
                    bar.update()
        else:
            from concurrent.futures import ProcessPoolExecutor, as_completed
            with ProcessPoolExecutor(workers) as pool:
                futures = [pool.submit(run_batch, t, cases_dir, repeats) for t in tasks]
                for fut in as_completed(futures):
                    rows = fut.result()
                    store.append(rows)
                    bar.update(len({r["point"] for r in rows}))
    finally:
        bar.close()
    return len(todo)
