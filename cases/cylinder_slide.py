"""A cylinder standing on its flat end, launched along flat ground, slides to a stop (note
001, "dry friction"): the closed forms of cases/slide_to_stop.py on a round face.

Kinetic friction mu_k m g opposes the slide whatever the shape of the face that carries it,
so the cylinder decelerates uniformly and stops after
    t_stop = v0 / (mu_k g),   d_stop = v0^2 / (2 mu_k g),
and stays. The tolerances and their reasons are slide_to_stop's (the time step's half
step of position, the partial last step, isotropic friction).

What the round face adds: an engine has no polygon to put its contact points on. It
samples the rim (or the face) with points of its own choosing, and the friction those
points carry must still sum to mu_k m g against the slip, in every direction: the variant
launched 22.5 deg off the x axis stops at the same distance on its launch line.

It does not tip: friction at the face turns it forward, and the normal force moves forward
by mu_k h (h the half-height) to balance that, which stays inside the radius r for
mu_k < r / h (here 1).

The wrong answers below are planted on the reference (its GJK narrow phase,
reference_impl/gjk.py, takes the cylinder's support function).
"""
from __future__ import annotations

from cases.family import CaseFamily, Catch, friction_label
from cases.scene import Body, Cylinder, Material, Scene, ground
from cases.slide_to_stop import AFTER_STOP, G, expect, heading, slide_readings, stop_time

R = 0.1   # radius, m
H = 0.1   # half-height, m: a squat cylinder (diameter 2, height 2), far from tipping (mu_k h < r)

# Grid: mu = 0.5 at 2 m/s (0.41 m, 0.41 s), along x and 22.5 deg off it (where a friction
# bound per tangent axis shows); 3D only (a standing cylinder in 2D is a rect).
GRID = ({"mu_s": 0.5, "mu_k": 0.5, "v0": 2.0},
        {"mu_s": 0.5, "mu_k": 0.5, "v0": 2.0, "heading": 22.5})


def scene(p) -> Scene:
    body = Body("cylinder", Cylinder(R, H), mass=1.0, position=(0.0, 0.0, H), velocity=tuple(p["v0"] * heading(p)))
    return Scene(bodies=(ground(), body), gravity=(0.0, 0.0, -G),
                 material=Material(e=0.0, mu_s=p["mu_s"], mu_k=p["mu_k"]))


def variant_id(p) -> str:
    return f"{friction_label(p)},v0={p['v0']:g}" + (f",heading={p['heading']:g}deg" if "heading" in p else "")


FAMILY = CaseFamily(
    name="cylinder_slide",
    summary="a cylinder standing on its flat end, launched along flat ground, stops after v0^2/(2 mu_k g) in "
            "v0/(mu_k g), on its launch line",
    source="note 001 (CG3 II.5), dry friction F_k = mu_k F_n; uniform deceleration (as slide_to_stop)",
    grid=GRID,
    scene=scene,
    duration=lambda p: stop_time(p["v0"], p["mu_k"]) + AFTER_STOP,
    observe=lambda traj, p: slide_readings(traj, "cylinder", p),
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("friction off", "mu=0.5,v0=2"),
        Catch("kinetic friction", "mu=0.5,v0=2"),
        Catch("friction doubled", "mu=0.5,v0=2"),
        Catch("friction cone", "mu=0.5,v0=2,heading=22.5deg"),
    ),
)
