"""A double pendulum: two balls on two hinges, one hung from the world, the other from the
first ball's centre. Its normal modes' periods and energy under gravity; its momentum,
angular momentum and energy floating free.

Bodies: balls of mass m and radius r (I_c about y: 2/5 m r^2, a disc's 1/2 m r^2 in 2D),
each turning with its arm; arm lengths L_1, L_2. In the arms' absolute angles theta_1,
theta_2 from the downward vertical (rigid-body equations of motion with joints, note 001;
Lagrange's equations):
    M(theta) theta'' + m_2 L_1 L_2 sin(theta_1 - theta_2) (theta_2'^2, -theta_1'^2)
        + g ((m_1 + m_2) L_1 sin(theta_1), m_2 L_2 sin(theta_2)) = 0,
    M = [[I_1 + (m_1 + m_2) L_1^2, m_2 L_1 L_2 cos(theta_1 - theta_2)],
         [m_2 L_1 L_2 cos(theta_1 - theta_2), I_2 + m_2 L_2^2]].
Linearised about hanging (M -> M_0, sin -> theta), K x = w^2 M_0 x with
K = diag((m_1 + m_2) g L_1, m_2 g L_2): two normal modes, w_slow < w_fast (the generalised
eigenproblem, scipy.linalg.eigh). Let go at rest in one mode's shape at 2 deg, the motion
stays in that mode up to the O(theta^2) coupling of the full equations: the expected period
is read from the full equations integrated to 1e-11 (scipy's DOP853; within 1e-4 of the
linear 2 pi / w at 2 deg for the slow mode, 1.1e-3 for the fast one, tests/test_joints.py), by the same zero crossings of theta_1 the
observer reads from the engine. Energy E = T + V is conserved.

Tolerances as in cases/pendulum.py: a symplectic step conserves a modified energy
H - dt/2 theta' . dV/dtheta (to O(dt^2); at 2 deg M is constant to 6e-4), so E wanders by
dt/2 of gravity's peak power, allowed twice; the period errs by O(dt^2), allowed
(w_fast dt)^2 / 6 of it.

Floating free (no gravity), the pair let go spinning: the arm turns at Omega about the
pair's centre of mass, which moves uniformly; the first ball spins at its own w_1 (the
hinge acts at its centre: no torque on it). No external force or torque acts and nothing
does work, so the linear momentum P, the angular momentum L (about the origin) and the
energy E are constant; the arm's angle is a cyclic coordinate. A reduced-coordinate step
keeps the cyclic coordinate's momentum, and a maximal-coordinate step applies the joint's
impulses in equal and opposite pairs at one point, so P is kept to round-off either way;
L and E too where the joint holds: the checks allow round-off only, and what an engine
does beyond it is its finding.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import mechanical_energy
from cases.pendulum import crossing_period
from cases.scene import Body, Joint, Scene, ball

G = 9.81
MASS = (1.0, 1.0)     # kg
RADIUS = 0.05         # m
LENGTH = (0.5, 0.5)   # m: pivot to the first ball, first ball to the second
PIVOT = (0.0, 0.0, 1.5)  # m
PERIODS = 4           # of the mode, under gravity
AMPLITUDE = 2.0       # deg: the larger arm angle of a mode's start
FREE_TIME = 2.0       # s floating free
# Floating free: the first ball at FREE_START, moving at FREE_V and spinning at FREE_W1;
# the arm (to the second ball, along +x) turning at OMEGA about y.
FREE_START, FREE_V, FREE_W1, OMEGA = (0.0, 0.0, 1.0), (0.3, 0.0, 0.2), 2.0, -3.0

# Grid: each normal mode at 2 deg (3D), the slow one in 2D, and the pair floating free
# (3D and 2D).
GRID = (
    {"motion": "slow mode", "dim": 3},
    {"motion": "fast mode", "dim": 3},
    {"motion": "slow mode", "dim": 2},
    {"motion": "free", "dim": 3},
    {"motion": "free", "dim": 2},
)


# --- closed forms ---------------------------------------------------------------------------

def inertias(dim: int) -> tuple[float, float]:
    """I_c of each ball about y."""
    return tuple(ball(RADIUS, dim).inertia(m)[1] for m in MASS)


def mass_matrix(dim: int, c: float = 1.0) -> np.ndarray:
    """M at cos(theta_1 - theta_2) = c (M_0 at c = 1)."""
    (m1, m2), (L1, L2), (I1, I2) = MASS, LENGTH, inertias(dim)
    return np.array([[I1 + (m1 + m2) * L1 * L1, m2 * L1 * L2 * c], [m2 * L1 * L2 * c, I2 + m2 * L2 * L2]])


def normal_modes(dim: int) -> tuple[np.ndarray, np.ndarray]:
    """(w, shapes): the linear modes' frequencies, ascending, and their shapes (columns,
    the larger component 1)."""
    from scipy.linalg import eigh  # imported here: scipy's import costs every command 0.5 s
    (m1, m2), (L1, L2) = MASS, LENGTH
    K = np.diag([(m1 + m2) * G * L1, m2 * G * L2])
    w2, x = eigh(K, mass_matrix(dim))
    return np.sqrt(w2), x / np.max(np.abs(x), axis=0)


def _rates(dim: int):
    (m1, m2), (L1, L2) = MASS, LENGTH

    def f(t, y):
        t1, t2, w1, w2 = y
        s, c = math.sin(t1 - t2), math.cos(t1 - t2)
        rhs = -np.array([m2 * L1 * L2 * s * w2 * w2 + (m1 + m2) * G * L1 * math.sin(t1),
                         -m2 * L1 * L2 * s * w1 * w1 + m2 * G * L2 * math.sin(t2)])
        return np.concatenate([[w1, w2], np.linalg.solve(mass_matrix(dim, c), rhs)])
    return f


def start_angles(p) -> np.ndarray:
    _, shapes = normal_modes(p["dim"])
    return math.radians(AMPLITUDE) * shapes[:, 0 if p["motion"] == "slow mode" else 1]


@functools.lru_cache(maxsize=16)
def _swing(motion: str, dim: int, dt: float) -> tuple[float, float]:
    """(period, P_max) of a mode's swing from the full equations, sampled every dt: the
    period from theta_1's zero crossings, as the observer reads it, and gravity's peak
    power |g ((m_1 + m_2) L_1 sin(theta_1) theta_1' + m_2 L_2 sin(theta_2) theta_2')|."""
    from scipy.integrate import solve_ivp  # imported here, as eigh above
    p = {"motion": motion, "dim": dim}
    T = duration(p)
    t = np.arange(round(T / dt) + 1) * dt
    sol = solve_ivp(_rates(dim), (0.0, t[-1]), np.concatenate([start_angles(p), [0.0, 0.0]]), method="DOP853",
                    rtol=1e-11, atol=1e-13, t_eval=t)
    t1, t2, w1, w2 = sol.y
    (m1, m2), (L1, L2) = MASS, LENGTH
    power = G * ((m1 + m2) * L1 * np.sin(t1) * w1 + m2 * L2 * np.sin(t2) * w2)
    return crossing_period(t, t1), float(np.max(np.abs(power)))


def _free_bodies(dim: int) -> tuple[Body, Body]:
    x1, v1 = np.array(FREE_START), np.array(FREE_V)
    arm = np.array([LENGTH[1], 0.0, 0.0])
    w2 = np.array([0.0, OMEGA, 0.0])
    first = Body("first", ball(RADIUS, dim), mass=MASS[0], position=tuple(x1), velocity=tuple(v1),
                 angular_velocity=(0.0, FREE_W1, 0.0))
    second = Body("second", ball(RADIUS, dim), mass=MASS[1], position=tuple(x1 + arm),
                  velocity=tuple(float(c) for c in v1 + np.cross(w2, arm)), angular_velocity=tuple(w2))
    return first, second


# --- scene ----------------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p["dim"]
    if p["motion"] == "free":
        first, second = _free_bodies(dim)
        return Scene(bodies=(first, second), gravity=(0.0, 0.0, 0.0), dimension=dim,
                     joints=(Joint("revolute", "second", "first", anchor=first.position),))
    t1, t2 = start_angles(p)
    x1 = np.array(PIVOT) + LENGTH[0] * np.array([math.sin(t1), 0.0, -math.cos(t1)])
    x2 = x1 + LENGTH[1] * np.array([math.sin(t2), 0.0, -math.cos(t2)])
    first = Body("first", ball(RADIUS, dim), mass=MASS[0], position=tuple(float(c) for c in x1))
    second = Body("second", ball(RADIUS, dim), mass=MASS[1], position=tuple(float(c) for c in x2))
    return Scene(bodies=(first, second), gravity=(0.0, 0.0, -G), dimension=dim,
                 joints=(Joint("revolute", "first", None, anchor=PIVOT),
                         Joint("revolute", "second", "first", anchor=first.position)))


def duration(p) -> float:
    if p["motion"] == "free":
        return FREE_TIME
    w, _ = normal_modes(p["dim"])
    return PERIODS * 2.0 * math.pi / w[0 if p["motion"] == "slow mode" else 1]


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    sc = scene(p)
    E = mechanical_energy(traj, sc)
    out = {"energy_drift": float(np.max(np.abs(E - E[0])))}
    if p["motion"] != "free":
        x = traj.pos("first")
        out["period"] = crossing_period(traj.t, np.arctan2(x[:, 0] - PIVOT[0], PIVOT[2] - x[:, 2]))
        return out
    P = sum(b.mass * traj.vel(b.name) for b in sc.dynamic_bodies)
    # balls: I_c is the same about every axis (a disc's about y, the only axis it turns about)
    L = sum(np.cross(traj.pos(b.name), b.mass * traj.vel(b.name)) + b.principal_inertia[1] * traj.omega(b.name)
            for b in sc.dynamic_bodies)
    out["momentum_drift"] = float(np.max(np.linalg.norm(P - P[0], axis=1)))
    out["angular_momentum_drift"] = float(np.max(np.linalg.norm(L - L[0], axis=1)))
    return out


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    steps = max(1, round(duration(p) / dt))
    if p["motion"] == "free":
        first, second = _free_bodies(p["dim"])
        bodies = (first, second)
        # bounds of the magnitudes each step rounds (the motion is uniform: its start's speeds, twice)
        reach = 2.0 * max(np.linalg.norm(b.position) + np.linalg.norm(b.velocity) * FREE_TIME for b in bodies)
        p_scale = 2.0 * sum(b.mass * np.linalg.norm(b.velocity) for b in bodies)
        L_scale = reach * p_scale + 2.0 * sum(b.principal_inertia[1] * np.linalg.norm(b.angular_velocity)
                                              for b in bodies)
        E_scale = 2.0 * sum(b.mass * np.dot(b.velocity, b.velocity) + b.principal_inertia[1]
                            * np.dot(b.angular_velocity, b.angular_velocity) for b in bodies)
        exact = ("no external force or torque and nothing doing work: exact in a step that applies the joint's "
                 "impulses in equal and opposite pairs at one point (maximal) or keeps the cyclic coordinate "
                 "(reduced); float64 round-off (1e-9 of the scale)")
        return [Check("momentum_drift", "N s", 0.0, 1e-9 * p_scale, "abs", exact, roundoff=4.0 * p_scale * steps),
                Check("angular_momentum_drift", "N m s", 0.0, 1e-9 * L_scale, "abs", exact,
                      roundoff=4.0 * L_scale * steps),
                Check("energy_drift", "J", 0.0, 1e-9 * E_scale, "abs", exact, roundoff=4.0 * E_scale * steps)]
    w, _ = normal_modes(p["dim"])
    T, P_max = _swing(p["motion"], p["dim"], dt)
    E_scale = sum(MASS) * G * (PIVOT[2] + sum(LENGTH))
    return [
        Check("period", "s", T, T * (w[-1] * dt) ** 2 / 6.0, "abs",
              "the mode's period from the full equations; a symplectic step errs by O(dt^2), allowed (w_fast dt)^2/6 "
              "of T (cases/pendulum.py)", roundoff=T * steps),
        Check("energy_drift", "J", 0.0, dt * P_max, "abs",
              "a symplectic step conserves H - dt/2 theta' . dV/dtheta: E wanders by dt/2 of gravity's peak power, "
              "allowed twice (O(dt^2) terms)", roundoff=4.0 * E_scale * steps, measures="integrator"),
    ]


def variant_id(p) -> str:
    return p["motion"] + (",2D" if p["dim"] == 2 else "")


FAMILY = CaseFamily(
    name="double_pendulum",
    summary="two balls on two hinges: each normal mode's period at 2 deg and the energy under gravity; momentum, "
            "angular momentum and energy kept floating free",
    source="note 001 (CG3 II.5), rigid-body equations of motion with joints; Lagrange's equations of the double "
           "pendulum and their normal modes (Goldstein, Classical Mechanics, ch. 6)",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        # planted on the reference's PGS formulation, whose joint rows pass both modes; the
        # reference's damping is planted in its default formulation (whose joint rows pass
        # the slow mode too), and on MuJoCo
        Catch("gravity", "slow mode", "reference-pgs"),
        Catch("time step", "fast mode", "reference-pgs"),
        Catch("damping", "slow mode"),
        Catch("damping", "slow mode", "mujoco"),
    ),
)
