"""A hinged rod released onto a stop: an impact with a pivot.

A rod (mass m, length L, half-thickness w), one end on a hinge at the pivot, is let go at
rest, horizontal, and swings down onto a fixed frictionless ball (the stop), which its
lower face meets at lever d from the pivot when it has turned theta_c. Two impulses act in
the impact: the contact's, Delta p along the face's normal n at r_c, and the hinge's, at the
pivot r_j, whatever it takes to keep the pivot still (note 001, CG3 II.5, "Collision
Handling": a joint holds v_rel+ = 0 at its point). With note 001's collision matrix of a
body, K_ab = 1/M + r_a*^T I^-1 r_b* (the velocity change at a per impulse at b), the joint's
condition gives its impulse, Delta p_j = -K_jj^-1 K_jc n Delta p, and the contact sees
    K = n^T (K_cc - K_cj K_jj^-1 K_jc) n = d^2 / I_p,
the rod's inverse inertia about the pivot, I_p = I_c + m (L/2)^2, at the lever d (the joint's
rows eliminated: tests/test_joints.py computes it from the blocks). Newton's law v_n+ = -e
v_n- at the contact, with v_n = d omega, then gives
    omega+ = -e omega-,
whatever d: the pivot's reaction takes the rest (a free rod would also move its centre). The
impact speed is the fall's: I_p omega-^2 / 2 = m g (L/2) sin(theta_c).

Checks: the rebound ratio -omega+ / omega- and the impact speed omega-, read off the rod's
angular velocity about the hinge: omega- the largest before it turns back, omega+ the
largest after (gravity slows the rising rod, so that is the first sample after the impact).
- The impact speed: the hinge holds in a reduced-coordinate engine and the fall is the
  pendulum's, stepped by symplectic Euler (cases/pendulum.py): the last sample before the
  contact lies up to one step's alpha dt short of the speed at the contact (alpha = m g
  (L/2) cos(theta_c) / I_p, the angular acceleration there), and the modified energy
  H - dt/2 P (P = I_p alpha omega, gravity's power) moves omega by dt/2 alpha, allowed
  twice as in the pendulum (the O(dt^2) terms): 2 alpha dt in all.
- The rebound ratio: the impact happens inside a step, tau after its first sample. Read off
  the samples, even the exact motion (omega_c at the contact) gives omega- = omega_c -
  alpha tau and omega+ = -e omega_c + alpha (dt - tau) (gravity slows the rebound for the
  rest of the step), a ratio e + (e alpha tau - alpha (dt - tau)) / omega_c; a stepper
  that resolves the impact at a step boundary applies the step's gravity before the
  impulse (-e (omega_k + alpha dt)), after it (-e omega_k + alpha dt) or inside it
  (-e omega_k): the same range. So the ratio lies within max(1, e) alpha dt / omega- of e
  (plus 1e-6 for the solver's convergence); tests/test_joints.py steps the rod at every
  contact phase with each order and checks the bound.
dt = 2e-4 s: the bounds are 9.4e-4 (ratio) and 0.010 rad/s (speed) at e = 0.5; the fall
takes 0.19 s and the run stops 0.02 s after the impact (`duration`): about 1050 steps.
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.scene import Body, Box, Joint, Material, Rect, Scene, ball

G = 9.81
MASS = 1.0            # kg, the rod
L = 0.5               # m, the rod's length
W = 0.02              # m, its half-thickness
PIVOT = (0.0, 0.0, 1.0)
LEVER = 0.4           # m, d: the contact's distance from the pivot along the rod
THETA_C = math.radians(30.0)  # the rod's turn below horizontal at the contact
STOP_R = 0.05         # m, the stop ball's radius
DT = 2e-4             # s: the bounds are ~ alpha dt / omega- (module notes)
AFTER = 0.02          # s simulated after the impact: soft contacts (a few ms here) separate

# Grid: one restitution, in 3D (a box rod, a ball stop) and in 2D (a rect rod, a disc stop:
# the 2D engines' revolute joints).
GRID = ({"e": 0.5, "dim": 3}, {"e": 0.5, "dim": 2})


def _rod_shape(dim: int):
    return Box((L / 2, W, W)) if dim == 3 else Rect((L / 2, W))


# --- closed forms ---------------------------------------------------------------------------

def pivot_inertia(dim: int) -> float:
    """I_p = I_c + m (L/2)^2 about the hinge's axis (y), kg m^2."""
    return _rod_shape(dim).inertia(MASS)[1] + MASS * (L / 2) ** 2


def impact_speed(dim: int) -> float:
    """omega- = sqrt(2 m g (L/2) sin(theta_c) / I_p), rad/s."""
    return math.sqrt(2 * MASS * G * (L / 2) * math.sin(THETA_C) / pivot_inertia(dim))


def angular_acceleration(dim: int) -> float:
    """alpha = m g (L/2) cos(theta_c) / I_p at the contact, rad/s^2."""
    return MASS * G * (L / 2) * math.cos(THETA_C) / pivot_inertia(dim)


def fall_time(dim: int) -> float:
    """The time from the release to the contact, t_c = integral of d theta / omega(theta)
    over [0, theta_c], omega^2 = 2 m g (L/2) sin(theta) / I_p; with theta = theta_c s^2 the
    integrand 2 theta_c s / omega is smooth at the release (s = 0), s."""
    k = 2 * MASS * G * (L / 2) / pivot_inertia(dim)
    s = np.linspace(0.0, 1.0, 2001)[1:]
    f = 2 * THETA_C * s / np.sqrt(k * np.sin(THETA_C * s * s))
    f0 = 2 * math.sqrt(THETA_C / k)  # the limit at s = 0
    return float(np.trapezoid(np.concatenate(([f0], f)), dx=1.0 / 2000))


def stop_centre() -> tuple[float, float, float]:
    """The stop ball's centre: at lever d along the rod turned theta_c down, then the rod's
    half-thickness plus the ball's radius below its axis (along the lower face's normal n).
    Before theta_c the face's distance from it, d sin(theta_c - theta) + (w + R)
    cos(theta_c - theta) - w, exceeds R, so the face meets it first at theta_c, at lever d."""
    u = np.array([math.cos(THETA_C), -math.sin(THETA_C)])   # along the rod (x, z)
    n = np.array([-math.sin(THETA_C), -math.cos(THETA_C)])  # the lower face's outward normal
    c = np.array([PIVOT[0], PIVOT[2]]) + LEVER * u + (W + STOP_R) * n
    return float(c[0]), 0.0, float(c[1])


# --- scene ----------------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p["dim"]
    rod = Body("rod", _rod_shape(dim), mass=MASS, position=(PIVOT[0] + L / 2, 0.0, PIVOT[2]))
    stop = Body("stop", ball(STOP_R, dim), static=True, position=stop_centre())
    hinge = Joint("revolute", "rod", None, anchor=PIVOT, axis=(0.0, 1.0, 0.0))
    return Scene(bodies=(rod, stop), gravity=(0.0, 0.0, -G), dimension=dim, joints=(hinge,),
                 material=Material(e=p["e"]))


def duration(p) -> float:
    return fall_time(p["dim"]) + AFTER


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    w = traj.omega("rod")[:, 1]  # about y: falling turns the rod about +y (x towards -z)
    turn = int(np.argmax(w < 0)) if np.any(w < 0) else len(w)
    before = float(np.max(w[:turn])) if turn else 0.0
    after = float(-np.min(w[turn:])) if turn < len(w) else 0.0
    return {"rebound_ratio": after / before if before > 0 else 0.0, "impact_speed": before}


# --- expectations ---------------------------------------------------------------------------

def rebound_bound(e: float, dim: int, dt: float) -> float:
    """How far the sampled ratio lies from e: max(1, e) alpha dt / omega- + 1e-6 (module notes)."""
    return max(1.0, e) * angular_acceleration(dim) * dt / impact_speed(dim) + 1e-6


def expect(p, dt) -> list[Check]:
    dim, e = p["dim"], p["e"]
    w, alpha = impact_speed(dim), angular_acceleration(dim)
    tol = rebound_bound(e, dim, dt)
    return [
        Check("rebound_ratio", "-", e, tol, "abs",
              "omega+ = -e omega- (the contact's K = d^2/I_p with the hinge's rows eliminated); read off the samples "
              "the impact falls inside a step, whose gravity acts before, inside or after the impulse: max(1, e) "
              "alpha dt / omega- (+1e-6 solver convergence)"),
        Check("impact_speed", "rad/s", w, 2.0 * alpha * dt, "abs",
              "the pendulum's fall: read at a sample up to one step's alpha dt before the contact, plus symplectic "
              "Euler's modified energy (dt/2 alpha, allowed twice)"),
    ]


FAMILY = CaseFamily(
    name="hinged_rod_stop",
    summary="a hinged rod released onto a fixed frictionless stop rebounds at omega+ = -e omega- (note 001's collision "
            "matrix with the hinge's rows)",
    source="note 001 (CG3 II.5): the collision matrix K of a body, joints holding v_rel+ = 0, Newton's restitution; "
           "a rigid body about a pivot",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=DT,
    variant_id=lambda p: f"e={p['e']:g}" + (",2D" if p["dim"] == 2 else ""),
    catches=(Catch("restitution", "e=0.5", "reference-pgs"), Catch("inertia", "e=0.5", "reference-pgs")),
)
