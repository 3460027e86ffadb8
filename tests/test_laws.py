"""physval/readings/laws.py: the physics-law residuals, on hand-made contact points whose residuals
follow from the definitions, and on the reference engine, whose sequential impulses solve
the laws to the solver's tolerance (so a residual there is a bug in the read-out or the
formulas)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cases.trajectory import ContactPoint
from cases.registry import builtin_families
from physval.core import Context
from physval.core.session import Execution
from physval.readings import laws

Z = np.array([0.0, 0.0, 1.0])


def _point(f_n=10.0, f_t=(0.0, 0.0, 0.0), gap=0.0, x=(0.0, 0.0, 0.0)):
    return ContactPoint("box", "ground", np.array(x, float), Z, f_n, np.array(f_t, float), gap)


def test_penetration_is_the_overlap_and_a_gap_is_none():
    r = laws.point_residual(_point(gap=-2e-3), np.zeros(3), np.zeros(3), 0.0, 0.5, 0.5, 1e-6)
    assert r.penetration == pytest.approx(2e-3)
    assert laws.point_residual(_point(gap=1e-3), np.zeros(3), np.zeros(3), 0.0, 0.5, 0.5, 1e-6).penetration == 0.0


def test_complementarity_is_the_power_on_a_contact_separating_faster_than_restitution_asks():
    # 10 N on a contact leaving at 0.3 m/s that arrived at -1 m/s: with e = 0.2 the law
    # allows 0.2 m/s, so 0.1 m/s is too much: 1 W; with e = 0.3 it is exact: 0 W
    v_after, v_before = 0.3 * Z, -1.0 * Z
    assert laws.point_residual(_point(), v_after, v_before, 0.2, 0.5, 0.5, 1e-6).complementarity == pytest.approx(1.0)
    assert laws.point_residual(_point(), v_after, v_before, 0.3, 0.5, 0.5, 1e-6).complementarity == pytest.approx(0.0, abs=1e-12)
    # a pushing force on an approaching contact does no separating work
    assert laws.point_residual(_point(), -0.1 * Z, np.zeros(3), 0.0, 0.5, 0.5, 1e-6).complementarity == 0.0


def test_cone_excess_is_relative_to_mu_s_f_n():
    # |f_t| = 6 N on f_n = 10 N: mu_s = 0.5 allows 5 N, so 20 % too much
    r = laws.point_residual(_point(f_t=(3.6, 4.8, 0.0)), np.zeros(3), np.zeros(3), 0.0, 0.5, 0.4, 1e-6)
    assert r.cone_excess == pytest.approx(0.2)
    inside = laws.point_residual(_point(f_t=(3.0, 0.0, 0.0)), np.zeros(3), np.zeros(3), 0.0, 0.5, 0.4, 1e-6)
    assert inside.cone_excess == 0.0
    frictionless = laws.point_residual(_point(f_t=(1e-3, 0.0, 0.0)), np.zeros(3), np.zeros(3), 0.0, 0.0, 0.0, 1e-6)
    assert frictionless.cone_excess == math.inf


@pytest.mark.parametrize("f_t, gap", [((-4.0, 0.0, 0.0), 0.0),   # full mu_k f_n against the slip
                                      ((0.0, 0.0, 0.0), 1.0),    # no friction
                                      ((0.0, -4.0, 0.0), 1.0),   # full friction, across the slip
                                      ((-2.0, 0.0, 0.0), 0.5)])  # half of it against the slip
def test_dissipation_gap_measures_how_much_less_friction_dissipates_than_it_could(f_t, gap):
    slip = np.array([0.7, 0.0, 0.0])
    r = laws.point_residual(_point(f_t=f_t), slip, slip, 0.0, 0.5, 0.4, 1e-6)
    assert r.dissipation_gap == pytest.approx(gap)


def test_no_dissipation_gap_at_rest_or_without_force():
    assert laws.point_residual(_point(), np.array([1e-4, 0, 0]), np.zeros(3), 0.0, 0.5, 0.4, 1e-6).dissipation_gap is None
    r = laws.point_residual(_point(f_n=0.0), np.array([1.0, 0, 0]), np.zeros(3), 0.0, 0.5, 0.4, 1e-6)
    assert r.cone_excess is None and r.dissipation_gap is None


def test_relative_velocity_uses_start_lever_arms_and_end_velocities():
    p = ContactPoint("ball", "ground", np.array([0.0, 0.0, 0.0]), Z, 1.0, np.zeros(3), 0.0)
    start = {"ball": np.array([0, 0, 0.1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0], float)}
    end = {"ball": np.array([0.002, 0, 0.1, 1, 0, 0, 0, 2.0, 0, 0, 0, 20.0, 0], float)}
    # rolling at 2 m/s with w = v / r about +y: v + w x r = 2 x + (20 y) x (-0.1 z) = 0 with the
    # start's lever arm; the end's, r = (-0.002, 0, -0.1), would make up a normal speed w 0.002
    assert np.allclose(laws.relative_velocity(p, end, start), 0.0, atol=1e-15)
    assert laws.relative_velocity(p, end)[2] == pytest.approx(20.0 * 0.002)


def test_a_steps_points_together_read_as_each_point_alone():
    """The probe folds a step's points in one pass over arrays (point_residuals,
    relative_velocities): each entry is what the one-point forms give, bit for bit."""
    rng = np.random.default_rng(3)
    states = {name: np.concatenate([rng.normal(size=3), [1, 0, 0, 0], rng.normal(size=6)]) for name in ("a", "b")}
    start = {name: s + rng.normal(size=13) * 1e-3 for name, s in states.items()}
    points = [ContactPoint(a, b, rng.normal(size=3), n / np.linalg.norm(n), f_n, rng.normal(size=3), gap)
              for a, b, n, f_n, gap in [("a", "ground", rng.normal(size=3), 5.0, -1e-3), ("b", "a", rng.normal(size=3),
                                        0.0, 2e-3), ("ground", "b", rng.normal(size=3), 3.0, 0.0)]]
    mat = [(0.2, 0.5, 0.4), (0.0, 0.0, 0.0), (0.5, 0.8, 0.6)]
    v, v0 = laws.relative_velocities(points, states, start), laws.relative_velocities(points, start)
    batch = laws.point_residuals(points, v, v0, *(np.array(c) for c in zip(*mat)), 1e-6)
    for i, p in enumerate(points):
        assert np.array_equal(v[i], laws.relative_velocity(p, states, start))
        one = laws.point_residual(p, v[i], v0[i], *mat[i], 1e-6)
        assert one.penetration == batch.penetration[i] and one.complementarity == batch.complementarity[i]
        assert one.cone_excess == (batch.cone_excess[i] if batch.carries[i] else None)
        assert one.dissipation_gap == (batch.dissipation_gap[i] if batch.sliding[i] else None)


def test_the_reference_meets_the_laws_on_the_battery():
    """Sequential impulses solve each contact to their tolerance: the residuals are at the
    solver's convergence level (cone 1e-8 from stopping at a velocity change of 1e-13 m/s
    per row after up to `iterations` sweeps), not at the physics' scale."""
    fams = builtin_families()
    rows = laws.measure(["reference"], Context(), fams, Execution(progress=False)).to_dict("records")
    assert len(rows) >= 6 and not any(r["note"] for r in rows)
    # A bounce is taken at the step boundary nearest the moment of contact (reference_impl/
    # contact.py), so the ball may rebound from up to v dt / 2 inside the ground: a time-
    # stepping choice, not a solver residual (central_impact.rebound_tolerance covers it).
    for r in rows:
        if r["case"] == "central_impact":
            p = next(v.params for v in fams[r["case"]].variants if v.id == r["variant"])
            v_dt = (2 * 9.81 * p["h"]) ** 0.5 * fams[r["case"]].dt_for(p)
            assert r["penetration_mm"] <= 1e3 * v_dt / 2
    assert laws.summary([r for r in rows if r["case"] != "central_impact"])[0]["penetration_mm"] < 1e-6
    worst = laws.summary(rows)[0]
    assert worst["complementarity_W"] < 1e-6
    assert worst["cone_excess"] < 1e-6
    assert worst["dissipation_gap_max"] < 1e-6


def test_an_engine_without_contact_points_gets_a_row_saying_so():
    import dataclasses
    from adapters import registry
    from physval.core.context import Resolver
    adapter = registry.get("reference")
    adapter.capabilities = dataclasses.replace(adapter.capabilities, contact_points=False)
    resolver = Resolver(Context()).provide("reference", adapter)
    rows = laws.measure(["reference"], Context(), builtin_families(), Execution(progress=False),
                        resolver=resolver).to_dict("records")
    assert rows == [{"engine": "reference", "case": "", "variant": "",
                     "note": "the engine does not report per-contact forces"}]
