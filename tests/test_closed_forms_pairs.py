"""The closed forms of the per-pair material families against independent routes: the
stopping distances from the work of friction and from stepping Coulomb's law, the row of
balls from an event-driven run that resolves any approaching pair by the impulse of
note 002 (J = (1 + e) m_eff v_rel) until none approaches; and the scenes state each
pair's own material."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cases import pair_friction as pfr
from cases import pair_restitution as pre
from cases.family import CaseError
from cases.trajectory import Trajectory

G = 9.81


# --- pair_friction ----------------------------------------------------------------------------

@pytest.mark.parametrize("p", pfr.GRID, ids=pfr.variant_id)
def test_each_block_has_its_own_pair_and_the_blocks_never_meet(p):
    scene = pfr.scene(p)
    assert scene.material_of("ground", "a").mu_s == p["mu_a"]
    assert scene.material_of("b", "ground").mu_s == p["mu_b"]
    assert scene.material_of("a", "b").mu_s == min(p["mu_a"], p["mu_b"])
    xa, xb = scene.body("a").position[0], scene.body("b").position[0]
    va, vb = scene.body("a").velocity[0], scene.body("b").velocity[0]
    assert xa - xb >= 2 * pfr.HALF and va > 0 > vb  # apart, and moving apart


@pytest.mark.parametrize("p", pfr.GRID, ids=pfr.variant_id)
def test_stop_distances_are_the_work_of_each_pairs_friction(p):
    """Work-energy: mu_i m g d_i = m v0^2 / 2 for each block, so d_a / d_b = mu_b / mu_a."""
    checks = {c.metric: c for c in pfr.expect(p, 1e-3)}
    for name in pfr.BLOCKS:
        mu = p[f"mu_{name}"]
        assert mu * G * checks[f"stop_distance_{name}"].expected == pytest.approx(pfr.V0**2 / 2, rel=1e-12)
    ratio = checks["stop_distance_a"].expected / checks["stop_distance_b"].expected
    assert ratio == pytest.approx(p["mu_b"] / p["mu_a"], rel=1e-12)


def _stepped_slide(v0: float, mu: float, dt: float, steps: int, velocity_first: bool):
    """Coulomb friction stepped exactly (the impulse mu g dt, never past rest)."""
    x = np.zeros(steps + 1)
    v = np.zeros(steps + 1)
    x[0], v[0] = 0.0, v0
    for k in range(steps):
        v_new = max(v[k] - mu * G * dt, 0.0)
        x[k + 1] = x[k] + (v_new if velocity_first else v[k]) * dt
        v[k + 1] = v_new
    return x, v


@pytest.mark.parametrize("velocity_first", [True, False])
@pytest.mark.parametrize("p", pfr.GRID, ids=pfr.variant_id)
def test_stepped_coulomb_friction_reads_within_the_tolerances(p, velocity_first):
    """Both Euler orders, stepped per pair, read by the family's observer: every check holds."""
    dt = 1e-3
    steps = int(round(pfr.duration(p) / dt))
    t = np.arange(steps + 1) * dt
    states = {}
    for name in pfr.BLOCKS:
        x, v = _stepped_slide(pfr.V0, p[f"mu_{name}"], dt, steps, velocity_first)
        s = np.zeros((steps + 1, 13))
        sign = 1.0 if name == "a" else -1.0
        s[:, 0], s[:, 7], s[:, 3] = sign * x, sign * v, 1.0
        states[name] = s
    values = pfr.observe(Trajectory(dt=dt, t=t, states=states), p)
    for c in pfr.expect(p, dt):
        assert abs(values[c.metric] - c.expected) <= c.tolerance, c.metric


# --- pair_restitution -------------------------------------------------------------------------

def _event_driven(masses, pairs_e, x0, v0, radius):
    """Three balls on a line, impacts resolved one at a time when a neighbouring pair
    closes its gap: J = (1 + e) m1 m2 / (m1 + m2) (v_i - v_j) (note 002, two particles);
    returns the final velocities and the pairs that met, in order."""
    x, v = np.array(x0, float), np.array(v0, float)
    m = np.array(masses, float)
    order = []
    for _ in range(100):
        times = []
        for i in range(len(x) - 1):
            closing = v[i] - v[i + 1]
            gap = x[i + 1] - x[i] - 2 * radius
            if closing > 1e-15:
                times.append((max(gap, 0.0) / closing, i))
        if not times:
            return v, order
        dt, i = min(times)
        x += v * dt
        e = pairs_e[(i, i + 1)]
        J = (1.0 + e) * m[i] * m[i + 1] / (m[i] + m[i + 1]) * (v[i] - v[i + 1])
        v[i] -= J / m[i]
        v[i + 1] += J / m[i + 1]
        order.append((i + 1, i + 2))
    raise AssertionError("impacts did not end")


@pytest.mark.parametrize("p", pre.GRID, ids=pre.variant_id)
def test_the_row_meets_twice_and_ends_at_the_closed_form(p):
    scene = pre.scene(p)
    bodies = [scene.body(n) for n in pre.BALLS]
    e = {(0, 1): scene.material_of("b1", "b2").e, (1, 2): scene.material_of("b2", "b3").e}
    v, order = _event_driven([b.mass for b in bodies], e, [b.position[0] for b in bodies],
                             [b.velocity[0] for b in bodies], pre.R)
    assert order == [(1, 2), (2, 3)]            # two impacts, 1-2 then 2-3, and no third
    assert np.allclose(v, pre.final_velocities(p), rtol=0, atol=1e-12)


@pytest.mark.parametrize("p", pre.GRID, ids=pre.variant_id)
def test_the_row_loses_the_deformation_work_of_each_impact(p):
    """Energy: the loss is the sum of note 001's W = m* v_rel^2 (1 - e^2) / 2 per impact."""
    m1, m2, m3 = pre.masses(p)
    v1, v2, v3 = pre.final_velocities(p)
    u = pre.velocities_after(m1, m2, pre.V0, 0.0, p["e12"])[1]
    lost = 0.5 * m1 * pre.V0**2 - 0.5 * (m1 * v1**2 + m2 * v2**2 + m3 * v3**2)
    work = (m1 * m2 / (m1 + m2) * pre.V0**2 * (1 - p["e12"]**2) / 2
            + m2 * m3 / (m2 + m3) * u**2 * (1 - p["e23"]**2) / 2)
    assert lost == pytest.approx(work, rel=1e-12)


@pytest.mark.parametrize("p", pre.GRID, ids=pre.variant_id)
def test_the_impacts_are_far_apart_in_time(p):
    """A compliant contact lasts tens of ms (16 steps here); the impacts must not overlap."""
    t1, t2 = pre.impact_times(p)
    assert t2 - t1 > 0.04 and pre.duration(p) - t2 >= 0.15 - 1e-12


def test_a_row_that_meets_a_third_time_is_refused():
    """Equal masses, soft first impact, hard second: ball 2 bounces back into ball 1."""
    p = {"e12": 0.3, "e23": 0.8, "e13": 0.3, "m": "1:1:1", "dim": 3}
    assert not pre.impacts(1.0, 1.0, 1.0, 0.3, 0.8, pre.V0)[1]
    with pytest.raises(CaseError, match="meet again"):
        pre.expect(p, 1e-3)


@pytest.mark.parametrize("p", pre.GRID, ids=pre.variant_id)
def test_each_impact_has_its_pairs_e(p):
    scene = pre.scene(p)
    assert (scene.material_of("b1", "b2").e, scene.material_of("b3", "b2").e) == (p["e12"], p["e23"])
    assert scene.material_of("b1", "b3").e == p["e13"]
    assert math.isclose(p["e13"], min(p["e12"], p["e23"])) or math.isclose(p["e13"], max(p["e12"], p["e23"]))
