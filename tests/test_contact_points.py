"""The per-contact read-out of the adapter contract (Simulation.contact_points), on every
engine that declares it: the reported forces must balance what the bodies' motion says
they are, independently of the engine.

- A box resting on the ground: the contact forces on the box sum to its weight m g (the
  box is in equilibrium), friction is zero (nothing pulls sideways), normals point from
  the ground into the box and are unit, and friction is perpendicular to the normal.
- A box sliding on the ground at 30 deg to the x axis (mu = 0.5): the summed normal force
  is m g and the summed friction force is mu m g against the slip (Coulomb, note 000
  "Coulomb friction"), in the slip's direction.
- A frictionless scene reports no friction force at all.

Tolerances: 1 % on the resting weight (an engine's contact solve converges to its own
residual; MuJoCo's soft contact settles to 1e-10), 3 % on the sliding friction
(a 2D/3D engine's friction set may be a pyramid; the slip direction stays fixed to
within the step's change g mu dt of a 2 m/s slide).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from adapters import registry
from adapters.base import Settings
from cases.scene import Body, Material, Scene, cube, ground

G, M, HALF, DT = 9.81, 1.0, 0.1, 1e-3


def _engines():
    out = []
    for name in registry.engine_names():
        if name.startswith("reference-") or not registry.available(name):
            continue
        if registry.get(name).capabilities.contact_points:
            out.append(name)
    return out


def _scene(engine: str, mu: float, velocity=(0.0, 0.0, 0.0)) -> Scene:
    dim = 3 if 3 in registry.get(engine).capabilities.dimensions else 2
    box = Body("box", cube(HALF, dim), mass=M, position=(0.0, 0.0, HALF), velocity=velocity)
    return Scene((ground(), box), material=Material(e=0.0, mu_s=mu), dimension=dim)


def _run(engine: str, scene: Scene, seconds: float):
    with registry.get(engine).build(scene, Settings(dt=DT)) as sim:
        for _ in range(round(seconds / DT)):
            sim.step()
        return sim.contact_points(), sim.states()


def _on_box(points):
    """Total normal and friction force on the box, with the points' own checks."""
    normal, friction = np.zeros(3), np.zeros(3)
    for p in points:
        assert {p.a, p.b} == {"box", "ground"}
        assert abs(np.linalg.norm(p.n) - 1.0) < 1e-9, f"normal {p.n} is not unit"
        assert abs(float(np.dot(p.f_t, p.n))) <= 1e-9 * (1.0 + np.linalg.norm(p.f_t)), "friction not tangent"
        assert math.isfinite(p.gap) and math.isfinite(p.f_n)
        sign = 1.0 if p.a == "box" else -1.0
        assert sign * p.n[2] > 0.99, f"normal {p.n} does not point from the ground into the box"
        normal += sign * p.f_n * p.n
        friction += sign * p.f_t
    return normal, friction


@pytest.mark.parametrize("engine", _engines())
def test_a_resting_box_carries_its_weight_without_friction(engine):
    points, _ = _run(engine, _scene(engine, mu=0.5), 0.5)
    assert points, "a resting box reports no contact point"
    normal, friction = _on_box(points)
    assert normal[2] == pytest.approx(M * G, rel=1e-2)
    assert np.linalg.norm(friction) <= 1e-2 * M * G


@pytest.mark.parametrize("engine", _engines())
def test_a_sliding_box_feels_kinetic_friction_against_its_slip(engine):
    mu, speed, angle = 0.5, 2.0, math.radians(30.0)
    dim = 3 if 3 in registry.get(engine).capabilities.dimensions else 2
    direction = np.array([math.cos(angle), math.sin(angle), 0.0]) if dim == 3 else np.array([1.0, 0.0, 0.0])
    points, states = _run(engine, _scene(engine, mu, tuple(speed * direction)), 0.1)
    normal, friction = _on_box(points)
    slip = states["box"][7:10]
    assert np.linalg.norm(slip) > 1.0, "the box should still be sliding at 0.1 s"
    assert normal[2] == pytest.approx(M * G, rel=3e-2)
    expected = -mu * M * G * slip / np.linalg.norm(slip)
    assert np.linalg.norm(friction - expected) <= 3e-2 * mu * M * G


@pytest.mark.parametrize("engine", _engines())
def test_a_frictionless_scene_reports_no_friction(engine):
    dim = 3 if 3 in registry.get(engine).capabilities.dimensions else 2
    velocity = (1.0, 0.0, 0.0)
    points, _ = _run(engine, _scene(engine, mu=0.0, velocity=velocity), 0.1)
    assert points
    assert all(np.all(p.f_t == 0.0) for p in points)
