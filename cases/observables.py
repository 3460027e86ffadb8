"""Readings that several case families take from a trajectory."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from cases.overlap import penetration, reach
from cases.trajectory import POS, QUAT, Trajectory


def free_acceleration(traj: Trajectory, name: str, gravity, band: float = 0.25) -> np.ndarray:
    """The acceleration the body really has in free flight, from its velocities: the median
    of dv/dt over the steps within `band` (relative to |g|, at least 1 m/s^2) of the scene's
    gravity; the scene's gravity if no step is. A free-flight reading must not assume the
    answer it judges: an engine whose gravity (or time step) is off by a few per cent still
    flies free, and its motion is read, then judged, rather than not found."""
    g = np.asarray(gravity, float)
    a = np.diff(traj.vel(name), axis=0) / traj.dt
    near = np.linalg.norm(a - g, axis=1) <= band * max(np.linalg.norm(g), 1.0)
    return np.median(a[near], axis=0) if near.any() else g


def ballistic_steps(traj: Trajectory, name: str, gravity) -> np.ndarray:
    """For each step k (sample k -> k+1): True when the velocity changed by exactly the free
    flight's a dt (`free_acceleration`: the scene's gravity, as the engine realised it),
    i.e. no contact acted on the body in that step. Tolerance 1e-3 g dt: far above float
    round-off, far below any contact impulse."""
    g = np.asarray(gravity, float)
    dv = np.diff(traj.vel(name), axis=0) - free_acceleration(traj, name, g) * traj.dt
    return np.linalg.norm(dv, axis=1) <= 1e-3 * max(np.linalg.norm(g), 1.0) * traj.dt


def first_impact(traj: Trajectory, name: str, gravity) -> tuple[int | None, int | None]:
    """(k_in, k_out): the last free-flight sample before the first contact, and the first
    sample after it from which the body flies free again (None if it never does); (None,
    None) if it never touches anything."""
    free = ballistic_steps(traj, name, gravity)
    hit = np.flatnonzero(~free)
    if hit.size == 0:
        return None, None
    k_in = int(hit[0])
    after = np.flatnonzero(free[k_in:])
    # free again from the first step after which every step up to the apex is ballistic
    for k in after + k_in:
        run = free[k:k + 5]
        if run.all() and run.size == 5:
            return k_in, int(k)
    return k_in, None


def free_flight_error(x, x0, v0, gravity, t: np.ndarray, dt: float) -> float:
    """Largest distance (m) of the positions x (n, d) at times t from the nearest free
    flight that a consistent one-step integrator produces, to be judged against round-off.

    Every one-step integrator that moves a body under constant acceleration g by
    dt (v_n + alpha g dt) in a step whose velocity goes from v_n to v_n + g dt, with alpha
    in [0, 1] (the step's displacement is dt times a velocity the step passes through), puts
    the body at x_n = x0 + v0 t + g t^2 / 2 + c g dt t, c = alpha - 1/2 constant: position
    first (explicit Euler) c = -1/2, velocity first (semi-implicit Euler) +1/2, the exact
    parabola (velocity Verlet, Runge-Kutta 2-4, the analytic flight) 0, k velocity-first
    sub-steps of dt/k 1/(2k) (Box2D, Rapier: k = 4, c = 1/8), k position-first ones -1/(2k).
    The best c (least squares, clipped to [-1/2, 1/2]) is removed; what is left is the
    distance from that band. A wrong g leaves (g' - g) t^2 / 2, a step other than dt leaves
    v0 t and g t^2 scaled: parabolas no line through the origin removes."""
    t = np.asarray(t, float)[:, None]
    r = np.asarray(x, float) - (np.asarray(x0, float) + np.asarray(v0, float) * t
                                + 0.5 * np.asarray(gravity, float) * t * t)
    b = np.asarray(gravity, float) * dt * t  # the direction c moves the positions in
    bb = float(np.sum(b * b))
    c = float(np.clip(np.sum(r * b) / bb, -0.5, 0.5)) if bb > 0.0 else 0.0
    return float(np.max(np.linalg.norm(r - c * b, axis=1)))


def fall_gravity(z: np.ndarray, g: float, dt: float, band: float = 0.25) -> float:
    """The gravity a height z really falls with, from its positions: minus the median second
    difference / dt^2 over the samples within `band` of -g dt^2; g if none is. (Positions
    and velocities are read separately: an engine stepping a time other than dt shows its
    gravity scaled by that ratio in the velocities and by its square in the positions.)"""
    d2 = np.diff(z, 2) / (dt * dt)
    near = np.abs(d2 + g) <= band * g
    return float(-np.median(d2[near])) if near.any() else g


def free_arc_start(z: np.ndarray, k: int, g: float, dt: float, run: int = 6) -> int | None:
    """First sample j >= k from which `run` samples of height z fly free: their second
    differences are -g dt^2 (to 1e-3 of it; g as the positions show it, `fall_gravity`).
    Velocities can be ballistic while positions are still being pushed out of an overlap
    (position-only depenetration), so an arc fitted to positions must start here."""
    d2 = np.diff(z[k:], 2)
    free = np.abs(d2 + g * dt * dt) <= 1e-3 * g * dt * dt
    w = run - 2  # second differences a run of `run` samples holds
    if w < 1:
        raise ValueError(f"free_arc_start: run={run}: a free arc is at least 3 samples")
    # j such that free[j:j + w] are all True: their count over the window is w (a running
    # sum; a loop over j was most of a long bounce_series job's time on an engine that chatters)
    count = np.concatenate(([0], np.cumsum(free)))
    found = np.flatnonzero(count[w:] - count[:-w] == w)
    return k + int(found[0]) if found.size else None


def arc_apex(t: np.ndarray, z: np.ndarray, g: float) -> float:
    """Apex height of the parabola z = a + b t - g t^2 / 2 fitted to free-flight samples
    (g > 0).

    Positions only: every explicit Euler integrator (velocity first or position first)
    keeps the second difference of z at exactly -g dt^2 in free flight, so its samples lie
    on such a parabola and the apex is exact in discrete time, while v^2/2 + g z of the
    sampled velocity drifts by g dt v / 2 depending on the integrator. A parabola needs two
    samples: with fewer (a window past the run's end, a one-step run) the highest sample's
    height, or 0 with none, a finite number that fails by its size (`arc_vertex`)."""
    return arc_vertex(t, z, g)[1]


def window_samples(traj: Trajectory, t0: float, t1: float = math.inf, least: int = 1) -> np.ndarray:
    """Indices of the samples in [t0, t1], at least `least` of them: a window holding fewer
    (one that starts after the run ended, as in check-case's one-step dry run or at a --dt
    that does not divide the duration, or that falls between two samples) is widened back to
    the `least` samples ending where it ends (the run's last sample if it ends after the
    run). So a reading over a window is always a finite number: a run cut short reads its
    final state instead of nothing."""
    inside = np.flatnonzero(traj.after(t0) & (traj.t <= t1 + 1e-12))
    if inside.size >= least:
        return inside
    end = min(max(int(np.count_nonzero(traj.t <= t1 + 1e-12)), least), len(traj.t))
    return np.arange(max(end - least, 0), end)  # a run shorter than `least` samples: all of it


def window_mean(traj: Trajectory, values: np.ndarray, t0: float) -> float:
    """Mean of per-sample values over the samples from t0 on (`window_samples`: the last sample
    alone if t0 lies past the run's end)."""
    return float(np.mean(values[window_samples(traj, t0)]))


def arc_vertex(t: np.ndarray, z: np.ndarray, g: float) -> tuple[float, float]:
    """(time, height) of the vertex of the parabola z = a + b t - g t^2 / 2 fitted to
    free-flight samples (g > 0): the fit of `arc_apex`, with the apex time as well. The arc
    meets height 0 at time +- sqrt(2 height / g) from its vertex. With fewer than two
    samples (or all at one time) no parabola is fitted: the highest sample, or (0, 0)
    with none, so a reading over a window that holds too little is a finite number."""
    t, z = np.asarray(t, float), np.asarray(z, float)
    if t.size == 0:
        return 0.0, 0.0
    if t.size < 2 or np.ptp(t) == 0.0:
        k = int(np.argmax(z))
        return float(t[k]), float(z[k])
    tau = t - t[0]
    b, a = np.polyfit(tau, z + 0.5 * g * tau**2, 1)
    return float(t[0] + b / g), float(a + b * b / (2.0 * g))


def rate(traj: Trajectory, values: np.ndarray, t0: float, t1: float = math.inf) -> float:
    """Slope (per second) of the least-squares line through per-sample values over
    [t0, t1]: an acceleration from velocities, a creep speed from positions. A line needs
    two samples: a window holding fewer is widened back to the two ending where it ends
    (`window_samples`; the last step's slope if t0 lies past the run's end); 0 on a run of
    a single sample (no step: nothing changed)."""
    k = window_samples(traj, t0, t1, least=2)
    if k.size < 2:
        return 0.0
    return float(np.polyfit(traj.t[k], values[k], 1)[0])


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


# --- robustness readings: energy, momentum, overlap, drift, collapse -----------------------

def _rotations(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) body-to-world matrices of (n, 4) unit quaternions (w, x, y, z)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def mechanical_energy(traj: Trajectory, scene) -> np.ndarray:
    """Kinetic plus gravitational potential energy of the dynamic bodies at every sample, J:
    sum of m v.v / 2 + w_b . (I w_b) / 2 - m g . x, with w_b = R^T w the angular velocity in
    the body frame, where the inertia is the principal diagonal I (note 001, rigid body)."""
    g = np.asarray(scene.gravity, float)
    total = np.zeros(len(traj.t))
    for body in scene.dynamic_bodies:
        v, w, x = traj.vel(body.name), traj.omega(body.name), traj.pos(body.name)
        w_body = np.einsum("nji,nj->ni", _rotations(traj.quat(body.name)), w)
        total += 0.5 * body.mass * np.sum(v * v, axis=1)
        total += 0.5 * np.sum(np.asarray(body.principal_inertia) * w_body * w_body, axis=1)
        total -= body.mass * (x @ g)
    return total


def energy_rise(traj: Trajectory, scene) -> float:
    """Largest excess of the mechanical energy over its initial value, J (0 if it never
    rises): what a solver injected where nothing does work."""
    energy = mechanical_energy(traj, scene)
    return float(max(np.max(energy) - energy[0], 0.0))


def momentum(traj: Trajectory, scene) -> np.ndarray:
    """(n, 3) total linear momentum of the dynamic bodies, kg m/s."""
    return sum(body.mass * traj.vel(body.name) for body in scene.dynamic_bodies)


def drift(traj: Trajectory, names, t0: float) -> float:
    """Largest distance any of the named bodies moves from where it was at t0, m (0 if t0
    lies past the run's end: the window is then the last sample, `window_samples`)."""
    later = window_samples(traj, t0)
    out = 0.0
    for name in names:
        x = traj.pos(name)[later]
        out = max(out, float(np.max(np.linalg.norm(x - x[0], axis=1))))
    return out


def rest_drift(traj: Trajectory, names, settled: float) -> float:
    """How far bodies put down at rest move, m: along the ground from where they were put,
    over the whole run (a walk while the contacts start up, then rest, is a drift too), and
    in any direction from `settled` on (before it, a contact's sag into its solver's
    stabilising depth is the start-up's, which a penetration or height check judges)."""
    walk = max(float(np.max(np.linalg.norm(traj.pos(n)[:, :2] - traj.pos(n)[0, :2], axis=1))) for n in names)
    return max(walk, drift(traj, names, settled))


def time_to_collapse(traj: Trajectory, names, sideways: float, down: float) -> float:
    """Time at which the first of the named bodies is more than `sideways` (horizontally)
    from where it started, or more than `down` below it; the end of the run if none ever
    is (the structure stood throughout). Sinking less than `down` is judged as overlap."""
    first = len(traj.t)
    for name in names:
        x = traj.pos(name)
        moved = np.flatnonzero((np.linalg.norm(x[:, :2] - x[0, :2], axis=1) > sideways) | (x[0, 2] - x[:, 2] > down))
        if moved.size:
            first = min(first, int(moved[0]))
    return float(traj.t[first]) if first < len(traj.t) else float(traj.t[-1])


def deepest_overlap(traj: Trajectory, scene, t0: float, samples: int = 20) -> float:
    """Largest depth (m) by which any two bodies overlap, at `samples` sample times spread
    evenly from t0 to the end; exact per pair (cases.overlap: distances and separating
    axes), pairs whose bounding spheres are apart skipped."""
    picks = window_samples(traj, t0)
    picks = np.unique(picks[np.linspace(0, len(picks) - 1, min(samples, len(picks))).round().astype(int)])
    pairs = scene.contact_pairs()
    index = {b.name: i for i, b in enumerate(scene.bodies)}
    ia = np.array([index[a.name] for a, _ in pairs], dtype=int)
    ib = np.array([index[b.name] for _, b in pairs], dtype=int)
    bound = np.array([reach(a.shape) + reach(b.shape) for a, b in pairs])
    deepest = 0.0
    for k in picks:
        now = [b if b.static else replace(b, position=tuple(traj.states[b.name][k, POS]),
                                          orientation=tuple(traj.states[b.name][k, QUAT]))
               for b in scene.bodies]
        x = np.array([b.position for b in now], dtype=float)
        near = ~(np.linalg.norm(x[ia] - x[ib], axis=1) > bound)  # every pair with a plane is near
        for i in np.flatnonzero(near):
            deepest = max(deepest, penetration(now[ia[i]], now[ib[i]]))
    return deepest


def stack_readings(traj: Trajectory, names: list[str], half: float, settled: float) -> dict:
    """What a resting stack of boxes (half-height `half`, `names` bottom to top, on the
    ground z = 0) shows from time `settled` on: the mean normal force below each box
    (`force_below_box<k>`), the deepest mean overlap of any interface (`penetration`); and
    the farthest any box moved (`drift`: along the ground over the whole run, rest_drift)."""
    below = ["ground"] + list(names)
    out = {}
    depth = []
    for k, name in enumerate(names):
        out[f"force_below_box{k}"] = window_mean(traj, traj.force(below[k], name), settled)
        bottom = traj.pos(name)[:, 2] - half
        top_below = np.zeros_like(bottom) if k == 0 else traj.pos(below[k])[:, 2] + half
        depth.append(window_mean(traj, top_below - bottom, settled))
    out["penetration"] = max(depth)
    out["drift"] = rest_drift(traj, names, settled)
    return out


# --- agreement readings: orientation, impulse over a window, rest speed -------------------

def rotations(traj: Trajectory, name: str) -> np.ndarray:
    """(n, 3, 3) body-to-world rotation matrices of the body at every sample."""
    return _rotations(traj.quat(name))


def impulse(traj: Trajectory, a: str, b: str, t0: float = -math.inf, t1: float = math.inf) -> float:
    """Normal impulse (N s) between a and b over the steps from sample time t0 to sample
    time t1 (the whole run by default): sum of F_k dt over the steps k that start at or
    after t0 and end at or before t1, where sample k's force is step k's (t_{k-1} -> t_k).
    With t0, t1 on samples, momentum balance over [t0, t1] holds with exactly these steps."""
    f = traj.force(a, b)
    k = np.arange(len(traj.t))
    steps = (k >= 1) & (traj.t[k - 1] >= t0 - 1e-12) & (traj.t <= t1 + 1e-12)
    return float(np.sum(f[steps]) * traj.dt)


def point_speed_bound(traj: Trajectory, name: str, reach: float) -> np.ndarray:
    """|v| + reach |omega| at every sample: no material point of the body within `reach` of
    its centre moves faster. 0 for a body at rest."""
    return np.linalg.norm(traj.vel(name), axis=1) + reach * np.linalg.norm(traj.omega(name), axis=1)
