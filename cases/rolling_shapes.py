"""A cylinder and a capsule on their side roll down an incline, or slip when friction cannot
make them roll (note 001, "dry friction"; impulse transfer dL = r x dp): the closed forms of
cases/rolling_incline.py with the shape's own moment of inertia about its axis.

A body of mass m whose cross-section is a circle of radius r, with I = k m r^2 about its
axis, released at rest across the slope of a plane inclined at theta, rolls while
    tan(theta) <= (1 + k) / k mu_s,   with   a = g sin(theta) / (1 + k) = g sin / (1 + I/(m r^2)),
and beyond that slips with a = g (sin - mu_k cos), alpha = mu_k g cos / (k r)
(cases/rolling_incline.py derives both). Only the shape sets k:
- solid cylinder:  I = m r^2 / 2, k = 1/2: a = 2/3 g sin(theta), rolls while tan <= 3 mu_s;
- solid capsule (a cylinder of half-length h with two hemispherical caps, the mass shared
  by volume, 2 h pi r^2 against 4/3 pi r^3): I = m_c r^2 / 2 + 2/5 m_h r^2 about its axis, so
      k = (3 h / 2 + 8 r / 15) / (3 h + 2 r)   (m_c / m = 3 h / (3 h + 2 r)),
  0.46 for r = h: between the cylinder's 1/2 and the sphere's 2/5; it rolls while
  tan <= 3.17 mu_s (1.46 / 0.46).
Both touch the plane along a line (the capsule along its straight part), so no contact
torque and no rolling resistance enter: the closed forms are those of the ball.

The body lies with its axis along y (a quarter turn about x), so it rolls downhill along +x
(the incline is tilted gravity over the plane z = 0, cases.scene.tilted_gravity) with
omega along +y. The wrong answers below are planted on the reference (its GJK narrow phase,
reference_impl/gjk.py, takes the shapes' support functions).
"""
from __future__ import annotations

import math

from cases.family import CaseFamily, Catch, Check, friction_label
from cases.rolling_incline import G, rolling_checks, rolling_readings
from cases.scene import Body, Capsule, Cylinder, Material, Scene, ground, tilted_gravity

R = 0.1        # radius of the cross-section, m
H = 0.1        # half-length of the cylinder, and of the capsule's straight part, m
T = 1.0        # simulated time, s (the body rolls 1.1-3.5 m)
ACROSS_SLOPE = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0)  # body z (the axis) onto world -y
SHAPES = {"cylinder": Cylinder(R, H), "capsule": Capsule(R, H)}

# Grid: mu = 0.2, where the cylinder rolls up to 31.0 deg and the capsule up to 32.4 deg:
# well inside (20 deg: the cylinder needs 61 % of mu_s) and slipping (45 deg); and the
# cylinder 2 deg past its limit (33 deg: it needs 107 % of mu_s), where a body of the
# sphere's k = 2/5 would still roll (up to 35.0 deg): the threshold comes from the same I.
# 3D only (a capsule has no 2D shape; a cylinder on its side in 2D is rolling_incline's disc).
GRID = tuple({"shape": shape, "theta_deg": theta, "mu_s": 0.2, "mu_k": 0.2}
             for shape in SHAPES for theta in (20.0, 45.0)) + (
    {"shape": "cylinder", "theta_deg": 33.0, "mu_s": 0.2, "mu_k": 0.2},)


def inertia_ratio(shape: str, r: float = R, h: float = H) -> float:
    """k = I / (m r^2) about the axis: 1/2 for a solid cylinder; for a solid capsule its
    cylinder's 1/2 and its caps' 2/5, weighted by their shares of the volume."""
    if shape == "cylinder":
        return 0.5
    cyl, caps = 2.0 * h, 4.0 / 3.0 * r  # volumes over pi r^2
    return (0.5 * cyl + 0.4 * caps) / (cyl + caps)


def scene(p) -> Scene:
    body = Body(p["shape"], SHAPES[p["shape"]], mass=1.0, position=(0.0, 0.0, R), orientation=ACROSS_SLOPE)
    return Scene(bodies=(ground(), body), gravity=tilted_gravity(math.radians(p["theta_deg"]), G),
                 material=Material(e=0.0, mu_s=p["mu_s"], mu_k=p["mu_k"]))


def observe(traj, p) -> dict:
    return rolling_readings(traj, p["shape"])


def expect(p, dt) -> list[Check]:
    return rolling_checks(math.radians(p["theta_deg"]), p["mu_s"], p["mu_k"], inertia_ratio(p["shape"]), R)


def variant_id(p) -> str:
    return f"{p['shape']},theta={p['theta_deg']:g}deg,{friction_label(p)}"


FAMILY = CaseFamily(
    name="rolling_shapes",
    summary="a cylinder and a capsule on their side roll down an incline with g sin / (1 + I/(m r^2)) while "
            "tan <= (1 + k)/k mu_s (k = I/(m r^2): 1/2, 0.46), else slip with g(sin - mu_k cos)",
    source="note 001 (CG3 II.5), dry friction and impulse transfer dL = r x dp; Newton-Euler for a rolling "
           "body; the solid cylinder's and capsule's moments about their axis",
    grid=GRID,
    scene=scene,
    duration=lambda p: T,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("friction off", "cylinder,theta=20deg,mu=0.2"),
        Catch("friction doubled", "capsule,theta=45deg,mu=0.2"),
        Catch("inertia", "capsule,theta=20deg,mu=0.2"),
        Catch("contact offset", "cylinder,theta=20deg,mu=0.2"),
    ),
)
