"""reference_impl/compliant.py: the Hertz constant (the note's equal-sphere form and the
general one agree) and impacts integrated with small steps against the closed forms of
Hooke's and Hertz's law."""
from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from reference_impl import compliant


@settings(max_examples=100, deadline=None)
@given(G=st.floats(1e6, 1e11), nu=st.floats(0.0, 0.49), R=st.floats(1e-3, 1.0))
def test_general_hertz_constant_reduces_to_the_notes_for_equal_spheres(G, nu, R):
    """4/3 E* sqrt(R*) with E = 2 G (1 + nu), R* = R/2 is note 001's 4/3 G/(1 - nu) sqrt(R/2)."""
    E = compliant.youngs_modulus(G, nu)
    general = compliant.hertz_constant(compliant.effective_modulus(E, nu, E, nu), compliant.effective_radius(R, R))
    assert general == pytest.approx(compliant.hertz_constant_equal_spheres(G, nu, R), rel=1e-12)


def test_sphere_on_a_rigid_plane_uses_its_own_radius_and_material():
    """R_2 = inf, E_2 = inf: R* = R, E* = E / (1 - nu^2)."""
    assert compliant.effective_radius(0.1) == 0.1
    assert compliant.effective_modulus(200e9, 0.3, math.inf, 0.3) == pytest.approx(200e9 / 0.91, rel=1e-15)


# relative accuracy of a velocity-Verlet impact resolved in ~1000 steps: O((h / T)^2) ~ 1e-6,
# plus the last step's linear interpolation of the end of contact
IMPACT = 1e-5


@pytest.mark.parametrize("m2", [1.0, 3.0, 100.0])
def test_hooke_impact_is_half_an_oscillation(m2):
    """F = k xi: the overlap is half a sine of frequency w = sqrt(k / m_eff): contact lasts
    pi / w, xi_max = v / w, and the bodies leave with e = 1 (the brief's closed form)."""
    m1, v1, v2, k = 1.0, 2.0, -1.0, 1e5
    m_eff = 1.0 / (1.0 / m1 + 1.0 / m2)
    w = math.sqrt(k / m_eff)
    out = compliant.central_impact(m1, m2, v1, v2, compliant.ForceLaw(k, 1.0), h=math.pi / w / 1000)
    assert out.duration == pytest.approx(math.pi / w, rel=IMPACT)
    assert out.xi_max == pytest.approx((v1 - v2) / w, rel=IMPACT)
    assert out.v_1 == pytest.approx((m1 * v1 + m2 * v2 - m2 * (v1 - v2)) / (m1 + m2), abs=IMPACT * (v1 - v2))
    assert out.v_2 == pytest.approx((m1 * v1 + m2 * v2 + m1 * (v1 - v2)) / (m1 + m2), abs=IMPACT * (v1 - v2))


@pytest.mark.parametrize("m2", [1.0, 3.0, 100.0])
def test_hertz_impact_closed_form(m2):
    """F = H xi^1.5: energy 1/2 m_eff v^2 = 2/5 H xi_max^2.5 gives
    xi_max = (5 m_eff v^2 / (4 H))^(2/5); the contact lasts
    2 int_0^xi_max dxi / sqrt(v^2 - 4 H xi^2.5 / (5 m_eff)) (computed here by quadrature,
    about 2.94 xi_max / v); elastic: e = 1. Steel spheres r = 0.1 m (H from E = 200 GPa,
    nu = 0.3), 1 kg and m2, closing at 3 m/s."""
    m1, v1, v2 = 1.0, 2.0, -1.0
    v = v1 - v2
    H = compliant.hertz_constant(compliant.effective_modulus(200e9, 0.3, 200e9, 0.3),
                                 compliant.effective_radius(0.1, 0.1))
    m_eff = 1.0 / (1.0 / m1 + 1.0 / m2)
    xi_max = (5.0 * m_eff * v * v / (4.0 * H)) ** 0.4
    duration = 2.0 * quad(lambda x: 1.0 / math.sqrt(max(v * v - 4.0 * H * x**2.5 / (5.0 * m_eff), 0.0)),
                          0.0, xi_max, limit=200)[0]
    assert duration == pytest.approx(2.9432 * xi_max / v, rel=1e-4)
    out = compliant.central_impact(m1, m2, v1, v2, compliant.ForceLaw(H, 1.5), h=duration / 1000)
    assert out.xi_max == pytest.approx(xi_max, rel=IMPACT)
    assert out.duration == pytest.approx(duration, rel=1e-4)  # the end is interpolated linearly
    assert out.v_1 == pytest.approx((m1 * v1 + m2 * v2 - m2 * v) / (m1 + m2), abs=IMPACT * v)
    assert out.v_2 == pytest.approx((m1 * v1 + m2 * v2 + m1 * v) / (m1 + m2), abs=IMPACT * v)


def test_force_law_cannot_pull():
    assert compliant.ForceLaw(1e9, 1.5).force(-1e-3) == 0.0
