"""reference_impl/acceleration_lcp.py: contact forces of resting contact (note 001,
Baraff). Closed forms of the note's figures and of a resting stack, and the note's A and
b checked against Newton-Euler: the separation of the contact, integrated for spinning
bodies, must accelerate at A f + b."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from reference_impl.acceleration_lcp import contact_forces
from reference_impl.lcp import STATIC, Bodies, Contact
from reference_impl.single_contact import cross_matrix

G = 9.81
Z = np.array([0.0, 0.0, 1.0])


def at_rest(n):
    return np.zeros((n, 6))


def test_point_mass_on_an_incline():
    """Note 001, Figure 7: f1 >= -m (n . g) = m |g| cos(theta), equality when resting on a
    frictionless incline (it slides but stays on the plane)."""
    theta, m = math.radians(30.0), 2.0
    n = np.array([-math.sin(theta), 0.0, math.cos(theta)])
    found = contact_forces([Contact(0, STATIC, np.zeros(3), np.zeros(3), n)],
                           Bodies(np.array([1.0 / m]), np.zeros((1, 3, 3))), at_rest(1),
                           np.array([[0.0, 0.0, -m * G]]), np.zeros((1, 3)))
    assert found.f == pytest.approx([m * G * math.cos(theta)], rel=1e-12)
    assert found.acceleration == pytest.approx([0.0], abs=1e-12)


def test_block_on_two_points_balances_force_and_moment():
    """Note 001, Figure 8, off-centre: a 1 kg block resting on points 0.1 m behind and
    0.3 m ahead of its centre: f1 + f2 = m g, -0.1 f1 + 0.3 f2 = 0: f1 = 3/4 m g."""
    I_inv = np.diag([1 / 0.01, 1 / 0.02, 1 / 0.03])
    arms = [np.array([-0.1, 0.0, -0.1]), np.array([0.3, 0.0, -0.1])]
    found = contact_forces([Contact(0, STATIC, r, np.zeros(3), Z) for r in arms],
                           Bodies(np.array([1.0]), I_inv[None]), at_rest(1),
                           np.array([[0.0, 0.0, -G]]), np.zeros((1, 3)))
    assert found.f == pytest.approx([0.75 * G, 0.25 * G], rel=1e-12)


def test_contact_lets_go_when_the_body_is_lifted():
    found = contact_forces([Contact(0, STATIC, np.zeros(3), np.zeros(3), Z)],
                           Bodies(np.array([1.0]), np.zeros((1, 3, 3))), at_rest(1),
                           np.array([[0.0, 0.0, 5.0]]), np.zeros((1, 3)))
    assert found.f == pytest.approx([0.0]) and found.acceleration == pytest.approx([5.0])


@pytest.mark.parametrize("n_boxes", [1, 2, 3, 4, 5])
def test_resting_stack_carries_the_weight_above(n_boxes):
    """Unit cubes (1 kg, half-extent 0.1 m) on four corners each: the four forces of an
    interface are indeterminate, their sum is the weight of the cubes above it."""
    half, m = 0.1, 1.0
    I_inv = np.eye(3) / (m * 2 * half * half / 3)
    contacts = [Contact(i, STATIC if i == 0 else i - 1, np.array([sx * half, sy * half, -half]),
                        np.array([sx * half, sy * half, half]), Z)
                for i in range(n_boxes) for sx in (-1, 1) for sy in (-1, 1)]
    found = contact_forces(contacts, Bodies(np.full(n_boxes, 1 / m), np.array([I_inv] * n_boxes)),
                           at_rest(n_boxes), np.tile([0.0, 0.0, -m * G], (n_boxes, 1)), np.zeros((n_boxes, 3)))
    assert found.f.reshape(n_boxes, 4).sum(axis=1) == pytest.approx(m * G * np.arange(n_boxes, 0, -1), rel=1e-12)
    assert np.all(found.f >= 0.0) and np.all(np.abs(found.acceleration) < 1e-12)


# --- A and b against Newton-Euler --------------------------------------------------------------

def newton_euler(bodies, forces):
    """d/dt of the stacked states [x, v, R (9), L] of rigid bodies (m, I0 principal);
    forces(t, states) -> list of (F, T) world force and torque about the centre."""
    def rhs(t, y):
        states = y.reshape(len(bodies), 18)
        out = []
        for (m, I0), state, (F, T) in zip(bodies, states, forces(states)):
            R, L = state[6:15].reshape(3, 3), state[15:]
            w = R @ np.diag(1.0 / I0) @ R.T @ L
            out.append(np.concatenate([state[3:6], F / m, (cross_matrix(w) @ R).ravel(), T]))
        return np.concatenate(out)
    return rhs


def second_derivative(rhs, y0, separation, h=1e-3):
    """s''(0) of s = separation(states): central differences (s(h) - 2 s(0) + s(-h)) / h^2,
    integrated both ways, at h and h/2, Richardson-extrapolated (error O(h^4))."""
    def central(h):
        s = [separation(solve_ivp(rhs, (0.0, end), y0, method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
                        .reshape(-1, 18)) for end in (-h, h)]
        return (s[0] - 2.0 * separation(y0.reshape(-1, 18)) + s[1]) / h**2
    return (4.0 * central(h / 2.0) - central(h)) / 3.0


def rotation(axis, angle):
    k = cross_matrix(np.asarray(axis) / np.linalg.norm(axis))
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k


def state(x, v, R, I0, w):
    """[x, v, R, L] with L = R I0 R^T w."""
    return np.concatenate([x, v, R.ravel(), R @ np.diag(I0) @ R.T @ w])


def test_tumbling_body_on_the_floor_matches_newton_euler():
    """A body with unequal inertias (m = 2 kg, I0 = 0.02, 0.05, 0.08), turned and tumbling
    (w = (1, 2, 0.5) rad/s: L x w != 0), touches the floor with a corner that is
    momentarily at rest (v = -w x r). Newton-Euler with the LCP's force at that corner
    must give the corner's height the acceleration A f + b (zero if f > 0): checks the
    note's F/M, I^-1 (T + L x w) x r and w x (w x r) terms."""
    m, I0 = 2.0, np.array([0.02, 0.05, 0.08])
    R = rotation([1.0, 2.0, 3.0], 0.7)
    w = np.array([1.0, 2.0, 0.5])
    r0 = np.array([0.1, -0.15, -0.2])   # the corner in the body frame
    r = R @ r0
    v = -np.cross(w, r)
    u = np.concatenate([v, w])[None]
    bodies = Bodies(np.array([1.0 / m]), (R @ np.diag(1.0 / I0) @ R.T)[None])
    found = contact_forces([Contact(0, STATIC, r, np.zeros(3), Z)], bodies, u,
                           np.array([[0.0, 0.0, -m * G]]), np.zeros((1, 3)))
    assert found.f[0] > 0.0

    def forces(states):
        (x, _, Rt, _), = [(s[:3], s[3:6], s[6:15].reshape(3, 3), s[15:]) for s in states]
        push = found.f[0] * Z
        return [(np.array([0.0, 0.0, -m * G]) + push, np.cross(Rt @ r0, push))]
    corner_height = lambda states: (states[0, :3] + states[0, 6:15].reshape(3, 3) @ r0) @ Z
    measured = second_derivative(newton_euler([(m, I0)], forces), state(np.zeros(3), v, R, I0, w), corner_height)
    assert measured == pytest.approx(found.acceleration[0], abs=1e-5)


def test_sliding_on_a_turning_body_has_two_n_dot_terms():
    """A small body (a), pulled by gravity, slides at 0.8 m/s across the top face of a
    turning slab (b, floating: no gravity, w_b = (0.3, -0.5, 1.2) rad/s). The face normal turns with b, n' = w_b x n, and the
    separation d = n(t) . (p_a(t) - p_b(t)) (p_b: b's material point under a at t = 0)
    has d'' = n . (p_a'' - p_b'') + 2 n' . (p_a' - p_b'): the note prints one n' term;
    Newton-Euler with the LCP's force decides."""
    m_a, I_a = 0.5, np.array([0.01, 0.01, 0.01])
    m_b, I_b = 3.0, np.array([0.2, 0.3, 0.4])
    R_b = rotation([0.2, 1.0, 0.1], 0.3)
    n0 = np.array([0.0, 0.0, 1.0])          # b's top face normal, body frame
    n = R_b @ n0
    x_b = np.zeros(3)
    rb0 = np.array([0.2, -0.1, 0.1])        # point of b's top face under a, body frame
    p = x_b + R_b @ rb0
    w_b, v_b = np.array([0.3, -0.5, 1.2]), np.array([0.1, 0.0, -0.2])
    ra = np.array([0.0, 0.0, -0.05])        # a's contact point below its centre (a turns with R = 1)
    x_a, w_a = p - ra, np.array([0.4, 0.1, -0.3])
    slide = np.cross(n, [1.0, 0.0, 0.0])
    slide = 0.8 * slide / np.linalg.norm(slide)
    # a's point: the velocity of b's material point plus the tangential slide
    v_a = v_b + np.cross(w_b, p - x_b) + slide - np.cross(w_a, ra)
    I_inv = lambda R, I0: R @ np.diag(1.0 / I0) @ R.T
    bodies = Bodies(np.array([1.0 / m_a, 1.0 / m_b]), np.array([I_inv(np.eye(3), I_a), I_inv(R_b, I_b)]))
    u = np.array([np.concatenate([v_a, w_a]), np.concatenate([v_b, w_b])])
    gravity = np.array([[0.0, 0.0, -m_a * G], [0.0, 0.0, 0.0]])  # a pressed onto a floating b
    found = contact_forces([Contact(0, 1, ra, p - x_b, n)], bodies, u, gravity, np.zeros((2, 3)))
    assert found.f[0] > 0.0

    def forces(states):
        Ra, Rb = (s[6:15].reshape(3, 3) for s in states)
        push = found.f[0] * (Rb @ n0)
        return [(gravity[0] + push, np.cross(Ra @ ra, push)), (gravity[1] - push, np.cross(Rb @ rb0, -push))]

    def separation(states):
        (xa, Ra), (xb, Rb) = ((s[:3], s[6:15].reshape(3, 3)) for s in states)
        return (Rb @ n0) @ ((xa + Ra @ ra) - (xb + Rb @ rb0))
    y0 = np.concatenate([state(x_a, v_a, np.eye(3), I_a, w_a), state(x_b, v_b, R_b, I_b, w_b)])
    measured = second_derivative(newton_euler([(m_a, I_a), (m_b, I_b)], forces), y0, separation)
    assert measured == pytest.approx(found.acceleration[0], abs=1e-5)
    one_term = found.acceleration[0] - np.cross(w_b, n) @ slide  # what the note's b would give
    assert abs(measured - one_term) > 0.05  # the note's single term is off by n' . v = 0.054 m/s^2
