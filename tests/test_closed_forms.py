"""Each case's closed-form expectation against an independent derivation: the grader
must be right before it judges an engine."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from cases import central_impact as ci
from cases import incline_threshold as it
from cases import resting_blocks as rb
from tests.fakes import coulomb_on_plane

masses = st.floats(0.01, 100.0)
speeds = st.floats(-10.0, 10.0)
cors = st.floats(0.0, 1.0)


@given(masses, masses, speeds, speeds, cors)
def test_post_impact_velocities_solve_momentum_and_restitution(m1, m2, v1, v2, e):
    # Two linear equations: m1 v1' + m2 v2' = m1 v1 + m2 v2 and v2' - v1' = -e (v2 - v1).
    A = np.array([[m1, m2], [-1.0, 1.0]])
    b = np.array([m1 * v1 + m2 * v2, -e * (v2 - v1)])
    expected = np.linalg.solve(A, b)
    assert np.allclose(ci.velocities_after(m1, m2, v1, v2, e), expected, rtol=1e-9, atol=1e-9)


@given(masses, masses, speeds, speeds, cors)
def test_deformation_work_is_the_kinetic_energy_lost(m1, m2, v1, v2, e):
    u1, u2 = np.linalg.solve([[m1, m2], [-1.0, 1.0]], [m1 * v1 + m2 * v2, -e * (v2 - v1)])
    lost = 0.5 * (m1 * v1**2 + m2 * v2**2) - 0.5 * (m1 * u1**2 + m2 * u2**2)
    scale = 0.5 * (m1 * v1**2 + m2 * v2**2) + 1e-12
    assert abs(ci.deformation_work(m1, m2, v1 - v2, e) - lost) <= 1e-9 * scale


def test_deformation_work_of_a_plastic_impact_is_the_relative_kinetic_energy():
    # The note's slide omits the 1/2: with e = 0 and m2 -> infinity, the whole kinetic energy
    # (1/2) m1 v^2 of the moving body is lost, not m1 v^2.
    assert ci.deformation_work(2.0, 1e12, 3.0, 0.0) == pytest.approx(0.5 * 2.0 * 9.0, rel=1e-9)


@given(st.floats(0.0, 1.0), st.floats(0.1, 5.0))
def test_first_apex_from_kinematics(e, h):
    g = 9.81
    v_in = math.sqrt(2 * g * h)           # energy: fall from rest through h
    v_out = e * v_in                      # restitution
    t_up = v_out / g                      # rise until the velocity is zero
    apex = v_out * t_up - 0.5 * g * t_up**2
    assert ci.first_apex(e, h) == pytest.approx(apex, rel=1e-9, abs=1e-12)


@given(st.floats(0.01, 1.5))
def test_threshold_is_where_friction_balances_gravity(mu):
    # Bisection on the force balance m g sin(th) = mu m g cos(th): the threshold is atan(mu),
    # never mu itself (a known grader bug in earlier suites).
    lo, hi = 0.0, math.pi / 2 - 1e-9
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if math.sin(mid) < mu * math.cos(mid) else (lo, mid)
    assert it.threshold_angle(mu) == pytest.approx(lo, abs=1e-9)
    assert it.slides(lo + 1e-6, mu) and not it.slides(lo - 1e-6, mu)


def plane_frame(theta: float) -> tuple[np.ndarray, np.ndarray]:
    """(downhill t, normal n) of a plane tilted by theta about y in a world whose gravity is
    straight down: n = R_y(theta) e_z, t the steepest descent along the plane."""
    c, s = math.cos(theta), math.sin(theta)
    R_y = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    n = R_y @ np.array([0.0, 0.0, 1.0])
    g = np.array([0.0, 0.0, -9.81])
    along = g - (g @ n) * n
    return along / np.linalg.norm(along), n


@pytest.mark.parametrize("mu_s, mu_k", [(0.2, 0.2), (0.5, 0.5), (0.8, 0.8), (0.5, 0.3)])
@pytest.mark.parametrize("angle", ["-1deg", "0.995", "1.005", "+1deg", "+10deg"])
def test_sliding_acceleration_from_integrating_coulomb_friction_on_a_tilted_plane(mu_s, mu_k, angle):
    """A second way: the plane tilted in a world with vertical gravity (its components along
    and into the plane from vector geometry, not sin and cos of the case), and the box's
    motion from integrating Coulomb friction in time (tests/fakes.coulomb_on_plane): it stays
    (no acceleration) or slides with the case's g (sin - mu_k cos). The scene's tilted
    gravity is that same vector in the plane's frame."""
    th = math.atan(mu_s) * float(angle) if "deg" not in angle else math.atan(mu_s) + math.radians(float(angle[:-3]))
    t, n = plane_frame(th)
    g = np.array([0.0, 0.0, -9.81])
    assert it.tilted_gravity(th, 9.81) == pytest.approx((g @ t, 0.0, g @ n), abs=1e-12)
    a, _ = coulomb_on_plane(g @ t, -(g @ n), mu_s, mu_k, duration=2.0)
    if it.slides(th, mu_s):
        assert it.sliding_acceleration(th, mu_k) == pytest.approx(a, rel=1e-7)
    else:
        assert abs(a) < 1e-9  # held: it does not accelerate


@pytest.mark.parametrize("n", range(1, 11))
def test_stack_forces_from_free_body_equations(n):
    # Box k: F_k (from below) - F_{k+1} (from above) - m g = 0, with F_n = 0 on top.
    m, g = 1.0, 9.81
    A = np.zeros((n, n))
    for k in range(n):
        A[k, k] = 1.0
        if k + 1 < n:
            A[k, k + 1] = -1.0
    F = np.linalg.solve(A, np.full(n, m * g))
    assert [rb.interface_force(n, k, m, g) for k in range(n)] == pytest.approx(F, rel=1e-12)


def test_grid_is_what_the_issue_asks_for():
    spheres = [p for p in ci.GRID if p["setup"] == "spheres"]
    assert {p["e"] for p in spheres} == {0.0, 0.5, 0.9, 1.0}
    assert {p["m"] for p in spheres} == {"1:1", "1:3", "1:100"}
    offsets = {p["offset_deg"] for p in it.GRID if "offset_deg" in p}
    assert {-10.0, -1.0, 1.0, 10.0} <= offsets  # well below, just below, just above, well above
    assert [p["n"] for p in rb.GRID if p["dim"] == 3] == [1, 2, 3, 4, 5]
