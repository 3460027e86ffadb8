"""A cylinder lying on its side on flat ground stays at rest: a line contact (note 001,
resting contact).

A rigid cylinder of radius r on its side touches the plane along a segment of its length
2 h. Placed there at rest under gravity, every point of that line is pressed equally (the
load is spread along the line, its resultant under the centre of mass), so nothing turns
and nothing moves:
- no rocking: the orientation stays as placed;
- no sinking: the centre stays at height r;
- the ground carries the weight: the normal force of the pair equals m g;
- no drift: the body stays where it was put.
An engine samples the line with contact points of its own choosing (its two ends, a
polygon of the rim, a patch). Any set whose forces sum to m g under the centre holds the
cylinder still; one that carries it on a single point at a time, alternating between the
ends, lets it rock about the other end and sink (MuJoCo's cylinder-plane contact before
4.0.1, issue 36).

Three variants: a short cylinder (length 2r) and a slender one (length 10r) on the plane,
and the slender one on a ground given as a static box (a slab whose top face is z = 0, its
centre off the cylinder's): the plane and the box are different collision pairs in every
engine (cylinder-plane against cylinder-box), and the statics are the same.

The wrong answers below are planted on the reference (its GJK narrow phase,
reference_impl/gjk.py, takes the cylinder's support function).
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import rest_drift, rotations, window_mean, window_samples
from cases.scene import Body, Box, Cylinder, Material, Scene, ground, quat_about_y

R = 0.05      # radius, m
M = 1.0       # mass, kg
G = 9.81
T = 1.0       # simulated time, s
SETTLED = 0.5  # the force, height and drift are read from here on (after any contact start-up), s
ON_ITS_SIDE = quat_about_y(np.pi / 2)  # body z (the axis) onto world x
# How deep a resting contact may sit: rigid bodies do not overlap; 1 mm is a solver's
# stabilising depth (as for resting boxes, cases/resting_blocks.py), and the softest mapped
# contact sags g / w^2 = 0.25 mm under its weight (a contact lasting 16 steps).
DEPTH = 1e-3  # m

# Grid: half-length h = r (a short cylinder, as long as it is wide) and h = 5 r (slender).
GRID = ({"half_length": R}, {"half_length": 5 * R}, {"half_length": 5 * R, "ground": "box"})
SLAB = (2.0, 2.0, 0.1)  # half-extents of the box ground, m
SLAB_CENTRE = (-0.3, -0.2, -0.1)


def floor(p) -> Body:
    """The plane z = 0, or (ground "box") the top face z = 0 of a static slab 4 m wide and
    0.2 m thick whose centre lies off the cylinder's (anywhere on a floor but its middle)."""
    if p.get("ground", "plane") == "plane":
        return ground()
    return Body("ground", Box(SLAB), static=True, position=SLAB_CENTRE)


def scene(p) -> Scene:
    body = Body("cylinder", Cylinder(R, p["half_length"]), mass=M, position=(0.0, 0.0, R), orientation=ON_ITS_SIDE)
    return Scene(bodies=(floor(p), body), gravity=(0.0, 0.0, -G), material=Material(e=0.0, mu_s=0.5))


def observe(traj, p) -> dict:
    axis = rotations(traj, "cylinder")  # columns: the body's axes in the world
    start = axis[0]
    # the largest angle any body axis turned from its start: arccos of the smallest
    # cosine between an axis now and the same axis at the start
    cosines = np.einsum("nij,ij->nj", axis, start)
    turned = float(np.arccos(np.clip(cosines.min(), -1.0, 1.0)))
    return {"tilt": turned,
            "lowest": float(traj.pos("cylinder")[window_samples(traj, SETTLED), 2].min()),
            "support_force": window_mean(traj, traj.force("ground", "cylinder"), SETTLED),
            "drift": rest_drift(traj, ["cylinder"], SETTLED)}  # its sag before SETTLED: `lowest` judges it


def expect(p, dt) -> list[Check]:
    h = p["half_length"]
    return [
        Check("tilt", "rad", 0.0, DEPTH / (2 * h), "abs",
              f"the largest turn of the body from its start; {DEPTH / (2 * h):.2g} rad lifts one end of the contact "
              f"line a whole resting depth ({DEPTH * 1e3:g} mm) above the other, or rolls the centre {DEPTH / (2 * h) * R * 1e3:.2g} mm"),
        Check("lowest", "m", R, DEPTH, "abs",
              f"the lowest the centre sits from {SETTLED} s on: at r on a rigid line; {DEPTH * 1e3:g} mm is a solver's "
              "stabilising depth (as resting_blocks)"),
        Check("support_force", "N", M * G, 1e-3, "rel",
              f"momentum balance: the mean force from {SETTLED} s on differs from m g by m dv / {T - SETTLED:g} s; "
              "0.1 % is a speed change of 2.5 mm/s, which a still body does not have"),
        Check("drift", "m", 0.0, 2e-4, "abs",
              "a body at rest stays where it was put: 0.2 mm along the ground over the run, and in any direction "
              f"from {SETTLED} s on, as resting_blocks' drift (0.2 % of the diameter)"),
    ]


FAMILY = CaseFamily(
    name="lying_cylinder",
    summary="a cylinder lying on its side (a line contact) stays at rest: no rocking, no sinking below r, "
            "the ground carries m g, no drift",
    source="note 001 (CG3 II.5), resting contact; statics of a body on a line of support",
    grid=GRID,
    scene=scene,
    duration=lambda p: T,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"L={2 * p['half_length']:g}m" + (f",{p['ground']} ground" if "ground" in p else ""),
    needs=frozenset({"contact_forces"}),
    catches=(
        Catch("force read-out", "L=0.1m"),
        Catch("contact offset", "L=0.1m"),
    ),
)
