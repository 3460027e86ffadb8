"""The closed forms of the contact-torque families (rolling_resistance, spin_down) against
independent routes (Newton-Euler integrated in time with regularised Coulomb friction and
a regularised rolling torque; the energy balance; Euler's equation integrated to its stop
event), their readings against trajectories whose answer is known exactly, and the effect
manifest catching an engine that simulates a contact torque nobody asked for."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, strategies as st
from scipy.integrate import solve_ivp

from adapters.base import Capabilities
from cases import conformance
from cases import rolling_resistance as rr
from cases import spin_down as sd
from cases.rolling_incline import inertia_ratio
from cases.scene import CONTACT_TORQUES, Body, Material, Scene, Sphere, ground
from tests.fakes import coulomb_on_plane
from tests.test_closed_forms_friction import trajectory

G = 9.81


# --- rolling_resistance -------------------------------------------------------------------

@pytest.mark.parametrize("p", rr.GRID, ids=rr.variant_id)
def test_rolling_resistance_from_integrating_newton_euler(p):
    """Newton-Euler for the ball with Coulomb friction at the contact point and the rolling
    torque bounded by d N (tests/fakes.coulomb_on_plane): whether it rolls, is held, and how
    fast it changes speed come out of the integration and match the family's closed form."""
    th, k, r = math.radians(p["theta_deg"]), inertia_ratio(p["dim"]), rr.radius(p)
    start = (p["v0"], p["v0"] / r)
    span = min(1.0, 0.8 * rr.stop_time(p["v0"], p["d"], k, r)) if rr.stops(p) else 1.0  # fitted before a stop
    a, alpha = coulomb_on_plane(G * math.sin(th), G * math.cos(th), rr.MU, rr.MU, k, r, rolling=p["d"],
                                start=start, duration=span)
    assert rr.acceleration(th, p["d"], k, r) == pytest.approx(a, abs=1e-7)
    assert alpha == pytest.approx(a / r, abs=1e-6)  # it rolls (or stays) without slipping
    checks = {c.metric: c for c in rr.expect(p, 1e-3)}
    assert checks["acceleration"].expected == pytest.approx(a, abs=1e-7)


@given(st.floats(0.1, 3.0), st.floats(1e-4, 0.02), st.sampled_from([0.4, 0.5]))
def test_stop_from_the_energy_balance(v0, d, k):
    """A second way on the flat: the kinetic energy (1 + k) m v^2 / 2 of a rolling ball falls
    at the power of the resistance torque, d N w = d m g v / R; integrated to v = 0."""
    speed = lambda E: math.sqrt(max(2.0 * E / (1.0 + k), 0.0))  # E per unit mass
    power = lambda t, y: [-d * G * speed(y[0]) / rr.R, speed(y[0])]  # (E', x'): dE/dt = -d N w
    stop = lambda t, y: y[0]
    stop.terminal = True
    sol = solve_ivp(power, (0, 1e4), [(1.0 + k) * v0 * v0 / 2, 0.0], events=stop, rtol=1e-11, atol=1e-14)
    # the speed is sqrt(E): the integrator finds the stop, where E has an infinite slope in t, to ~1e-6
    assert rr.stop_time(v0, d, k) == pytest.approx(sol.t_events[0][0], rel=1e-5)
    assert rr.stop_distance(v0, d, k) == pytest.approx(sol.y_events[0][0][1], rel=1e-5)


@given(st.floats(0.001, 0.5), st.floats(0.0, 0.02), st.sampled_from([0.4, 0.5]))
def test_a_ball_is_held_exactly_while_the_torque_to_hold_it_is_within_d_n(theta, d, k):
    # to hold a ball at rest friction must carry m g sin (theta) at the contact, whose torque
    # m g sin R the resistance can balance up to d m g cos
    holds = G * math.sin(theta) * rr.R <= d * G * math.cos(theta)
    if abs(math.tan(theta) - d / rr.R) > 1e-9:
        assert (rr.acceleration(theta, d, k) == 0.0) == holds


def test_d_zero_is_the_rolling_incline_and_the_grid_never_slips():
    from cases import rolling_incline as ri
    for th in (0.1, 0.3):
        assert rr.acceleration(th, 0.0, 0.4) == pytest.approx(ri.acceleration(th, 0.5, 0.5, 0.4))
    for p in rr.GRID:  # friction needed to roll, k m |a| + d N / R, within mu_s N
        th, k, r = math.radians(p["theta_deg"]), inertia_ratio(p["dim"]), rr.radius(p)
        a = rr.acceleration(th, p["d"], k, r)
        needed = abs(k * a + p["d"] * G * math.cos(th) / r) if a else G * math.sin(th)
        assert needed < rr.MU * G * math.cos(th)


@pytest.mark.parametrize("order", ["velocity first", "position first"])
def test_rolling_readings_of_an_exact_euler_run(order):
    p = rr.GRID[0]
    dt, a = 1e-3, rr.acceleration(0.0, p["d"], 0.4)
    t = np.arange(0, rr.duration(p) + dt / 2, dt)
    v = np.maximum(p["v0"] + a * np.arange(len(t)) * dt, 0.0)
    steps = v[1:] if order == "velocity first" else v[:-1]
    x = np.concatenate([[0.0], np.cumsum(steps) * dt])
    traj = trajectory(t, ball=(np.c_[x, 0 * t, 0 * t + rr.R], np.c_[v, 0 * t, 0 * t], np.c_[0 * t, v / rr.R, 0 * t]))
    got = rr.observe(traj, p)
    for check in rr.expect(p, dt):
        assert abs(got[check.metric] - check.expected) <= check.tolerance, check.metric


def test_the_controls_see_the_torques_engines_add_by_default():
    """MuJoCo's condim-6 defaults, a rolling lever of 1e-4 m and a torsional one of 1e-5 m,
    land at 10 tolerances of each control (they landed at 0.70 and 0.98 before), and a
    rolling ball whose lever is converted with the wrong radius misses the second one."""
    for p in (q for q in rr.GRID if q["d"] == 0.0):
        k = inertia_ratio(p["dim"])
        tol = rr.expect(p, 1e-3)[0].tolerance
        assert abs(rr.acceleration(0.0, 1e-4, k, rr.radius(p))) == pytest.approx(10 * tol, rel=1e-12)
    control = next(q for q in sd.GRID if q["d_t"] == 0.0)
    tol = {c.metric: c.tolerance for c in sd.expect(control, 1e-3)}["spin_deceleration"]
    assert sd.spin_deceleration(1e-5, control["R"]) == pytest.approx(10 * tol, rel=1e-12)
    small = next(q for q in rr.GRID if rr.radius(q) != rr.R)
    wrong = rr.acceleration(0.0, small["d"] * small["R"] / rr.R, 0.4, rr.radius(small))  # d / 0.1 taken as mu_r
    assert abs(wrong - rr.expect(small, 1e-3)[0].expected) > 10 * rr.ACC_TOL


# --- spin_down ----------------------------------------------------------------------------

@given(st.floats(0.1, 30.0), st.floats(1e-4, 0.01), st.floats(0.02, 0.3))
def test_spin_down_from_integrating_eulers_equation(w0, d_t, radius):
    """I w' = -d_t m g sign(w) for a solid ball (I = 2/5 m R^2), integrated to its stop."""
    inertia = 0.4 * radius * radius  # per unit mass
    stop = lambda t, y: y[0]
    stop.terminal = True
    sol = solve_ivp(lambda t, y: [-d_t * G / inertia], (0, 1e4), [w0], events=stop, rtol=1e-11, atol=1e-13)
    assert sd.spin_time(w0, d_t, radius) == pytest.approx(sol.t_events[0][0], rel=1e-7)
    half = sol.t_events[0][0] / 2
    assert sd.spin(half, w0, d_t, radius) == pytest.approx(w0 / 2, rel=1e-9)


def test_the_spin_deceleration_does_not_depend_on_the_mass():
    # tau = d_t m g and I = 2/5 m R^2 both scale with m
    for m in (0.1, 1.0, 10.0):
        assert d_t_torque(m) / (0.4 * m * 0.01) == pytest.approx(sd.spin_deceleration(0.002, 0.1))


def d_t_torque(m: float, d_t: float = 0.002) -> float:
    return d_t * m * G


@pytest.mark.parametrize("p", sd.GRID, ids=sd.variant_id)
def test_spin_readings_of_an_exact_euler_run(p):
    dt = 1e-3
    t = np.arange(0, sd.duration(p) + dt / 2, dt)
    alpha = sd.spin_deceleration(p["d_t"], p["R"]) if p["d_t"] else 0.0
    w = np.maximum(p["w0"] - alpha * np.arange(len(t)) * dt, 0.0)
    traj = trajectory(t, ball=(np.c_[0 * t, 0 * t, 0 * t + p["R"]], 0, np.c_[0 * t, 0 * t, w]))
    got = sd.observe(traj, p)
    for check in sd.expect(p, dt):
        assert abs(got[check.metric] - check.expected) <= check.tolerance, check.metric


# --- the effects and the capability ---------------------------------------------------------

def _ball_scene(**material) -> Scene:
    return Scene(bodies=(ground(), Body("ball", Sphere(0.1), mass=1.0, position=(0, 0, 0.1))),
                 material=Material(mu_s=0.5, **material))


def test_contact_torques_are_effects_only_when_a_pair_asks_for_them():
    assert not _ball_scene().effects & set(CONTACT_TORQUES)
    assert _ball_scene(rolling_resistance=0.005).effects >= {"rolling_resistance"}
    assert "torsional_friction" not in _ball_scene(rolling_resistance=0.005).effects
    assert _ball_scene(torsional_friction=0.002).effects >= {"torsional_friction"}


def test_an_engine_without_the_torque_reports_the_pair_unsupported():
    caps = Capabilities(dimensions=frozenset({3}), shapes=frozenset({"sphere", "plane"}), native_restitution=True,
                        static_kinetic=True, contact_forces=True, iterations=True)
    assert "rolling resistance = 0.005 m for ground/ball" in caps.cannot_run(_ball_scene(rolling_resistance=0.005))
    assert caps.cannot_run(_ball_scene()) is None
    rolls = Capabilities(**{**caps.__dict__, "contact_torques": frozenset({"rolling_resistance"})})
    assert rolls.cannot_run(_ball_scene(rolling_resistance=0.005)) is None
    assert "torsional friction" in rolls.cannot_run(_ball_scene(torsional_friction=0.002))
    with pytest.raises(ValueError, match="contact_torques"):
        Capabilities(**{**caps.__dict__, "contact_torques": frozenset({"rolling"})})


def test_the_manifest_catches_rolling_resistance_nobody_asked_for():
    """The conformance battery compares what an engine says it simulated with what the scene
    asked for: an engine that reports rolling resistance on a scene without it fails there."""
    p = {"check": "no_gravity_when_the_scene_has_none", "dim": 3}
    probe = conformance._probe(p)
    assert "rolling_resistance" not in probe.scene.effects
    traj = trajectory(np.arange(3) * 1e-3, body=(np.zeros((3, 3)), 0, 0))
    traj = replace(traj, effects=probe.scene.effects | {"rolling_resistance"})
    counts = {k: v for k, v in conformance._observe(traj, p).items() if k.endswith("_effects")}
    assert counts == {"unasked_effects": 1.0, "missing_effects": 0.0}


# --- the adapters' mappings of the lever arms -------------------------------------------------

def _two_balls(**pair) -> Scene:
    """Two balls of different radii on the ground; the balls' own pair overridden."""
    return Scene(bodies=(ground(), Body("big", Sphere(0.1), mass=1.0, position=(0, 0, 0.1)),
                         Body("small", Sphere(0.05), mass=0.1, position=(0, 0, 0.25))),
                 material=Material(mu_s=0.5, rolling_resistance=0.004, torsional_friction=0.001),
                 pairs=(("big", "small", Material(mu_s=0.5, **pair)),))


@pytest.mark.parametrize("pair", [dict(rolling_resistance=0.004, torsional_friction=0.001),
                                  # the ground takes a share: r_ground > 0 (every body solved)
                                  dict(rolling_resistance=0.002, torsional_friction=0.0005)])
def test_pybullet_values_reproduce_every_pair_under_bullets_rule(pair):
    pb = pytest.importorskip("adapters.pybullet_engine")
    scene = _two_balls(**pair)
    mu, _ = pb._material_values(scene)
    for effect, knob in pb.TORQUE_KNOBS.items():
        r = pb._torque_values(scene, mu, effect)
        for a, b in scene.contact_pairs():  # btManifoldResult: r_a mu_b + r_b mu_a
            combined = r[a.name] * mu[b.name] + r[b.name] * mu[a.name]
            assert combined == pytest.approx(scene.material_of(a.name, b.name).torque(effect), rel=1e-12), knob


def test_pybullet_refuses_pairs_no_non_negative_values_give():
    # both balls' ground pairs at 1 mm, their own pair at 3 mm: r_ground would be negative
    pb = pytest.importorskip("adapters.pybullet_engine")
    scene = _two_balls(torsional_friction=0.003)
    with pytest.raises(Exception, match="spinningFriction under Bullet's rule"):
        pb._torque_values(scene, pb._material_values(scene)[0], "torsional_friction")


def test_pybullet_refuses_a_torque_on_a_frictionless_pair():
    pb = pytest.importorskip("adapters.pybullet_engine")
    scene = _ball_scene(rolling_resistance=0.005)
    scene = Scene(bodies=scene.bodies, material=Material(rolling_resistance=0.005))
    with pytest.raises(Exception, match="rollingFriction"):
        pb._torque_values(scene, pb._material_values(scene)[0], "rolling_resistance")


def test_mujoco_pairs_carry_the_lever_arms_as_they_are():
    mj = pytest.importorskip("adapters.mujoco_engine")
    from adapters.base import Settings
    xml, knobs = mj.scene_mjcf(_two_balls(rolling_resistance=0.0, torsional_friction=0.003), Settings(dt=1e-3),
                               100, 16.0)
    pairs = knobs["pair"]
    assert pairs["big|ground"]["condim"] == 6 and pairs["big|ground"]["friction"] == [0.5, 0.5, 0.001, 0.004, 0.004]
    assert pairs["big|small"]["condim"] == 4 and pairs["big|small"]["friction"][2:] == [0.003, 0.0, 0.0]
    plain = mj.scene_mjcf(_ball_scene(), Settings(dt=1e-3), 100, 16.0)[1]["pair"]["ball|ground"]
    assert plain["condim"] == 3


def test_box2d_divides_by_the_larger_radius():
    b2 = pytest.importorskip("adapters.box2d_engine")
    from cases.scene import Circle, Rect
    disc = Body("disc", Circle(0.1), mass=1.0, position=(0, 0, 0.1))
    scene = Scene(bodies=(ground(), disc), material=Material(mu_s=0.5, rolling_resistance=0.005), dimension=2)
    assert b2._rolling(scene) == {"ground": 0.0, "disc": pytest.approx(0.05)}  # mu_r = d / r
    square = Body("square", Rect((0.1, 0.1)), mass=1.0, position=(0, 0, 0.1))
    scene = Scene(bodies=(ground(), square), material=Material(mu_s=0.5, rolling_resistance=0.005), dimension=2)
    with pytest.raises(Exception, match="radius, which is 0 for polygons"):
        b2._rolling(scene)
