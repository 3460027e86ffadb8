"""Every check keeps its meaning under a fault: an engine whose gravity, time step,
restitution or friction is a little off must be judged `fail`, with a size, never
`error` (an observer that crashed) or `unstable` (one that returned NaN).

`Faulty` plants a fault in the reference engine (adapters/planting.py), which then builds
a subtly wrong world from the scene it is given: gravity scaled, every pair's e or mu
scaled, or its time step longer than the one the harness asked for (so the harness reads
time as if the step were dt). The observers must still find free flight, arcs and slides
in what it does, and the closed forms must then reject it.
"""
from __future__ import annotations

import functools
from dataclasses import replace

import pytest

from adapters import registry
from adapters.planting import Fault, Planted
from cases.registry import builtin_families
from physval.core import Job
from tests.helpers import run_job

FAULTS = {
    "g=9.80": dict(g=9.80 / 9.81),    # the measured fault of issue 11
    "g+5%": dict(g=1.05),
    "g-5%": dict(g=0.95),
    "dt+1%": dict(dt=1.01),
    "e-5%": dict(e=0.95),
    "mu+5%": dict(mu=1.05),
    "mu-5%": dict(mu=0.95),
}


class Scaled(Fault):
    """One fault of FAULTS: gravity scaled, every pair's e or mu scaled, or a time step
    longer than the one the harness asked for (so the harness reads time as if the step
    were dt)."""
    name = "scaled"

    def __init__(self, g: float = 1.0, dt: float = 1.0, e: float = 1.0, mu: float = 1.0):
        self.g, self.dt, self.e, self.mu = g, dt, e, mu

    def _material(self, m):
        return replace(m, e=min(m.e * self.e, 1.0), mu_s=m.mu_s * self.mu,
                       mu_k=None if m.mu_k is None else m.mu_k * self.mu)

    def scene(self, scene, capabilities):
        return replace(scene, gravity=tuple(self.g * c for c in scene.gravity),
                       material=self._material(scene.material),
                       pairs=tuple((a, b, self._material(m)) for a, b, m in scene.pairs))

    def settings(self, settings):
        return replace(settings, dt=settings.dt * self.dt)


def Faulty(**fault) -> Planted:
    """The reference engine building a world with one fault (see FAULTS), planted through
    the adapter layer's hook (adapters/planting.py)."""
    return Planted(registry.get("reference"), Scaled(**fault), name="faulty")


@functools.cache
def rows(family: str, variant: str, fault: str) -> tuple[dict, ...]:
    fam = builtin_families()[family]
    (v,) = [v for v in fam.variants if v.id == variant]
    return tuple(run_job(Job(family, v, "faulty"), fam, adapter=Faulty(**FAULTS[fault]), known=[]))


# (family, variant, fault, checks that must fail): the faults the issue measured, and each
# family's closed form rejecting what it can see. Gravity does not change a rebound ratio
# or an apex (e^2 h is geometry): there the fault must only be read, not crash the reading.
CASES = [
    ("central_impact", "drop,e=0.5", "g=9.80", set()),
    ("central_impact", "drop,e=0.5", "dt+1%", set()),
    ("central_impact", "drop,e=0.9,2D", "g-5%", set()),
    ("central_impact", "drop,e=0.5", "e-5%", {"rebound_ratio", "first_apex"}),
    ("bounce_series", "e=0.5", "g=9.80", {"impact_time_1"}),  # 0.18 ms late against 0.05 ms
    ("bounce_series", "e=0.5", "g+5%", {"impact_time_1", "impact_time_2", "impact_time_3", "rest_time"}),
    ("bounce_series", "e=0.5", "dt+1%", {"impact_time_1", "impact_time_2", "impact_time_3", "rest_time"}),
    ("bounce_series", "e=1.0", "g=9.80", {"impact_time_1", "impact_time_2"}),
    ("bounce_series", "e=1.0", "e-5%", {"apex_1", "apex_2", "apex_3", "apex_4"}),
    ("incline_threshold", "mu=0.5,theta=atan(mu_s)+1deg", "g+5%", {"sliding_acceleration"}),
    ("incline_threshold", "mu=0.5,theta=atan(mu_s)+1deg", "dt+1%", {"sliding_acceleration"}),
    ("incline_threshold", "mu=0.5,theta=1.005atan(mu_s)", "mu+5%", {"slides"}),      # holds too much
    ("incline_threshold", "mu=0.5,theta=0.995atan(mu_s)", "mu-5%", {"slides", "creep_rate"}),  # lets go early
    ("rolling_incline", "theta=20deg,mu=0.2", "g-5%", {"acceleration", "angular_acceleration"}),
    ("eccentric_impact", "e=0.5,mu=1.0,slip=1", "mu-5%", set()),
    ("eccentric_impact", "e=0.5", "e-5%", {"vx_1", "vx_2", "wy_2", "energy_lost"}),
    ("stack_strike", "n=1,m=0.2,h=0.1", "g+5%", {"ground_impulse"}),
    ("tumbling_box", "tilt=y,e=0.0,mu=0.8", "g-5%", {"ground_impulse"}),
]


@pytest.mark.parametrize("family, variant, fault, failing", CASES,
                         ids=[f"{f}[{v}]-{fault}" for f, v, fault, _ in CASES])
def test_a_fault_is_judged_not_crashed(family, variant, fault, failing):
    got = rows(family, variant, fault)
    broken = [f"{r['metric']}: {r['status']} ({r['reason']})" for r in got if r["status"] in ("error", "unstable")]
    assert not broken, broken
    fails = {r["metric"] for r in got if r["status"] == "fail"}
    assert failing <= fails, f"{sorted(failing - fails)} passed under {fault}"
    for r in got:
        if r["status"] == "fail":  # with a size
            assert r["abs_error"] == r["abs_error"] and r["abs_error"] > 0.0


def test_the_unfaulted_wrapper_passes():
    """The wrapper itself changes nothing: without a fault every check above passes, so a
    failure under a fault is the fault's."""
    fam = builtin_families()["bounce_series"]
    (v,) = [v for v in fam.variants if v.id == "e=0.5"]
    assert {r["status"] for r in run_job(Job(fam.name, v, "faulty"), fam, adapter=Faulty(), known=[])} == {"pass"}
