"""Face landing: a cube dropped flat, its bottom face parallel to the ground, lands on all
its corners at once.

Closed form. The cube falls from rest with its bottom face h above the ground and meets
it at v_in = sqrt(2 g h), every corner at the same instant with the same approach
velocity. The simultaneous impact (note 000: one LCP over the four corners, each with
v_n+ = -e v_n-) has the symmetric solution: equal corner impulses (any split with zero
resultant moment does too), so the cube leaves in pure translation at e v_in,
    rebound height of the centre = e^2 h,  spin = 0,
with no tangential velocity anywhere, so friction does nothing and mu changes nothing;
every later bounce repeats this, and the cube comes to rest on the face it fell on. A
compliant model gives the same by symmetry (four equal springs: no moment). A model that
takes the corners one at a time (or a collision detector that reports one corner first)
strikes one corner with the whole impulse: a lever of a sqrt 2 from the centre, which
sends the cube spinning at 13 rad/s (e = 0) to 19 rad/s (e = 0.5) (PyBullet with its
GEOM_PLANE ground: 19.3 rad/s at e = 0.5, measured) and can turn it onto another face.

The ground shape. PyBullet's convex-plane collision adds one manifold point per step, the
deepest vertex, so a cube landing flat on a GEOM_PLANE is struck at one corner first; its
box-box detector gives all four corners in the first step. The ground is an adapter
choice, recorded in every engine's knobs ("ground"). The plain "pybullet" keeps the
GEOM_PLANE, and the engine variant "pybullet-boxground" builds the plane as a large box:
run both to see the difference. Neither is faithful everywhere (measured over the
library): the box lands faces and edges right, but on it the friction anchors no longer
hold a box near the friction limit (it creeps 0.16-0.45 mm/s where the plane holds it
still) and a disc meets it unseen until 4 mm deep; so the plane stays the default and
the box is a named variant with its own deviations. MuJoCo's plane and box give the
same landing (measured, so no variant); DART's adapter always uses a box (its PlaneShape
gives one contact point); the reference's plane is the exact half-space (every corner
within its margin is a contact); Pymunk's is a thick segment (two points for a square).

A hull lands the same way: a regular hexagonal prism given as a convex hull (`Hull` of its
twelve corners: circumradius HALF, half-height HALF) dropped flat on its hexagonal face
meets the ground at six corners at once, symmetric about the centre's vertical, so the
LCP's symmetric solution again leaves it in pure translation at e v_in (and the plastic
landing, e = 0, at rest on the face). Its two variants (restitutive and frictionless,
plastic with friction) pose the multi-point impact through each engine's convex-hull
collision instead of its box routine; the tolerances are the cube's, with the same lever
HALF (the prism's corners lie HALF from its axis).

A hull on a mesh: the same prism landing (restitutive and frictionless, plastic with
friction) on the ground plane given as a static triangle mesh (two triangles 2 MESH_HALF
wide): a convex shape against a triangle mesh, the pair where restitution was reported
wrong (mesh-on-mesh restitution in Newton, issue 36). The solid is the plane, so the closed
form and its tolerances are the plane's.

Readings: the rebound height (apex of the centre's free arc after the first impact,
fitted to the samples as cases.central_impact does, 0 if the cube never leaves the
ground), the largest spin over the run, and, at the end, how well the face it fell on
points down. 2D: a square on a line, two corners at once, the same closed form.

Sources: note 000 (Resolving systems of collisions: simultaneous impulses as an LCP);
note 001 (CG3 II.5), Newton's restitution law, rigid-body impulse with the lever r x n.
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Catch, Check, plane_label
from cases.observables import arc_apex, first_impact, free_arc_start, rotations
from cases.scene import Body, Hull, Material, Scene, cube, ground, mesh_ground

HALF = 0.1      # half-extent of the cube, m
M = 1.0         # kg
G = 9.81
H = 0.3         # drop height of the bottom face, m (impact at 2.43 m/s)
T = 1.2         # simulated time, s (see duration())
PENETRATION = 1e-3  # m: the depth a solver may rest at (stack_forces: 0.5 % of the box)

# Grid: a bounce with no friction (PyBullet then takes maximal coordinates) and with
# friction (reduced coordinates, cone friction, anchors), and a plastic landing with
# friction; 3D (four corners at once) and 2D (two), so Pymunk takes part.
GRID = tuple({"e": e, "mu": mu, "dim": dim} for dim in (3, 2) for e, mu in ((0.5, 0.0), (0.5, 0.5), (0.0, 0.5))) + \
    tuple({"e": e, "mu": mu, "dim": 3, "shape": "hull"} for e, mu in ((0.5, 0.0), (0.0, 0.5))) + \
    tuple({"e": e, "mu": mu, "dim": 3, "shape": "hull", "ground": "mesh"} for e, mu in ((0.5, 0.0), (0.0, 0.5)))
MESH_HALF = 1.0  # m: half-width of the mesh ground, ten prism radii (the prism lands and rests at the centre)
# the hull: a regular hexagonal prism about z, its corners HALF from the axis, its faces HALF
# above and below the centre (centred and principal, as a Hull must be: the hexagon's second
# moments are isotropic)
HEX_PRISM = Hull(tuple((HALF * math.cos(k * math.pi / 3), HALF * math.sin(k * math.pi / 3), z)
                       for z in (-HALF, HALF) for k in range(6)))


# --- closed forms ---------------------------------------------------------------------------

def impact_speed(h: float = H) -> float:
    """v_in = sqrt(2 g h): free fall through h."""
    return math.sqrt(2.0 * G * h)


def rebound_height(e: float, h: float = H) -> float:
    """The centre rises e^2 h after the first impact: it leaves at e v_in in pure translation."""
    return e * e * h


# --- scene ----------------------------------------------------------------------------------

def scene(p) -> Scene:
    shape = HEX_PRISM if p.get("shape") == "hull" else cube(HALF, p["dim"])
    box = Body("box", shape, mass=M, position=(0.0, 0.0, HALF + H))
    floor = mesh_ground(MESH_HALF) if p.get("ground") == "mesh" else ground()
    return Scene(bodies=(floor, box), gravity=(0.0, 0.0, -G), material=Material(e=p["e"], mu_s=p["mu"]),
                 dimension=p["dim"])


def duration(p) -> float:
    # the bounces of e = 0.5 end by t_fall (1 + 2e / (1 - e)) = 0.74 s (a geometric series;
    # the reference at dt = 1e-3 lies still, every point slower than 1 mm/s, from 0.739 s);
    # the rest shows whether the cube came to rest on its face
    return T


# --- observables ----------------------------------------------------------------------------

def first_rebound(traj) -> float:
    """Apex of the centre's free arc after the first impact, above its rest height HALF,
    from the arc's samples (exact for every Euler scheme, cases.observables.arc_apex);
    0 if the cube does not fly free again."""
    z = traj.pos("box")[:, 2]
    _, k_out = first_impact(traj, "box", (0.0, 0.0, -G))
    if k_out is None or traj.vel("box")[k_out, 2] <= 0:
        return 0.0
    j = free_arc_start(z, k_out, G, traj.dt)
    if j is None or traj.vel("box")[j, 2] <= 0:
        return 0.0
    return max(arc_apex(traj.t[j:j + 6], z[j:j + 6], G) - HALF, 0.0)


def observe(traj, p) -> dict:
    R_end = rotations(traj, "box")[-1]
    return {
        "rebound_height": first_rebound(traj),
        "max_spin": float(np.max(np.linalg.norm(traj.omega("box"), axis=1))),
        # the bottom face's outward normal is -z in the body frame: -(R (-e_z)) . e_z
        "down_face_alignment": float(R_end[2, 2]),
    }


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    e = p["e"]
    # The rebound speed e v_in is known to (1 + e) g dt: the contact is found at a step
    # boundary within a step of the touch (the approach speed within g dt of v_in), and the
    # impact step's gravity acts before or after the impulse (g dt). As a ratio of v_in:
    r = (1 + e) * G * dt / impact_speed()
    tilt = PENETRATION / (2 * HALF)  # rad: one edge of the face a penetration depth lower than the other
    return [
        Check("rebound_height", "m", rebound_height(e), (2 * e * r + r * r) * H + G * dt**2, "abs",
              f"(1 + e) g dt / v_in = {r:.2g} on the rebound ratio (the contact found within a step of the touch, "
              "the impact step's gravity before or after the impulse) carried through e^2 h, plus g dt^2 for "
              "where samples fall"),
        Check("max_spin", "rad/s", 0.0, G * dt / HALF, "abs",
              "a corner moving g dt relative to the centre: one step of gravity a contact has not yet cancelled; "
              "one corner struck alone gives 13 (e = 0) to 19 rad/s (e = 0.5)"),
        Check("down_face_alignment", "-", 1.0, 1 - math.cos(tilt), "abs",
              f"flat on the face it fell on to within {PENETRATION * 1e3:g} mm across it ({tilt:.2g} rad); "
              "any other face gives <= 0"),
    ]


def variant_id(p) -> str:
    return (f"e={p['e']},mu={p['mu']}{plane_label(p)}" + (",hexagonal prism hull" if p.get("shape") == "hull" else "")
            + (",mesh ground" if p.get("ground") == "mesh" else ""))


FAMILY = CaseFamily(
    name="face_landing",
    summary="a cube (and a hexagonal prism hull, on a plane and on a mesh ground) dropped flat lands on all its "
            "corners at once: rebound height e^2 h, no spin, at rest on the face it fell on",
    source="note 000 (simultaneous impulses as an LCP); note 001 (CG3 II.5), Newton's restitution law, impulse "
           "with lever arms",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("restitution off", "e=0.5,mu=0.0"),
        Catch("restitution doubled", "e=0.5,mu=0.0"),
    ),
)
