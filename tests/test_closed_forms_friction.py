"""The closed forms of the bounce, friction and rolling families against independent
derivations (event-by-event sums, ODE integration, momentum about the contact point,
energy), and their readings against trajectories whose answer is known exactly: the
grader must be right before it judges an engine."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.integrate import solve_ivp

from cases import bounce_series as bs
from cases import central_impact as ci
from cases import creep as cr
from cases import friction_isotropy as fi
from cases import rolling_incline as ri
from cases import slide_to_stop as ss
from cases import slip_to_roll as sr
from cases.observables import arc_vertex, point_velocity, rate, settle_time
from cases.trajectory import Trajectory
from tests.fakes import coulomb_on_plane, stepped_ball
from tests.test_observables import RULES

G = 9.81


def trajectory(t, **bodies) -> Trajectory:
    """A trajectory of bodies given as (position, velocity, omega) arrays over t."""
    states = {}
    for name, (x, v, w) in bodies.items():
        s = np.zeros((len(t), 13))
        s[:, 0:3], s[:, 3], s[:, 7:10], s[:, 10:13] = x, 1.0, v, w
        states[name] = s
    return Trajectory(dt=float(t[1] - t[0]), t=t, states=states)


# --- shared readings ----------------------------------------------------------------------

@given(st.floats(-5.0, 5.0), st.floats(0.0, 3.0), st.floats(0.0, 1.0))
def test_arc_vertex_of_exact_and_of_euler_samples(v0, z0, t0):
    t = t0 + np.arange(20) * 1e-3
    tau = t - t0
    exact = z0 + v0 * tau - G * tau**2 / 2
    t_v, z_v = arc_vertex(t, exact, G)
    assert t_v == pytest.approx(t0 + v0 / G, abs=1e-9)
    assert z_v == pytest.approx(z0 + v0**2 / (2 * G), abs=1e-9)
    # velocity-first Euler samples lie on the parabola shifted by -g dt tau / 2: a parabola too
    euler = z0 + v0 * tau - G * 1e-3 * np.arange(20) * (np.arange(20) + 1) / 2 * 1e-3
    t_e, z_e = arc_vertex(t, euler, G)
    assert z_e == pytest.approx(z0 + (v0 - G * 1e-3 / 2) ** 2 / (2 * G), abs=1e-9)


def test_rate_is_the_slope_over_the_window():
    t = np.arange(0, 2.0001, 1e-3)
    x = np.where(t < 1.0, 5.0 * t, 5.0 + 0.5 * (t - 1.0))
    traj = trajectory(t, box=(np.c_[x, 0 * t, 0 * t], 0, 0))
    assert rate(traj, x, 1.0) == pytest.approx(0.5, abs=1e-9)
    assert rate(traj, x, 0.1, 0.9) == pytest.approx(5.0, abs=1e-9)


def test_settle_time_and_a_run_that_never_settles():
    t = np.arange(0, 1.0001, 1e-3)
    traj = trajectory(t, box=(0, 0, 0))
    v = np.maximum(0.5 - t, 0.0)
    assert settle_time(traj, v, 1e-3) == pytest.approx(0.5, abs=1.5e-3)
    assert settle_time(traj, v + 1.0, 1e-3) == pytest.approx(t[-1] + 1e-3)  # never: a lower bound, not NaN
    assert settle_time(traj, 0 * t, 1e-3) == 0.0


def test_point_velocity_of_a_rolling_ball_is_zero_at_the_bottom():
    # rolling forward along +x turns the ball about +y with w = v / R (slip_to_roll's convention)
    t = np.arange(0, 0.01, 1e-3)
    v, R = 2.0, 0.1
    traj = trajectory(t, ball=(0, (v, 0, 0), (0, v / R, 0)))
    assert np.allclose(point_velocity(traj, "ball", (0, 0, -R)), 0.0, atol=1e-12)
    assert np.allclose(point_velocity(traj, "ball", (0, 0, R))[:, 0], 2 * v)  # the top runs at 2 v


# --- bounce_series ------------------------------------------------------------------------

def bounces_event_by_event(e, h, n):
    """Fall, then flight after flight: speed in, speed out = e speed in, time aloft 2 u / g."""
    t, v = math.sqrt(2 * h / G), math.sqrt(2 * G * h)
    times, apexes = [t], []
    for _ in range(n):
        u = e * v
        apexes.append(u * u / (2 * G))
        t += 2 * u / G
        times.append(t)
        v = u  # lands at the speed it left with
    return times, apexes


@given(st.floats(0.05, 1.0), st.floats(0.1, 3.0))
def test_apexes_and_impact_times_from_flights(e, h):
    times, apexes = bounces_event_by_event(e, h, 6)
    for n in range(1, 7):
        assert bs.apex(e, h, n) == pytest.approx(apexes[n - 1], rel=1e-9)
        assert bs.impact_time(e, h, n) == pytest.approx(times[n - 1], rel=1e-9)


@given(st.floats(0.05, 0.95), st.floats(0.1, 3.0))
def test_rest_time_is_the_sum_of_all_flights(e, h):
    times, _ = bounces_event_by_event(e, h, 2000)
    assert bs.rest_time(e, h) == pytest.approx(times[-1], rel=1e-9)


def exact_series(e, h, dt, phase=0.0, until=None):
    """The continuous bounce series sampled at dt; the ball stops once a flight is under a step."""
    times, _ = bounces_event_by_event(e, h + phase, 400)
    t = np.arange(0.0, until or times[-1] + 0.3, dt)
    z, vz = np.zeros_like(t), np.zeros_like(t)
    t1 = times[0]
    fall = t < t1
    z[fall], vz[fall] = h + phase - G * t[fall] ** 2 / 2, -G * t[fall]
    for n in range(len(times) - 1):
        u = G * (times[n + 1] - times[n]) / 2
        if u < G * dt:
            break
        tau = t - times[n]
        aloft = (tau >= 0) & (t < times[n + 1])
        z[aloft], vz[aloft] = u * tau[aloft] - G * tau[aloft] ** 2 / 2, u - G * tau[aloft]
    pos = np.c_[0 * t, 0 * t, z + bs.R]
    return trajectory(t, ball=(pos, np.c_[0 * t, 0 * t, vz], 0))


@settings(max_examples=10, deadline=None)
@given(st.sampled_from([0.5, 0.7, 1.0]), st.floats(0.0, 1e-3))
def test_bounce_readings_of_an_exact_series_at_any_phase(e, phase):
    dt = 1e-3
    traj = exact_series(e, bs.H, dt, phase, until=None if e < 1 else bs.duration({"e": e}))
    obs = bs.observe(traj, {"e": e})
    for n in range(1, bs.N + 1):
        assert obs[f"apex_{n}"] == pytest.approx(bs.apex(e, bs.H + phase, n), abs=1e-9)
        assert obs[f"impact_time_{n}"] == pytest.approx(bs.impact_time(e, bs.H + phase, n), abs=1e-9)
    if e < 1:
        # the sampled series is cut where a flight lasts under a step: within the unresolved tail
        tail = 2 * bs.v_rest(dt) / (G * (1 - e))
        assert bs.rest_time(e, bs.H + phase) - tail - dt <= obs["rest_time"] <= bs.rest_time(e, bs.H + phase)


def test_a_weaker_bounce_fails_the_apex_checks():
    obs = bs.observe(exact_series(0.45, bs.H, 1e-3), {"e": 0.5})
    checks = {c.metric: c for c in bs.expect({"e": 0.5}, 1e-3)}
    assert all(abs(obs[f"apex_{n}"] - checks[f"apex_{n}"].expected) > checks[f"apex_{n}"].tolerance
               for n in range(1, bs.N + 1))


def test_bounce_tolerances_grow_with_the_bounces_and_shrink_with_dt():
    for e in (0.5, 1.0):
        tol = [bs.impact_time_tolerance(e, bs.H, n, 1e-3) for n in range(1, 6)]
        assert tol == sorted(tol)
        assert bs.apex_tolerance(e, bs.H, 3, 1e-4) < bs.apex_tolerance(e, bs.H, 3, 1e-3) / 5
    # the launch speed bound after one impact is central_impact's rebound tolerance times v0
    v0 = bs.impact_speed(0.5, bs.H, 1)
    assert bs.launch_speed_error(0.5, bs.H, 1, 1e-3) == pytest.approx(v0 * ci.rebound_tolerance(0.5, v0, 1e-3))


@pytest.mark.parametrize("phase", [0.0, 0.3, 0.7])
@pytest.mark.parametrize("e", [0.5, 1.0])
@pytest.mark.parametrize("rule", RULES, ids=lambda r: "-".join(r))
def test_stepped_bounces_are_within_every_tolerance(rule, e, phase):
    """The series stepped as rigid engines step it (tests/fakes.py: x or v first, each impact
    found late, at the nearest boundary or early, its step's gravity before, inside or
    after the impulse), from a drop height anywhere within one step's travel: every apex,
    impact time and the rest time within the tolerances built from rebound_tolerance."""
    dt = 1e-3
    h = bs.H + phase * bs.impact_speed(e, bs.H, 1) * dt
    traj, _ = stepped_ball(e, h, dt, bs.duration({"e": e}), *rule, radius=bs.R)
    obs = bs.observe(traj, {"e": e})
    for c in bs.expect({"e": e}, dt):
        expected = c.expected  # closed forms at H; the phase moves them by far less than dt
        if c.metric.startswith("apex"):
            expected = bs.apex(e, h, int(c.metric[-1]))
        elif c.metric.startswith("impact_time"):
            expected = bs.impact_time(e, h, int(c.metric[-1]))
        elif c.metric == "rest_time":
            expected = bs.rest_time(e, h)
        assert abs(obs[c.metric] - expected) <= c.tolerance, (c.metric, obs[c.metric], expected, c.tolerance)


@pytest.mark.parametrize("order", ["velocity first", "position first"])
def test_first_impact_tolerance_covers_both_euler_falls(order):
    dt, h = 1e-3, bs.H
    n = np.arange(2000)
    shift = n + 1 if order == "velocity first" else n - 1
    z = h - G * dt**2 * n * shift / 2
    k = int(np.argmax(z < 0))
    t = n[:k] * dt
    t_v, z_v = arc_vertex(t, z[:k], G)
    t_hit = t_v + math.sqrt(2 * z_v / G)
    assert abs(t_hit - bs.impact_time(1.0, h, 1)) <= bs.impact_time_tolerance(1.0, h, 1, dt)


# --- slide_to_stop ------------------------------------------------------------------------

@given(st.floats(0.1, 10.0), st.floats(0.05, 1.5))
def test_stop_from_integrating_coulomb_friction(v0, mu):
    # x'' = -mu g while x' > 0 (kinetic friction against the motion), integrated numerically
    sol = solve_ivp(lambda t, y: [y[1], -mu * G], (0, 100), [0.0, v0], events=lambda t, y: y[1],
                    rtol=1e-10, atol=1e-12)
    t_stop, x_stop = sol.t_events[0][0], sol.y_events[0][0][0]
    assert ss.stop_time(v0, mu) == pytest.approx(t_stop, rel=1e-7)
    assert ss.stop_distance(v0, mu) == pytest.approx(x_stop, rel=1e-7)


@settings(max_examples=30, deadline=None)
@given(st.floats(0.5, 5.0), st.floats(0.1, 1.0), st.sampled_from([1e-3, 5e-4, 2e-3]),
       st.sampled_from(["velocity first", "position first"]))
def test_euler_with_exact_friction_stops_within_the_tolerance(v0, mu, dt, order):
    # what an engine whose friction impulse is exact does: clamp the velocity at zero
    x, v, t = 0.0, v0, 0.0
    while v > 0:
        v_new = max(v - mu * G * dt, 0.0)
        x += (v_new if order == "velocity first" else v) * dt
        v, t = v_new, t + dt
    checks = {c.metric: c for c in ss.expect({"v0": v0, "mu_k": mu}, dt)}
    assert abs(x - checks["stop_distance"].expected) <= checks["stop_distance"].tolerance
    assert abs(t - checks["stop_time"].expected) <= checks["stop_time"].tolerance


# --- slip_to_roll -------------------------------------------------------------------------

@given(st.floats(-5.0, 5.0), st.floats(-80.0, 80.0), st.sampled_from([3, 2]))
def test_rolling_velocity_from_angular_momentum_about_the_contact_point(v0, w0, dim):
    # friction acts through the contact point, gravity and the normal force cancel:
    # m R v + I w is kept, and at the end w = v / R
    k = sr.inertia_ratio(dim)
    m, R = 1.0, sr.R
    L = m * R * v0 + k * m * R * R * w0
    v_f = L / (m * R + k * m * R)
    assert sr.rolling_velocity(v0, w0, k) == pytest.approx(v_f, rel=1e-9, abs=1e-12)


def test_the_textbook_forms_of_the_rolling_velocity():
    v0, w0, R = 1.7, -23.0, sr.R
    assert sr.rolling_velocity(v0, w0, 0.4) == pytest.approx((5 * v0 + 2 * R * w0) / 7)
    assert sr.rolling_velocity(v0, w0, 0.5) == pytest.approx((2 * v0 + R * w0) / 3)


@given(st.floats(-4.0, 4.0), st.floats(-60.0, 60.0), st.floats(0.1, 1.0), st.sampled_from([3, 2]))
def test_roll_time_from_integrating_newton_euler(v0, w0, mu, dim):
    # m v' = F, I w' = -R F with F = -mu m g sign(v - R w), until the slip vanishes
    k, R = sr.inertia_ratio(dim), sr.R
    s0 = v0 - R * w0
    if abs(s0) < 1e-6:
        return
    sign = math.copysign(1.0, s0)
    rhs = lambda t, y: [-mu * G * sign, R * mu * G * sign / (k * R * R)]
    sol = solve_ivp(rhs, (0, 100), [v0, w0], events=lambda t, y: y[0] - R * y[1], rtol=1e-10, atol=1e-12)
    assert sr.roll_time(v0, w0, mu, k) == pytest.approx(sol.t_events[0][0], rel=1e-7, abs=1e-12)
    assert sr.rolling_velocity(v0, w0, k) == pytest.approx(sol.y_events[0][0][0], rel=1e-7, abs=1e-9)


def test_the_grid_ball_rolls_forward_with_positive_spin():
    # the scene's sign convention: +w about +y with v = R w is rolling, not slipping
    p = {"v0": 2.0, "w0": 20.0, "mu": 0.5}
    assert sr.roll_time(p["v0"], p["w0"], p["mu"], 0.4) == 0.0
    assert sr.rolling_velocity(p["v0"], p["w0"], 0.4) == pytest.approx(2.0)


# --- rolling_incline ----------------------------------------------------------------------

@pytest.mark.parametrize("p", ri.GRID + ({"theta_deg": 34.0, "mu_s": 0.2, "mu_k": 0.2, "dim": 3},
                                         {"theta_deg": 36.0, "mu_s": 0.2, "mu_k": 0.2, "dim": 3}), ids=ri.variant_id)
def test_rolling_and_slipping_from_integrating_coulomb_friction(p):
    """A second way: Newton-Euler for the ball integrated in time with Coulomb friction at
    the contact point (tests/fakes.coulomb_on_plane, regularised, static up to mu_s): whether
    it rolls or slips, and its accelerations, come out of the integration and match the
    case's closed forms on every variant and on either side of the sphere's rolling limit
    tan(theta) = 7/2 mu_s (34.99 deg at mu_s = 0.2)."""
    th, k = math.radians(p["theta_deg"]), ri.inertia_ratio(p["dim"])
    a, alpha = coulomb_on_plane(G * math.sin(th), G * math.cos(th), p["mu_s"], p["mu_k"], k, ri.R)
    assert ri.acceleration(th, p["mu_s"], p["mu_k"], k) == pytest.approx(a, rel=1e-7)
    assert ri.angular_acceleration(th, p["mu_s"], p["mu_k"], k) == pytest.approx(alpha, rel=1e-7)
    assert ri.rolls(th, p["mu_s"], k) == (a == pytest.approx(ri.R * alpha, rel=1e-7))


@given(st.floats(0.01, 1.4), st.floats(0.01, 1.0), st.sampled_from([0.4, 0.5]))
def test_rolling_threshold_is_where_the_needed_friction_leaves_the_cone(theta, mu, k):
    # friction needed to roll: F = k m a with a = g sin / (1 + k); available: mu m g cos
    needed = k * G * math.sin(theta) / (1.0 + k)
    available = mu * G * math.cos(theta)
    if abs(needed - available) > 1e-9:
        assert ri.rolls(theta, mu, k) == (needed <= available)


def test_rolling_thresholds_of_sphere_and_disc():
    mu = 0.2
    assert ri.rolls(math.atan(3.5 * mu) - 1e-9, mu, 0.4) and not ri.rolls(math.atan(3.5 * mu) + 1e-9, mu, 0.4)
    assert ri.rolls(math.atan(3.0 * mu) - 1e-9, mu, 0.5) and not ri.rolls(math.atan(3.0 * mu) + 1e-9, mu, 0.5)


@given(st.floats(0.8, 1.5), st.floats(0.01, 0.2), st.sampled_from([0.4, 0.5]))
def test_slipping_ball_from_newton_euler(theta, mu_k, k):
    if ri.rolls(theta, mu_k, k):
        return
    m, R = 1.0, ri.R
    normal = m * G * math.cos(theta)
    friction = mu_k * normal                      # kinetic, up the slope, at the contact point
    a = (m * G * math.sin(theta) - friction) / m
    alpha = friction * R / (k * m * R * R)       # its torque about the centre
    assert ri.acceleration(theta, mu_k, mu_k, k) == pytest.approx(a, rel=1e-12)
    assert ri.angular_acceleration(theta, mu_k, mu_k, k) == pytest.approx(alpha, rel=1e-12)
    assert a > R * alpha  # the slip grows: it never turns into rolling


def test_the_grid_labels_roll_and_slip_as_intended():
    for p in ri.GRID:
        th, k = math.radians(p["theta_deg"]), ri.inertia_ratio(p["dim"])
        assert ri.rolls(th, p["mu_s"], k) == (p["theta_deg"] < 35.0 if p["dim"] == 3 else p["theta_deg"] < 31.0)


# --- friction_isotropy --------------------------------------------------------------------

def sliding_boxes(friction_of, mu=0.5, dt=1e-3):
    """Boxes of the family's scene integrated with a given friction law (acceleration as a
    function of the horizontal velocity), to the family's duration."""
    t = np.arange(0.0, fi.duration({"mu": mu}) + dt / 2, dt)
    bodies = {}
    for phi in fi.DIRECTIONS:
        v = np.zeros((len(t), 3))
        v[0] = fi.V0 * fi.direction(phi)
        for k in range(1, len(t)):
            v[k] = v[k - 1] + friction_of(v[k - 1], mu) * dt
        bodies[f"box_{fi.label(phi)}"] = (0, v, 0)
    return trajectory(t, **bodies)


def coulomb_disc(v, mu):
    return -mu * G * v / np.linalg.norm(v)


def box_limit(v, mu):
    """A square friction limit: each world-axis component saturates at mu g separately."""
    return -mu * G * np.sign(v) * (np.abs(v) > 1e-12)


def test_isotropic_friction_passes_and_a_square_limit_fails():
    p = {"mu": 0.5}
    checks = {c.metric: c for c in fi.expect(p, 1e-3)}
    good = fi.observe(sliding_boxes(coulomb_disc), p)
    assert all(abs(good[m] - c.expected) <= c.tolerance for m, c in checks.items())
    bad = fi.observe(sliding_boxes(box_limit), p)
    assert bad["deceleration_45deg"] > 1.3 * 0.5 * G  # mu sqrt(2) g until it stops, early
    failing = {m for m, c in checks.items() if abs(bad[m] - c.expected) > c.tolerance}
    assert {"deceleration_22.5deg", "deceleration_45deg", "lateral_acceleration_22.5deg",
            "deceleration_spread"} <= failing


# --- creep --------------------------------------------------------------------------------

@given(st.floats(0.05, 1.5), st.floats(0.0, 0.999))
def test_cone_load_from_the_angle_of_the_holding_force(mu, fraction):
    """A second way: in a world with vertical gravity the plane's normal is R_y(theta) e_z,
    and the contact force holding the box is -m g, straight up. Its angle to the normal,
    against the cone's half-angle atan(mu_s), is the load: tan(angle) / mu_s, the tangential
    over mu_s times the normal part (vector geometry, not the case's tan(theta) / mu_s)."""
    th = fraction * math.atan(mu)
    c, s = math.cos(th), math.sin(th)
    n = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]) @ np.array([0.0, 0.0, 1.0])
    f = np.array([0.0, 0.0, 9.81])  # holds 1 kg against gravity
    normal = f @ n
    tangential = np.linalg.norm(f - normal * n)
    angle = math.atan2(np.linalg.norm(np.cross(f, n)), normal)  # between the force and the normal
    assert cr.cone_load(th, mu) == pytest.approx(tangential / (mu * normal), rel=1e-9, abs=1e-12)
    assert cr.cone_load(th, mu) == pytest.approx(math.tan(angle) / mu, rel=1e-7, abs=1e-9)
    assert (angle <= math.atan(mu)) == (cr.cone_load(th, mu) <= 1.0)
    assert cr.creep_rate(th, mu) == 0.0


def test_creep_has_no_rate_beyond_break_away():
    with pytest.raises(ValueError):
        cr.creep_rate(math.atan(0.5) + 1e-6, 0.5)


def test_every_creep_variant_is_held_by_the_cone():
    for p in cr.GRID + cr.FULL_GRID:
        assert cr.cone_load(cr.theta(p), p["mu"]) < 1.0


def test_creep_reading_is_the_downhill_speed_after_start_up():
    t = np.arange(0.0, cr.T + 5e-4, 1e-3)
    x = np.where(t < 0.5, 1e-3 * t, 5e-4 + 3e-6 * (t - 0.5))  # a start-up jolt, then 3 um/s
    obs = cr.observe(trajectory(t, box=(np.c_[x, 0 * t, 0 * t + cr.HALF], 0, 0)), cr.GRID[0])
    assert obs["creep_rate"] == pytest.approx(3e-6, rel=1e-6)
