"""Where two trajectories of one scene part: the measure `physval compare` applies to two
runs of a job (physval.readings.divergence) and the invariance battery to a run and its
transformed twin (physval.core.invariance).

Differences are taken per state quantity relative to its scale in the job (`scales`): the
scene's size L (the largest distance of a body from the origin), its speed (the largest body
speed, and at least sqrt(g L), what a fall across the scene reaches), its rate of turning
(the largest angular speed, and at least speed / L); a quaternion's scale is 1. Scales are
the job's, not each body's: a box resting in a stack turns at ~1e-13 rad/s, rounding, and
measured against that its rounding would part at once. PARTED = 1e-9 lies seven orders of
magnitude above the rounding of one double-precision operation (1.1e-16), so a double engine
that reorders a sum does not part at once, and below anything a plot or a check can show
(1 nm on a scene of a metre). Two trajectories equal to the last bit never part.
"""
from __future__ import annotations

import numpy as np

from cases.trajectory import OMEGA, POS, QUAT, VEL

PARTED = 1e-9
G = 9.81  # m/s^2: the floor of the speed scale is sqrt(G L)
QUANTITIES = (("position", POS), ("orientation", QUAT), ("velocity", VEL), ("angular velocity", OMEGA))


def scales(states: list[np.ndarray]) -> dict[str, float]:
    """Each quantity's scale over every body of both runs (the module's docstring)."""
    def largest(cols):
        return max((float(np.nanmax(np.linalg.norm(s[:, cols], axis=1), initial=0.0)) for s in states), default=0.0)
    size = max(largest(POS), np.finfo(float).tiny)
    speed = max(largest(VEL), np.sqrt(G * size))
    return {"position": size, "orientation": 1.0, "velocity": speed,
            "angular velocity": max(largest(OMEGA), speed / size)}


def relative(sa: np.ndarray, sb: np.ndarray, scale: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """(per sample: the largest difference of any state component over its quantity's scale,
    per sample: which component it was)."""
    rel = np.empty_like(sa)
    for name, cols in QUANTITIES:
        rel[:, cols] = np.abs(sb[:, cols] - sa[:, cols]) / scale[name]
    rel = np.where(np.isnan(rel), np.inf, rel)  # NaN in one run only (a blow-up) parts it
    rel = np.where(np.isnan(sa) & np.isnan(sb), 0.0, rel)
    return rel.max(axis=1), rel.argmax(axis=1)


def quantity(col: int) -> str:
    """The name of a state row's column: 'velocity[0]'."""
    for name, cols in QUANTITIES:
        if cols.start <= col < cols.stop:
            return f"{name}[{col - cols.start}]"
    return str(col)


def apart(ta, tb, n: int) -> tuple[np.ndarray, dict]:
    """(per sample: the largest relative difference over the bodies of both trajectories,
    per body: what `relative` gives) over the first n samples."""
    bodies = sorted(set(ta.states) & set(tb.states))
    scale = scales([t.states[b][:n] for t in (ta, tb) for b in bodies])
    per_body = {body: relative(ta.states[body][:n], tb.states[body][:n], scale) for body in bodies}
    worst = np.max([rel for rel, _ in per_body.values()], axis=0) if per_body else np.zeros(n)
    return worst, per_body


def first_past(worst: np.ndarray, per_body: dict, threshold: float) -> dict:
    """Where the difference first exceeds `threshold`: {"step", "body", "column", "what"
    ('box velocity[0]')}, or {} where it never does."""
    past = np.flatnonzero(worst > threshold)
    if not len(past):
        return {}
    k = int(past[0])
    body = max(per_body, key=lambda name: per_body[name][0][k])
    col = int(per_body[body][1][k])
    return {"step": k, "body": body, "column": col, "what": f"{body} {quantity(col)}"}
