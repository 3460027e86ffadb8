"""Round-off allowances (cases/roundoff.py, Check.roundoff and Check.roundoff_at): sound for
the arithmetic they stand for, tight (a few times the rounding a flight really makes, not
a worst-case sum a thousand times it), and leaving no room for a wrong g on any float32
engine's sub-step count."""
from __future__ import annotations

import numpy as np
import pytest

from cases import conformance as cf
from cases import free_rigid_body as fr
from cases import roundoff
from cases.family import Check
from cases.observables import free_flight_error
from physval import faults

G = np.array([0.0, 0.0, -9.81])
# every engine declaring float32 steps k = 1 (MuJoCo Warp, Newton's solvers, PhysX) or its
# iterations as k sub-steps (Box2D, Box3D, Rapier: 4 by default)
FLOAT32_SUBSTEPS = (1, 4)


def emulated_velocity_drift(steps, dt, v0, g, k, F=np.float32) -> float:
    """max |v - v0 - g t| of v += g h stepped in F, k sub-steps a step."""
    h = F(dt / k)
    c = (h * np.asarray(g, float).astype(F)).astype(F)
    v = np.add.accumulate(np.vstack([np.asarray(v0, float).astype(F)[None, :],
                                     np.broadcast_to(c, (steps * k, len(c)))]), axis=0, dtype=F)
    t = np.arange(steps * k + 1) * (dt / k)
    exact = np.asarray(v0, float) + np.asarray(g, float) * t[:, None]
    return float(np.max(np.linalg.norm(v.astype(float) - exact, axis=1)))


def flights():
    """(name, steps, dt, x0, v0) of the families' free flights."""
    for p in fr.GRID:
        yield fr.variant_id(p), max(1, round(fr.duration(p) / fr.DT)), fr.DT, fr.X0, fr._body(p).velocity
    yield "conformance free fall", 1000, 1e-3, (0.0, 0.0, 10.0), (0.0, 0.0, 0.0)


@pytest.mark.parametrize("k", FLOAT32_SUBSTEPS)
@pytest.mark.parametrize("name,steps,dt,x0,v0", list(flights()), ids=[f[0] for f in flights()])
def test_the_velocity_bound_holds_and_is_tight(name, steps, dt, x0, v0, k):
    """The float32 drift of v += g h stays within velocity_roundoff's k u share, and uses at
    least an eighth of it: a constant increment rounds the same way throughout a binade, so
    the errors add up (a bound from the values actually rounded, not from the largest)."""
    bound = roundoff.velocity_roundoff(steps, dt, v0, G) * k * 2.0**-24
    drift = emulated_velocity_drift(steps, dt, v0, G, k)
    assert drift <= bound
    assert drift >= bound / 8.0, f"{drift:.3g} of {bound:.3g}: not tight"


def test_the_emulation_reproduces_a_float32_engine_bit_for_bit():
    """Rapier's free_rigid_body flight (4 sub-steps, float32) reads 7.3439e-4 m/s of velocity
    drift and 1.3484e-4 m of position error in the default run; the emulation gives the same
    numbers from the arithmetic alone (so its positions are a measurement, not a model)."""
    p = fr.GRID[0]
    steps = round(fr.duration(p) / fr.DT)
    v0 = fr._body(p).velocity
    assert emulated_velocity_drift(steps, fr.DT, v0, G, 4) == pytest.approx(7.3439e-4, rel=1e-4)
    assert roundoff.flight_position_error(steps, fr.DT, fr.X0, v0, G, 32, 4) == pytest.approx(1.3484e-4, rel=1e-4)
    assert roundoff.flight_position_error(steps, fr.DT, fr.X0, v0, G, 64, 4) < 1e-11


@pytest.mark.parametrize("k", FLOAT32_SUBSTEPS)
def test_a_wrong_g_fails_every_float32_free_flight(k):
    """The Gravity fault's 9.80 for 9.81 (0.1 %) leaves each free-flight check of
    conformance and free_rigid_body at least 1.5 times its float32 allowance at k sub-steps
    (the worst-case linear sums let 0.3 % and 2.2 % through)."""
    rel = 1.0 - faults.Gravity.g_used / faults.Gravity.g_asked
    assert rel == pytest.approx(1e-3, rel=0.02)
    checks = [(p, c) for p in fr.GRID for c in fr.expect(p, fr.DT)
              if c.metric in ("com_velocity_error", "com_position_error")]
    for p, c in checks:
        T = round(fr.duration(p) / fr.DT) * fr.DT
        t = np.arange(round(T / fr.DT) + 1) * fr.DT
        v0 = np.asarray(fr._body(p).velocity)
        wrong = G * (1.0 - rel)
        if c.metric == "com_velocity_error":
            error = float(np.max(np.linalg.norm((wrong - G) * t[:, None], axis=1)))
        else:
            error = free_flight_error(np.asarray(fr.X0) + v0 * t[:, None] + 0.5 * wrong * t[:, None] ** 2,
                                      fr.X0, v0, G, t, fr.DT)
        assert error > 1.5 * c.at_precision(32, k).tolerance, (fr.variant_id(p), c.metric)
    fall = next(c for c in cf._expect({"check": "free_fall_matches_discrete_closed_form", "dim": 3}, 1e-3)
                if c.metric == "discrete_error")
    t = np.arange(1001) * 1e-3
    z = 10.0 - 0.5 * 9.81 * (1.0 - rel) * t**2
    assert free_flight_error(z[:, None], [10.0], [0.0], [-9.81], t, 1e-3) > 1.5 * fall.at_precision(32, k).tolerance


def test_at_precision_adds_both_round_off_parts_and_float64_keeps_its_bar():
    calls = []

    def at(bits, k):
        calls.append((bits, k))
        return 1e-3 if bits == 32 else 0.0
    c = Check("x", "m", 0.0, 1e-9, "abs", "why", roundoff=2.0, roundoff_at=at)
    assert c.at_precision(32, 4).tolerance == pytest.approx(1e-9 + 2.0 * 4 * 2.0**-24 + 1e-3)
    assert c.at_precision(64, 1).tolerance == pytest.approx(1e-9 + 2.0 * 2.0**-53)
    assert calls == [(32, 4), (64, 1)]
    assert c.at_precision(32, 4).roundoff_at is None

