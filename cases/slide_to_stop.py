"""A box launched along flat ground slides to a stop (note 001, "dry friction").

A box of mass m slides on the plane z = 0 with speed v0 along x. While it slides, kinetic
friction F_k = mu_k F_n = mu_k m g opposes the motion (note 001: direction opposite to the
relative velocity, size proportional to the normal force), so it decelerates uniformly:
    v(t) = v0 - mu_k g t,   x(t) = v0 t - mu_k g t^2 / 2.
It stops when v = 0, at
    t_stop = v0 / (mu_k g),   d_stop = x(t_stop) = v0^2 / (2 mu_k g),
and stays: with no tangential force left, static friction has nothing to hold (mu_s
only matters for sliding to start, which is why the mu_s > mu_k variant still stops at
the mu_k distance).

Discrete time: with the friction impulse exact, explicit Euler follows v_k = v0 - mu_k g k dt
and x sums v dt with the new velocities (velocity first) or the old ones (position first),
so the stopping distance is v0^2 / (2 mu_k g) -/+ v0 dt / 2, up to the partial last step.

A variant launches the box at an angle `heading` to the x axis (in the x-y plane, the box
still square to the axes): Coulomb's law has no preferred direction (friction opposes
the slip whatever its direction), so the box stops at the same distance along its heading
and never leaves that line. A solver that bounds friction along two fixed tangent
directions separately (a square cone) pushes harder along the diagonal and off the line.

A cube does not tip while sliding: friction at the bottom face turns it forward, and the
normal force moves forward by mu_k h (h the half-height) to balance that, which stays
inside the half-width h for mu_k < 1.
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Catch, Check, friction_label, plane_label
from cases.observables import settle_time
from cases.scene import Body, Material, Scene, cube, ground

HALF = 0.1     # half-extent of the cube, m
G = 9.81
AFTER_STOP = 0.3  # simulated time past t_stop: the box must stay stopped, s

# Grid: low and medium friction at 2 m/s, a faster launch (a longer slide: more steps for a
# friction error to add up), and mu_s > mu_k (the stop is set by mu_k alone). 2D variants
# (a square in the x-z plane) let 2D engines take part.
GRID = (
    {"mu_s": 0.2, "mu_k": 0.2, "v0": 2.0, "dim": 3},
    {"mu_s": 0.5, "mu_k": 0.5, "v0": 2.0, "dim": 3},
    {"mu_s": 0.5, "mu_k": 0.5, "v0": 5.0, "dim": 3},
    {"mu_s": 0.5, "mu_k": 0.3, "v0": 2.0, "dim": 3},
    {"mu_s": 0.2, "mu_k": 0.2, "v0": 2.0, "dim": 2},
    {"mu_s": 0.5, "mu_k": 0.5, "v0": 2.0, "dim": 2},
    # launched 22.5 deg off the x axis: the cone's shape shows (a square cone stops it short
    # and off its line)
    {"mu_s": 0.5, "mu_k": 0.5, "v0": 2.0, "dim": 3, "heading": 22.5},
)


# --- closed forms ---------------------------------------------------------------------

def stop_time(v0: float, mu_k: float, g: float = G) -> float:
    return v0 / (mu_k * g)


def stop_distance(v0: float, mu_k: float, g: float = G) -> float:
    return v0 * v0 / (2.0 * mu_k * g)


# --- scene ----------------------------------------------------------------------------

def heading(p) -> np.ndarray:
    """Unit launch direction in the ground plane."""
    a = np.radians(p.get("heading", 0.0))
    return np.array([np.cos(a), np.sin(a), 0.0])


def scene(p) -> Scene:
    dim = p.get("dim", 3)
    box = Body("box", cube(HALF, dim), mass=1.0, position=(0, 0, HALF), velocity=tuple(p["v0"] * heading(p)))
    return Scene(bodies=(ground(), box), gravity=(0.0, 0.0, -G),
                 material=Material(e=0.0, mu_s=p["mu_s"], mu_k=p["mu_k"]), dimension=dim)


def duration(p) -> float:
    return stop_time(p["v0"], p["mu_k"]) + AFTER_STOP


def stopped_below(p, dt) -> float:
    """A box is stopped once its speed stays below what friction removes in one step."""
    return p["mu_k"] * G * dt


# --- observables ----------------------------------------------------------------------

def slide_readings(traj, name: str, p) -> dict:
    """Where the body `name` stopped (distance from its start along the ground), when, and
    (a variant with a heading) how far off its launch line."""
    x = traj.pos(name)
    speed = np.linalg.norm(traj.vel(name)[:, :2], axis=1)  # along the ground
    out = {"stop_distance": float(np.linalg.norm(x[-1, :2] - x[0, :2])),
           "stop_time": settle_time(traj, speed, stopped_below(p, traj.dt))}
    if "heading" in p:  # how far the stop point lies off the launch line
        d = x[-1, :2] - x[0, :2]
        u = heading(p)[:2]
        out["off_line"] = float(abs(d[0] * u[1] - d[1] * u[0]))
    return out


def observe(traj, p) -> dict:
    return slide_readings(traj, "box", p)


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    v0, mu_k = p["v0"], p["mu_k"]
    a = mu_k * G
    return [
        Check("stop_distance", "m", stop_distance(v0, mu_k), v0 * dt / 2 + a * dt * dt, "abs",
              f"v0 dt / 2 = {v0 * dt / 2:.2g} m: position updated with the new or the old velocity, "
              "plus the partial last step"),
        Check("stop_time", "s", stop_time(v0, mu_k), 2 * dt, "abs",
              "the stop falls within a step, and 'stopped' is read one step of friction (mu_k g dt) early"),
    ] + ([Check("off_line", "m", 0.0, 1e-3 * stop_distance(v0, mu_k), "abs",
                "isotropic friction pushes exactly against the slip: the box stays on its launch line; 0.1 % of "
                "the slide leaves room for the convergence of the two tangent rows")] if "heading" in p else [])


def variant_id(p) -> str:
    mu = friction_label(p)
    plane = plane_label(p)
    return f"{mu},v0={p['v0']:g}{plane}" + (f",heading={p['heading']:g}deg" if "heading" in p else "")


FAMILY = CaseFamily(
    name="slide_to_stop",
    summary="a box launched along flat ground stops after v0^2/(2 mu_k g) in v0/(mu_k g) and stays",
    source="note 001 (CG3 II.5), dry friction F_k = mu_k F_n; uniform deceleration",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("kinetic friction", "mu=0.5,v0=2"),
        Catch("friction off", "mu=0.5,v0=2"),
        Catch("friction doubled", "mu=0.5,v0=2"),
        Catch("friction cone", "mu=0.5,v0=2,heading=22.5deg"),
    ),
)
