"""A four-bar linkage swinging under gravity, against Freudenstein's equation.

Three links (crank a, coupler b, rocker c) and the ground (d) form a closed loop of four
revolute joints: the crank turns about O_2 = PIVOT, the rocker about O_4 = PIVOT + d x, the
coupler joins the crank's end A to the rocker's end B. With the crank's angle theta_2 and
the rocker's theta_4 measured from the ground line O_2 O_4 (x) towards z, the loop closes
exactly when (Freudenstein 1955)
    K_1 cos(theta_4) - K_2 cos(theta_2) + K_3 = cos(theta_2 - theta_4),
    K_1 = d / a,  K_2 = d / c,  K_3 = (a^2 - b^2 + c^2 + d^2) / (2 a c),
whatever the motion: it is the geometry of the joints, so the rocker's angle is a closed
form of the crank's, theta_4(theta_2) = atan2(Q, P) +- acos(R / sqrt(P^2 + Q^2)) with
P = K_1 - cos(theta_2), Q = -sin(theta_2), R = K_2 cos(theta_2) - K_3 (the branch the
linkage starts on). Released at rest with the crank at 60 deg, gravity turns the crank
down through a full turn less 95 deg (to -265 deg, where it has climbed back to its start
energy) in about 0.7 s. Checks: the largest gap between the rocker's angle and
theta_4(theta_2) over 1 s, the mechanical energy's drift, and that the crank moves at all.

The linkage is a one-degree-of-freedom system in theta_2 (_motion): with the generalised
mass M(theta_2) and potential V(theta_2) from the closed form, energy gives theta_2' and
every link's rate along the path, from which the tolerances follow.
- The angle: a time step holds the joints' velocities together but turns each body by
  w dt, taking an anchor at r from its centre off its tangent by w^2 r dt^2 / 2; the loop
  opens by the sum over its joints (loop_gap, 5.1e-5 m at dt = 1e-3), which turns the
  rocker by at most 1/(c |sin mu|) a metre (rocker_sensitivity, mu the transmission angle).
  A stabilisation closes it again; allowed is twice one step's gap, a loop closed within
  two steps (MuJoCo's stable minimum for a constraint's time constant). 4.2e-4 rad at dt = 1e-3.
- The energy: symplectic Euler keeps the modified energy H - dt/2 H_p H_q (Hairer, Lubich
  & Wanner IX.3), so E wanders by dt/2 max |theta_2' (V' - M' theta_2'^2 / 2)| (peak_power),
  allowed twice (O(dt^2) terms), as in cases/pendulum.py.

A closed loop is the first scene whose joints no tree holds. MuJoCo closes it with an
equality constraint (<connect> at the coupler-rocker joint), a soft constraint whose gap is
set by its solref (adapters/mujoco_engine.py has the figures): at the time constant 2 dt it
misses by 3.7e-4 rad, at MuJoCo's default 0.02 s by 2.0e-3. The maximal-coordinate engines
hold the loop by their joints' constraint rows; Rapier meets both checks, Box2D, Box3D and
Pymunk's soft joints leave the loop open by millimetres and lose 0.10-0.16 J (their known
deviations). Drake, DART and PyBullet hold the tree in joint coordinates and close the loop
with a ball (point-to-point) constraint: Drake's SAP constraint meets both checks, DART's
(error reduction 0.01 a step) and PyBullet's (erp 0.2) leave the loop open longer (their
known deviations).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import mechanical_energy
from cases.scene import Body, Box, Joint, Rect, Scene, quat_about_y

G = 9.81
A, B, C, D = 0.1, 0.35, 0.3, 0.4   # m: crank, coupler, rocker, ground (Grashof crank-rocker: 0.1 + 0.4 < 0.35 + 0.3)
PIVOT = (0.0, 0.0, 1.0)            # O_2, m
THETA_2 = math.radians(60.0)       # the crank's start angle
WIDTH = 0.01                       # m, each link's half-thickness
MASS = 0.5                         # kg a link
T = 1.0                            # s
SWING = 0.1                        # rad: "moves" means the crank's angle spans more than this

GRID = ({"dim": 3}, {"dim": 2})

K1, K2, K3 = D / A, D / C, (A * A - B * B + C * C + D * D) / (2 * A * C)


def output_angle(theta_2, branch: float) -> np.ndarray:
    """theta_4(theta_2) on the branch `branch` (+1 or -1) of Freudenstein's equation."""
    theta_2 = np.asarray(theta_2, float)
    P, Q, R = K1 - np.cos(theta_2), -np.sin(theta_2), K2 * np.cos(theta_2) - K3
    return np.arctan2(Q, P) + branch * np.arccos(np.clip(R / np.hypot(P, Q), -1.0, 1.0))


def start_points() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """O_2, A, B, O_4 in the x-z plane at the start (B on the upper branch)."""
    o2, o4 = np.array([PIVOT[0], PIVOT[2]]), np.array([PIVOT[0] + D, PIVOT[2]])
    a = o2 + A * np.array([math.cos(THETA_2), math.sin(THETA_2)])
    # B: the upper intersection of the circles (A, B) and (O_4, C)
    gap = o4 - a
    L = np.linalg.norm(gap)
    along = (B * B - C * C + L * L) / (2 * L)
    up = math.sqrt(B * B - along * along)
    u = gap / L
    b = a + along * u + up * np.array([-u[1], u[0]])
    return o2, a, b, o4


def _branch() -> float:
    o2, a, b, o4 = start_points()
    theta_4 = math.atan2(b[1] - o4[1], b[0] - o4[0])
    return min((+1.0, -1.0), key=lambda s: abs(float(output_angle(THETA_2, s)) - theta_4))


# --- the linkage as a one-degree-of-freedom system (for the tolerances) ---------------------

@functools.lru_cache(maxsize=None)  # a pure function of dim, read by every check's tolerance
def _motion(dim: int) -> dict:
    """The linkage's state along its path, on a grid of crank angles theta_2 reachable from
    the release at rest: every link's angle (theta_3 of the coupler from A to B) and its
    rate per unit crank rate, the potential V and generalised mass M (sum of m |dr_c/dtheta_2|^2
    + I_c (dphi/dtheta_2)^2), and from energy conservation the crank's rate
    theta_2' = sqrt(2 (V_0 - V) / M). Derivatives by central differences on a grid of 2^14
    points a turn (relative error ~1e-7, far below what the tolerances need)."""
    branch = _branch()
    th2 = THETA_2 + np.linspace(-2 * math.pi, 2 * math.pi, 2 ** 15 + 1)
    th4 = np.unwrap(output_angle(th2, branch))
    o2, o4 = np.array([PIVOT[0], PIVOT[2]]), np.array([PIVOT[0] + D, PIVOT[2]])
    a = o2 + A * np.stack([np.cos(th2), np.sin(th2)], 1)
    b = o4 + C * np.stack([np.cos(th4), np.sin(th4)], 1)
    th3 = np.unwrap(np.arctan2(b[:, 1] - a[:, 1], b[:, 0] - a[:, 0]))
    centres = ((o2 + a) / 2, (a + b) / 2, (o4 + b) / 2)
    angles = (th2, th3, th4)
    I_c = [_link(n, o2, o2 + L * np.array([1.0, 0.0]), dim).shape.inertia(MASS)[1]
           for n, L in (("crank", A), ("coupler", B), ("rocker", C))]
    V = MASS * G * sum(c[:, 1] for c in centres)
    rates = [np.gradient(phi, th2) for phi in angles]
    M = sum(MASS * np.sum(np.gradient(c, th2, axis=0) ** 2, axis=1) for c in centres)
    M = M + sum(I * r * r for I, r in zip(I_c, rates))
    V_0 = float(np.interp(THETA_2, th2, V))
    # reachable: the crank angles joined to the start by V <= V_0 (it turns either way)
    i0 = int(np.argmin(np.abs(th2 - THETA_2)))
    ok = V <= V_0 + 1e-12
    lo = i0 - (np.flatnonzero(~ok[:i0 + 1][::-1])[:1].tolist() or [i0 + 1])[0] + 1
    hi = i0 + (np.flatnonzero(~ok[i0:])[:1].tolist() or [len(th2) - i0])[0]
    sl = slice(lo, hi)
    w2 = np.sqrt(np.maximum(2.0 * (V_0 - V[sl]) / M[sl], 0.0))
    # H_q = dH/dtheta_2 at fixed momentum p = M theta_2': V' - M' theta_2'^2 / 2
    H_q = np.gradient(V, th2)[sl] - 0.5 * np.gradient(M, th2)[sl] * w2 * w2
    return {"theta": [phi[sl] for phi in angles], "omega": [r[sl] * w2 for r in rates],
            "theta_2_rate": w2, "H_q": H_q}


def loop_gap(dt: float, dim: int) -> float:
    """The largest gap one time step opens in the loop, m: a step moves each body along its
    velocity (the joints' velocity rows hold their anchors' velocities together) and turns it
    by w dt, which takes an anchor at distance r from the centre of mass off that tangent by
    w^2 r dt^2 / 2 (the centripetal term). A joint's gap is its two bodies' terms (anchors at
    half a link, r = l / 2), the loop's the sum over the four joints."""
    motion = _motion(dim)
    w2, w3, w4 = motion["omega"]
    term = [w * w * L / 4.0 for w, L in ((w2, A), (w3, B), (w4, C))]  # w^2 (l/2) / 2 a body
    return float(np.max((term[0] + (term[0] + term[1]) + (term[1] + term[2]) + term[2]) * dt * dt))


def rocker_sensitivity(dim: int) -> float:
    """max |d theta_4 / d g| = 1 / (c |sin mu|), rad/m: the rocker's angle per metre of the
    loop's closure gap g at a fixed crank angle (dotting a e_2 + b e_3 - c e_4 - d x = g with
    e_3 gives -c sin(theta_3 - theta_4) d theta_4 = e_3 . g), largest where the transmission
    angle mu = theta_3 - theta_4 is smallest along the motion."""
    _, th3, th4 = _motion(dim)["theta"]
    return float(1.0 / (C * np.min(np.abs(np.sin(th3 - th4)))))


def peak_power(dim: int) -> float:
    """max |H_p H_q| = max |theta_2' (V' - M' theta_2'^2 / 2)|, W, along the motion (' by
    theta_2): the term of symplectic Euler's modified energy; the pendulum's gravity power,
    plus here the generalised mass M's change along the path."""
    motion = _motion(dim)
    return float(np.max(np.abs(motion["theta_2_rate"] * motion["H_q"])))


def _link(name: str, p: np.ndarray, q: np.ndarray, dim: int) -> Body:
    """A thin bar from p to q (x-z points), its body x axis along it."""
    mid, along = (p + q) / 2, q - p
    half = float(np.linalg.norm(along)) / 2
    angle = math.atan2(along[1], along[0])  # from x towards z: a turn of -angle about +y
    shape = Box((half, WIDTH, WIDTH)) if dim == 3 else Rect((half, WIDTH))
    return Body(name, shape, mass=MASS, position=(float(mid[0]), 0.0, float(mid[1])), orientation=quat_about_y(-angle))


def scene(p) -> Scene:
    dim = p["dim"]
    o2, a, b, o4 = start_points()
    crank, coupler, rocker = _link("crank", o2, a, dim), _link("coupler", a, b, dim), _link("rocker", o4, b, dim)

    def at(x):
        return (float(x[0]), 0.0, float(x[1]))
    return Scene(bodies=(crank, coupler, rocker), gravity=(0.0, 0.0, -G), dimension=dim,
                 joints=(Joint("revolute", "crank", None, anchor=at(o2)),
                         Joint("revolute", "rocker", None, anchor=at(o4)),
                         Joint("revolute", "coupler", "crank", anchor=at(a)),
                         Joint("revolute", "coupler", "rocker", anchor=at(b))))


def duration(p) -> float:
    return T


def _angles(traj, name: str) -> np.ndarray:
    """The link's angle from x towards z: its body x axis in the x-z plane."""
    q = traj.quat(name)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    ex, ez = 1 - 2 * (y * y + z * z), 2 * (x * z - w * y)  # the rotation's first column, x and z rows
    return np.unwrap(np.arctan2(ez, ex))


def observe(traj, p) -> dict:
    theta_2, theta_4 = _angles(traj, "crank"), _angles(traj, "rocker")
    gap = np.angle(np.exp(1j * (theta_4 - output_angle(theta_2, _branch()))))
    E = mechanical_energy(traj, scene(p))
    return {"output_angle_error": float(np.max(np.abs(gap))),
            "energy_drift": float(np.max(np.abs(E - E[0]))),
            "moves": float(np.ptp(theta_2) > SWING)}


def expect(p, dt) -> list[Check]:
    dim = p["dim"]
    steps = max(1, round(T / dt))
    E_scale = 3 * MASS * G * (PIVOT[2] + A + C)  # |E| and each of its terms are at most this, J
    return [Check("output_angle_error", "rad", 0.0, 2.0 * loop_gap(dt, dim) * rocker_sensitivity(dim), "abs",
                  "Freudenstein's equation is the loop's geometry; a step opens the loop by its centripetal "
                  "drift (loop_gap), which turns the rocker by 1/(c sin mu) a metre (rocker_sensitivity); "
                  "allowed twice: a stabilisation that closes it within two steps (MuJoCo's stable minimum)",
                  # each of the loop's 8 anchors rounded at |x| <= 1.5 m, the loop closed again each step
                  # (rounding does not add up over steps)
                  roundoff=8 * 1.5 * rocker_sensitivity(dim)),
            Check("energy_drift", "J", 0.0, dt * peak_power(dim), "abs",
                  "no force but gravity does work; a symplectic step keeps H - dt/2 H_p H_q, so E wanders by "
                  "dt/2 max |theta_2' (V' - M' theta_2'^2/2)| (peak_power), allowed twice (O(dt^2) terms)",
                  roundoff=4.0 * E_scale * steps, measures="integrator"),
            Check("moves", "bool", 1.0, 0.0, "abs",
                  f"a verdict: released at 60 deg the crank swings more than {SWING} rad in {T} s")]


FAMILY = CaseFamily(
    name="four_bar",
    summary="a four-bar linkage (a closed loop of four hinges) swinging under gravity keeps Freudenstein's equation "
            "between its crank and rocker angles",
    source="note 001 (CG3 II.5), joints as constraints; Freudenstein, 'Approximate synthesis of four-bar "
           "linkages', Trans. ASME 77 (1955)",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: "3D" if p["dim"] == 3 else "2D",
    catches=(
        # planted on MuJoCo: the reference's formulations leave the loop open and lose energy
        # (known deviations); Rapier, the other engine that passes, takes no planted damping
        Catch("damping", "3D", "mujoco"),
    ),
)
