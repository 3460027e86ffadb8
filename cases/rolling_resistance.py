"""A ball rolling without slipping is slowed by rolling resistance, and by nothing else
(note 001, "dry friction": rolling friction F_r = mu_r F_n, mu_r << mu_k; Newton-Euler
for a rolling ball).

The law (cases.scene.Material.rolling_resistance): the contact exerts a torque about the
rolling axis opposing the rolling, |tau_r| <= d N, d a length (note 001's mu_r = d / R for
a ball of radius R). The first family to test a contact TORQUE: every other family's
contact acts through forces at the contact point only, and its rolling cases
(rolling_incline, slip_to_roll) assume d = 0, so none of them can tell an engine that
drops the resistance from one that invents it.

A ball of mass m, radius R, I = k m R^2 (k = 2/5 solid sphere, 1/2 disc in 2D), on a plane
inclined at theta (theta = 0: flat), moving downhill (+x) and turning about +y with
v = R w (rolling). Gravity pulls m g sin(theta) along x at the centre, the normal force is
N = m g cos(theta), friction F acts at the contact point (positive up the slope), and the
rolling resistance torque d N opposes the rolling w > 0. Newton and Euler (about +y; the
contact point is at -R z, so friction's torque is +F R):
    m a = m g sin(theta) - F,        k m R^2 alpha = F R - d N.
Rolling, a = R alpha, so F = k m a + d N / R, and
    a = g (sin(theta) - (d / R) cos(theta)) / (1 + k).
- flat (theta = 0), rolling forward at v0: it decelerates uniformly at
      a_r = (d / R) g / (1 + k)   (sphere: 5/7 (d/R) g; disc: 2/3 (d/R) g),
  and stops after t = v0 / a_r, d_stop = v0^2 / (2 a_r); at rest nothing drives it any
  more, so it stays;
- on an incline it rolls down with the rolling-incline acceleration g sin / (1 + k)
  (cases/rolling_incline.py) minus (d/R) g cos / (1 + k), if tan(theta) > d / R; below
  that, released at rest, the resistance holds it (the torque needed to keep it from
  rolling, m g sin(theta) R, is at most d m g cos(theta)) and it does not move;
- d = 0 (the control): a rolling ball on the flat keeps its speed for good. An engine
  whose contact dissipates while rolling (a damper in the normal direction that the
  rolling ball's contact keeps loading and unloading, regularised friction rows) shows
  a deceleration the scene did not ask for; so does one that switches on a rolling
  resistance of its own (MuJoCo's condim 6 brings 1e-4 m): the control is judged tightly
  enough to see a tenth of that (CONTROL_LEVER).
- two radii: d is a lever arm; an engine whose coefficient is the dimensionless
  mu_r = d / R needs the ball's own radius to convert it, and a conversion with a radius
  of its own passes a single radius. The 0.05 m ball decelerates twice as fast.
Friction needed to roll: |F| = (k m |a| + d N / R) stays far below mu_s N for mu_s = 0.5
(0.2 % to 15 % of it on this grid): the ball never slips.

Discrete time: with the torque impulse d N dt exact each step, symplectic Euler follows
v_n = v0 - a_r n dt exactly; the stop distance carries the half step of the position
update (v0 dt / 2).
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Catch, Check, plane_label
from cases.observables import rate
from cases.rolling_incline import inertia_ratio
from cases.scene import Body, Material, Scene, ball, ground, tilted_gravity

R = 0.1      # radius, m (a variant's "R" when it has one)
G = 9.81
MU = 0.5     # sliding friction: ample to keep every variant rolling
FIT_FROM = 0.1   # accelerations are fitted from here on, after the contact's start-up, s
T = 1.0          # simulated time of the incline and control variants, s
AFTER_STOP = 0.3  # simulated time past the stop on the flat, s
ACC_TOL = 0.01    # m/s^2, as cases/rolling_incline.py: 0.1 % of g
HELD_TOL = 1e-3   # m a held ball may move in T
# The control (d = 0) is judged against the smallest rolling resistance it must see: a
# tenth of the smallest lever arm an engine switches on by default (MuJoCo's condim-6
# rolling friction, 1e-4 m), which decelerates a rolling ball of radius R at
# (d / R) g / (1 + k), 7e-4 m/s^2 for the 0.1 m ball: MuJoCo's default lands at 10
# tolerances (at 0.7 under ACC_TOL). Engines that roll freely measure 3e-5 m/s^2 at most.
CONTROL_LEVER = 1e-5  # m

# Grid: d = 5 mm (mu_r = d / R = 0.05) on the flat from 0.7 m/s (stops in about 2 s), the
# same on a ball of half the radius (mu_r = 0.1: twice the deceleration, so a conversion
# to mu_r with a radius of its own is seen), the same without resistance (the control), on
# a 10 deg incline (tan 10 deg = 0.18 > 0.05: rolls down slower than without resistance)
# and a 2 deg one (tan = 0.035 < 0.05: held at rest); the flat pair again as discs for the
# 2D engines.
GRID = (
    {"d": 0.005, "theta_deg": 0.0, "v0": 0.7, "dim": 3},
    {"d": 0.005, "theta_deg": 0.0, "v0": 0.7, "R": 0.05, "dim": 3},
    {"d": 0.0, "theta_deg": 0.0, "v0": 0.7, "dim": 3},
    {"d": 0.005, "theta_deg": 10.0, "v0": 0.0, "dim": 3},
    {"d": 0.005, "theta_deg": 2.0, "v0": 0.0, "dim": 3},
    {"d": 0.005, "theta_deg": 0.0, "v0": 0.7, "dim": 2},
    {"d": 0.0, "theta_deg": 0.0, "v0": 0.7, "dim": 2},
)


def radius(p) -> float:
    return p.get("R", R)


# --- closed forms ---------------------------------------------------------------------

def acceleration(theta: float, d: float, k: float, radius: float = R, g: float = G) -> float:
    """Downhill acceleration of a ball rolling downhill (or forward on the flat) against
    rolling resistance d; 0 where the resistance holds a ball at rest (tan <= d / R)."""
    a = g * (math.sin(theta) - d / radius * math.cos(theta)) / (1.0 + k)
    return a if theta == 0.0 or a > 0.0 else 0.0


def stop_time(v0: float, d: float, k: float, radius: float = R, g: float = G) -> float:
    return v0 / -acceleration(0.0, d, k, radius, g)


def stop_distance(v0: float, d: float, k: float, radius: float = R, g: float = G) -> float:
    return v0 * v0 / (2.0 * -acceleration(0.0, d, k, radius, g))


def stops(p) -> bool:
    """The flat variants with resistance roll to a stop."""
    return p["theta_deg"] == 0.0 and p["d"] > 0.0


def held(p) -> bool:
    """The incline variants where the resistance holds the ball at rest (tan <= d / R)."""
    return p["theta_deg"] > 0.0 and acceleration(math.radians(p["theta_deg"]), p["d"], 0.4, radius(p)) == 0.0


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p.get("dim", 3)
    v0, r = p["v0"], radius(p)
    body = Body("ball", ball(r, dim), mass=1.0, position=(0, 0, r), velocity=(v0, 0, 0),
                angular_velocity=(0, v0 / r, 0))  # rolling: the contact point is at rest
    return Scene(bodies=(ground(), body), gravity=tilted_gravity(math.radians(p["theta_deg"]), G),
                 material=Material(e=0.0, mu_s=MU, rolling_resistance=p["d"]), dimension=dim)


def duration(p) -> float:
    if stops(p):
        return stop_time(p["v0"], p["d"], inertia_ratio(p.get("dim", 3)), radius(p)) + AFTER_STOP
    return T


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    vx = traj.vel("ball")[:, 0]
    if stops(p):  # fitted well before the stop, where the deceleration is uniform
        t1 = 0.8 * stop_time(p["v0"], p["d"], inertia_ratio(p.get("dim", 3)), radius(p))
        x = traj.pos("ball")[:, 0]
        return {"acceleration": rate(traj, vx, FIT_FROM, t1), "stop_distance": float(x[-1] - x[0])}
    if held(p):  # a creep at constant speed has no acceleration: read the distance too
        x = traj.pos("ball")[:, 0]
        return {"acceleration": rate(traj, vx, FIT_FROM), "distance": float(x[-1] - x[0])}
    return {"acceleration": rate(traj, vx, FIT_FROM)}


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    k, r = inertia_ratio(p.get("dim", 3)), radius(p)
    a = acceleration(math.radians(p["theta_deg"]), p["d"], k, r)
    if p["d"] == 0.0:
        tol = -acceleration(0.0, CONTROL_LEVER, k, r)
        checks = [Check("acceleration", "m/s^2", a, tol, "abs",
                        f"no rolling resistance asked: nothing may slow a rolling ball; {tol:.2g} m/s^2 is what a "
                        f"lever of {CONTROL_LEVER:g} m would do, a tenth of the least an engine adds by default "
                        "(MuJoCo's 1e-4 m)")]
    else:
        checks = [Check("acceleration", "m/s^2", a, ACC_TOL, "abs",
                        "symplectic Euler is exact for constant acceleration (the torque impulse d N dt is exact "
                        "each step); 0.01 m/s^2 is 0.1 % of g")]
    if stops(p):
        v0 = p["v0"]
        reach = v0 * v0 / (2.0 * a * a) * ACC_TOL  # d(v0^2 / 2a) = v0^2 / (2 a^2) da
        checks.append(Check("stop_distance", "m", stop_distance(v0, p["d"], k, r), reach + v0 * dt / 2, "abs",
                            f"the deceleration's 0.01 m/s^2 carried to v0^2 / (2 a) ({reach:.2g} m), plus "
                            "v0 dt / 2 for a position update with the new or the old velocity"))
    if held(p):
        checks.append(Check("distance", "m", 0.0, HELD_TOL, "abs",
                            "held by rolling resistance, the ball does not move: 1 mm over 1 s bounds a creep of "
                            "1 mm/s (a soft contact settles by micrometres)"))
    return checks


def variant_id(p) -> str:
    where = "flat" if p["theta_deg"] == 0.0 else f"theta={p['theta_deg']:g}deg"
    start = f",v0={p['v0']:g}" if p["v0"] else ""
    size = f",R={radius(p):g}" if radius(p) != R else ""
    return f"d={p['d']:g},{where}{start}{size}{plane_label(p)}"


FAMILY = CaseFamily(
    name="rolling_resistance",
    summary="a ball rolling against rolling resistance d decelerates at (d/R) g / (1 + k) and stops at v0^2/(2a); "
            "on an incline a = g (sin - d/R cos) / (1 + k), held below tan = d/R; with d = 0 it never slows",
    source="note 001 (CG3 II.5), dry friction: rolling friction F_r = mu_r F_n (mu_r = d / R); Newton-Euler "
           "for a rolling ball",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("rolling resistance off", "d=0.005,flat,v0=0.7"),
        Catch("rolling resistance doubled", "d=0.005,flat,v0=0.7"),
        Catch("rolling radius", "d=0.005,flat,v0=0.7,R=0.05"),
        Catch("contact torques", "d=0,flat,v0=0.7"),
        Catch("friction off", "d=0.005,theta=10deg"),
    ),
)
