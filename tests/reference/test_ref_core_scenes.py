"""The core scenes through the reference adapter, against closed forms derived here.

Scenes are built from cases.scene as the case files build theirs; the expectations are
derived in this file, independently of cases/ (momentum and restitution solved as a
linear system, free flight by kinematics, the incline by a force balance)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from adapters.base import Settings
from adapters.reference_engine import ReferenceAdapter
from cases.scene import Body, Box, Material, Scene, Sphere, ground, pair_key, tilted_gravity

G = 9.81
DT = 1e-3
R = 0.1  # sphere radius and cube half-extent, m


def run(scene: Scene, seconds: float, dt: float = DT):
    """States (name -> (n+1, 13)) and contact forces (pair -> (n+1,)) of a run."""
    sim = ReferenceAdapter().build(scene, Settings(dt=dt))
    n = int(round(seconds / dt))
    names = [b.name for b in scene.dynamic_bodies]
    states = {k: np.empty((n + 1, 13)) for k in names}
    forces = {}
    first = sim.states()
    for k in names:
        states[k][0] = first[k]
    for i in range(1, n + 1):
        sim.step()
        now = sim.states()
        for k in names:
            states[k][i] = now[k]
        for pair, f in sim.contact_forces().items():
            forces.setdefault(pair, np.zeros(n + 1))[i] = f
    return sim, states, forces


# --- 1. central impact ------------------------------------------------------------------

MASSES = [(1.0, 1.0), (1.0, 3.0), (1.0, 100.0)]
CORS = [0.0, 0.5, 0.9, 1.0]


def two_spheres(m1, m2, e):
    gap = 0.05
    return Scene(bodies=(Body("a", Sphere(R), mass=m1, position=(-(R + gap / 2), 0, 0), velocity=(2.0, 0, 0),
                              rotates=False),
                         Body("b", Sphere(R), mass=m2, position=(R + gap / 2, 0, 0), velocity=(-1.0, 0, 0),
                              rotates=False)),
                 gravity=(0.0, 0.0, 0.0), material=Material(e=e))


@pytest.mark.parametrize("e", CORS, ids=lambda e: f"e={e}")
@pytest.mark.parametrize("m1,m2", MASSES, ids=lambda m: f"{m}")
def test_central_impact_is_exact(m1, m2, e):
    # momentum m1 v1' + m2 v2' = m1 v1 + m2 v2 and Newton's law v2' - v1' = -e (v2 - v1)
    v1, v2 = 2.0, -1.0
    expected = np.linalg.solve([[m1, m2], [-1.0, 1.0]], [m1 * v1 + m2 * v2, -e * (v2 - v1)])
    sim, states, _ = run(two_spheres(m1, m2, e), 0.05)
    got = np.array([states["a"][-1, 7], states["b"][-1, 7]])
    assert np.all(np.abs(got - expected) <= 1e-9 * np.abs(expected) + 1e-15), \
        f"{got}, but should be {expected} (m = {m1}:{m2}, e = {e})"
    # the impulse is along x: nothing else moves or turns
    for k in "ab":
        assert np.all(states[k][:, [1, 2, 8, 9, 10, 11, 12]] == 0.0)
    assert sim.effects == {"contact", "restitution"} if e > 0 else {"contact"}


def test_central_impact_effects_and_stages_are_only_what_the_scene_calls_for():
    scene = two_spheres(1.0, 3.0, 0.5)
    sim, _, _ = run(scene, 0.05)
    assert sim.effects == scene.effects == {"contact", "restitution"}
    stages = sim.knobs["stages_ran"]
    assert "gravity" not in stages and "rotations" not in stages and "si:friction" not in stages
    assert {"collide", "si:velocity", "positions"} <= set(stages)
    json.dumps(sim.knobs)  # knobs are JSON


# --- 2. ball drop -------------------------------------------------------------------------

def drop(e, h=1.0):
    return Scene(bodies=(ground(), Body("ball", Sphere(R), mass=1.0, position=(0, 0, R + h), rotates=False)),
                 gravity=(0.0, 0.0, -G), material=Material(e=e))


def first_bounce(vz):
    """Index k of the last falling sample before the first bounce (vz[k] < 0 <= vz[k + 1])."""
    k = int(np.argmax((vz[:-1] < 0) & (vz[1:] >= 0)))
    assert vz[k] < 0 <= vz[k + 1]
    return k


# contact phases: the drop height shifted by fractions of the last step's travel
PHASES = [0.0, 0.25, 0.5, 0.75]


@pytest.mark.parametrize("phase", PHASES, ids=lambda p: f"phase={p}")
@pytest.mark.parametrize("e", CORS, ids=lambda e: f"e={e}")
def test_ball_drop_rebounds_with_ratio_e_and_reaches_e2h(e, phase):
    v_c = math.sqrt(2 * G * 1.0)  # speed at contact, from energy
    h = 1.0 + phase * v_c * DT
    _, states, _ = run(drop(e, h), math.sqrt(2 * h / G) + 2 * e * v_c / G * 0.6 + 0.05)
    z, vz = states["ball"][:, 2] - R, states["ball"][:, 9]
    k = first_bounce(vz)
    # the impulse reverses the velocity the ball had at the start of the contact step
    assert -vz[k + 1] / vz[k] == pytest.approx(e, abs=1e-12)
    # Apex: the bounce starts within |v| dt / 2 of the surface (the step boundary nearest
    # the contact); symplectic Euler adds e (1 - e) |v| dt / 2 (its rise and fall
    # discretisations differ by the launch step), so
    #   |apex - e^2 h| <= (1 - e^2) |v| dt / 2 + e (1 - e) |v| dt / 2 + g dt^2.
    v = abs(vz[k])
    tol = (1 - e * e) * v * DT / 2 + e * (1 - e) * v * DT / 2 + G * DT * DT
    apex = z[k + 1:].max()
    assert abs(apex - e * e * h) <= tol, f"apex {apex}, but should be {e * e * h} +- {tol}"
    if e == 0.0:  # plastic: lands and stays, no overlap beyond rounding
        assert np.all(np.abs(vz[k + 3:]) == 0.0) and np.all(z[k + 3:] >= -1e-12)


# --- 3. incline threshold ---------------------------------------------------------------

def incline(theta, mu_s, mu_k=None):
    return Scene(bodies=(ground(), Body("box", Box((R, R, R)), mass=1.0, position=(0, 0, R))),
                 gravity=tilted_gravity(theta, G), material=Material(e=0.0, mu_s=mu_s, mu_k=mu_k))


INCLINES = [(mu, off) for mu in (0.2, 0.5, 0.8) for off in (-10, -1, 1, 10)]


@pytest.mark.parametrize("mu,offset", INCLINES, ids=lambda x: str(x))
def test_incline_box_stays_below_the_threshold_and_slides_above(mu, offset):
    theta = math.atan(mu) + math.radians(offset)  # the force balance m g sin = mu m g cos
    _, states, _ = run(incline(theta, mu), 1.0)
    vx = states["box"][:, 7]
    if offset < 0:
        creep = np.max(np.abs(states["box"][:, 7:10]))
        assert creep < 1e-6, f"creep {creep} m/s, but should stay (theta {math.degrees(theta):.2f} deg)"
    else:
        a = G * (math.sin(theta) - mu * math.cos(theta))
        measured = (vx[-1] - vx[len(vx) // 2]) / (0.5)
        assert measured == pytest.approx(a, rel=1e-3)
        # it slides flat: no tipping, no lift
        assert np.max(np.abs(states["box"][:, 10:13])) < 1e-6
        assert np.max(np.abs(states["box"][:, 2] - R)) < 1e-6


@pytest.mark.parametrize("offset", [-1, 1])
def test_static_friction_holds_and_kinetic_friction_slides(offset):
    mu_s, mu_k = 0.5, 0.3
    theta = math.atan(mu_s) + math.radians(offset)
    _, states, _ = run(incline(theta, mu_s, mu_k), 0.5)
    vx = states["box"][:, 7]
    if offset < 0:
        assert np.max(np.abs(vx)) < 1e-6
    else:
        a = G * (math.sin(theta) - mu_k * math.cos(theta))
        assert (vx[-1] - vx[250]) / 0.25 == pytest.approx(a, rel=1e-3)


# --- 4. resting blocks --------------------------------------------------------------------

def stack(n):
    boxes = tuple(Body(f"box{k}", Box((R, R, R)), mass=1.0, position=(0, 0, R + 2 * R * k)) for k in range(n))
    return Scene(bodies=(ground(),) + boxes, gravity=(0.0, 0.0, -G), material=Material(e=0.0, mu_s=0.5))


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5])
def test_stack_holds_with_interface_forces_equal_to_the_weight_above(n):
    sim, states, forces = run(stack(n), 3.0)
    last_second = slice(-1000, None)
    names = ["ground"] + [f"box{k}" for k in range(n)]
    for k in range(n):
        weight_above = (n - k) * 1.0 * G
        f = forces[pair_key(names[k], names[k + 1])][last_second].mean()
        assert f == pytest.approx(weight_above, rel=1e-6), f"interface {k}: {f} N, but should be {weight_above} N"
    # penetration: overlap of each box with the one (or the ground) below it
    z = np.array([states[f"box{k}"][:, 2] for k in range(n)])
    overlap = np.concatenate([R - z[0], *(2 * R - (z[k] - z[k - 1]) for k in range(1, n))])
    assert overlap.max() < 1e-4
    for k in range(n):
        start = np.array([0.0, 0.0, R + 2 * R * k])
        drift = np.max(np.abs(states[f"box{k}"][:, 0:3] - start))
        assert drift < 1e-5, f"box {k} drifted {drift} m"
