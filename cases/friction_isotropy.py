"""Boxes sliding in several directions decelerate alike (note 001, "dry friction").

Coulomb friction opposes the relative velocity, whatever its direction in the contact
plane (note 001: "direction is in contact plane opposite to relative velocity"; the
static limit is the cone mu_s^2 F_n^2 >= F_t^2, a disc in the tangent plane). So a box
sliding on the plane z = 0 in any direction d decelerates along d with
    a = mu_k g
and feels no force across d: it runs straight. An engine that bounds the two tangent
components separately (|F_t1|, |F_t2| <= mu F_n, a square: a "box friction" or
pyramid) pulls a box sliding at an angle to its tangent basis harder (up to mu sqrt(2)
at 45 deg) and, where one component saturates first, turns it towards an axis.

One scene holds one box per direction, launched radially from the origin (they move
apart and never meet). The boxes stay aligned with the world axes, so a direction is
also the angle to each box's faces. 2D has no counterpart: a 2D contact has one tangent.
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import rate
from cases.scene import Body, Material, Scene, cube, ground

HALF = 0.1     # half-extent of each cube, m
G = 9.81
V0 = 2.0       # launch speed, m/s
START = 1.0    # distance of each box from the origin at launch, m (neighbours 0.39 m apart)
# Directions from the x axis, deg: along an axis (0, 90), along the diagonal of a square
# friction limit (45) and between them (22.5, 67.5), where a square limit also turns the box.
DIRECTIONS = (0.0, 22.5, 45.0, 67.5, 90.0)
# The deceleration is fitted over this part of the slide (fractions of t_stop): after the
# start-up of the contact, before the stop.
FIT_FROM, FIT_TO = 0.1, 0.75

# Grid: low and medium friction.
GRID = tuple({"mu": mu} for mu in (0.2, 0.5))


def label(phi: float) -> str:
    return f"{phi:g}deg"


def direction(phi: float) -> np.ndarray:
    return np.array([math.cos(math.radians(phi)), math.sin(math.radians(phi)), 0.0])


def across(phi: float) -> np.ndarray:
    """The horizontal unit vector 90 deg to the left of direction(phi)."""
    return np.array([-math.sin(math.radians(phi)), math.cos(math.radians(phi)), 0.0])


# --- closed form ----------------------------------------------------------------------

def deceleration(mu_k: float, g: float = G) -> float:
    """The same in every direction: kinetic friction mu_k m g against the motion."""
    return mu_k * g


def stop_time(mu_k: float, v0: float = V0, g: float = G) -> float:
    return v0 / (mu_k * g)


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    boxes = tuple(Body(f"box_{label(phi)}", cube(HALF), mass=1.0,
                       position=tuple(START * direction(phi) + (0.0, 0.0, HALF)),
                       velocity=tuple(V0 * direction(phi)))
                  for phi in DIRECTIONS)
    return Scene(bodies=(ground(),) + boxes, gravity=(0.0, 0.0, -G),
                 material=Material(e=0.0, mu_s=p["mu"]))


def duration(p) -> float:
    return FIT_TO * stop_time(p["mu"])


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    t0, t1 = FIT_FROM * stop_time(p["mu"]), FIT_TO * stop_time(p["mu"])
    out = {}
    for phi in DIRECTIONS:
        v = traj.vel(f"box_{label(phi)}")
        out[f"deceleration_{label(phi)}"] = -rate(traj, v @ direction(phi), t0, t1)
        out[f"lateral_acceleration_{label(phi)}"] = rate(traj, v @ across(phi), t0, t1)
    decel = [out[f"deceleration_{label(phi)}"] for phi in DIRECTIONS]
    out["deceleration_spread"] = max(decel) - min(decel)
    return out


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    why = "symplectic Euler is exact for constant acceleration; 0.01 m/s^2 is 0.1-0.2 % of g and of mu g"
    checks = []
    for phi in DIRECTIONS:
        checks.append(Check(f"deceleration_{label(phi)}", "m/s^2", deceleration(p["mu"]), 0.01, "abs", why))
        checks.append(Check(f"lateral_acceleration_{label(phi)}", "m/s^2", 0.0, 0.01, "abs",
                            "friction opposes the slip: no force across it; 0.01 m/s^2 as along it"))
    checks.append(Check("deceleration_spread", "m/s^2", 0.0, 0.01, "abs",
                        "the friction limit is a disc (isotropic); the spread of equal values is zero, "
                        "0.01 m/s^2 as for each direction"))
    return checks


FAMILY = CaseFamily(
    name="friction_isotropy",
    summary="boxes sliding at 0 to 90 deg to the world axes decelerate by mu g alike and run straight",
    source="note 001 (CG3 II.5), dry friction opposite the relative velocity; the friction cone",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"mu={p['mu']}",
    catches=(
        Catch("friction cone", "mu=0.5"),
        Catch("friction doubled", "mu=0.5"),
        Catch("friction off", "mu=0.5"),
    ),
)
