"""The parameters each engine really uses: asked vs measured.

For several requested values, measure on each engine
- restitution: the rebound ratio of a dropped ball (central_impact's drop scene and
  observable);
- static friction: the break-away angle of a box on an incline, found by bisection on
  incline_threshold's scene (sliding = accelerating), reported as tan(angle);
- kinetic friction: from the sliding acceleration 10 deg above the threshold,
  mu_k = tan(theta) - a / (g cos(theta)).
A mismatch is a finding for the report, not a verdict: these rows have no tolerance.
"""
from __future__ import annotations

import math

from adapters import registry
from adapters.base import Adapter, Settings, Unsupported
from cases import central_impact, incline_threshold
from physval.runner import Unstable, simulate

DT = 1e-3
RESTITUTIONS = (0.2, 0.5, 0.8, 1.0)
FRICTIONS = (0.2, 0.5, 0.8)
BISECTIONS = 12  # 20 deg bracket / 2^12: the break-away angle to 0.005 deg, tan to ~1e-4
# Sliding means accelerating: creep of a sticking box is a constant mm/s at worst, while
# 0.04 deg above the threshold a box accelerates at about 0.007 m/s^2. (The case's own
# verdict, 1 cm in 1 s, would put the threshold about 0.1 deg late: +0.002 in tan.)
A_SLIDING = 1e-3  # m/s^2: tan(theta) resolved to A / (g cos theta) ~ 1e-4


def _dimension(adapter: Adapter) -> int:
    return 3 if 3 in adapter.capabilities.dimensions else 2


def _observe(adapter: Adapter, family, params: dict) -> dict:
    scene = family.scene(params)
    with adapter.build(scene, Settings(DT)) as sim:
        run = simulate(sim, scene, DT, family.duration(params))
    return family.observe(run.trajectory, params)


def rebound_ratio(adapter: Adapter, e: float) -> float:
    params = {"setup": "drop", "e": e, "h": central_impact.H, "dim": _dimension(adapter)}
    return _observe(adapter, central_impact.FAMILY, params)["rebound_ratio"]


def _incline(adapter: Adapter, mu: float, offset_deg: float) -> dict:
    params = {"mu_s": mu, "mu_k": mu, "offset_deg": offset_deg, "dim": _dimension(adapter)}
    return _observe(adapter, incline_threshold.FAMILY, params)


def breakaway_angle(adapter: Adapter, mu: float) -> float:
    """Bisection between atan(mu) - 10 deg (must stay) and + 10 deg (must slide), in rad."""
    lo, hi = -10.0, 10.0
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        if _incline(adapter, mu, mid)["sliding_acceleration"] > A_SLIDING:
            hi = mid
        else:
            lo = mid
    return math.atan(mu) + math.radians(0.5 * (lo + hi))


def kinetic_friction(adapter: Adapter, mu: float) -> float:
    theta = math.atan(mu) + math.radians(10.0)
    a = _incline(adapter, mu, 10.0)["sliding_acceleration"]
    return math.tan(theta) - a / (incline_threshold.G * math.cos(theta))


def measure(engine: str) -> list[dict]:
    """Asked-vs-measured rows for one engine; a run that fails is a row with its reason."""
    try:
        adapter = registry.get(engine)
    except registry.EngineError as exc:
        return [dict(engine=engine, parameter="-", asked=math.nan, measured=math.nan, note=str(exc))]
    rows = []
    probes = [("restitution e", e, lambda e=e: rebound_ratio(adapter, e), "rebound ratio of a dropped ball")
              for e in RESTITUTIONS]
    probes += [("static friction mu_s", mu, lambda mu=mu: math.tan(breakaway_angle(adapter, mu)),
                "tan of the break-away angle") for mu in FRICTIONS]
    probes += [("kinetic friction mu_k", mu, lambda mu=mu: kinetic_friction(adapter, mu),
                "sliding acceleration 10 deg above the threshold") for mu in FRICTIONS]
    for name, asked, run, how in probes:
        try:
            value, note = run(), how
        except (Unsupported, Unstable) as exc:
            value, note = math.nan, f"{type(exc).__name__}: {exc}"
        except Exception as exc:  # an engine crash is recorded; the others go on
            value, note = math.nan, f"error: {type(exc).__name__}: {exc}"
        rows.append(dict(engine=engine, parameter=name, asked=asked, measured=value,
                         difference=value - asked, note=f"{how}; dt = {DT:g} s, {_dimension(adapter)}D"
                         if note == how else note))
    return rows
