"""Central impact with a coefficient of restitution (note 001, "central impact").

Two setups:
- `spheres`: two frictionless spheres meet head-on, no gravity. Newton's law of restitution
  v2' - v1' = -e (v2 - v1) and conservation of momentum give
      v1' = (m1 v1 + m2 v2 - m2 e (v1 - v2)) / (m1 + m2)
      v2' = (m1 v1 + m2 v2 + m1 e (v1 - v2)) / (m1 + m2)
  and the kinetic energy lost ("deformation work", note 001)
      W = m1 m2 / (m1 + m2) * v_rel^2 * (1 - e^2) / 2.
  The note's slide prints W without the 1/2; the 1/2 is right: with e = 0 the loss is the
  kinetic energy of the relative motion, (1/2) m_eff v_rel^2 (tests/test_closed_forms.py).
- `drop`: a ball dropped from rest, its bottom h above the ground, under gravity g. It
  meets the ground at v_in = sqrt(2 g h) and leaves at e v_in, so the rebound ratio is e
  and the first apex (bottom above ground) is e^2 h.
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Check, plane_label
from cases.observables import arc_apex, first_impact, free_arc_start
from cases.scene import Body, Material, Scene, ball, ground

R = 0.1        # sphere radius, m
V1, V2 = 2.0, -1.0  # approach velocities along x, m/s (closing speed 3 m/s)
GAP = 0.05     # initial gap between the spheres, m
H = 1.0        # drop height of the ball's bottom, m
G = 9.81

# Grid: restitution from perfectly plastic to elastic, and mass ratios from equal to 1:100
# (a light sphere hitting a near-wall exercises the effective mass m1 m2 / (m1 + m2)).
# The 2D variants (discs in the x-z plane) let 2D engines take part; 3D engines embed them.
E_VALUES = (0.0, 0.5, 0.9, 1.0)
MASS_RATIOS = (1, 3, 100)
GRID = tuple({"setup": "spheres", "e": e, "m": f"1:{r}", "dim": 3} for e in E_VALUES for r in MASS_RATIOS) + \
       tuple({"setup": "drop", "e": e, "h": H, "dim": 3} for e in E_VALUES) + \
       tuple({"setup": "spheres", "e": e, "m": "1:3", "dim": 2} for e in (0.0, 0.5, 1.0)) + \
       tuple({"setup": "drop", "e": e, "h": H, "dim": 2} for e in (0.0, 0.5, 0.9))


def masses(p) -> tuple[float, float]:
    m1, m2 = p["m"].split(":")
    return float(m1), float(m2)


# --- closed forms ---------------------------------------------------------------------

def velocities_after(m1, m2, v1, v2, e):
    p = m1 * v1 + m2 * v2
    return (p - m2 * e * (v1 - v2)) / (m1 + m2), (p + m1 * e * (v1 - v2)) / (m1 + m2)


def deformation_work(m1, m2, v_rel, e):
    return m1 * m2 / (m1 + m2) * v_rel**2 * (1.0 - e**2) / 2.0


def first_apex(e, h):
    return e**2 * h


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p.get("dim", 3)
    if p["setup"] == "spheres":
        m1, m2 = masses(p)
        x1 = -(R + GAP / 2)
        return Scene(
            bodies=(Body("a", ball(R, dim), mass=m1, position=(x1, 0, 0), velocity=(V1, 0, 0), rotates=False),
                    Body("b", ball(R, dim), mass=m2, position=(-x1, 0, 0), velocity=(V2, 0, 0), rotates=False)),
            gravity=(0.0, 0.0, 0.0),
            material=Material(e=p["e"]), dimension=dim)
    return Scene(
        bodies=(ground(), Body("ball", ball(R, dim), mass=1.0, position=(0, 0, R + p["h"]), rotates=False)),
        gravity=(0.0, 0.0, -G),
        material=Material(e=p["e"]), dimension=dim)


def duration(p) -> float:
    if p["setup"] == "spheres":
        return 0.2  # contact at 0.017 s; the rest lets soft contacts separate fully
    v_in = math.sqrt(2 * G * p["h"])
    # past the first apex (t_fall + e v_in / g), before the second impact (t_fall + 2 e v_in / g)
    return v_in / G + 1.5 * p["e"] * v_in / G + 0.1


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    if p["setup"] == "spheres":
        m1, m2 = masses(p)
        v1, v2 = traj.vel("a")[-1, 0], traj.vel("b")[-1, 0]
        ke0 = 0.5 * (m1 * V1**2 + m2 * V2**2)
        return {"v1_after": v1, "v2_after": v2, "momentum_after": m1 * v1 + m2 * v2,
                "energy_lost": ke0 - 0.5 * (m1 * v1**2 + m2 * v2**2)}
    z = traj.pos("ball")[:, 2] - R  # height of the ball's bottom
    vz = traj.vel("ball")[:, 2]
    k_in, k_out = first_impact(traj, "ball", (0, 0, -G))
    # Speeds at contact height from the free-flight arcs on either side of the impact:
    # v = sqrt(2 g apex) of each fitted parabola (exact for Euler samples, see arc_apex).
    # Height a depenetration push-out adds to the rebound arc counts against the engine.
    before = slice(max(k_in - 5, 0), k_in + 1)
    h_in = arc_apex(traj.t[before], z[before], G)
    h_out = 0.0
    j = None if k_out is None or vz[k_out] <= 0 else free_arc_start(z, k_out, G, traj.dt)
    if j is not None and vz[j] > 0:
        after = slice(j, j + 6)
        h_out = max(arc_apex(traj.t[after], z[after], G), 0.0)
    apex = float(np.max(z[k_in + 1:]))
    return {"rebound_ratio": math.sqrt(h_out / h_in), "first_apex": apex}


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    e = p["e"]
    if p["setup"] == "spheres":
        m1, m2 = masses(p)
        v1e, v2e = velocities_after(m1, m2, V1, V2, e)
        v_rel = V1 - V2
        # One frictionless contact without external force is resolved by one impulse:
        # exact up to round-off and the solver's convergence.
        tol_v = 1e-6 * v_rel
        why_v = "one impulse, no external force: exact to solver convergence (1e-6 of the closing speed)"
        return [
            Check("v1_after", "m/s", v1e, tol_v, "abs", why_v),
            Check("v2_after", "m/s", v2e, tol_v, "abs", why_v),
            Check("momentum_after", "kg m/s", m1 * V1 + m2 * V2, 1e-9 * (m1 * abs(V1) + m2 * abs(V2)), "abs",
                  "equal and opposite impulses conserve momentum to round-off"),
            Check("energy_lost", "J", deformation_work(m1, m2, v_rel, e),
                  (m1 * abs(v1e) + m2 * abs(v2e)) * tol_v + 1e-12, "abs",
                  "the velocity tolerance carried through dE = sum m v dv"),
        ]
    h = p["h"]
    v_in = math.sqrt(2 * G * h)
    # Whether the g dt of the impact step acts before or after the impulse is a first-order
    # time-stepping choice: it moves the rebound ratio by up to g dt / v_in.
    tol_ratio = G * dt / v_in
    return [
        Check("rebound_ratio", "-", e, tol_ratio, "abs",
              f"g dt / v_in = {tol_ratio:.2g}: gravity of the impact step before or after the impulse"),
        Check("first_apex", "m", first_apex(e, h), (2 * e * tol_ratio + tol_ratio**2) * h + G * dt**2, "abs",
              "the rebound tolerance carried through apex = ratio^2 h, plus g dt^2 for where samples fall"),
    ]


def variant_id(p) -> str:
    plane = plane_label(p)
    if p["setup"] == "spheres":
        return f"e={p['e']},m={p['m']}{plane}"
    return f"drop,e={p['e']}{plane}"


FAMILY = CaseFamily(
    name="central_impact",
    summary="two spheres meet head-on (post-impact velocities, momentum, energy lost); a ball dropped on the ground (rebound ratio, first apex)",
    source="note 001 (CG3 II.5), central impact and deformation work W; Newton's restitution law",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    sweep_variants=("e=0.5,m=1:3", "drop,e=0.5", "drop,e=0.5,2D"),  # what `physval sweep` varies dt and iterations on
    variant_id=variant_id,
    tags=frozenset({"core"}),
)
