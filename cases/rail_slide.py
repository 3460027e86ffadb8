"""A slider on a rail with friction: a block on a prismatic joint, launched along it,
slowed by the joint's dry friction to a stop.

Which friction: the joint's own (Joint.friction), not a contact's. A prismatic joint holds
the block on the rail in every direction but the slide, so the joint, not a contact, carries
the weight: a contact under the block would share the load with the joint in proportions no
law fixes, and its friction with it. The rail's friction is then Coulomb's law in the joint:
at most mu N against the slide, N the joint's reaction, here the weight m g, constant for a
horizontal rail, so the joint's friction bound is mu m g (the scene gives it as that force).
While the block slides the friction is exactly mu m g against the motion (Coulomb; note 001's
friction slides): it decelerates at mu g, so from x = 0 at speed v_0
    x(t) = v_0 t - mu g t^2 / 2,   v(t) = v_0 - mu g t,
to the stop at t_s = v_0 / (mu g), x_s = v_0^2 / (2 mu g), where static friction holds it.

Checks: the deceleration while sliding (the slope of v over 10-90 % of t_s), the stop
distance and the speed at the end (a verdict: stopped and held).
- The deceleration: a step that applies the bound mu m g while the block slides changes v by
  exactly mu g dt a step, so v is linear in t to rounding (tolerance 0 plus rounding, which
  adds up over the steps: each step's v is rounded).
- The stop distance: semi-implicit Euler's positions are sums of the stepped velocities,
  x_N = dt sum v_k, which with v_k = v_0 - k mu g dt ends at v_0^2 / (2 mu g) - v_0 dt / 2
  + O(mu g dt^2) (note 002's discrete free-flight form, with -mu g for -g): allowed v_0 dt.
Variants: 3D and 2D (the 2D engines' prismatic joints), mu = 0.5, v_0 = 2 m/s: a stop after
0.41 s and 0.41 m, 0.6 s simulated.
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.scene import Body, Box, Joint, Rect, Scene

G = 9.81
MASS = 1.0                  # kg
HALF = 0.05                 # m, the block's half-extent
START = (0.0, 0.0, 0.5)     # m, the block's centre at the start (no ground: the rail is the joint)
T = 0.6                     # s, 1.5 t_s of the grid's variant
REST = 1e-3                 # m/s: "stopped" is slower than this at the end

# Grid: one friction and launch speed, in 3D and in 2D (each dimension's engines).
GRID = ({"mu": 0.5, "v0": 2.0, "dim": 3}, {"mu": 0.5, "v0": 2.0, "dim": 2})


def stop_time(mu: float, v0: float) -> float:
    """t_s = v_0 / (mu g), s."""
    return v0 / (mu * G)


def stop_distance(mu: float, v0: float) -> float:
    """x_s = v_0^2 / (2 mu g), m."""
    return v0 * v0 / (2.0 * mu * G)


def scene(p) -> Scene:
    shape = Box((HALF, HALF, HALF)) if p["dim"] == 3 else Rect((HALF, HALF))
    block = Body("slider", shape, mass=MASS, position=START, velocity=(p["v0"], 0.0, 0.0))
    rail = Joint("prismatic", "slider", None, anchor=START, axis=(1.0, 0.0, 0.0), friction=p["mu"] * MASS * G)
    return Scene(bodies=(block,), gravity=(0.0, 0.0, -G), dimension=p["dim"], joints=(rail,))


def duration(p) -> float:
    return T


def observe(traj, p) -> dict:
    t, x, v = traj.t, traj.pos("slider")[:, 0] - START[0], traj.vel("slider")[:, 0]
    t_s = stop_time(p["mu"], p["v0"])
    sliding = (t >= 0.1 * t_s) & (t <= 0.9 * t_s)
    return {"deceleration": float(-np.polyfit(t[sliding], v[sliding], 1)[0]),
            "stop_distance": float(x[-1]),
            "end_speed": float(abs(v[-1]))}


def expect(p, dt) -> list[Check]:
    mu, v0 = p["mu"], p["v0"]
    t_s = stop_time(mu, v0)
    x_s = stop_distance(mu, v0)
    return [
        Check("deceleration", "m/s^2", mu * G, 0.0, "abs",
              "Coulomb friction in the joint: exactly mu N = mu m g against the slide, so v drops by mu g dt a "
              "step; rounding only",
              # v (at most v_0) rounded at each step up to the window's end, a slope over 0.8 t_s
              roundoff=2.0 * v0 * round(0.9 * t_s / dt) / (0.8 * t_s)),
        Check("stop_distance", "m", x_s, v0 * dt, "abs",
              "x_s = v_0^2/(2 mu g); semi-implicit Euler's positions sum the stepped velocities and stop v_0 dt/2 "
              "short (+ O(mu g dt^2)): allowed v_0 dt", roundoff=4.0 * (START[0] + x_s) * round(T / dt)),
        Check("end_speed", "m/s", 0.0, REST, "abs",
              f"a verdict: stopped at t_s = {t_s:.3f} s and held by static friction to {T} s (slower than {REST} m/s)"),
    ]


FAMILY = CaseFamily(
    name="rail_slide",
    summary="a block on a prismatic joint launched along it stops under the joint's Coulomb friction: deceleration "
            "mu g, stop at v0^2 / (2 mu g)",
    source="note 001 (CG3 II.5), Coulomb friction; note 002, the discrete closed form of a constant-force step",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"mu={p['mu']:g},v0={p['v0']:g}" + (",2D" if p["dim"] == 2 else ""),
    catches=(
        # the joint's friction off or doubled, planted on the reference's sequential impulses
        # (its friction row on the joint's coordinate): the deceleration and the stop see it
        Catch("friction off", "mu=0.5,v0=2"),
        Catch("friction doubled", "mu=0.5,v0=2"),
        Catch("time step", "mu=0.5,v0=2", "mujoco"),
    ),
)
