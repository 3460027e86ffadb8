"""The observables read what they claim from a trajectory whose answer is known exactly:
a continuous-time bounce sampled at dt, with the impact at any phase within a step."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from cases import central_impact as ci
from cases.trajectory import Trajectory

G, R = 9.81, ci.R


def exact_bounce(e: float, h: float, dt: float, phase: float) -> Trajectory:
    """Ball bottom from height h (plus a phase shift), exact restitution at z = 0."""
    z0 = h + phase
    t_hit = math.sqrt(2 * z0 / G)
    v_out = e * G * t_hit
    t = np.arange(0.0, t_hit + 1.5 * max(v_out, 1e-9) / G + 0.1, dt)
    z = np.where(t < t_hit, z0 - 0.5 * G * t**2, v_out * (t - t_hit) - 0.5 * G * (t - t_hit) ** 2)
    vz = np.where(t < t_hit, -G * t, v_out - G * (t - t_hit))
    if e == 0:
        z, vz = np.where(t < t_hit, z, 0.0), np.where(t < t_hit, vz, 0.0)
    states = np.zeros((len(t), 13))
    states[:, 2], states[:, 3], states[:, 9] = z + R, 1.0, vz
    return Trajectory(dt=dt, t=t, states={"ball": states})


@settings(max_examples=40, deadline=None)
@given(st.sampled_from([0.0, 0.5, 0.9, 1.0]), st.floats(0.0, 1e-3))
def test_rebound_ratio_and_apex_at_any_phase(e, phase):
    dt = 1e-3
    obs = ci.observe(exact_bounce(e, 1.0, dt, phase), {"setup": "drop", "e": e, "h": 1.0})
    assert obs["rebound_ratio"] == pytest.approx(e, abs=1e-9)
    # the apex is sampled: it may fall between samples by at most g dt^2 / 8
    assert obs["first_apex"] == pytest.approx(e**2 * (1.0 + phase), abs=G * dt**2 / 8 + 1e-12)


def test_a_rebound_that_is_too_weak_fails_the_check():
    traj = exact_bounce(0.45, 1.0, 1e-3, 0.0)
    obs = ci.observe(traj, {"setup": "drop", "e": 0.5, "h": 1.0})
    (ratio,) = [c for c in ci.expect({"setup": "drop", "e": 0.5, "h": 1.0}, 1e-3) if c.metric == "rebound_ratio"]
    assert abs(obs["rebound_ratio"] - ratio.expected) > ratio.tolerance
