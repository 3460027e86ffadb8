"""Newton's cradle: k balls released into a row of equal balls, e = 1.

Closed form and the assumption it rests on (note 001, "Newton's cradle", "Analyzing
Newton's Cradle"): energy and momentum alone do not fix the outcome when one ball
touches several (note 001: "an infinite number of solutions"), and with rigid
simultaneous impulses (an LCP over the touching row) the classic result does not follow:
the impulse spreads over the row. It follows when the collisions happen one pair at a
time ("Assumption in CG: collisions are dispersion-free", note 001's summary: multiple
contact collisions as a sequence of single contact impacts). Here a small gap between
neighbours makes them sequential: each collision is a central impact of two equal masses
with e = 1 (note 001, "Rigid Body Impact - Central Case"),
    v_1' = v_2,  v_2' = v_1   (equal masses exchange velocities),
so every collision hands the incoming velocity on, and after the last one the k balls at
the far end move at v and the others rest, for any k. The gap (10 steps of travel at
dt = 1e-3) lets a rigid contact finish before the next begins; an engine whose contact
lasts longer than that (a compliant one) overlaps collisions and disperses: a finding.

Compliant contact (note 001, Herrmann & Seitz): with balls touching and a force law
F = H xi^r, a pulse travels down the row and disperses; dispersion falls as the exponent
grows (Hooke r = 1 far from the cradle, Hertz r = 1.5 close to it). There is no closed
form; the expected velocities come from the contact model's own equations of motion,
integrated to 1e-11 (scipy). These variants (`COMPLIANT_GRID`, in the grid) give the
balls' material that law (cases.scene.Compliance); only an engine that models it runs
them (`reference-hertz`, `reference-hooke`), a rigid engine reports them unsupported.
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import IMPACT_ROUNDINGS, CaseFamily, Catch, Check, impulse_roundoff
from cases.scene import Body, Compliance, Material, Scene, ball

R = 0.1       # ball radius, m
M = 7850.0 * 4.0 / 3.0 * math.pi * R**3  # kg: steel (32.9 kg), as the compliant variants' modulus
N = 5         # balls in the cradle
V = 1.0       # speed of the released balls, m/s
GAP = 0.01    # m between neighbours: 10 steps of travel at dt = 1e-3

# Grid: one, two and three balls released (3D), one and three in 2D (discs in the x-z
# plane, which 2D engines run).
GRID = tuple({"k": k, "dim": 3} for k in (1, 2, 3)) + tuple({"k": k, "dim": 2} for k in (1, 3))

# Compliant contact, balls touching, one ball released: the dispersion of note 001.
# Steel E = 200 GPa, nu = 0.3 (Hertz); k = 1e7 N/m (Hooke).
COMPLIANT_GRID = (
    {"k": 1, "dim": 3, "law": "hertz", "E": 200e9, "nu": 0.3},
    {"k": 1, "dim": 3, "law": "hooke", "stiffness": 1e7},
)


def names() -> list[str]:
    return [f"ball{i}" for i in range(N)]


# --- closed forms ---------------------------------------------------------------------------

def exchange(v_1: float, v_2: float) -> tuple[float, float]:
    """Central impact of equal masses with e = 1 (note 001): velocities swap."""
    return v_2, v_1


def sequential_velocities(k: int, v: float = V, n: int = N) -> list[float]:
    """Final velocities, ball 0 (the far left) to ball n-1, when the left k balls move at v
    into n - k resting ones and every collision is a separate pair (gaps). Neighbours
    collide while the left one is faster and then swap velocities, so whatever the order
    the collisions come in, they end when the velocities are sorted: here, sweeps of
    swaps until no neighbours approach."""
    vel = [v] * k + [0.0] * (n - k)
    moved = True
    while moved:
        moved = False
        for i in range(n - 1):  # one wave: every approaching pair swaps
            if vel[i] > vel[i + 1]:
                vel[i], vel[i + 1] = exchange(vel[i], vel[i + 1])
                moved = True
    return vel


def force_law(p):
    """(H, r) of the compliant contact between two balls: Hertz H = 4/3 E* sqrt(R*) with
    E* = E / (2 (1 - nu^2)), R* = R / 2 (note 001, "Hertz Constant", equal spheres); Hooke
    H = k, r = 1."""
    if p["law"] == "hertz":
        E_star = p["E"] / (2.0 * (1.0 - p["nu"] ** 2))
        return 4.0 / 3.0 * E_star * math.sqrt(R / 2.0), 1.5
    return p["stiffness"], 1.0


def compliant_velocities(p) -> list[float]:
    """Final velocities of the touching row under F = H xi^r between neighbours (no pull),
    from the equations of motion m x_i'' = F(xi_{i-1,i}) - F(xi_{i,i+1}),
    xi_{i,i+1} = 2R - (x_{i+1} - x_i), integrated until every pair has parted."""
    H, r = force_law(p)
    k = p["k"]

    def rates(t, y):
        x, v = y[:N], y[N:]
        xi = np.maximum(2.0 * R - np.diff(x), 0.0)
        F = H * xi**r
        a = np.zeros(N)
        a[:-1] -= F / M
        a[1:] += F / M
        return np.concatenate([v, a])
    x0 = 2.0 * R * np.arange(N, dtype=float)
    v0 = np.array([V] * k + [0.0] * (N - k))
    y = np.concatenate([x0, v0])
    # contact times are ~1e-4 s (Hertz, steel) to ~1e-3 s (Hooke, 1e7 N/m): integrate in
    # chunks until no pair overlaps or approaches
    for _ in range(1000):
        from scipy.integrate import solve_ivp  # here: scipy.integrate costs 0.5 s to import
        sol = solve_ivp(rates, (0.0, 1e-3), y, method="DOP853", rtol=1e-11, atol=1e-14)
        y = sol.y[:, -1]
        gaps, closing = np.diff(y[:N]) - 2.0 * R, -np.diff(y[N:])
        if np.all(gaps > 0.0) and np.all(closing <= 0.0):
            return list(y[N:])
    raise RuntimeError("the compliant row did not part within 1 s")


# --- scene ----------------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p["dim"]
    gap = 0.0 if "law" in p else GAP
    step = 2.0 * R + gap
    v0 = [V] * p["k"] + [0.0] * (N - p["k"])
    balls = tuple(Body(name, ball(R, dim), mass=M, position=(step * i, 0.0, 0.0), velocity=(v, 0.0, 0.0),
                       rotates=False) for i, (name, v) in enumerate(zip(names(), v0)))
    law = p.get("law")
    compliance = (Compliance("hertz", E=p["E"], nu=p["nu"]) if law == "hertz"
                  else Compliance("hooke", k=p["stiffness"]) if law == "hooke" else None)
    return Scene(bodies=balls, gravity=(0.0, 0.0, 0.0), material=Material(e=1.0, compliance=compliance),
                 dimension=dim)


def duration(p) -> float:
    # the wave crosses N - 1 gaps at V (the rigid cradle); the rest lets a soft contact
    # (16 steps in MuJoCo, 4 ms for the Hooke variant) part
    return (N - 1) * GAP / V + 0.04


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    out = {f"v_{name}": float(traj.vel(name)[-1, 0]) for name in names()}
    out["momentum"] = M * sum(out.values())
    out["energy"] = 0.5 * M * sum(v * v for v in (out[f"v_{n}"] for n in names()))
    return out


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    k = p["k"]
    if "law" in p:
        final = compliant_velocities(p)
        # an integrator that resolves each contact (0.6 ms Hertz, 4 ms Hooke) in >= 300
        # steps of a second-order scheme errs by O((h / t_c)^2) ~ 1e-5 of the speed
        tol = 1e-5 * V
        why = "the contact force integrated in >= 300 steps per contact (second order): 1e-5 of the speed"
    else:
        final = sequential_velocities(k)
        # each ball's velocity passes through at most k (N - k) single-pair impulses, each
        # exact to solver convergence (1e-6 of the closing speed)
        tol = 1e-6 * V * k * (N - k)
        why = f"{k * (N - k)} sequential pair impulses, each exact to solver convergence (1e-6 of V)"
    checks = [Check(f"v_{name}", "m/s", v, tol, "abs", why) for name, v in zip(names(), final)]
    p0, e0 = M * V * k, 0.5 * M * V * V * k
    # rigid: at least N - 1 contacts and k (N - k) sequential pair impacts, each between two
    # balls at speeds <= V; a compliant contact acts over hundreds of steps (float64 engines)
    impacts = 0 if "law" in p else max(N - 1, k * (N - k))
    checks += [Check("momentum", "kg m/s", p0, 1e-9 * p0, "abs",
                     "equal and opposite impulses conserve momentum to round-off (1e-9 in float64; "
                     f"{IMPACT_ROUNDINGS} roundings of m |v| a sub-step for each of {impacts} pair impacts at "
                     "the engine's float width)", impulse_roundoff(2.0 * M * V, impacts)),
               Check("energy", "J", e0, 2.0 * M * V * N * tol, "abs",
                     "the velocity tolerance carried through E = sum m v^2 / 2")]
    return checks


def variant_id(p) -> str:
    plane = ",2D" if p["dim"] == 2 else ""
    law = f",{p['law']},touching" if "law" in p else ""
    return f"k={p['k']}{law}{plane}"


FAMILY = CaseFamily(
    name="newtons_cradle",
    summary="k = 1, 2, 3 balls released into a row of equal balls with small gaps, e = 1: the same number leave the far end at the same speed",
    source="note 001 (CG3 II.5), Newton's cradle and dispersion; central impact of equal masses; collisions as a sequence of single impacts",
    grid=GRID + COMPLIANT_GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("restitution off", "k=1"),
        Catch("restitution off", "k=1,2D"),
    ),
)
