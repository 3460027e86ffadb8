"""Creep: a box held by static friction below the break-away angle must not move (note
001, "dry friction": the contact stays static while the contact force lies inside the
friction cone mu_s^2 F_n^2 >= F_t^2).

A box of mass m rests on a plane inclined at theta < atan(mu_s). Holding it takes a
friction force m g sin(theta) against a limit mu_s m g cos(theta), so the load on the
cone is tan(theta) / mu_s < 1 and the box stays where it is: its creep rate, the speed at
which it walks downhill, is zero. An engine whose friction is soft (a regularised or
spring-like static friction) or that lets a sticking contact slip a little every step
creeps instead, faster the nearer the cone's edge.

This is the long, sensitive version of incline_threshold's creep check (1 s, 0.1 mm/s):
5 s, with the rate fitted to the downhill position after the first second (the contact's
start-up), at angles given as fractions of the break-away angle atan(mu_s). The bound is
1 um/s: a box creeping that fast moves 1 % of its size (2 mm) in half an hour of simulated
time, which a resting scene must not; at 1e-4 of the g dt gravity adds in a step it lies far
above a converged sticking solve's residual (the reference stops at 1e-10 m/s), and 100
times below the 0.1 mm/s of the short check.

The incline is built by tilting gravity: the plane stays z = 0 and gravity is
g (sin theta, 0, -cos theta), so downhill is +x in every engine.
"""
from __future__ import annotations

import math

from cases.family import CaseFamily, Catch, Check, plane_label
from cases.observables import rate
from cases.scene import Body, Material, Scene, cube, ground, tilted_gravity

HALF = 0.1     # half-extent of the cube, m
G = 9.81
T = 5.0        # simulated time, s
SETTLED = 1.0  # the creep rate is fitted from here on, s
CREEP_BOUND = 1e-6  # m/s, see the module docstring

# Grid: 0.9 and 0.99 of the break-away angle (the friction force near its limit, where
# soft friction creeps most) at medium friction; 0.99 at high friction; a square in the
# x-z plane at 0.99 lets 2D engines take part.
GRID = tuple({"mu": 0.5, "fraction": f, "dim": 3} for f in (0.9, 0.99)) + (
    {"mu": 0.8, "fraction": 0.99, "dim": 3},
    {"mu": 0.5, "fraction": 0.99, "dim": 2},
)
# A larger grid for a deeper look (not run by default): low to high friction, loads from
# a quarter of the limit to 0.999 of it. Run it with dataclasses.replace(FAMILY, grid=FULL_GRID).
FULL_GRID = tuple({"mu": mu, "fraction": f, "dim": d} for d in (3, 2) for mu in (0.2, 0.5, 0.8)
                  for f in (0.25, 0.5, 0.9, 0.99, 0.999))


def theta(p) -> float:
    """The incline: a fraction of the break-away angle atan(mu_s)."""
    return p["fraction"] * math.atan(p["mu"])


# --- closed form ----------------------------------------------------------------------

def cone_load(th: float, mu_s: float) -> float:
    """Friction needed to hold the box over the most the cone allows: tan(theta) / mu_s."""
    return math.tan(th) / mu_s


def creep_rate(th: float, mu_s: float) -> float:
    """Zero while the cone holds the box (cone_load <= 1); a sliding box has no creep rate."""
    if cone_load(th, mu_s) > 1.0:
        raise ValueError(f"theta = {math.degrees(th):.3f} deg is beyond atan(mu_s): the box slides")
    return 0.0


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p.get("dim", 3)
    return Scene(bodies=(ground(), Body("box", cube(HALF, dim), mass=1.0, position=(0, 0, HALF))),
                 gravity=tilted_gravity(theta(p), G),
                 material=Material(e=0.0, mu_s=p["mu"]), dimension=dim)


def duration(p) -> float:
    return T


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    return {"creep_rate": rate(traj, traj.pos("box")[:, 0], SETTLED)}


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    return [Check("creep_rate", "m/s", creep_rate(theta(p), p["mu"]), CREEP_BOUND, "abs",
                  "a sticking box does not move; 1 um/s walks it 1 % of its size in 33 min")]


def variant_id(p) -> str:
    plane = plane_label(p)
    return f"mu={p['mu']},theta={p['fraction']:g}atan(mu){plane}"


FAMILY = CaseFamily(
    name="creep",
    summary="a box held by static friction at 0.9-0.99 of the break-away angle does not creep (5 s, bound 1 um/s)",
    source="note 001 (CG3 II.5), dry friction: static while the contact force lies inside the friction cone",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    full_grid=FULL_GRID,
    catches=(
        Catch("friction off", "mu=0.5,theta=0.99atan(mu),2D"),
    ),
)
