"""A pendulum on a hinge: its period at small and large amplitude, and its energy over
several periods.

A ball (mass m, radius r, I_c = 2/5 m r^2; in 2D a disc, I_c = 1/2 m r^2) hangs on a joint at distance L from its centre
and is let go at rest at angle theta_0 from the vertical. It is a physical pendulum
(rigid-body equations of motion, note 001; the joint a bilateral constraint): about the
pivot I_p = I_c + m L^2 and
    I_p theta'' = -m g L sin(theta),   w_0^2 = m g L / I_p.
Energy E = I_p theta'^2 / 2 - m g L cos(theta) is conserved, and the period at any
amplitude is exact in the complete elliptic integral of the first kind K (Landau &
Lifshitz, Mechanics, sec. 11, problem 1; scipy.special.ellipk takes m = k^2):
    T(theta_0) = 4 K(k) / w_0,   k = sin(theta_0 / 2),
which at small amplitude is 2 pi / w_0 (1 + theta_0^2 / 16 + ...): the 5 deg variant is
0.05 % longer than 2 pi / w_0, the 150 deg one 76 % longer.

The bob is a ball on an invisible arm, so no contact acts and the two readings measure the
joint and the integrator: the angle theta = atan2(x, -z) of the bob about the pivot, and
the rigid bodies' mechanical energy (cases.observables.mechanical_energy: every engine's
own velocities, so a joint that lets the bob drift off its circle, or a stabilisation that
pushes it back, shows in E too).

Tolerances: the engines step velocities before positions (semi-implicit, symplectic Euler
in the joint's coordinate for a reduced-coordinate engine). Such a step keeps a modified
energy H~ = H - dt/2 H_p H_q + O(dt^2) exactly (Hairer, Lubich & Wanner, Geometric
Numerical Integration, IX.3), and H_p H_q = theta' m g L sin(theta) is the power P of
gravity, 0 at the release: E wanders by dt/2 |P| <= dt/2 P_max, allowed twice (the
O(dt^2) terms). Its O(dt) term integrates to zero over a period (P is odd under time
reversal), so the period errs by O(dt^2): for the harmonic oscillator the map's
frequency is w_0 (1 + (w_0 dt)^2 / 24); the local frequency squared w_0^2 cos(theta) is
at most w_0^2 along every orbit, and the check allows four times the harmonic term, the
bound (w_0 dt)^2 / 6 of a second-order step (Runge-Kutta error constants are at most 1/6)
as in cases/free_rigid_body.py. The period is read from the zero crossings of theta,
interpolated linearly: that errs by dt^2 theta'' / (8 theta'), and theta'' = 0 where
theta crosses zero. tests/test_closed_forms_joints.py checks that symplectic Euler on the
pendulum meets both tolerances and explicit Euler does not. A maximal-coordinate engine
holds the joint by constraint rows and their stabilisation, whose drift adds to both.

Variants: a revolute joint at 5 and 150 deg (3D), a ball joint at 90 deg (a spherical
pendulum let go at rest swings in its plane: the same closed form), and the 150 deg hinge
in a 2D scene (the 2D engines' revolute joints).
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import mechanical_energy
from cases.scene import Body, Joint, Scene, ball

G = 9.81
MASS = 1.0     # kg
RADIUS = 0.05  # m, the bob
LENGTH = 0.5   # m, pivot to the bob's centre
PIVOT = (0.0, 0.0, 1.0)  # m, world frame
PERIODS = 4    # simulated periods: the energy is watched over all, the period read over all crossings

# Grid: the small-amplitude limit (5 deg: 2 pi / w_0 to 0.05 %), a large swing (150 deg:
# K(k) far from pi/2, T = 1.76 T_0), a ball joint (90 deg) and the 150 deg swing in 2D.
GRID = (
    {"joint": "revolute", "amplitude": 5.0, "dim": 3},
    {"joint": "revolute", "amplitude": 150.0, "dim": 3},
    {"joint": "ball", "amplitude": 90.0, "dim": 3},
    {"joint": "revolute", "amplitude": 150.0, "dim": 2},
)


# --- closed forms ---------------------------------------------------------------------------

def pivot_inertia(dim: int = 3, m: float = MASS, r: float = RADIUS, L: float = LENGTH) -> float:
    """I_p = I_c + m L^2, the bob's moment about the pivot (parallel axes): I_c of a ball
    (2/5 m r^2) in 3D, of a disc (1/2 m r^2) in 2D, about y."""
    return ball(r, dim).inertia(m)[1] + m * L * L


def small_frequency(dim: int = 3, m: float = MASS, r: float = RADIUS, L: float = LENGTH, g: float = G) -> float:
    """w_0 = sqrt(m g L / I_p), rad/s."""
    return math.sqrt(m * g * L / pivot_inertia(dim, m, r, L))


def period(theta_0: float, w_0: float) -> float:
    """T = 4 K(k) / w_0, k = sin(theta_0 / 2): the exact period at amplitude theta_0 (rad)."""
    from scipy.special import ellipk  # imported here: scipy's import costs every command 0.5 s
    return 4.0 * float(ellipk(math.sin(theta_0 / 2.0) ** 2)) / w_0


def peak_power(theta_0: float, dim: int = 3, m: float = MASS, r: float = RADIUS, L: float = LENGTH,
               g: float = G) -> float:
    """P_max = max |theta' m g L sin(theta)| over the swing, W: theta'^2 = 2 m g L
    (cos(theta) - cos(theta_0)) / I_p, maximised on a fine grid of theta in [0, theta_0]
    (relative error of the grid's maximum < 1e-6)."""
    th = np.linspace(0.0, theta_0, 4001)
    w = np.sqrt(np.maximum(2.0 * m * g * L * (np.cos(th) - math.cos(theta_0)) / pivot_inertia(dim, m, r, L), 0.0))
    return float(np.max(w * m * g * L * np.sin(th)))


def crossing_period(t: np.ndarray, theta: np.ndarray) -> float:
    """The period from the zero crossings of theta (linearly interpolated): twice the mean
    spacing of the crossings; inf with fewer than three crossings."""
    k = np.flatnonzero(np.sign(theta[1:]) * np.sign(theta[:-1]) < 0)
    if len(k) < 3:
        return math.inf
    crossings = t[k] + (t[k + 1] - t[k]) * theta[k] / (theta[k] - theta[k + 1])
    return float(2.0 * (crossings[-1] - crossings[0]) / (len(crossings) - 1))


# --- scene ----------------------------------------------------------------------------------

def scene(p) -> Scene:
    th = math.radians(p["amplitude"])
    x, z = PIVOT[0] + LENGTH * math.sin(th), PIVOT[2] - LENGTH * math.cos(th)
    bob = Body("bob", ball(RADIUS, p["dim"]), mass=MASS, position=(x, 0.0, z))
    hinge = Joint(p["joint"], "bob", None, anchor=PIVOT, axis=(0.0, 1.0, 0.0))
    return Scene(bodies=(bob,), gravity=(0.0, 0.0, -G), dimension=p["dim"], joints=(hinge,))


def duration(p) -> float:
    return PERIODS * period(math.radians(p["amplitude"]), small_frequency(p["dim"]))


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    x = traj.pos("bob")
    theta = np.arctan2(x[:, 0] - PIVOT[0], PIVOT[2] - x[:, 2])
    E = mechanical_energy(traj, scene(p))
    return {"period": crossing_period(traj.t, theta),
            "energy_drift": float(np.max(np.abs(E - E[0])))}


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    th = math.radians(p["amplitude"])
    w_0 = small_frequency(p["dim"])
    T = period(th, w_0)
    steps = max(1, round(duration(p) / dt))
    E_scale = MASS * G * (LENGTH + PIVOT[2])  # |E| and every term of it are at most this, J
    return [
        Check("period", "s", T, T * (w_0 * dt) ** 2 / 6.0, "abs",
              "T = 4 K(sin(theta_0/2)) / w_0; a symplectic step's period errs by O(dt^2) ((w_0 dt)^2/24 for the "
              "harmonic oscillator), allowed (w_0 dt)^2/6 of T, a second-order step's bound; crossings "
              "interpolated where theta'' = 0", roundoff=T * steps),
        Check("energy_drift", "J", 0.0, dt * peak_power(th, p["dim"]), "abs",
              "symplectic Euler conserves H - dt/2 theta' m g L sin(theta): E wanders by dt/2 of gravity's peak "
              "power, allowed twice (O(dt^2) terms)", roundoff=4.0 * E_scale * steps, measures="integrator"),
    ]


def variant_id(p) -> str:
    return f"{p['joint']},amplitude={p['amplitude']:g}" + (",2D" if p["dim"] == 2 else "")


FAMILY = CaseFamily(
    name="pendulum",
    summary="a ball on a hinge (revolute or ball joint) let go at theta_0: period 4 K(sin(theta_0/2)) / w_0 "
            "(complete elliptic integral), energy kept over four periods",
    source="note 001 (CG3 II.5), rigid-body equations of motion with a joint; Landau & Lifshitz Mechanics "
           "sec. 11 (pendulum period); Hairer, Lubich & Wanner IX.3 (modified energy of symplectic Euler)",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        # planted on the reference's PGS formulation, whose joint rows pass the small swing
        # (its large swings lose energy: a known deviation); the reference's damping is
        # planted in its default formulation (the sequential impulses' joint rows pass the
        # small swing too), and on MuJoCo's large swing
        Catch("gravity", "revolute,amplitude=5", "reference-pgs"),
        Catch("time step", "revolute,amplitude=5", "reference-pgs"),
        Catch("damping", "revolute,amplitude=5"),
        Catch("damping", "revolute,amplitude=150", "mujoco"),
    ),
)
