"""The observables read what they claim from a trajectory whose answer is known exactly:
a continuous-time bounce sampled at dt, with the impact at any phase within a step."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from cases import central_impact as ci
from cases.observables import (arc_apex, arc_vertex, ballistic_steps, deepest_overlap, drift, energy_rise,
                               fall_gravity, first_impact, free_acceleration, free_arc_start, free_flight_error,
                               impulse, mechanical_energy, momentum, point_speed_bound,
                               point_velocity, rate, rest_drift, rotations, settle_time, stack_readings,
                               time_to_collapse,
                               window_mean, window_samples)
from cases.scene import pair_key
from cases.trajectory import Trajectory
from tests.fakes import stepped_ball

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


# --- the discrete impact: rebound_tolerance against stepped impacts of every kind ------------

RULES = [("velocity", gravity, detection) for gravity in ("before", "cancelled", "after")
         for detection in ("late", "nearest", "early")] + \
        [("position", gravity, "late") for gravity in ("before", "cancelled", "after")]


def drop_params(e):
    return {"setup": "drop", "e": e, "h": 1.0}


@pytest.mark.parametrize("e", [0.0, 0.5, 0.9, 1.0])
@pytest.mark.parametrize("rule", RULES, ids=lambda r: "-".join(r))
def test_stepped_rebound_is_the_formula_and_within_the_tolerance(rule, e):
    """A ball stepped as a rigid engine steps it (tests/fakes.py: x or v first, the impact
    found late, at the nearest boundary or early, the step's gravity before, inside or
    after the impulse), dropped at phases across one step: the observer reads exactly
    `stepped_rebound_ratio` at the simulated depth and kappa, and within the tolerance."""
    dt = 1e-3
    order, gravity, detection = rule
    v = math.sqrt(2 * G)
    tol = ci.rebound_tolerance(e, v, dt)
    worst = 0.0
    for phase in np.linspace(0.0, v * dt, 11):
        p = dict(drop_params(e), h=1.0 + phase)
        traj, impacts = stepped_ball(e, p["h"], dt, ci.duration(p), order, gravity, detection, radius=R)
        obs = ci.observe(traj, drop_params(e))
        _, d, kappa = impacts[0]
        z = traj.pos("ball")[:, 2] - R
        k = impacts[0][0]
        v_in = math.sqrt(2 * G * ci.arc_apex(traj.t[k - 5:k + 1], z[k - 5:k + 1], G))  # the incoming arc
        assert obs["rebound_ratio"] == pytest.approx(ci.stepped_rebound_ratio(e, v_in, dt, kappa, d), abs=1e-9)
        assert abs(d) <= v_in * dt and abs(kappa) <= (1 + e) / 2 + 1e-12  # inside the corners the bound takes
        worst = max(worst, abs(obs["rebound_ratio"] - e))
    assert worst <= tol


def test_the_rebound_bound_is_reached_by_stepped_impacts():
    """Not a loose bound: over the stepping rules and phases the reading comes within a few
    per cent of it (e = 0.5: found late with gravity after the impulse, kappa = -3/4; e = 1:
    restitution of the speed after the step's gravity, kappa = 1, DART's and Pymunk's order)."""
    dt, v = 1e-3, math.sqrt(2 * G)
    for e in (0.5, 1.0):
        got = max(abs(ci.observe(stepped_ball(e, 1.0 + ph, dt, ci.duration(drop_params(e)), *rule, radius=R)[0],
                                 drop_params(e))["rebound_ratio"] - e)
                  for rule in RULES for ph in np.linspace(0.0, v * dt, 11))
        assert 0.9 * ci.rebound_tolerance(e, v, dt) <= got <= ci.rebound_tolerance(e, v, dt)


def test_rebound_tolerance_has_the_first_order_terms():
    """To first order the ratio moves by kappa g dt / v - g d (1 - e^2) / (e v^2): with
    |kappa| <= (1 + e)/2 and |d| <= v dt the bound is g dt / v ((1 + e)/2 + (1 - e^2)/e)."""
    dt, v = 1e-5, 4.0
    for e in (0.3, 0.5, 0.9, 1.0):
        first = G * dt / v * ((1 + e) / 2 + (1 - e * e) / e)
        assert ci.rebound_tolerance(e, v, dt) - 1e-6 == pytest.approx(first, rel=1e-3)  # less the solver floor
    assert ci.rebound_tolerance(0.0, v, dt) == pytest.approx(1e-6)  # plastic: no rising arc at all


# --- windows: a reading over a window is a finite number whatever the run's length ----------

def falling_box(steps: int, dt: float = 1e-3) -> Trajectory:
    """A box falling freely from rest for `steps` steps (velocity-first Euler), sliding
    at 1 m/s along x, with the force of a resting contact growing 1 N a step."""
    from cases.scene import pair_key
    t = np.arange(steps + 1) * dt
    states = np.zeros((steps + 1, 13))
    states[:, 0], states[:, 3], states[:, 7] = t, 1.0, 1.0
    states[:, 9] = -G * t
    states[:, 2] = 1.0 - G * dt * dt * np.arange(steps + 1) * (np.arange(steps + 1) + 1) / 2
    return Trajectory(dt=dt, t=t, states={"box": states}, forces={pair_key("ground", "box"): np.arange(steps + 1.0)},
                      bodies=frozenset({"ground", "box"}))


def no_warnings(read):
    """read(), with any warning (numpy's RankWarning, 'Mean of empty slice') an error."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return read()


@pytest.mark.parametrize("t0", [0.0005, 0.002, 0.5])
def test_a_window_past_the_runs_end_reads_the_last_samples(t0):
    """check-case's one-step run (two samples) observed with windows that start after it
    ended (a guide-style observer reading from a settling time): the mean and the drift
    read the last sample, the rate the last step, each a finite number and without a warning."""
    from cases.observables import drift, rate, window_mean
    traj = falling_box(1)
    vz = traj.vel("box")[:, 2]
    assert no_warnings(lambda: window_mean(traj, vz, t0)) == vz[-1]
    assert no_warnings(lambda: window_mean(traj, traj.force("ground", "box"), t0)) == 1.0
    assert no_warnings(lambda: drift(traj, ["box"], t0)) == 0.0
    assert no_warnings(lambda: rate(traj, vz, t0)) == pytest.approx(-G, rel=1e-12)
    assert no_warnings(lambda: rate(traj, traj.pos("box")[:, 0], t0)) == pytest.approx(1.0, rel=1e-12)


def test_a_rate_over_one_sample_is_the_slope_of_the_step_ending_there():
    """A window [t0, t1] that holds one sample (or none, between two samples): numpy's line
    through one point is any line (a RankWarning and a meaningless slope); the rate is the
    step ending at the window's last sample."""
    from cases.observables import rate
    traj = falling_box(100)
    x = traj.pos("box")[:, 2]
    for t0, t1, k in ((0.05, 0.05, 50), (0.0503, 0.0507, 50), (0.0, 0.0, 1)):
        expected = (x[k] - x[k - 1]) / traj.dt
        assert no_warnings(lambda: rate(traj, x, t0, t1)) == pytest.approx(expected, rel=1e-9), (t0, t1)


def test_windows_inside_the_run_read_as_before():
    """The widening touches only windows too short for their reading: within a run the
    rate is the least-squares slope and the mean and drift those of the samples from t0 on."""
    from cases.observables import drift, rate, window_mean
    traj = falling_box(100)
    vz, late = traj.vel("box")[:, 2], traj.t >= 0.04 - 1e-12
    assert rate(traj, vz, 0.04) == pytest.approx(-G, rel=1e-9)
    assert rate(traj, vz, 0.04) == float(np.polyfit(traj.t[late], vz[late], 1)[0])
    assert window_mean(traj, vz, 0.04) == float(np.mean(vz[late]))
    x = traj.pos("box")[late]
    assert drift(traj, ["box"], 0.04) == float(np.max(np.linalg.norm(x - x[0], axis=1)))


def test_stack_readings_and_overlap_past_the_runs_end_are_finite():
    from cases import resting_blocks
    from cases.observables import deepest_overlap, stack_readings
    from physval.core.record import simulate
    from adapters import registry
    from adapters.base import Settings
    p = resting_blocks.FAMILY.variants[0].params
    scene = resting_blocks.scene(p)
    with registry.get("reference").build(scene, Settings(dt=1e-3)) as sim:
        traj = simulate(sim, scene, 1e-3, 1, forces=True).trajectory
    names = [b.name for b in scene.dynamic_bodies]
    got = no_warnings(lambda: stack_readings(traj, names, resting_blocks.HALF, settled=5.0))
    # the drift's window is the last sample; along the ground it reads the whole run: one step
    # of a box at rest moves it by rounding alone (1e-21 m)
    assert got and all(math.isfinite(v) for v in got.values()) and got["drift"] < 1e-15, got
    assert math.isfinite(no_warnings(lambda: deepest_overlap(traj, scene, 5.0)))


def test_a_stack_that_walks_before_it_settles_has_drifted():
    """A resting stack whose top box walks 1 mm along the ground while its contacts start up
    and is still from SETTLED on has not stayed where it was put: its drift fails (it read 0
    when the drift was taken from SETTLED on only). A sag of 0.25 mm into the solver's
    stabilising depth before SETTLED, then rest, is no drift (penetration judges it)."""
    from cases import resting_blocks as rb
    p = {"n": 3, "dim": 3}
    names = rb.names(3)
    t = np.linspace(0.0, rb.T, 3001)
    starting = t < rb.SETTLED / 2

    def resting():
        states = {}
        for k, name in enumerate(names):
            s = np.zeros((len(t), 13))
            s[:, 2], s[:, 3] = rb.HALF + 2 * rb.HALF * k, 1.0
            states[name] = s
        forces = {pair_key(a, b): np.full(len(t), rb.interface_force(3, k))
                  for k, (a, b) in enumerate(zip(["ground", *names], names))}
        return Trajectory(dt=t[1], t=t, states=states, forces=forces, bodies=frozenset({"ground", *names}))
    walked = resting()
    walked.states["box2"][:, 0] = np.where(starting, 1e-3 * t / (rb.SETTLED / 2), 1e-3)
    drift_check = {c.metric: c for c in rb.expect(p, 1e-3)}["drift"]
    assert rb.observe(walked, p)["drift"] == pytest.approx(1e-3) and 1e-3 > drift_check.tolerance
    sagged = resting()
    sagged.states["box2"][:, 2] -= np.where(starting, 2.5e-4 * t / (rb.SETTLED / 2), 2.5e-4)
    assert rb.observe(sagged, p)["drift"] == pytest.approx(0.0, abs=1e-12)


# --- the guide's promise: every helper gives a finite number on any run ---------------------------

def _one_box_scene():
    from cases.scene import Body, Scene, cube, ground
    return Scene(bodies=(ground(), Body("box", cube(0.1), mass=1.0, position=(0, 0, 1.0), velocity=(1.0, 0, 0))))


# Each helper of cases.observables called as an observer would on a run (the box falling, one
# window from t0 = 0.05 s, past the end of short runs). The arc helpers get the run's samples
# from k = 1 on: none on a run of no step, one on a run of one step.
HELPER_CALLS = {
    "free_acceleration": lambda tr, sc: free_acceleration(tr, "box", sc.gravity),
    "ballistic_steps": lambda tr, sc: ballistic_steps(tr, "box", sc.gravity),
    "first_impact": lambda tr, sc: first_impact(tr, "box", sc.gravity),
    "free_flight_error": lambda tr, sc: free_flight_error(tr.pos("box"), (0, 0, 1.0), (1.0, 0, 0), sc.gravity, tr.t, tr.dt),
    "fall_gravity": lambda tr, sc: fall_gravity(tr.pos("box")[:, 2], G, tr.dt),
    "free_arc_start": lambda tr, sc: free_arc_start(tr.pos("box")[:, 2], 0, G, tr.dt),
    "arc_apex": lambda tr, sc: arc_apex(tr.t[1:], tr.pos("box")[1:, 2], G),
    "arc_vertex": lambda tr, sc: arc_vertex(tr.t[1:], tr.pos("box")[1:, 2], G),
    "window_samples": lambda tr, sc: window_samples(tr, 0.05),
    "window_mean": lambda tr, sc: window_mean(tr, tr.vel("box")[:, 2], 0.05),
    "rate": lambda tr, sc: rate(tr, tr.vel("box")[:, 2], 0.05),
    "settle_time": lambda tr, sc: settle_time(tr, tr.vel("box")[:, 2], 0.1),
    "point_velocity": lambda tr, sc: point_velocity(tr, "box", (0, 0, -0.1)),
    "mechanical_energy": lambda tr, sc: mechanical_energy(tr, sc),
    "energy_rise": lambda tr, sc: energy_rise(tr, sc),
    "momentum": lambda tr, sc: momentum(tr, sc),
    "drift": lambda tr, sc: drift(tr, ["box"], 0.05),
    "rest_drift": lambda tr, sc: rest_drift(tr, ["box"], 0.05),
    "time_to_collapse": lambda tr, sc: time_to_collapse(tr, ["box"], 0.01, 0.01),
    "deepest_overlap": lambda tr, sc: deepest_overlap(tr, sc, 0.05),
    "stack_readings": lambda tr, sc: stack_readings(tr, ["box"], 0.1, 0.05),
    "rotations": lambda tr, sc: rotations(tr, "box"),
    "impulse": lambda tr, sc: impulse(tr, "ground", "box", 0.05),
    "point_speed_bound": lambda tr, sc: point_speed_bound(tr, "box", 0.2),
}


def _numbers(value):
    """Every number in a helper's result (None where a helper documents it: no impact)."""
    if value is None or isinstance(value, (bool, np.bool_)):
        return []
    if isinstance(value, dict):
        return [x for v in value.values() for x in _numbers(v)]
    if isinstance(value, tuple):
        return [x for v in value for x in _numbers(v)]
    return list(np.ravel(np.asarray(value, float)))


def test_every_helper_is_called_here():
    import inspect
    import cases.observables as obs
    public = {n for n, f in vars(obs).items() if inspect.isfunction(f) and f.__module__ == obs.__name__
              and not n.startswith("_")}
    assert public == set(HELPER_CALLS)


@pytest.mark.parametrize("steps", [0, 1, 2, 100])
@pytest.mark.parametrize("helper", sorted(HELPER_CALLS))
def test_every_helper_gives_finite_numbers_on_any_run(helper, steps):
    """A run of no step, of one step (check-case's dry run), of two, and a longer one."""
    traj, scene = falling_box(steps), _one_box_scene()
    got = no_warnings(lambda: HELPER_CALLS[helper](traj, scene))
    assert all(math.isfinite(x) for x in _numbers(got)), (helper, steps, got)


def test_an_arc_of_fewer_than_two_samples_reads_its_highest_sample():
    from cases.observables import arc_apex, arc_vertex
    assert arc_apex(np.array([]), np.array([]), G) == 0.0
    assert arc_vertex(np.array([0.3]), np.array([0.7]), G) == (0.3, 0.7)
    assert arc_apex(np.array([0.3, 0.3]), np.array([0.5, 0.7]), G) == 0.7  # one instant: no parabola
    t = np.arange(5) * 1e-3
    assert arc_apex(t, 0.2 + 1.0 * t - G * t * t / 2, G) == pytest.approx(0.2 + 1.0 / (2 * G), rel=1e-12)
