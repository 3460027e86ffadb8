"""`physval bench`: speed measured side by side in one run, reported as ratios (this
machine is noisy; absolute times are for orientation only). Never a pass/fail test.

- `sweep-workers`: the same small sweep with 1 and with 2 local workers (throughput ratio);
- `step`: wall time per step of the same scenes on every engine, as ratios to the
  reference (a 5-box stack and a 10-layer pyramid);
- `pgs`: the reference's projected Gauss-Seidel, cost of one sweep against the number of
  contacts (doubling the contacts should at most about double the time).
"""
from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import pandas as pd

from adapters import registry
from adapters.base import Settings
from cases.scene import Body, Material, Scene, cube, ground
from physval.report import _md_table, write_atomic

G = 9.81


# --- sweep throughput ---------------------------------------------------------------------

def sweep_workers(engines: list[str], repeats: int = 1) -> pd.DataFrame:
    """One small sweep (central_impact's sweep variants) run with 1 and then 2 workers,
    each into a fresh folder, so neither reuses the other's points."""
    from physval.runner import families
    from physval.sweep import Store, run_sweep, sweep_points
    fams = families()
    points = sweep_points({"central_impact": fams["central_impact"]}, engines)
    out = []
    for workers in (1, 2):
        with tempfile.TemporaryDirectory() as tmp:
            store = Store(Path(tmp) / "sweep.csv", fams)
            t0 = time.perf_counter()
            run_sweep(points, fams, store, workers=workers, progress=False, repeats=repeats)
            wall = time.perf_counter() - t0
        out.append({"workers": workers, "points": len(points), "wall_s": wall, "points_per_s": len(points) / wall})
    df = pd.DataFrame(out)
    df["throughput_vs_1_worker"] = df.points_per_s / df.points_per_s.iloc[0]
    return df


# --- step time side by side ---------------------------------------------------------------

def stack(n: int) -> Scene:
    """n unit cubes (half 0.1 m, 1 kg) stacked on the ground, touching."""
    boxes = tuple(Body(f"box{k}", cube(0.1), mass=1.0, position=(0, 0, 0.1 + 0.2 * k)) for k in range(n))
    return Scene(bodies=(ground(),) + boxes, gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.5))


def pyramid(layers: int) -> Scene:
    """A 2D-style pyramid in the x-z plane of 3D cubes: `layers` at the bottom, one on top,
    each row offset by half a box (gaps of 1 mm between neighbours in a row)."""
    bodies = [ground()]
    for row in range(layers):
        count = layers - row
        for i in range(count):
            x = (i - (count - 1) / 2) * 0.201
            bodies.append(Body(f"b{row}_{i}", cube(0.1), mass=1.0, position=(x, 0, 0.1 + 0.2 * row)))
    return Scene(bodies=tuple(bodies), gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.5))


SCENES = {"5-box stack": lambda: stack(5), "10-layer pyramid": lambda: pyramid(10)}


def step_time(engine: str, scene: Scene, dt: float = 1e-3, steps: int = 20, repeats: int = 2) -> float:
    """Minimum over repeats of the mean wall time per step (s), after 10 warm-up steps."""
    adapter = registry.get(engine)
    best = math.inf
    for _ in range(repeats):
        with adapter.build(scene, Settings(dt)) as sim:
            for _ in range(10):
                sim.step()
            t0 = time.perf_counter()
            for _ in range(steps):
                sim.step()
            best = min(best, (time.perf_counter() - t0) / steps)
    return best


def steps_side_by_side(engines: list[str], steps: int = 20) -> pd.DataFrame:
    out = []
    for label, make in SCENES.items():
        scene = make()
        row = {"scene": label, "bodies": len(scene.dynamic_bodies)}
        for eng in engines:
            try:
                row[f"{eng} us/step"] = step_time(eng, scene, steps=steps) * 1e6
            except Exception as exc:  # an engine that cannot run it is recorded, the rest go on
                row[f"{eng} us/step"] = math.nan
                row[f"{eng} note"] = f"{type(exc).__name__}: {exc}"
        ref = row.get("reference us/step")
        for eng in engines:
            if eng != "reference" and ref:
                row[f"reference / {eng}"] = ref / row[f"{eng} us/step"]
        out.append(row)
    return pd.DataFrame(out)


# --- report -------------------------------------------------------------------------------

def write(out: Path, sections: dict[str, pd.DataFrame], notes: dict[str, str]) -> None:
    out = Path(out)
    lines = ["# physval benchmarks", "",
             "Measured side by side in one run on this machine; read the ratios, not the absolute times.", ""]
    for name, df in sections.items():
        write_atomic(out / f"bench_{name}.csv", df.to_csv(index=False))
        lines += [f"## {name}", "", notes.get(name, ""), "", _md_table(df.round(4)), ""]
    write_atomic(out / "bench.md", "\n".join(lines))


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
