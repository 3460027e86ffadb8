"""reference_impl/spook.py: the parameters of note 004, and what SPOOK is - a spring k
with damping c = k d h (relaxation time d steps) solved as a constraint - checked against
the damped oscillator's closed form and the spring's static deflection."""
from __future__ import annotations

import math

import numpy as np
import pytest

from reference_impl import lcp, spook
from reference_impl.lcp import STATIC, Bodies, Contact

Z = np.array([0.0, 0.0, 1.0])


def test_parameters_of_note_004():
    eps, a, b = spook.parameters(k=1e6, d=4.0, h=1e-3)
    assert eps == pytest.approx(4.0 / (1e6 * 1e-6 * 17.0), rel=1e-15)
    assert a == pytest.approx(4.0 / (1e-3 * 17.0), rel=1e-15)
    assert b == pytest.approx(16.0 / 17.0, rel=1e-15)


def drop_on_spring(m, k, d, h, g, seconds, q0=0.0):
    """A particle touching the floor (gap q0) under gravity g, stepped by SPOOK alone: the
    gap moves by h times the separation velocity after each step. Returns the overlap -q
    after every step."""
    bodies = Bodies(np.array([1.0 / m]), np.zeros((1, 3, 3)))
    rows = lcp.build_rows([Contact(0, STATIC, np.zeros(3), np.zeros(3), Z)], np.zeros((1, 6)))
    W, q, a_ext = np.zeros((1, 6)), q0, np.zeros((1, 6))
    a_ext[0, 2] = -g
    settings = spook.SpookSettings(k=k, d=d)
    overlap = []
    for _ in range(round(seconds / h)):
        W = spook.step_velocities(rows, bodies, W, a_ext, np.array([q]), h, settings).u
        q += h * W[0, 2]
        overlap.append(-q)
    return np.array(overlap)


@pytest.mark.parametrize("tau", [0.02, 0.005])
def test_spook_is_a_spring_damper_with_relaxation_time_d_steps(tau):
    """m x'' = m g - k x - c x' with c = k tau and tau = d h, x the overlap, from rest at
    x = 0: x = x_eq (1 - e^(-zeta w t) (cos w_d t + zeta / sqrt(1 - zeta^2) sin w_d t)),
    x_eq = m g / k, w = sqrt(k / m), zeta = c / (2 sqrt(k m)), w_d = w sqrt(1 - zeta^2).
    m = 1 kg, k = 100 N/m, g = 10 m/s^2 (x_eq = 0.1 m), h = 1e-4 s: agreement to O(h)."""
    m, k, g, h = 1.0, 100.0, 10.0, 1e-4
    x = drop_on_spring(m, k, tau / h, h, g, 0.5)
    t = h * np.arange(1, len(x) + 1)
    w, zeta = math.sqrt(k / m), k * tau / (2.0 * math.sqrt(k * m))
    w_d = w * math.sqrt(1.0 - zeta**2)
    expected = m * g / k * (1.0 - np.exp(-zeta * w * t) * (np.cos(w_d * t) + zeta / math.sqrt(1.0 - zeta**2)
                                                           * np.sin(w_d * t)))
    assert np.max(np.abs(x - expected)) < 1e-3 * m * g / k


def test_resting_overlap_is_the_springs_static_deflection():
    """Stiff contact at the engine's step (k = 1e6 N/m, h = 1e-3 s, d = 4): a 1 kg particle
    comes to rest at overlap m g / k = 9.81 um (re-derived in spook.py: at rest
    lambda = m g h and -q = eps lambda / a = m g / k)."""
    x = drop_on_spring(1.0, 1e6, 4.0, 1e-3, 9.81, 0.2)
    assert x[-1] == pytest.approx(9.81e-6, rel=1e-9)
    assert np.all(x >= 0.0)  # it sinks in without bouncing off (critically damped and more)


def test_known_deviation_restoring_an_overlap_launches_the_body():
    """Finding: a unilateral SPOOK contact restores an overlap by a velocity, not a force.
    A particle at rest 1 mm deep (stiff contact, no gravity, d = 4, h = 1 ms) gets
    v = a |q| = 4 |q| / (h (1 + 4d)) = 0.235 m/s in the first step; the next steps ask for
    less (a |q'| + (1 - b) v < v) and the contact cannot pull, so the particle keeps
    0.235 m/s and leaves. In the world this is the bounce of an e = 0 impact whose contact
    was found only after the bodies overlapped (see test_ref_formulations_world.py)."""
    x = drop_on_spring(1.0, 1e12, 4.0, 1e-3, 0.0, 0.02, q0=-1e-3)
    speed = -np.diff(x) / 1e-3
    assert speed == pytest.approx(np.full(len(speed), 4.0 / 17.0), rel=1e-6)
