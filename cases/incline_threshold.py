"""A box on an incline: Coulomb's friction threshold (note 001, "dry friction").

A box of mass m on a plane inclined at theta, released at rest. Along the slope gravity
pulls with m g sin(theta); static friction can hold up to mu_s m g cos(theta). So the box
stays while tan(theta) <= mu_s (the threshold angle is atan(mu_s), not mu_s), and above it
slides with the kinetic coefficient:
    a = g (sin(theta) - mu_k cos(theta)).
A cube whose half-height equals its half-width does not tip while it sticks below 45 deg,
nor while it slides with mu_k < 1, so the grid keeps theta < 50 deg and mu <= 0.8.

The break-away angle itself is measured to 0.5 %: at 0.995 atan(mu_s) the box must stay,
at 1.005 atan(mu_s) it must slide. An engine holding more static friction than mu_s (or
letting go below it) by more than about 1 % fails one of the two (tan(theta) moves by
0.5 % of theta / (sin theta cos theta), 0.5-0.7 % of mu_s here). Just above the threshold
the box accelerates slowly (0.010 m/s^2 at mu = 0.2), so these variants run T_FINE = 2 s:
it slides 2-9 cm, twice SLIDE_DISTANCE at least.

The incline is built by tilting gravity: the plane stays z = 0 and gravity is
g (sin theta, 0, -cos theta), so downhill is +x in every engine.
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Catch, Check, friction_label, plane_label
from cases.observables import rate, window_mean
from cases.scene import Body, Material, Scene, cube, ground, tilted_gravity

HALF = 0.1     # half-extent of the cube, m
G = 9.81
T = 1.0        # simulated time, s
T_FINE = 2.0   # simulated time of the break-away variants, s (see the module docstring)
# "slides" means it moved more than this in T: creep of a sticking box is mm/s at worst,
# while 1 deg above the threshold the box slides >= 8 cm in T for every mu of the grid.
SLIDE_DISTANCE = 0.01

# Grid: low, medium and high friction; angles well below, just below, just above and well
# above the threshold atan(mu_s). A pair with mu_k < mu_s exercises static vs kinetic.
OFFSETS_DEG = (-10.0, -1.0, 1.0, 10.0)
# The 2D variants (a square in the x-z plane) let 2D engines take part.
GRID = tuple({"mu_s": mu, "mu_k": mu, "offset_deg": d, "dim": 3} for mu in (0.2, 0.5, 0.8) for d in OFFSETS_DEG) + (
    {"mu_s": 0.5, "mu_k": 0.3, "offset_deg": -1.0, "dim": 3},   # stays: static friction decides
    {"mu_s": 0.5, "mu_k": 0.3, "offset_deg": 1.0, "dim": 3},    # slides: kinetic friction acts
) + tuple({"mu_s": 0.5, "mu_k": 0.5, "offset_deg": d, "dim": 2} for d in OFFSETS_DEG)
# The break-away angle to 0.5 %: each friction just below (stays) and just above (slides)
# atan(mu_s), as fractions of it.
FRACTIONS = (0.995, 1.005)
GRID += tuple({"mu_s": mu, "mu_k": mu, "fraction": f, "dim": 3} for mu in (0.2, 0.5, 0.8) for f in FRACTIONS) + \
    tuple({"mu_s": 0.5, "mu_k": 0.3, "fraction": f, "dim": 3} for f in FRACTIONS) + \
    tuple({"mu_s": 0.5, "mu_k": 0.5, "fraction": f, "dim": 2} for f in FRACTIONS)


def theta(p) -> float:
    """The incline: atan(mu_s) plus `offset_deg` degrees, or `fraction` times atan(mu_s)."""
    if "fraction" in p:
        return p["fraction"] * math.atan(p["mu_s"])
    return math.atan(p["mu_s"]) + math.radians(p["offset_deg"])


# --- closed forms ---------------------------------------------------------------------

def threshold_angle(mu_s: float) -> float:
    return math.atan(mu_s)


def slides(th: float, mu_s: float) -> bool:
    return math.tan(th) > mu_s


def sliding_acceleration(th: float, mu_k: float, g: float = G) -> float:
    return g * (math.sin(th) - mu_k * math.cos(th))


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    return Scene(
        bodies=(ground(), Body("box", cube(HALF, p.get("dim", 3)), mass=1.0, position=(0, 0, HALF))),
        gravity=tilted_gravity(theta(p), G),
        material=Material(e=0.0, mu_s=p["mu_s"], mu_k=p["mu_k"]), dimension=p.get("dim", 3))


def duration(p) -> float:
    return T_FINE if "fraction" in p else T


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    x = traj.pos("box")[:, 0]
    vx = traj.vel("box")[:, 0]
    moved = x[-1] - x[0]
    # Fit the slope of vx over the second half: away from the start-up of the contact.
    half = duration(p) / 2
    return {"slides": float(moved > SLIDE_DISTANCE),
            "sliding_acceleration": rate(traj, vx, half),
            "creep_rate": window_mean(traj, np.abs(vx), half)}


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    th = theta(p)
    moving = slides(th, p["mu_s"])
    checks = [Check("slides", "bool", float(moving), 0.0, "abs",
                    f"a verdict: moved more than {SLIDE_DISTANCE} m in {duration(p)} s or not")]
    if moving:
        # Symplectic Euler is exact for a constant acceleration, so only the solver's
        # convergence remains: a velocity off by 1e-6 m/s in a step moves the fitted slope
        # by at most 1e-6 m/s / dt. (It was 0.01 m/s^2, which passed g 5 % off at +1 deg.)
        tol_a = 1e-6 / dt
        checks.append(Check(
            "sliding_acceleration", "m/s^2", sliding_acceleration(th, p["mu_k"]), tol_a, "abs",
            f"symplectic Euler is exact for constant acceleration; solver convergence (1e-6 m/s a step) / dt = "
            f"{tol_a:.2g} m/s^2 (g or mu_k 1 % off exceeds it)"))
    else:
        checks.append(Check(
            "creep_rate", "m/s", 0.0, 1e-4, "abs",
            "a sticking box does not move; 0.1 mm/s would walk it half its size in 17 min"))
    return checks


def variant_id(p) -> str:
    mu = friction_label(p)
    plane = plane_label(p)
    if "fraction" in p:
        return f"{mu},theta={p['fraction']:g}atan(mu_s){plane}"
    return f"{mu},theta=atan(mu_s){p['offset_deg']:+g}deg{plane}"


FAMILY = CaseFamily(
    name="incline_threshold",
    summary="a box on an incline stays below atan(mu_s) (to 0.5 %) and slides with g(sin - mu_k cos) above it",
    source="note 001 (CG3 II.5), dry friction mu_s, mu_k; Coulomb's law on an incline",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    sweep_variants=("mu=0.5,theta=atan(mu_s)+1deg", "mu=0.5,theta=atan(mu_s)-1deg", "mu=0.5,theta=atan(mu_s)+1deg,2D"),  # what `physval sweep` varies dt and iterations on
    variant_id=variant_id,
    tags=frozenset({"core"}),
    catches=(
        Catch("static friction", "mu=0.5,theta=atan(mu_s)+1deg"),
        Catch("friction off", "mu=0.5,theta=atan(mu_s)-10deg"),
        Catch("friction doubled", "mu=0.5,theta=atan(mu_s)+10deg"),
        Catch("kinetic friction", "mu=0.5,theta=atan(mu_s)+10deg"),
    ),
)
