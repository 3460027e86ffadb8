"""Oblique landing: a brick (a box with three different sides) or a ball thrown at the
ground in zero gravity lands on an edge, a corner or its lowest point, spinning and
sliding: one impact with a lever arm, friction and the full inertia tensor.

FIRST TO TEST: (1) distinct principal moments in an impact. Every other landing, tumbling
and impact family strikes a cube or a ball, whose inertia is the same about every axis,
so an engine that puts a moment on the wrong axis, or drops the products of inertia of a
body turned off its principal axes, passes them all (free_rigid_body alone sees it, in
free flight). The brick has half-sides (0.05, 0.1, 0.2) m: moments m (b^2 + c^2) / 3 and
so on, 0.0167, 0.0142, 0.0042 kg m^2; the corner pose turns it 30 deg about z and 20 deg
about y, so no principal axis lies along the world's and its world inertia
I_w = R diag(I) R^T is full. The edge pose turns it a quarter about z first, so the edge
it lands on runs along its x axis and the impact turns it about x: an engine that swaps
the x and z moments (0.0167 for 0.0042) turns it four times as fast (the 2D rect is that
pose's cross-section, half-sides b and c). (2) Impacts with slip and spin at the contact on the
ground: the brick lands on its edge moving sideways and spinning, the ball lands sliding
(or spinning back) along a direction off the axes; before, only eccentric_impact (a
ball on a free rod) had a sliding impact, and edge_landing drops its cube without spin.

Closed form (note 004, "The collision matrix", "Newton Coulomb impulses for rigid
bodies"; note 001, "Inverse Mass Matrix of Contact", "Impact with Friction"). The
ground is fixed; n = e_z; r runs from the centre to the contact point (an edge's
midpoint, the lowest corner, or -R n for the ball); the contact point moves at
u = v + w x r (u_n < 0: approaching). An impulse J at it changes u by K J with
    K = 1/m 1 - r* I_w^-1 r*       (r* the cross-product matrix of r; I_w in world frame).
Newton-Coulomb: try sticking, u' = -e u_n n, J = K^-1 (u' - u), kept if |J_t| <= mu J_n;
else slide along the slip t = u_t / |u_t| with J = j (n - mu t), j = -(1 + e) u_n /
n^T K (n - mu t). Then v' = v + J / m, w' = w + I_w^-1 (r x J), and the angular momentum
about the centre L' = I_w w' = I_w w + r x J.
Which regime, and why the note's friction law is the law here: the sliding variants are
those where the slip keeps its direction through the impact (the brick on its edge moves
in the x-z plane it is symmetric about; the ball's K is 1/m + R^2/I on the tangent plane
and 1/m along n, uncoupled), so friction opposes the slip before, during and after the
impact and every Coulomb law (the note's, the LCP's maximal dissipation, the impact
integrated in impulse time) gives the same impulse. The grid's slips are chosen so the
sliding ones do not stop (slip after along the slip before) and the sticking ones hold
inside the cone with room (|J_t| / J_n < mu / sqrt 2, so a friction pyramid holds them
too); tests/test_closed_forms_landings.py checks both and solves the impulse-momentum
equations by another route. A corner of the turned brick has a coupled K: there the
slip direction turns during a sliding impact and the friction laws differ, so the corner
is landed frictionless and sticking only.

Which restitution law (cases/impact_laws.py): with friction and e > 0 the engines' laws
differ where K couples n to the tangent plane (the brick) or a slip is there to oppose
(every frictional landing here but the ball's sticking one). Newton's law (the note's)
restores -e u_n with friction on the whole impulse; the two-phase law (Box2D, Box3D,
Rapier) applies friction to the compression impulse only and restitution without it;
Poisson's law makes the restitution impulse e times the compression one. Each variant
whose outcome depends on the law is in the grid once per law that changes it (ids ending
",two_phase"; ",poisson" in the full grid, as no built-in engine declares Poisson's law),
and an engine runs the one of the law it declares
(Capabilities.restitution_law; the others report unsupported), so it is judged by its
own law and not by another's.

The bodies start touching (the contact point at z = 0) and there is no gravity: the
impact is the first step's, with exact geometry, and nothing but the impulse acts.
Velocities are read when the body flies free again (cases.observables.first_impact);
the angular momentum in world frame L = R I R^T w is read rather than w, since a brick
spinning off its principal axes precesses in free flight (L stays, w turns), and the
contact point's velocity after the impact from v and I_w(start)^-1 L at the start pose.

Sources: note 004 (Umea, Visual Interactive Simulation), collision matrix and the
Newton-Coulomb impulse; note 001 (CG3 II.5), inverse mass matrix of contact, impact with
friction.
"""
from __future__ import annotations

import math

import numpy as np

from cases import rotations
from cases.eccentric_impact import body_collision_matrix
from cases.family import CaseFamily, Catch, Check, plane_label
from cases.impact_laws import (DEFAULT_GRID_LAWS, DEFAULT_LAW, IMPULSE_OF_LAW, law_label, law_needs, law_of,
                               outcomes_differ, with_laws)
from cases.observables import first_impact
from cases.scene import Body, Box, Material, Rect, Scene, ball, ground
from cases.tumbling_box import rotation

M = 1.0                      # kg, brick and ball
SIDES = (0.05, 0.1, 0.2)     # the brick's half-sides a, b, c along its x, y, z, m
R = 0.1                      # the ball's radius, m
V = 1.0                      # approach speed of the centre along -n, m/s
E = 0.5                      # restitution: the body leaves the ground and is read in free flight
TILT, YAW = 20.0, 30.0       # deg: the brick's tilt about y (edge, corner) and yaw about z first (corner)
EDGE_TURN = 90.0             # deg about z before the tilt (edge): the landing edge along the brick's x axis
DT = 1e-4                    # s: a contact found a step late moves the lever by w dt (expect)
T = 0.03                     # s: the impact in the first step; MuJoCo's soft contact takes ~20 more

# Grid (the sticking ratio |J_t| / J_n of each, tests/test_closed_forms_landings.py). Brick on
# its edge (3D and 2D): frictionless (moves I_x into the outcome); sliding, slip 1.9 m/s
# along x from 1 m/s and a spin of -4 rad/s about y, mu = 0.1 (0.41 needed to stick); and
# sticking, slip 1.4 m/s, mu = 0.5 (0.32 needed). Turned brick on a corner (3D):
# frictionless with spin about x and z, and sticking, slip 0.9 m/s along x, mu = 0.8 (0.32
# needed). Ball (3D and 2D): sliding with a slip off the axes (1, 0.4) m/s, mu = 0.1 (0.21
# needed), and sticking with backspin (slip -0.5 m/s), mu = 0.3 (0.10 needed).
GRID = tuple({"body": "brick", "pose": "edge", "mu": mu, "vx": 1.0 if mu else 0.0, "w": w, "dim": dim}
             for dim in (3, 2) for mu, w in ((0.0, (0.0, 0.0, 0.0)), (0.1, (0.0, -4.0, 0.0)),
                                             (0.5, (0.0, -2.0, 0.0)))) + \
       ({"body": "brick", "pose": "corner", "mu": 0.0, "vx": 0.0, "w": (3.0, 0.0, 5.0), "dim": 3},
        {"body": "brick", "pose": "corner", "mu": 0.8, "vx": 0.5, "w": (0.0, -2.0, 0.0), "dim": 3},
        {"body": "ball", "pose": "point", "mu": 0.1, "vx": 1.0, "w": (4.0, 0.0, 0.0), "dim": 3},
        {"body": "ball", "pose": "point", "mu": 0.3, "vx": 0.5, "w": (0.0, 10.0, 0.0), "dim": 3},
        {"body": "ball", "pose": "point", "mu": 0.1, "vx": 1.0, "w": (0.0, -4.0, 0.0), "dim": 2},
        {"body": "ball", "pose": "point", "mu": 0.3, "vx": 0.5, "w": (0.0, 10.0, 0.0), "dim": 2})
N = np.array([0.0, 0.0, 1.0])


# --- geometry -------------------------------------------------------------------------------

def quat_mul(p, q) -> tuple[float, float, float, float]:
    """The rotation q then p, as a (w, x, y, z) tuple of floats (a body's orientation)."""
    return tuple(float(c) for c in rotations.multiply(p, q))


def quat_about(axis, angle: float) -> tuple[float, float, float, float]:
    s = math.sin(angle / 2)
    return (math.cos(angle / 2), axis[0] * s, axis[1] * s, axis[2] * s)


def orientation(p) -> tuple[float, float, float, float]:
    """Edge (3D): a quarter turn about z (the brick's x axis along the world's y), then TILT
    about the world's y, so the edge it lands on runs along its x axis; corner: YAW about z,
    then TILT about the world's y; 2D rect: TILT about y; ball: none."""
    if p["body"] == "ball":
        return (1.0, 0.0, 0.0, 0.0)
    tilt = quat_about((0.0, 1.0, 0.0), math.radians(TILT))
    if p["dim"] == 2:
        return tilt
    turn = EDGE_TURN if p["pose"] == "edge" else YAW
    return quat_mul(tilt, quat_about((0.0, 0.0, 1.0), math.radians(turn)))


def vertices(dim: int) -> np.ndarray:
    """The brick's body-frame vertices (2D: the rect's four in the x-z plane, half-sides
    b and c: the 3D edge pose's cross-section)."""
    a, b, c = SIDES
    if dim == 2:
        return np.array([(x, 0.0, z) for x in (-b, b) for z in (-c, c)])
    return np.array([(x, y, z) for x in (-a, a) for y in (-b, b) for z in (-c, c)])


def lever(p, q=None) -> np.ndarray:
    """r: centre to contact point, world frame, at orientation q (default the start's): the
    mean of the brick's lowest vertices (an edge's midpoint, or the corner), or -R n."""
    if p["body"] == "ball":
        return -R * N
    world = vertices(p["dim"]) @ rotation(orientation(p) if q is None else q).T
    z = world[:, 2]
    return world[np.isclose(z, z.min(), atol=1e-12)].mean(axis=0)


def principal_inertia(p) -> np.ndarray:
    """The body-frame principal moments: the brick's m (b^2 + c^2) / 3, ... (the rect's
    m (b^2 + c^2) / 3 about y is the brick's I_x, the moment its edge landing turns it
    about); the ball's 2/5 m R^2, the disc's m R^2 / 2."""
    return np.array(_body(p).principal_inertia)


def inverse_inertia(p, q=None) -> np.ndarray:
    """I_w^-1 = R diag(1/I) R^T in world frame (2D: about y only)."""
    I = principal_inertia(p)
    if p["dim"] == 2:
        return np.diag([0.0, 1.0 / I[1], 0.0])
    Rm = rotation(orientation(p) if q is None else q)
    return Rm @ np.diag(1.0 / I) @ Rm.T


def world_inertia(p, q) -> np.ndarray:
    I = principal_inertia(p)
    if p["dim"] == 2:
        return np.diag([0.0, I[1], 0.0])
    Rm = rotation(q)
    return Rm @ np.diag(I) @ Rm.T


# --- closed form ----------------------------------------------------------------------------

def start_velocity(p) -> np.ndarray:
    return np.array([p["vx"], 0.0, -V])


def impulse(p, q=None, depth: float = 0.0) -> np.ndarray:
    """The impulse J on the body by the variant's restitution law (module docstring), at
    orientation q, the contact point `depth` above the lowest point (see expect)."""
    r, I_inv = lever(p, q) + depth * N, inverse_inertia(p, q)
    K = body_collision_matrix(M, I_inv, r)
    u = start_velocity(p) + np.cross(np.array(p["w"]), r)
    return IMPULSE_OF_LAW[law_of(p)](K, u, N, E, p["mu"], p["mu"])


def after_impact(p, q=None, depth: float = 0.0) -> dict[str, float]:
    """Every metric's closed-form value: v', L' = I_w w + r x J, and the contact point's
    velocity after (normal: Newton's law; tangential: the slip left), at orientation q,
    the impulse taken `depth` above the lowest point."""
    q = orientation(p) if q is None else q
    r, J = lever(p, q) + depth * N, impulse(p, q, depth)
    I_w = world_inertia(p, q)
    w0 = np.array(p["w"])
    v = start_velocity(p) + J / M
    L = I_w @ w0 + np.cross(r, J)
    w = w0 + inverse_inertia(p, q) @ np.cross(r, J)
    u = v + np.cross(w, r)
    return _metrics(p, v, L, u)


def _metrics(p, v, L, u) -> dict[str, float]:
    out = {"vx": v[0], "vy": v[1], "vz": v[2], "Lx": L[0], "Ly": L[1], "Lz": L[2],
           "contact_rebound": u[2], "slip_x": u[0], "slip_y": u[1]}
    if p["dim"] == 2:
        for k in ("vy", "Lx", "Lz", "slip_y"):
            del out[k]
    return {k: float(x) for k, x in out.items()}


def sticks(p) -> bool:
    """Whether Newton's sticking impulse lies in the friction cone."""
    J = impulse({**p, "mu": math.inf, "law": "newton"})
    return bool(np.linalg.norm(J[:2]) <= p["mu"] * J[2])


def approach_speed(p) -> float:
    """|v| + |w| |r|: the scale of the contact point's speed (tolerances, law_differs)."""
    return float(np.linalg.norm(start_velocity(p)) + np.linalg.norm(p["w"]) * np.linalg.norm(lever(p)))


def law_differs(p, law: str) -> bool:
    """The closed form under `law` is not Newton's (beyond round-off)."""
    newton = {k: v for k, v in p.items() if k != "law"}
    return outcomes_differ(after_impact(dict(newton, law=law)), after_impact(newton), approach_speed(p))


def law_matters(p) -> bool:
    """The restitution laws give this variant different outcomes."""
    return any(law_differs(p, law) for law in IMPULSE_OF_LAW if law != "newton")


# --- scene ----------------------------------------------------------------------------------

def _body(p) -> Body:
    dim = p["dim"]
    if p["body"] == "ball":
        shape = ball(R, dim)
    else:
        shape = Box(SIDES) if dim == 3 else Rect((SIDES[1], SIDES[2]))
    height = R if p["body"] == "ball" else -float(lever(p)[2])  # the contact point at z = 0
    return Body("body", shape, mass=M, position=(0.0, 0.0, height), orientation=orientation(p),
                velocity=tuple(float(x) for x in start_velocity(p)), angular_velocity=tuple(p["w"]))


def scene(p) -> Scene:
    return Scene(bodies=(ground(), _body(p)), gravity=(0.0, 0.0, 0.0), material=Material(e=E, mu_s=p["mu"]),
                 dimension=p["dim"])


def duration(p) -> float:
    return T


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    """v, L = I_w(q_k) w_k at the first free sample k after the impact, and the contact
    point's velocity v + w x r with w = I_w(start)^-1 L at the start pose (module docstring)."""
    _, k = first_impact(traj, "body", (0.0, 0.0, 0.0))
    if k is None:
        k = len(traj.t) - 1
    v, w, q = traj.vel("body")[k], traj.omega("body")[k], traj.quat("body")[k]
    L = world_inertia(p, q) @ w
    if p["dim"] == 2:
        L = np.array([0.0, principal_inertia(p)[1] * w[1], 0.0])
    w0 = inverse_inertia(p) @ L
    return _metrics(p, v, L, v + np.cross(w0, lever(p)))


# --- expectations ---------------------------------------------------------------------------

def step_rotation(p, dt: float, sign: float):
    """The start orientation turned by the spin for one step (sign -1: one step back)."""
    w = np.array(p["w"])
    angle = float(np.linalg.norm(w)) * dt
    if angle == 0.0 or sign == 0.0:
        return orientation(p)
    return quat_mul(quat_about(w / np.linalg.norm(w), sign * angle), orientation(p))


def expect(p, dt) -> list[Check]:
    exact = after_impact(p)
    # The contact may be resolved a step late (or early, speculatively): the body has then
    # turned by w dt and the lever with it, and (late) its lowest point lies up to |v_n| dt
    # below the ground, the engine's contact point anywhere between it and the surface. The
    # closed form at the pose one step either side, with the point raised by up to that
    # depth, bounds what this does to each metric.
    depth = abs(after_impact(p)["contact_rebound"]) / E * dt  # the approach |u_n| dt
    shifted = [after_impact(p, step_rotation(p, dt, s), d) for s in (-1.0, 0.0, 1.0) for d in (0.0, depth)]
    tol_v = 1e-6 * approach_speed(p)
    why_step = (f", plus the lever turned by one step of spin ({np.linalg.norm(p['w']) * dt:.2g} rad) and raised "
                f"by one step's overlap ({depth * 1e3:.2g} mm)")
    checks = []
    for metric, value in exact.items():
        step = max(abs(s[metric] - value) for s in shifted)
        if metric.startswith("L"):
            tol, unit = tol_v * M * np.linalg.norm(lever(p)), "kg m^2/s"
            why = "an impulse M tol_v at the lever |r|: r x J to solver convergence"
        else:
            tol, unit = tol_v, "m/s"
            why = "one impulse, no other force: exact to solver convergence (1e-6 of the approach speed)"
        if metric == "contact_rebound":
            why = "Newton's law at the contact point, -e u_n: " + why
        checks.append(Check(metric, unit, value, tol + step, "abs", why + why_step))
    return checks


def variant_id(p) -> str:
    w = ",".join(f"{x:g}" for x in p["w"])
    motion = f",vx={p['vx']:g},w=({w})" if p["vx"] or any(p["w"]) else ""
    return f"{p['body']},{p['pose']},mu={p['mu']}{motion}{law_label(p)}{plane_label(p)}"


def needs(p) -> frozenset[str]:
    """The restitution law, where it changes the outcome (adapters.base Capabilities.restitution_law)."""
    return law_needs(p, law_matters(p))


# Each variant whose outcome depends on the restitution law also under each other law that
# changes it (cases/impact_laws.py; ids end ",two_phase", ",poisson"): the laws built-in
# engines declare in the grid, every law in the full grid.
FULL_GRID = with_laws(GRID, law_differs)
GRID = with_laws(GRID, law_differs, (DEFAULT_LAW, *DEFAULT_GRID_LAWS))


FAMILY = CaseFamily(
    name="oblique_landing",
    summary="a brick with three different sides (turned off its principal axes) or a ball lands on an edge, a "
            "corner or a point, spinning and sliding, in zero gravity: velocity and angular momentum after the "
            "impact (full inertia tensor, Newton-Coulomb impulse)",
    source="note 004 (collision matrix K, Newton-Coulomb impulse); note 001 (CG3 II.5), inverse mass matrix of "
           "contact, impact with friction",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=DT,
    needs=needs,
    variant_id=variant_id,
    full_grid=FULL_GRID,
    catches=(
        Catch("inertia axes", "brick,edge,mu=0.0"),
        Catch("inertia axes", "brick,corner,mu=0.0,vx=0,w=(3,0,5)"),
        Catch("inertia", "brick,edge,mu=0.0"),
        Catch("restitution off", "brick,edge,mu=0.0"),
        Catch("restitution doubled", "brick,edge,mu=0.0"),
        Catch("friction off", "brick,edge,mu=0.5,vx=1,w=(0,-2,0)"),
        Catch("friction doubled", "brick,edge,mu=0.1,vx=1,w=(0,-4,0)"),
        Catch("restitution law", "brick,edge,mu=0.1,vx=1,w=(0,-4,0)"),
        Catch("restitution law", "brick,edge,mu=0.5,vx=1,w=(0,-2,0)"),
        Catch("angular velocity frame", "brick,corner,mu=0.0,vx=0,w=(3,0,5)"),
    ),
)
