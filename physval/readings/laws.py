"""Physics-law residuals: how far an engine's own contact forces are from the laws of rigid
contact, read point by point from `Simulation.contact_points` (cases.trajectory.ContactPoint).

At a contact point with normal n (from b into a), normal force f_n, friction force f_t and
relative velocity v of a's material point against b's after the step,
    v = (v_a + w_a x (x - p_a)) - (v_b + w_b x (x - p_b)),   v_n = n . v,   v_t = v - v_n n,
with the lever arms x - p taken at the start of the step (where the engine found the point
and built its rows) and the velocities at its end, rigid contact with restitution e and
Coulomb friction asks (note 000, "Contact conditions", "Global system from restitution
hypothesis" and "Coulomb friction"):
- non-penetration:   gap >= 0                           -> penetration  = max(0, -gap), m
- complementarity:   0 <= f_n  _|_  v_n + e min(v_n-, 0) >= 0, with v_n- the normal velocity
                     at the start of the step (e = 0 at rest: 0 <= f_n _|_ v_n >= 0)
                                                        -> complementarity = f_n max(v_n + e min(v_n-, 0), 0), W:
                     the power of a normal force on a contact separating faster than the
                     restitution law asks (zero when the force or that excess speed is zero)
- friction cone:     |f_t| <= mu_s f_n                   -> cone excess = |f_t| / (mu_s f_n) - 1 (>= 0)
- maximal dissipation: a sliding contact (|v_t| > SLIDING) takes f_t = -mu_k f_n v_t/|v_t|,
                     the force in the cone that dissipates most (note 000, "maximum
                     dissipation principle")    -> gap = 1 + f_t . v_t / (mu_k f_n |v_t|),
                     0 at full Coulomb friction against the slip, 1 without friction, 2 for
                     full friction along the slip.
The velocities are the ones at the end of the step (a velocity-level solver makes its
impulses complementary to those). Cone and dissipation are read at points that carry
force (f_n above ACTIVE of the scene's weight); a frictionless pair (mu_s = 0) shows any
friction force as an infinite cone excess.

The battery (`BATTERY`) is a handful of the library's scenes, each the first variant an
engine can represent, so 2D-only engines take part; `measure` runs them as jobs of the
core with the `Residuals` probe (cached per engine version, physval.core.store.cache_dir)
and `summary` gives each engine's worst residual over them. No pass/fail: the residuals
are a reading of each engine, reported side by side (laws.csv and the report's section).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from fnmatch import fnmatchcase
from pathlib import Path

import numpy as np
import pandas as pd

from cases.scene import Scene
from cases.trajectory import ContactPoint
from physval.core import COLUMNS, Job, Probe
from physval.core.session import Execution, Stream, run_plan, stored
from physval.core.store import cache_dir
from physval.report import fmt, md_table, pyplot, save_figure, write_atomic

SLIDING = 1e-3  # m/s: a contact slides above this tangential speed (creep at rest is um/s)
ACTIVE = 1e-6   # points carrying more than this fraction of the scene's weight count for cone and dissipation

# (family, variant-id globs in order of preference): the first the engine can represent
BATTERY: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("resting_blocks", ("n=3", "n=3,2D")),
    ("slide_to_stop", ("mu=0.5,v0=2", "mu=0.5,v0=2,2D")),
    ("friction_isotropy", ("mu=0.5",)),
    ("incline_threshold", ("mu=0.5,theta=atan(mu_s)-1deg", "mu=0.5,theta=atan(mu_s)-1deg,2D")),
    ("incline_threshold", ("mu=0.5,theta=atan(mu_s)+10deg", "mu=0.5,theta=atan(mu_s)+10deg,2D")),
    ("slip_to_roll", ("v0=2,w0=-60,mu=0.5", "v0=2,w0=-60,mu=0.5,2D")),
    ("central_impact", ("drop,e=0.5", "drop,e=0.5,2D")),
    ("tumbling_box", ("*",)),
    ("stack_strike", ("*",)),
)

RESIDUALS = ("penetration_mm", "complementarity_W", "cone_excess", "dissipation_gap_mean", "dissipation_gap_max")


@dataclass(frozen=True)
class PointResidual:
    penetration: float           # m
    complementarity: float       # W
    cone_excess: float | None    # None: the point carries no force
    dissipation_gap: float | None  # None: not sliding, or no force, or frictionless


def relative_velocity(p: ContactPoint, states: dict[str, np.ndarray],
                      start: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """v of a's material point at p.x minus b's, velocities from `states`, lever arms from
    the positions in `start` (default: `states`); a static body (no state) does not move."""
    return relative_velocities([p], states, start)[0]


def relative_velocities(points: list[ContactPoint], states: dict[str, np.ndarray],
                        start: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """relative_velocity of every point, (points, 3), in one pass over arrays: a step's
    points cost a few numpy calls, not a few per point (14 us each: a 3 s stack on
    PyBullet spent 6 s of its 7 s job in per-point np.cross)."""
    start = states if start is None else start
    names = list(states)
    row = {name: i for i, name in enumerate(names)}
    rest = len(names)  # a static body's row: no velocity, no spin
    s = np.vstack([*(states[name] for name in names), np.zeros(13)])
    origin = np.vstack([*(start[name][0:3] for name in names), np.zeros(3)])
    x = np.array([p.x for p in points], dtype=float).reshape(-1, 3)

    def at(bodies: list[int]) -> np.ndarray:
        return s[bodies, 7:10] + np.cross(s[bodies, 10:13], x - origin[bodies])
    return at([row.get(p.a, rest) for p in points]) - at([row.get(p.b, rest) for p in points])


def point_residual(p: ContactPoint, v: np.ndarray, v_before: np.ndarray, e: float, mu_s: float, mu_k: float,
                   f_active: float) -> PointResidual:
    """The residuals of one point with relative velocity v after the step and v_before at its start."""
    r = point_residuals([p], np.reshape(v, (1, 3)), np.reshape(v_before, (1, 3)), np.array([e]), np.array([mu_s]),
                        np.array([mu_k]), f_active)
    return PointResidual(float(r.penetration[0]), float(r.complementarity[0]),
                         float(r.cone_excess[0]) if r.carries[0] else None,
                         float(r.dissipation_gap[0]) if r.sliding[0] else None)


@dataclass(frozen=True)
class PointResiduals:
    """The residuals of a step's points, one entry each: cone_excess counts where
    `carries` (the point carries force), dissipation_gap where `sliding`."""
    penetration: np.ndarray
    complementarity: np.ndarray
    cone_excess: np.ndarray
    dissipation_gap: np.ndarray
    carries: np.ndarray
    sliding: np.ndarray


def point_residuals(points: list[ContactPoint], v: np.ndarray, v_before: np.ndarray, e: np.ndarray,
                    mu_s: np.ndarray, mu_k: np.ndarray, f_active: float) -> PointResiduals:
    """The residuals of every point (point_residual), with relative velocities v after the
    step and v_before at its start (points, 3) and each point's e, mu_s, mu_k."""
    n = np.array([p.n for p in points], dtype=float).reshape(-1, 3)
    f_n = np.array([p.f_n for p in points], dtype=float)
    f_t = np.array([p.f_t for p in points], dtype=float).reshape(-1, 3)
    gap = np.array([p.gap for p in points], dtype=float)
    v_n = (n * v).sum(axis=1)
    v_t = v - v_n[:, None] * n
    target = -e * np.minimum((n * v_before).sum(axis=1), 0.0)  # the separation speed restitution asks for
    friction = np.linalg.norm(f_t, axis=1)
    slip = np.linalg.norm(v_t, axis=1)
    carries = f_n > f_active
    sliding = carries & (slip > SLIDING) & (mu_k > 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        cone = np.where(mu_s > 0.0, np.fmax(0.0, friction / (mu_s * f_n) - 1.0), np.where(friction > 0.0, math.inf, 0.0))
        dissipation = 1.0 + (f_t * v_t).sum(axis=1) / (mu_k * f_n * slip)
    return PointResiduals(np.fmax(0.0, -gap), f_n * np.maximum(v_n - target, 0.0), cone, dissipation, carries, sliding)


def _most(current: float, values: np.ndarray) -> float:
    """The largest of `current` and `values`, NaN left out."""
    values = values[~np.isnan(values)]
    return max(current, float(values.max())) if len(values) else current


def scene_weight(scene: Scene) -> float:
    """|g| times the dynamic mass: the force scale of the scene (1 N without gravity)."""
    g = float(np.linalg.norm(scene.gravity))
    weight = g * sum(b.mass for b in scene.bodies if b.dynamic)
    return weight if weight > 0 else 1.0


class Residuals(Probe):
    """Folds every contact point's residual, step by step, into the run's figures."""

    def __init__(self, job: Job):
        from physval.core.context import Context
        fam = Context().resolver().family(job.family)
        self.scene = fam.scene(job.variant.params)
        self.f_active = ACTIVE * scene_weight(self.scene)
        self.materials: dict[tuple[str, str], tuple[float, float, float]] = {}
        self.pen = self.comp = self.cone = 0.0
        self.gaps: list[float] = []
        self.points = 0
        self.states = None

    def on_step(self, sim, k: int) -> None:
        if k == 0 or self.states is None:
            self.states = sim.states()
            if k == 0:
                return
        before, self.states = self.states, sim.states()
        points = sim.contact_points()
        if not points:
            return
        m = np.array([self._material(p.a, p.b) for p in points]).reshape(-1, 3)
        r = point_residuals(points, relative_velocities(points, self.states, before),
                            relative_velocities(points, before), m[:, 0], m[:, 1], m[:, 2], self.f_active)
        self.points += len(points)
        self.pen = _most(self.pen, r.penetration)
        self.comp = _most(self.comp, r.complementarity)
        self.cone = _most(self.cone, r.cone_excess[r.carries])
        self.gaps.extend(r.dissipation_gap[r.sliding].tolist())

    def _material(self, a: str, b: str) -> tuple[float, float, float]:
        """(e, mu_s, mu_k) of the pair."""
        m = self.materials.get((a, b))
        if m is None:
            mat = self.scene.material_of(a, b)
            m = self.materials[(a, b)] = (mat.e, mat.mu_s, mat.mu_k_)
        return m

    def after(self, run, sim, rebuild) -> dict:
        gaps = self.gaps
        return {"laws": json.dumps({
            "point_steps": self.points, "sliding_point_steps": len(gaps), "penetration_mm": self.pen * 1e3,
            "complementarity_W": self.comp, "cone_excess": self.cone,
            "dissipation_gap_mean": float(np.mean(gaps)) if gaps else math.nan,
            "dissipation_gap_max": max(gaps) if gaps else math.nan})}


PROBE = f"{__name__}:Residuals"


def _first_runnable(fam, glob: str, adapter):
    """The first variant matching `glob` the engine can represent, or None."""
    for v in fam.variants:
        if fnmatchcase(v.id, glob) and adapter.capabilities.cannot_run(fam.scene(v.params), fam.needs_of(v.params)) is None:
            return v
    return None


def battery(families: dict, adapter) -> list[tuple[str, object]]:
    """(family name, variant) of each battery entry the engine can represent."""
    chosen = []
    for name, globs in BATTERY:
        if name in families:
            found = next(filter(None, (_first_runnable(families[name], g, adapter) for g in globs)), None)
            if found is not None:
                chosen.append((name, found))
    return chosen


def measure(engines: list[str], ctx, families: dict, execution: Execution = Execution(), resolver=None,
            **_) -> pd.DataFrame | None:
    """The residual rows of the engines over the battery, each scene at its family's dt
    (None if interrupted); an engine that cannot report contact points, or fails on a
    scene, gets a row saying so. `resolver`: the parent's (default: the context's)."""
    return run_plan(waves(engines, ctx, families, resolver), ctx, cache_dir() / STORE, COLUMNS_LAWS, execution,
                    label=LABEL)


def stream(engines: list[str], ctx, families: dict) -> Stream:
    """The reading as a stream of the command's executor (physval.core.session.run_streams):
    its jobs run beside the command's own; its value is measure()'s."""
    return stored(waves(engines, ctx, families), ctx, cache_dir() / STORE, COLUMNS_LAWS, label=LABEL, first=True)


STORE = "laws.csv"
LABEL = "physics-law residuals"
COLUMNS_LAWS = COLUMNS + ["laws"]


def waves(engines: list[str], ctx, families: dict, resolver=None):
    """The reading's plan: one wave, the battery on every engine that reports contact
    points; returns the residual rows."""
    resolver = resolver or ctx.resolver()
    rows, jobs = [], []
    for engine in engines:
        try:
            adapter = resolver.adapter(engine)
        except Exception as exc:
            rows.append({"engine": engine, "case": "", "variant": "", "note": str(exc)})
            continue
        if not adapter.capabilities.contact_points:
            rows.append({"engine": engine, "case": "", "variant": "",
                         "note": "the engine does not report per-contact forces"})
            continue
        jobs += [Job(name, v, engine, probe=PROBE) for name, v in battery(families, adapter)]
    got = (yield jobs) if jobs else {}
    for job in jobs:
        found = got[job.key]
        first = found[0] if found else {}
        row = {"engine": job.engine, "case": job.family, "variant": job.variant.id, "dt": first.get("dt", ""),
               "wall_s": first.get("wall_s", ""), "note": ""}
        if first.get("laws"):
            row.update(json.loads(first["laws"]))
        else:
            row["note"] = f"{first.get('status', 'error')}: {first.get('reason', '')}"
        rows.append(row)
    return pd.DataFrame(rows)


def summary(rows: list[dict]) -> list[dict]:
    """Each engine's worst residual over the battery, with the case it came from."""
    out = []
    for engine in dict.fromkeys(r["engine"] for r in rows):
        mine = [r for r in rows if r["engine"] == engine and r.get("point_steps") == r.get("point_steps")
                and r.get("point_steps") not in (None, "")]
        entry = {"engine": engine, "scenes": len(mine)}
        for key in RESIDUALS:
            values = [(float(r[key]), r["case"]) for r in mine if not math.isnan(float(r[key]))]
            worst = max(values, default=(math.nan, ""))
            entry[key] = worst[0]
            entry[f"{key} worst in"] = worst[1]
        out.append(entry)
    return out


def plot(worst: pd.DataFrame, path: Path) -> None:
    """Each engine's worst physics-law residual over the battery, one panel per law."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(RESIDUALS), figsize=(3.4 * len(RESIDUALS), 3.8), squeeze=False,
                             layout="constrained")
    floor = 1e-16  # an exact zero is drawn at the floor of the log axis
    for ax, key in zip(axes[0], RESIDUALS):
        values = pd.to_numeric(worst[key], errors="coerce")
        shown = values.where(values > floor, floor).fillna(floor)
        ax.bar(worst.engine, shown, color=["tab:gray" if math.isnan(v) else "tab:blue" for v in values])
        ax.set_yscale("log")
        ax.set_title(key, fontsize=9)
        ax.tick_params(axis="x", labelrotation=45, labelsize=8)
    save_figure(fig, path)


def read(out: Path) -> pd.DataFrame | None:
    """The rows `section` wrote into a result folder (laws.csv; None: none)."""
    path = Path(out) / "laws.csv"
    if not path.is_file():
        return None
    laws = pd.read_csv(path)
    return laws.assign(**{c: laws[c].fillna("") for c in ("case", "variant", "note") if c in laws})


def section(laws: pd.DataFrame, out: Path) -> str:
    out = Path(out)
    write_atomic(out / "laws.csv", laws.to_csv(index=False))
    measured = laws[laws.point_steps.notna()] if "point_steps" in laws else laws.iloc[0:0]
    worst = pd.DataFrame(summary(measured.to_dict("records")))
    lines = ["## Physics-law residuals", "",
             "Each engine's own contact forces (`Simulation.contact_points`) against the laws of rigid contact, "
             "point by point and step by step over a battery of library scenes (`physval/readings/laws.py`, each "
             "scene at its family's time step): penetration; complementarity, the power "
             "f_n max(v_n + e min(v_n-, 0), 0) of a normal force on a contact separating faster than restitution "
             "asks; friction-cone excess |f_t| / (mu_s f_n) - 1; maximal-dissipation gap "
             f"1 + f_t . v_t / (mu_k f_n |v_t|) on sliding points (|v_t| > {SLIDING:g} m/s; 0 is full Coulomb "
             f"friction against the slip, 1 none). Points with f_n below {ACTIVE:g} of the scene's weight are "
             "left out of cone and dissipation. An engine that reports one resultant per touching pair "
             "(Pymunk) is read at the pair's mean point, so a pair that rocks or turns on two points reads as one "
             "point's slip. No tolerance: these are readings, all in `laws.csv`.", ""]
    if len(worst):
        plot(worst, out / "plots" / "laws.png")
        shown = pd.DataFrame({"engine": worst.engine, "scenes": worst.scenes})
        for key in RESIDUALS:
            shown[key] = [f"{fmt(v)} ({where})" if where else "-"
                          for v, where in zip(worst[key], worst[f"{key} worst in"])]
        lines += ["Worst over the battery per engine (in brackets: the scene it occurs in):", "",
                  md_table(shown), "", "![physics-law residuals](plots/laws.png)", ""]
    notes = laws[laws.note.fillna("") != ""]
    if len(notes):
        lines += ["Not measured:", ""] + [f"- {r.engine}{' ' + r.case if r.case else ''}: {r.note}"
                                          for r in notes.itertuples()] + [""]
    return "\n".join(lines)
