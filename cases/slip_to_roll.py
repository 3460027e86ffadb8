"""A ball launched sliding and spinning on flat ground until it rolls (note 001, "dry
friction"; rigid-body impulse transfer dL = r x dp).

Convention: the ball moves along x; w is its angular velocity about +y (rad/s). A turn
about +y carries +z towards +x, so the bottom point (arm r = -R z) moves with
    s = v + (w y) x (-R z) = v - R w      (the slip),
and the ball rolls forward without slipping at w = v / R. Backspin is w < v / R
(w < 0: the bottom runs forward faster than the ball), topspin w > v / R.

While s != 0, kinetic friction F = -mu_k m g sign(s) acts at the bottom point:
    m dv/dt = F,      I dw/dt = (r x F)_y = -R F,
so the slip changes at ds/dt = dv/dt - R dw/dt = -mu_k g sign(s) (1 + m R^2 / I) and
vanishes at
    t_roll = |s0| / (mu_k g (1 + m R^2 / I)).
Then friction has nothing to do (no rolling resistance, note 001's mu_r is zero here) and
the ball rolls on with v_f = v0 - mu_k g sign(s0) t_roll = v0 - (v0 - R w0) / (1 + m R^2 / I):
- solid sphere, I = 2/5 m R^2:  ds/dt = -7/2 mu_k g sign(s),  v_f = (5 v0 + 2 R w0) / 7;
- disc (2D, about its axis), I = 1/2 m R^2:  ds/dt = -3 mu_k g sign(s),  v_f = (2 v0 + R w0) / 3.
The same v_f follows from the angular momentum about the contact point, m R v + I w, which
friction (acting through that point) and gravity (through the centre, balanced by the
normal force) leave unchanged (tests/test_closed_forms_friction.py).
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Catch, Check, plane_label
from cases.observables import point_velocity, settle_time
from cases.scene import Body, Material, Scene, ball, ground

R = 0.1     # radius, m
M = 1.0     # mass, kg
G = 9.81
AFTER_ROLL = 0.3  # simulated time past t_roll, s

# Grid: a ball sliding without spin (friction adds topspin until it rolls), backspin
# strong enough to send it back (v_f < 0: a "draw"), and a ball set down spinning in place
# (friction drives it forward). The disc variants let 2D engines take part.
GRID = (
    {"v0": 2.0, "w0": 0.0, "mu": 0.2, "dim": 3},
    {"v0": 2.0, "w0": -60.0, "mu": 0.5, "dim": 3},
    {"v0": 0.0, "w0": 40.0, "mu": 0.5, "dim": 3},
    {"v0": 2.0, "w0": 0.0, "mu": 0.2, "dim": 2},
    {"v0": 2.0, "w0": -60.0, "mu": 0.5, "dim": 2},
)


def inertia_ratio(dim: int) -> float:
    """I / (m R^2): 2/5 for a solid sphere, 1/2 for a disc about its axis."""
    return 0.4 if dim == 3 else 0.5


# --- closed forms ---------------------------------------------------------------------

def slip_rate(mu_k: float, k: float, g: float = G) -> float:
    """|ds/dt| while sliding: mu_k g (1 + m R^2 / I), with k = I / (m R^2)."""
    return mu_k * g * (1.0 + 1.0 / k)


def roll_time(v0: float, w0: float, mu_k: float, k: float, radius: float = R, g: float = G) -> float:
    return abs(v0 - radius * w0) / slip_rate(mu_k, k, g)


def rolling_velocity(v0: float, w0: float, k: float, radius: float = R) -> float:
    """v_f = v0 - (v0 - R w0) / (1 + 1/k): (5 v0 + 2 R w0)/7 for k = 2/5, (2 v0 + R w0)/3 for k = 1/2."""
    return v0 - (v0 - radius * w0) / (1.0 + 1.0 / k)


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p.get("dim", 3)
    body = Body("ball", ball(R, dim), mass=M, position=(0, 0, R), velocity=(p["v0"], 0, 0),
                angular_velocity=(0, p["w0"], 0))
    return Scene(bodies=(ground(), body), gravity=(0.0, 0.0, -G),
                 material=Material(e=0.0, mu_s=p["mu"]), dimension=dim)


def duration(p) -> float:
    return roll_time(p["v0"], p["w0"], p["mu"], inertia_ratio(p.get("dim", 3))) + AFTER_ROLL


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    k = inertia_ratio(p.get("dim", 3))
    slip = np.linalg.norm(point_velocity(traj, "ball", (0.0, 0.0, -R))[:, :2], axis=1)
    return {"roll_time": settle_time(traj, slip, slip_rate(p["mu"], k) * traj.dt),
            "rolling_velocity": float(traj.vel("ball")[-1, 0]),
            "rolling_spin": float(traj.omega("ball")[-1, 1])}


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    k = inertia_ratio(p.get("dim", 3))
    v_f = rolling_velocity(p["v0"], p["w0"], k)
    dv = p["mu"] * G * dt  # what friction changes v by in one step
    return [
        Check("roll_time", "s", roll_time(p["v0"], p["w0"], p["mu"], k), 2 * dt, "abs",
              "the slip ends within a step, and 'rolling' is read one step of slip change early"),
        Check("rolling_velocity", "m/s", v_f, dv, "abs",
              f"mu_k g dt = {dv:.2g} m/s: the last sliding step may end anywhere within the step"),
        Check("rolling_spin", "rad/s", v_f / R, dv / (k * R), "abs",
              "the same last-step friction impulse, as spin: mu_k g dt / (k R), k = I / (m R^2)"),
    ]


def variant_id(p) -> str:
    plane = plane_label(p)
    return f"v0={p['v0']:g},w0={p['w0']:g},mu={p['mu']}{plane}"


FAMILY = CaseFamily(
    name="slip_to_roll",
    summary="a sliding, spinning ball on flat ground rolls after |v0 - R w0| / (mu g (1 + mR^2/I)) at (5 v0 + 2 R w0)/7 (disc: (2 v0 + R w0)/3)",
    source="note 001 (CG3 II.5), dry friction and impulse transfer dL = r x dp; angular momentum about the contact point",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("friction off", "v0=2,w0=0,mu=0.2"),
        Catch("friction doubled", "v0=2,w0=0,mu=0.2"),
    ),
)
