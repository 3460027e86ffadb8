"""The free rotation of reference_impl/rigid_body.py (the implicit midpoint rule for
Euler's equations, Cayley-turned quaternion): against Euler's equations integrated by
scipy to 1e-13, not against the engine itself.

The body: principal inertia (0.05, 0.0325, 0.0125) kg m^2, spinning mostly about its
intermediate axis, so it flips over (the Dzhanibekov effect): the hardest free motion for
a rotation step, which a first-order one drifts through."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from reference_impl.rigid_body import RigidBody, mat_vec, rotation_matrix, similarity

INERTIA = (0.05, 0.0325, 0.0125)  # I_x > I_y > I_z: y is the intermediate axis
W0 = (0.0, 5.0, 2.0)              # rad/s, world = body frame at t = 0
T = 0.8                           # s: past the first flip (at 0.63 s)


def tumble(dt: float, T: float = T, inertia=INERTIA, w0=W0):
    """A free body stepped by integrate_position for T: its orientation matrices and world
    angular velocities at every step."""
    body = RigidBody("box", None, 1.0, inertia, w=w0)
    Rs, ws = [body.R], [tuple(body.w)]
    for _ in range(int(round(T / dt))):
        body.integrate_position(dt)
        Rs.append(body.R)
        ws.append(tuple(body.w))
    return np.array(Rs), np.array(ws)


def world_momentum_and_energy(Rs, ws, inertia=INERTIA):
    """L = R I_0 R^T w and E = w . L / 2 at every step."""
    L = np.array([mat_vec(similarity(R, inertia), w) for R, w in zip(Rs, ws)])
    return L, 0.5 * np.einsum("ni,ni->n", ws, L)


def exact(T: float, inertia=INERTIA, w0=W0):
    """(R(T), world w(T)) from Euler's equations I w_dot = (I w) x w in the body frame and
    q_dot = q (0, w_body) / 2, by scipy's DOP853 at rtol = atol = 1e-13."""
    I = np.array(inertia)

    def rates(t, y):
        q, w = y[:4], y[4:]
        qw, qx, qy, qz = q
        q_dot = 0.5 * np.array([-qx * w[0] - qy * w[1] - qz * w[2],
                                qw * w[0] + qy * w[2] - qz * w[1],
                                qw * w[1] + qz * w[0] - qx * w[2],
                                qw * w[2] + qx * w[1] - qy * w[0]])
        return np.concatenate([q_dot, np.cross(I * w, w) / I])
    y = solve_ivp(rates, (0.0, T), [1.0, 0.0, 0.0, 0.0, *w0], method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    R = np.array(rotation_matrix(y[:4] / np.linalg.norm(y[:4])))
    return R, R @ y[4:]


def test_world_angular_momentum_is_kept_to_round_off():
    """Torque-free: L in the world frame is constant (note 001, dL/dt = T). The Cayley
    turn by the midpoint spin maps the body's L_0 onto L_1 exactly (module docstring)."""
    Rs, ws = tumble(1e-3)
    L, _ = world_momentum_and_energy(Rs, ws)
    assert np.max(np.linalg.norm(L - L[0], axis=1)) / np.linalg.norm(L[0]) < 1e-12


def test_energy_is_kept_to_round_off_through_the_flip():
    """The implicit midpoint rule keeps quadratic invariants (E = L . I^-1 L / 2 is one)
    exactly; what is left is round-off and the fixed-point iteration's 1e-15. The first-
    order update it replaced drifted 0.61 % here at dt = 1e-3."""
    for dt in (1e-3, 1e-2):
        Rs, ws = tumble(dt)
        _, E = world_momentum_and_energy(Rs, ws)
        assert np.max(np.abs(E / E[0] - 1.0)) < 1e-12


def test_the_flip_happens_when_eulers_equations_say():
    """The body's y axis on L changes sign when w_y does in Euler's equations (0.6296 s,
    scipy); the first-order update it replaced flipped 0.8 ms early at dt = 1e-3."""
    dt = 1e-3
    Rs, ws = tumble(dt)
    L, _ = world_momentum_and_energy(Rs, ws)
    s = np.einsum("ni,i->n", Rs[:, :, 1], L[0])
    k = int(np.flatnonzero(np.sign(s[1:]) != np.sign(s[:-1]))[0])
    flip = (k + s[k] / (s[k] - s[k + 1])) * dt
    sol = solve_ivp(lambda t, w: np.cross(np.array(INERTIA) * w, w) / np.array(INERTIA), (0.0, T), W0,
                    method="DOP853", rtol=1e-13, atol=1e-13, events=lambda t, w: w[1])
    assert flip == pytest.approx(sol.t_events[0][0], abs=1e-6)  # second order: 2e-7 s measured


def test_second_order_convergence_against_eulers_equations():
    """Halving dt quarters the error of the orientation and of the world angular velocity
    at T (second order), on a tumbling body that passes through the flip."""
    R_ref, w_ref = exact(T)
    errors = []
    for dt in (4e-3, 2e-3, 1e-3):
        Rs, ws = tumble(dt)
        errors.append((np.linalg.norm(Rs[-1] - R_ref), np.linalg.norm(ws[-1] - w_ref)))
    errors = np.array(errors)
    ratios = errors[:-1] / errors[1:]
    assert np.all((ratios > 3.6) & (ratios < 4.4)), ratios
    assert np.all(errors[-1] < 1e-4)


@pytest.mark.parametrize("inertia", [(0.02, 0.02, 0.02), (0.02, 0.02, 0.05)], ids=["sphere", "symmetric top"])
def test_symmetric_bodies_precess_at_the_closed_form_rate(inertia):
    """A sphere keeps its spin; a symmetric top (I_1 = I_2) turns its body-frame w about
    the symmetry axis at Omega = (I_3 - I_1) / I_1 w_3 (Landau and Lifshitz, sec. 33): the
    body-frame w_1 + i w_2 turns by Omega T, and w_3 is constant. The equations are then
    linear, and the implicit midpoint step is the Cayley rotation by 2 atan(Omega dt / 2)
    per step, exactly: the phase lags Omega T by (Omega dt)^2 Omega T / 12."""
    w0, dt, n = (1.0, 0.0, 3.0), 1e-3, 1000
    Rs, ws = tumble(dt, n * dt, inertia, w0)
    w_body = Rs[-1].T @ ws[-1]
    Omega = (inertia[2] - inertia[0]) / inertia[0] * w0[2]
    turned = lambda angle: (w0[0] * math.cos(angle), w0[0] * math.sin(angle), w0[2])
    assert w_body == pytest.approx(turned(n * 2.0 * math.atan(Omega * dt / 2.0)), abs=1e-12)
    lag = (Omega * dt) ** 2 * Omega * n * dt / 12.0  # 7.6e-6 rad for the top
    assert w_body == pytest.approx(turned(Omega * n * dt), abs=1.01 * lag * w0[0] + 1e-12)
