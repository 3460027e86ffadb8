"""A ball released on an incline rolls, or slips when friction cannot make it roll (note
001, "dry friction"; impulse transfer dL = r x dp).

A ball of mass m, radius R and moment of inertia I = k m R^2 about its centre, released at
rest on a plane inclined at theta. Along the slope (downhill x) gravity pulls with
m g sin(theta) at the centre; friction F acts up the slope at the contact point, turning
the ball about +y (forward roll: v = R w). Newton and Euler:
    m a = m g sin(theta) - F,    k m R^2 alpha = F R.
Rolling (a = R alpha) needs F = k m a, so
    a = g sin(theta) / (1 + k),   F = k / (1 + k) m g sin(theta),
and static friction can supply it while F <= mu_s m g cos(theta), i.e.
    tan(theta) <= (1 + k) / k mu_s.
- solid sphere, k = 2/5:  a = 5/7 g sin(theta), rolls while tan(theta) <= 7/2 mu_s;
- disc (2D), k = 1/2:     a = 2/3 g sin(theta), rolls while tan(theta) <= 3 mu_s.
Beyond that it slips: F = mu_k m g cos(theta), so
    a = g (sin(theta) - mu_k cos(theta)),   alpha = mu_k g cos(theta) / (k R)
(5 mu_k g cos / (2 R) for the sphere, 2 mu_k g cos / R for the disc), and the slip
a - R alpha grows for good.

The incline is built by tilting gravity: the plane stays z = 0 and gravity is
g (sin theta, 0, -cos theta), so downhill is +x in every engine.
"""
from __future__ import annotations

import math

from cases.family import CaseFamily, Catch, Check, friction_label, plane_label
from cases.observables import rate
from cases.scene import Body, Material, Scene, ball, ground, tilted_gravity

R = 0.1     # radius, m
G = 9.81
T = 1.0     # simulated time, s
FIT_FROM = 0.1  # accelerations are fitted from here on, after the contact's start-up, s

# Grid: mu = 0.2, where the sphere rolls up to 35.0 deg and the disc up to 31.0 deg: well
# inside (20 deg), near the limit (30 deg: the sphere needs 83 % of mu_s), and slipping
# (45 deg). mu_s > mu_k (reference only): rolling is set by mu_s, slipping by mu_k.
GRID = (
    {"theta_deg": 20.0, "mu_s": 0.2, "mu_k": 0.2, "dim": 3},
    {"theta_deg": 30.0, "mu_s": 0.2, "mu_k": 0.2, "dim": 3},
    {"theta_deg": 45.0, "mu_s": 0.2, "mu_k": 0.2, "dim": 3},
    {"theta_deg": 30.0, "mu_s": 0.2, "mu_k": 0.1, "dim": 3},
    {"theta_deg": 45.0, "mu_s": 0.2, "mu_k": 0.1, "dim": 3},
    {"theta_deg": 20.0, "mu_s": 0.2, "mu_k": 0.2, "dim": 2},
    {"theta_deg": 45.0, "mu_s": 0.2, "mu_k": 0.2, "dim": 2},
)


def inertia_ratio(dim: int) -> float:
    """k = I / (m R^2): 2/5 for a solid sphere, 1/2 for a disc about its axis."""
    return 0.4 if dim == 3 else 0.5


# --- closed forms ---------------------------------------------------------------------

def rolls(theta: float, mu_s: float, k: float) -> bool:
    return math.tan(theta) <= (1.0 + k) / k * mu_s


def acceleration(theta: float, mu_s: float, mu_k: float, k: float, g: float = G) -> float:
    if rolls(theta, mu_s, k):
        return g * math.sin(theta) / (1.0 + k)
    return g * (math.sin(theta) - mu_k * math.cos(theta))


def angular_acceleration(theta: float, mu_s: float, mu_k: float, k: float, radius: float = R,
                         g: float = G) -> float:
    if rolls(theta, mu_s, k):
        return acceleration(theta, mu_s, mu_k, k, g) / radius
    return mu_k * g * math.cos(theta) / (k * radius)


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p.get("dim", 3)
    return Scene(bodies=(ground(), Body("ball", ball(R, dim), mass=1.0, position=(0, 0, R))),
                 gravity=tilted_gravity(math.radians(p["theta_deg"]), G),
                 material=Material(e=0.0, mu_s=p["mu_s"], mu_k=p["mu_k"]), dimension=dim)


def duration(p) -> float:
    return T


# --- observables ----------------------------------------------------------------------

def rolling_readings(traj, name: str) -> dict:
    """Downhill acceleration of the body's centre and its angular acceleration about +y
    (the forward roll), fitted from FIT_FROM on."""
    return {"acceleration": rate(traj, traj.vel(name)[:, 0], FIT_FROM),
            "angular_acceleration": rate(traj, traj.omega(name)[:, 1], FIT_FROM)}


def observe(traj, p) -> dict:
    return rolling_readings(traj, "ball")


# --- expectations ---------------------------------------------------------------------

def rolling_checks(theta: float, mu_s: float, mu_k: float, k: float, radius: float = R) -> list[Check]:
    """The two readings' closed forms for a body of I = k m radius^2 on an incline at theta."""
    args = (theta, mu_s, mu_k, k)
    return [
        Check("acceleration", "m/s^2", acceleration(*args), 0.01, "abs",
              "symplectic Euler is exact for constant acceleration; 0.01 m/s^2 is 0.1 % of g"),
        Check("angular_acceleration", "rad/s^2", angular_acceleration(*args, radius=radius), 0.01 / radius, "abs",
              "0.01 m/s^2 at the contact point, as for the centre"),
    ]


def expect(p, dt) -> list[Check]:
    return rolling_checks(math.radians(p["theta_deg"]), p["mu_s"], p["mu_k"], inertia_ratio(p.get("dim", 3)))


def variant_id(p) -> str:
    mu = friction_label(p)
    plane = plane_label(p)
    return f"theta={p['theta_deg']:g}deg,{mu}{plane}"


FAMILY = CaseFamily(
    name="rolling_incline",
    summary="a ball on an incline rolls with 5/7 g sin (disc: 2/3) while tan <= 7/2 mu_s (disc: 3 mu_s), else slips with g(sin - mu_k cos)",
    source="note 001 (CG3 II.5), dry friction mu_s, mu_k and impulse transfer dL = r x dp; Newton-Euler for a rolling ball",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("friction off", "theta=20deg,mu=0.2"),
        Catch("friction doubled", "theta=45deg,mu=0.2"),
        Catch("kinetic friction", "theta=45deg,mu_s=0.2,mu_k=0.1"),
        Catch("contact offset", "theta=20deg,mu=0.2"),
    ),
)
