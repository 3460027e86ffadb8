"""Brick tumble: a brick (half-sides a < b < c) lying on its largest face, released tilted
a little above the ground, lands on an edge or a corner, tumbles and comes to rest.

What it tests: the rest state that energy and the brick's shape allow, for a body with
three different half-sides (tumbling_box drops a cube, whose barriers over every edge are
equal; here each face has its own rest height and each edge its own barrier), after a
tumble that couples all three axes (the diagonal tilt turns the brick about an axis that
is no principal axis). What it does not see: the closed form below is an invariant of the
inertia tensor, of the restitution and of the friction, so an engine with any of those
wrong (x and z moments swapped, e = 0, mu = 0: measured, every check passes) still ends
on the a-face at height a with every joule above it gone. The impact of a brick with
distinct moments is judged in oblique_landing. What it catches (`catches`): collision
geometry larger than the body (a contact offset: the rest height and the energy) and
contact forces read wrong (the ground's impulse).

Which face ends down (the argument of cases/tumbling_box.py, for three half-sides). With
n = R^T e_z the world's up direction in the body frame, the lowest vertex lies
sigma(n) = a |n_1| + b |n_2| + c |n_3| below the centre (the support function), so a
brick that does not sink into the ground has its centre at z >= sigma(n) and its energy
E >= m g sigma(n). On the unit sphere of n, sigma has six minima (a face down: a, b or c),
twelve saddles (balanced on an edge: sqrt(a_i^2 + a_j^2)) and eight maxima (a vertex
down); 6 - 12 + 8 = 2, the sphere's Euler characteristic, so there are no other critical
points. Below the lowest saddle value s* = sqrt(a^2 + b^2) every connected part of
{sigma < s} holds exactly one minimum. The brick is released with n on the arc from
e_1 (lying on its a-face) along which sigma rises monotonically to sigma_0, so n starts in
e_1's part; if its energy m g z0 < m g s*, n stays there (sigma <= E / (m g) < s*) and
the only rest state in that part is lying on the a-face (n = e_1): resting on an edge or
a vertex needs sigma at a saddle or a maximum, above the energy. Hence, at rest:
- the face that was down at release (body -x) points straight down;
- the centre is at height a;
- all the energy above that is gone: dissipated = m g (z0 - a);
- the brick does not move; and the ground's impulse over the run is m g T (the brick
  starts and ends at rest, gravity and the ground the only forces).
2D: a rect of half-sides (a, c) in the x-z plane, sigma = a |n_x| + c |n_z|, one saddle
type, sqrt(a^2 + c^2).

Release: the brick's x axis up (a quarter turn about y), then tilted TILT degrees about
the world's y (an edge along the brick's y lowest: sigma = a cos + c sin) or about the
world's (1, 1, 0)/sqrt 2 (one corner lowest), its lowest point H above the ground.
tests/test_closed_forms_landings.py checks sigma, the critical values, the monotone arc
and the margin below s* independently.

Sources: note 001 (CG3 II.5), rigid-body energy and the impulse-momentum balance; the
support function of the box (cases/tumbling_box.py).
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Catch, Check, plane_label
from cases.oblique_landing import quat_about, quat_mul
from cases.observables import impulse, mechanical_energy, point_speed_bound, rotations
from cases.scene import Body, Box, Material, Rect, Scene, ground
from cases.tumbling_box import PENETRATION, REST, T, rotation, settling_checks

SIDES = (0.05, 0.1, 0.2)  # half-sides a, b, c, m (oblique_landing's brick)
M = 1.0
G = 9.81
H = 0.005                 # height of the lowest point at release, m
TILT = {"y": 10.0, "diag": 10.0}  # deg: below the barrier s* with room (margin())

# Grid: an edge first with a bounce and gripping friction, a corner first (off the principal
# axes) plastic and slipping; a 2D rect so the 2D engines take part.
GRID = ({"tilt": "y", "e": 0.3, "mu": 0.8, "dim": 3},
        {"tilt": "diag", "e": 0.0, "mu": 0.3, "dim": 3},
        {"tilt": "y", "e": 0.3, "mu": 0.3, "dim": 2})


# --- geometry and closed forms --------------------------------------------------------------

def orientation(p, angle: float | None = None) -> tuple[float, float, float, float]:
    """The brick's x axis up (a quarter turn about y), then `angle` (default TILT) about
    the tilt axis."""
    base = quat_about((0.0, 1.0, 0.0), -math.pi / 2)
    angle = math.radians(TILT[p["tilt"]]) if angle is None else angle
    return quat_mul(quat_about(tilt_axis(p), angle), base)


def tilt_axis(p) -> tuple[float, float, float]:
    return (0.0, 1.0, 0.0) if p["tilt"] == "y" else (1 / math.sqrt(2), 1 / math.sqrt(2), 0.0)


def halves(dim: int) -> np.ndarray:
    a, b, c = SIDES
    return np.array([a, b, c]) if dim == 3 else np.array([a, 0.0, c])


def support(q, dim: int) -> float:
    """sigma(n) = a |n_1| + b |n_2| + c |n_3|, n = R^T e_z: the lowest vertex's depth."""
    n = rotation(q).T @ np.array([0.0, 0.0, 1.0])
    return float(halves(dim) @ np.abs(n))


def barrier(dim: int) -> float:
    """s*: the lowest saddle of sigma, the brick balanced on the edge between its a- and
    b-faces (2D: the rect's a- and c-sides)."""
    a, b, c = SIDES
    return math.hypot(a, b) if dim == 3 else math.hypot(a, c)


def release_height(p) -> float:
    return H + support(orientation(p), p["dim"])


def margin(p) -> float:
    """How far (m) the release height lies below the barrier s*."""
    return barrier(p["dim"]) - release_height(p)


def energy_dissipated(p) -> float:
    return M * G * (release_height(p) - SIDES[0])


# --- scene ----------------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p["dim"]
    shape = Box(SIDES) if dim == 3 else Rect((SIDES[0], SIDES[2]))
    brick = Body("brick", shape, mass=M, position=(0.0, 0.0, release_height(p)), orientation=orientation(p))
    return Scene(bodies=(ground(), brick), gravity=(0.0, 0.0, -G), material=Material(e=p["e"], mu_s=p["mu"]),
                 dimension=dim)


def duration(p) -> float:
    # tumbling_box's 0.8 s; measured on the reference at dt = 1e-3: every variant lies still
    # (every point slower than 1 mm/s) by 0.21 s, so the rest window [0.6, 0.8] s has room
    return T


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    R = rotations(traj, "brick")
    energy = mechanical_energy(traj, scene(p))
    reach = float(np.linalg.norm(halves(p["dim"])))
    return {
        "down_face_alignment": float(R[-1][2, 0]),  # the body x axis (the a-face's inward normal) straight up
        "rest_height": float(traj.pos("brick")[-1, 2]),
        "energy_dissipated": float(energy[0] - energy[-1]),
        "rest_speed": float(np.max(point_speed_bound(traj, "brick", reach)[traj.after(traj.t[-1] - REST)])),
        "ground_impulse": impulse(traj, "ground", "brick"),
    }


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    T_run = round(duration(p) / dt) * dt
    tilt = PENETRATION / (2 * SIDES[1])  # rad: the a-face's shorter side a penetration depth lower at one end
    return [
        Check("down_face_alignment", "-", 1.0, 1 - math.cos(tilt), "abs",
              f"flat on the a-face to within {PENETRATION * 1e3:g} mm across its shorter side ({tilt:.2g} rad); "
              "any other face gives <= 0; plus the orientation's norm, unit to a rounding per sub-step",
              1.0),
        Check("rest_height", "m", SIDES[0], PENETRATION, "abs",
              f"resting on the a-face; {PENETRATION * 1e3:g} mm is a solver's stabilising depth"),
        *settling_checks(M, energy_dissipated(p), T_run, dt),
    ]


def variant_id(p) -> str:
    return f"tilt={p['tilt']},e={p['e']},mu={p['mu']}{plane_label(p)}"


FAMILY = CaseFamily(
    name="brick_tumble",
    summary="a brick with three different sides released tilted (edge or corner first, off its principal axes) "
            "below its lowest edge-tipping barrier: it ends flat on its largest face, at rest, every joule above "
            "rest dissipated, ground impulse m g T",
    source="note 001 (CG3 II.5), rigid-body energy and impulse-momentum balance; the brick's support function",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    needs=frozenset({"contact_forces"}),
    variant_id=variant_id,
    catches=(
        Catch("force read-out", "tilt=y,e=0.3,mu=0.8"),
        Catch("contact offset", "tilt=y,e=0.3,mu=0.8"),
    ),
)
