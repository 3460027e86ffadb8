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
engine can represent, so 2D-only engines take part; `measure` runs them and `summary`
gives each engine's worst residual over them. No pass/fail: the residuals are a reading
of each engine, reported side by side (reports/laws.csv and the report's section).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from fnmatch import fnmatchcase

import numpy as np

from cases.scene import Scene
from cases.trajectory import ContactPoint

MAX_SECONDS = 1.0  # each battery scene runs its family's duration, at most this long
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
    start = states if start is None else start
    def at(name):
        s = states.get(name)
        if s is None:
            return np.zeros(3)
        return s[7:10] + np.cross(s[10:13], p.x - start[name][0:3])
    return at(p.a) - at(p.b)


def point_residual(p: ContactPoint, v: np.ndarray, v_before: np.ndarray, e: float, mu_s: float, mu_k: float,
                   f_active: float) -> PointResidual:
    """The residuals of one point with relative velocity v after the step and v_before at its start."""
    n = np.asarray(p.n, dtype=float)
    v_n = float(n @ v)
    v_t = v - v_n * n
    target = -e * min(float(n @ v_before), 0.0)  # the separation speed restitution asks for
    f_t = np.asarray(p.f_t, dtype=float)
    friction = float(np.linalg.norm(f_t))
    cone = gap = None
    if p.f_n > f_active:
        cone = max(0.0, friction / (mu_s * p.f_n) - 1.0) if mu_s > 0.0 else (math.inf if friction > 0.0 else 0.0)
        slip = float(np.linalg.norm(v_t))
        if slip > SLIDING and mu_k > 0.0:
            gap = 1.0 + float(f_t @ v_t) / (mu_k * p.f_n * slip)
    return PointResidual(max(0.0, -p.gap), p.f_n * max(v_n - target, 0.0), cone, gap)


def scene_weight(scene: Scene) -> float:
    """|g| times the dynamic mass: the force scale of the scene (1 N without gravity)."""
    g = float(np.linalg.norm(scene.gravity))
    weight = g * sum(b.mass for b in scene.bodies if b.dynamic)
    return weight if weight > 0 else 1.0


def run_residuals(sim, scene: Scene, steps: int) -> dict:
    """Step `sim` `steps` times and fold every point's residual into the run's figures."""
    f_active = ACTIVE * scene_weight(scene)
    materials: dict[tuple[str, str], tuple[float, float, float]] = {}
    pen = comp = cone = 0.0
    gaps: list[float] = []
    n_points = 0
    states = sim.states()
    for _ in range(steps):
        before = states
        sim.step()
        states = sim.states()
        for p in sim.contact_points():
            m = materials.get((p.a, p.b))
            if m is None:
                mat = scene.material_of(p.a, p.b)
                m = materials[(p.a, p.b)] = (mat.e, mat.mu_s, mat.mu_k_)
            r = point_residual(p, relative_velocity(p, states, before), relative_velocity(p, before),
                               *m, f_active)
            n_points += 1
            pen = max(pen, r.penetration)
            comp = max(comp, r.complementarity)
            if r.cone_excess is not None:
                cone = max(cone, r.cone_excess)
            if r.dissipation_gap is not None:
                gaps.append(r.dissipation_gap)
    return {"point_steps": n_points, "sliding_point_steps": len(gaps),
            "penetration_mm": pen * 1e3, "complementarity_W": comp, "cone_excess": cone,
            "dissipation_gap_mean": float(np.mean(gaps)) if gaps else math.nan,
            "dissipation_gap_max": max(gaps) if gaps else math.nan}


def _first_runnable(fam, glob: str, adapter):
    """(variant, scene) of the first variant matching `glob` the engine can represent, or None."""
    for v in fam.variants:
        if fnmatchcase(v.id, glob):
            scene = fam.scene(v.params)
            if adapter.capabilities.cannot_run(scene, fam.needs_of(v.params)) is None:
                return v, scene
    return None


def battery(families: dict, adapter) -> list[tuple[str, object, Scene]]:
    """(family name, variant, its scene) of each battery entry the engine can represent."""
    chosen = []
    for name, globs in BATTERY:
        if name in families:
            found = next(filter(None, (_first_runnable(families[name], g, adapter) for g in globs)), None)
            if found is not None:
                chosen.append((name, *found))
    return chosen


def measure(engine: str, families: dict, dt: float | None = None) -> list[dict]:
    """The residual rows of one engine over the battery, each scene at `dt` (default: its
    family's time step); an engine that cannot report
    contact points, or fails on a scene, gets a row saying so (nothing raises)."""
    from adapters import registry
    from adapters.base import Settings, Unsupported
    adapter = registry.get(engine)
    if not adapter.capabilities.contact_points:
        return [{"engine": engine, "case": "", "variant": "",
                 "note": "the engine does not report per-contact forces"}]
    rows = []
    for name, variant, scene in battery(families, adapter):
        fam = families[name]
        step = dt or fam.dt_for(variant.params)
        row = {"engine": engine, "case": name, "variant": variant.id, "dt": step, "note": ""}
        start = time.perf_counter()
        try:
            with adapter.build(scene, Settings(dt=step)) as sim:
                seconds = min(fam.duration(variant.params), MAX_SECONDS)
                row.update(run_residuals(sim, scene, round(seconds / step)))
        except Unsupported as exc:
            row["note"] = f"unsupported: {exc}"
        except Exception as exc:  # an engine failure is a finding, not a crash of the run
            row["note"] = f"error: {type(exc).__name__}: {exc}"
        row["wall_s"] = time.perf_counter() - start
        rows.append(row)
    return rows


def summary(rows: list[dict]) -> list[dict]:
    """Each engine's worst residual over the battery, with the case it came from."""
    out = []
    for engine in dict.fromkeys(r["engine"] for r in rows):
        mine = [r for r in rows if r["engine"] == engine and r.get("point_steps")]
        entry = {"engine": engine, "scenes": len(mine)}
        for key in RESIDUALS:
            values = [(r[key], r["case"]) for r in mine if not math.isnan(r[key])]
            worst = max(values, default=(math.nan, ""))
            entry[key] = worst[0]
            entry[f"{key} worst in"] = worst[1]
        out.append(entry)
    return out
