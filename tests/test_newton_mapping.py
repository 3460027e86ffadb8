"""adapters/newton_engine.py's mapping of e onto the penalty contact of Newton's
semi-implicit and Featherstone solvers, against an independent integration of the contact's
law (a spring, and a damper acting only while the bodies approach)."""
from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("newton")
from adapters.newton_engine import damping_of_restitution, restitution_of_damping  # noqa: E402

pytestmark = pytest.mark.engine("newton-*")


def _bounce(zeta: float, steps: int = 200_000) -> float:
    """Exit over entry speed of a unit oscillator (w = 1) with damping 2 zeta x' while the
    penetration x grows, by RK4 with a fine step."""
    def f(s):
        x, v = s
        return np.array([v, -x - (2.0 * zeta * v if v > 0.0 else 0.0)])
    s, h = np.array([0.0, 1.0]), 40.0 / steps
    for _ in range(steps):
        k1 = f(s); k2 = f(s + h / 2 * k1); k3 = f(s + h / 2 * k2); k4 = f(s + h * k3)
        s_new = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if s_new[0] < 0.0:  # left the contact: exit speed by linear interpolation of v
            t = s[0] / (s[0] - s_new[0])
            return -(s[1] + t * (s_new[1] - s[1]))
        s = s_new
    raise AssertionError("never left the contact")


@pytest.mark.parametrize("zeta", [0.05, 0.3, 0.9, 1.0, 1.7, 4.0])
def test_the_closed_form_restitution_is_the_integrated_bounce(zeta):
    assert restitution_of_damping(zeta) == pytest.approx(_bounce(zeta), abs=2e-4)


@pytest.mark.parametrize("e", [0.01, 0.2, 0.5, 0.9, 0.999])
def test_the_damping_found_gives_the_restitution_asked(e):
    assert restitution_of_damping(damping_of_restitution(e)) == pytest.approx(e, rel=1e-9)


def test_the_ends_of_the_range():
    assert damping_of_restitution(1.0) == 0.0 and math.isinf(damping_of_restitution(0.0))
    assert restitution_of_damping(1.0) == pytest.approx(math.exp(-1.0))
