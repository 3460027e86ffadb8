"""Readings that several case families take from a trajectory."""
from __future__ import annotations

import math

import numpy as np

from cases.trajectory import Trajectory


def ballistic_steps(traj: Trajectory, name: str, gravity) -> np.ndarray:
    """For each step k (sample k -> k+1): True when the velocity changed by exactly g dt,
    i.e. no contact acted on the body in that step. Tolerance 1e-3 g dt: far above float
    round-off, far below any contact impulse."""
    v = traj.vel(name)
    dv = np.diff(v, axis=0) - np.asarray(gravity, float) * traj.dt
    return np.linalg.norm(dv, axis=1) <= 1e-3 * max(np.linalg.norm(gravity), 1.0) * traj.dt


def first_impact(traj: Trajectory, name: str, gravity) -> tuple[int, int | None]:
    """(k_in, k_out): the last free-flight sample before the first contact, and the first
    sample after it from which the body flies free again (None if it never does)."""
    free = ballistic_steps(traj, name, gravity)
    hit = np.flatnonzero(~free)
    if hit.size == 0:
        raise ValueError(f"{name} never touched anything")
    k_in = int(hit[0])
    after = np.flatnonzero(free[k_in:])
    # free again from the first step after which every step up to the apex is ballistic
    for k in after + k_in:
        run = free[k:k + 5]
        if run.all() and run.size == 5:
            return k_in, int(k)
    return k_in, None


def free_arc_start(z: np.ndarray, k: int, g: float, dt: float, run: int = 6) -> int | None:
    """First sample j >= k from which `run` samples of height z fly free: their second
    differences are -g dt^2 (to 1e-3 of it). Velocities can be ballistic while positions
    are still being pushed out of an overlap (position-only depenetration), so an arc
    fitted to positions must start here."""
    d2 = np.diff(z[k:], 2)
    free = np.abs(d2 + g * dt * dt) <= 1e-3 * g * dt * dt
    for j in range(len(free) - run + 3):
        if free[j:j + run - 2].all():
            return k + j
    return None


def arc_apex(t: np.ndarray, z: np.ndarray, g: float) -> float:
    """Apex height of the parabola z = a + b t - g t^2 / 2 fitted to free-flight samples.

    Positions only: every explicit Euler integrator (velocity first or position first)
    keeps the second difference of z at exactly -g dt^2 in free flight, so its samples lie
    on such a parabola and the apex is exact in discrete time, while v^2/2 + g z of the
    sampled velocity drifts by g dt v / 2 depending on the integrator."""
    b, a = np.polyfit(t - t[0], z + 0.5 * g * (t - t[0]) ** 2, 1)
    return float(a + b * b / (2.0 * g))


def window_mean(traj: Trajectory, values: np.ndarray, t0: float) -> float:
    """Mean of per-sample values over the samples from t0 on."""
    return float(np.mean(values[traj.after(t0)]))

def arc_vertex(t: np.ndarray, z: np.ndarray, g: float) -> tuple[float, float]:
    """(time, height) of the vertex of the parabola z = a + b t - g t^2 / 2 fitted to
    free-flight samples: the fit of `arc_apex`, with the apex time as well. The arc meets
    height 0 at time +- sqrt(2 height / g) from its vertex."""
    tau = t - t[0]
    b, a = np.polyfit(tau, z + 0.5 * g * tau**2, 1)
    return float(t[0] + b / g), float(a + b * b / (2.0 * g))


def rate(traj: Trajectory, values: np.ndarray, t0: float, t1: float = math.inf) -> float:
    """Slope (per second) of the least-squares line through per-sample values over
    [t0, t1]: an acceleration from velocities, a creep speed from positions."""
    window = traj.after(t0) & (traj.t <= t1 + 1e-12)
    return float(np.polyfit(traj.t[window], values[window], 1)[0])


def settle_time(traj: Trajectory, values: np.ndarray, bound: float) -> float:
    """Time of the first sample from which |values| stays <= bound to the end of the run.
    If the last sample still exceeds it, the end of the run plus a step: a lower bound
    (it settles later, if ever), so a case judges it as late rather than as not a number."""
    above = np.flatnonzero(np.abs(values) > bound)
    if above.size == 0:
        return float(traj.t[0])
    if above[-1] == len(values) - 1:
        return float(traj.t[-1] + traj.dt)
    return float(traj.t[above[-1] + 1])


def point_velocity(traj: Trajectory, name: str, arm) -> np.ndarray:
    """Velocity of the body's material point at `arm` (world-frame offset from its centre,
    held fixed): v + omega x arm; with arm = -R n the slip of a ball on a plane of normal n."""
    return traj.vel(name) + np.cross(traj.omega(name), np.asarray(arm, float))

