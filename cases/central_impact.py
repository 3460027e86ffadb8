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
  and the first apex (bottom above ground) is e^2 h. A time stepper resolves the impact
  at a step boundary: `rebound_tolerance` derives what that does to the ratio (the ball
  found up to a step's travel early or late rebounds from that depth; the step's gravity
  acts before, inside or after the impulse), about g dt / v_in, and the drops run at
  dt = 1e-4 s to keep it small.
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import IMPACT_ROUNDINGS, CaseFamily, Catch, Check, impulse_roundoff, plane_label
from cases.observables import arc_apex, fall_gravity, first_impact, free_arc_start
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
    if k_in is None or k_in < 2:  # it never met the ground (or started on it): no rebound to read
        return {"rebound_ratio": 0.0, "first_apex": float(z[-1])}
    # Speeds at contact height from the free-flight arcs on either side of the impact:
    # v = sqrt(2 g apex) of each fitted parabola (exact for Euler samples, see arc_apex),
    # with g as the positions show it (the ratio of the two needs no exact g).
    # Height a depenetration push-out adds to the rebound arc counts against the engine.
    g = fall_gravity(z, G, traj.dt)
    before = slice(max(k_in - 5, 0), k_in + 1)
    h_in = arc_apex(traj.t[before], z[before], g)
    h_out = 0.0
    j = None if k_out is None or vz[k_out] <= 0 else free_arc_start(z, k_out, g, traj.dt)
    if j is not None and vz[j] > 0:
        after = slice(j, j + 6)
        h_out = max(arc_apex(traj.t[after], z[after], g), 0.0)
    # the highest point once the ball stopped falling (a contact that brakes the approach
    # over a few steps, speculatively, must not count the heights it passed on the way down)
    up = np.flatnonzero(vz[k_in + 1:] >= 0.0)
    apex = float(np.max(z[k_in + 1 + up[0]:])) if up.size else float(z[-1])
    return {"rebound_ratio": math.sqrt(h_out / h_in) if h_in > 0.0 else 0.0, "first_apex": apex}


# --- the discrete impact: the rebound tolerance -----------------------------------------

def stepped_rebound_ratio(e: float, v: float, dt: float, kappa: float, d: float, g: float = G) -> float:
    """The rebound ratio the fitted arcs read when a time stepper resolves the impact of a
    ball meeting the ground at speed v at a step boundary, with the ball a depth d below
    the ground there (d < 0: above it), and the step's gravity enters the rebound as kappa
    g dt (see `rebound_tolerance`).

    Free flight sampled by symplectic Euler (velocity, then position) lies on the parabola
    whose slope at sample k is v_k - g dt / 2; so the incoming arc passes sample k (height
    -d, approach speed s = |v_k| before the step's gravity) at speed S = s + g dt / 2 and
    meets the ground at v^2 = S^2 - 2 g d. The impact step leaves with v+ = e s + c g dt,
    and the outgoing arc (slope v+ - g dt / 2 at k + 1, from height -d + v+ dt) meets the
    ground at
        u^2 = (v+ + g dt / 2)^2 - 2 g d = (e S + kappa g dt)^2 - 2 g d,  kappa = c + (1 - e) / 2.
    Position-first Euler (x, then v, the contact found at the new position) gives the same
    u^2 from the sample where the overlap is found. An impulse that leaves the ball not
    rising (v+ <= 0) leaves no rebound arc: ratio 0, as the observer reads it.
    tests/test_observables.py checks this against stepped impacts of every kind."""
    if v * v + 2.0 * g * d <= 0.0:  # a ball this slow never reaches depth d: no rebound arc
        return 0.0
    S = math.sqrt(v * v + 2.0 * g * d)
    if e * (S - g * dt / 2.0) + (kappa - (1.0 - e) / 2.0) * g * dt <= 0.0:
        return 0.0
    return math.sqrt(max((e * S + kappa * g * dt) ** 2 - 2.0 * g * d, 0.0)) / v


def rebound_tolerance(e: float, v: float, dt: float, g: float = G) -> float:
    """Largest error of the rebound ratio read off a time-stepped impact at speed v:
    `stepped_rebound_ratio` at the corners of
    - the detection: the impact resolved at a step boundary up to one step's travel v dt
      after the moment of contact (found once overlapping) or before it (a speculative or
      nearest-boundary bounce): |d| <= v dt. For e < 1 this matters: the ball rebounds from
      depth d, so to first order the ratio moves by -g d (1 - e^2) / (e v^2);
    - the contact phase: the impact takes one step, whose gravity g dt may act before the
      impulse (restitution of the speed after it, c = e), be cancelled by it (c = 0), or act
      after it (c = -1): kappa = c + (1 - e) / 2 within +-(1 + e) / 2, moving the ratio by
      kappa g dt / v;
    plus 1e-6 for the solver's convergence. Both terms fall as dt / v; at e = 1 the first
    vanishes and the second is g dt / v: restitution applied after the step's gravity
    (kappa = 1) gives exactly that, and a tolerance without the second-order part of
    this term would pass or fail such an engine by rounding."""
    if v <= 0.0:  # no impact speed: the ratio is not defined, any reading lies within e of it
        return e + 1e-6
    corners = [stepped_rebound_ratio(e, v, dt, kappa, d, g)
               for kappa in (-(1.0 + e) / 2.0, (1.0 + e) / 2.0) for d in (-v * dt, v * dt)]
    return max(abs(r - e) for r in corners) + 1e-6


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
                  "equal and opposite impulses conserve momentum to round-off (1e-9 in float64; "
                  f"{IMPACT_ROUNDINGS} roundings of m |v| a sub-step at the engine's float width)",
                  impulse_roundoff(m1 * max(abs(V1), abs(v1e)) + m2 * max(abs(V2), abs(v2e)))),
            Check("energy_lost", "J", deformation_work(m1, m2, v_rel, e),
                  (m1 * abs(v1e) + m2 * abs(v2e)) * tol_v + 1e-12, "abs",
                  "the velocity tolerance carried through dE = sum m v dv"),
        ]
    h = p["h"]
    v_in = math.sqrt(2 * G * h)
    tol_ratio = rebound_tolerance(e, v_in, dt)
    return [
        Check("rebound_ratio", "-", e, tol_ratio, "abs",
              f"{tol_ratio:.2g}: the step's impact, found up to v dt early or late (rebound from that depth) "
              "with the step's gravity before, inside or after the impulse (rebound_tolerance)"),
        Check("first_apex", "m", first_apex(e, h), (2 * e * tol_ratio + tol_ratio**2) * h + G * dt**2, "abs",
              "the rebound tolerance carried through apex = ratio^2 h, plus g dt^2 for where samples fall"),
    ]


def drop_dt(p) -> float:
    """The time step: 1e-4 s for a drop, whose rebound errs by about g dt / v_in per impact
    (rebound_tolerance: 2.2e-4 at e = 1, 5e-4 at e = 0.5), 1e-3 s where no gravity acts."""
    return 1e-4 if p["setup"] == "drop" else 1e-3


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
    dt=drop_dt,
    sweep_variants=("e=0.5,m=1:3", "drop,e=0.5", "drop,e=0.5,2D"),  # what `physval sweep` varies dt and iterations on
    variant_id=variant_id,
    tags=frozenset({"core"}),
    catches=(
        Catch("restitution off", "e=0.5,m=1:3"),
        Catch("restitution doubled", "e=0.5,m=1:3"),
        Catch("restitution", "e=0.5,m=1:3"),
    ),
)
