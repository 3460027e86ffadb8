"""The per-contact read-out of the adapter contract (Simulation.contact_points), on every
engine that declares it: the reported forces must balance what the bodies' motion says
they are, independently of the engine.

- A box resting on the ground: the contact forces on the box sum to its weight m g (the
  box is in equilibrium), friction is zero (nothing pulls sideways), normals point from
  the ground into the box and are unit, and friction is perpendicular to the normal.
- A box sliding on the ground at 30 deg to the x axis (mu = 0.5): whatever the engine's
  friction does, the forces it reports must account for the box's motion: summed over the
  steps, (sum of contact forces + m g) dt = m (v_end - v_start) (momentum balance), which
  checks the normal and the friction read-out, their signs and their body. The box must be
  decelerated by friction, so the friction read-out cannot be zero.
- A frictionless scene reports no friction force at all.

Tolerances: 1 % on the resting weight (an engine's contact solve converges to its own
residual; MuJoCo's soft contact settles to 1e-10); 1e-4 m/s on the momentum balance over
100 steps of a 2 m/s slide (an engine's velocity update uses the forces it solved; MuJoCo's
Newton solver leaves 7e-7 m/s a step).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from adapters import registry
from adapters.base import Settings
from physval.core.plan import leaves_out
from cases.scene import Body, Material, Scene, cube, ground

G, M, HALF, DT = 9.81, 1.0, 0.1, 1e-3


# the families these scenes stand for in a default run: a box resting and sliding on the ground
TAGS = frozenset({"core"})


# Engines whose reported forces are known not to be the step's impulses, with the measurement.
NOT_IMPULSES = {
    "drake-cenic": "Drake's contact results of the continuous plant are the force at the step's end state (CENIC takes "
                   "steps of its own within one dt where the contact is stiff), not the step's impulse: over 100 steps "
                   "of the sliding box they add to 1.39 N s of normal impulse where its momentum and weight show 0.98 "
                   "(0.41 N s in z, tolerance 1e-4)",
    "newton-vbd": "VBD's contact force is read from its unconverged implicit solve: over 100 steps of the sliding box "
                  "the reported normal impulse is 0.98207 N s where its weight and momentum show 0.98100 (1.07e-3 N s "
                  "apart at its default 10 iterations, 1.9e-4 at 40; tolerance 1e-4)",
    "newton-kamino": "Kamino reports the friction of mu N (0.4905 N s over the 100 steps) while the box slows at "
                     "0.99958 mu g: 2.1e-4 N s apart, 2.0e-6 N s every step, the same at 200 iterations (its 1e-5 "
                     "convergence tolerances end the solve first; tolerance 1e-4)",
}


def _engines(known: dict[str, str] | None = None):
    """The engines that report contact points, each a param (slow where a default run leaves
    the scene out; a strict xfail where `known` gives the measured reason it fails)."""
    out = []
    for name in registry.engine_names():
        if name.startswith("reference-") or not registry.available(name):
            continue
        adapter = registry.get(name)
        if adapter.capabilities.contact_points:
            # an engine whose default run leaves such a scene out (a continuous-collision
            # configuration: the swept families only) is tested with
            # `pytest -m slow`, as its runs are (physval.core.plan.leaves_out)
            dim = 3 if 3 in adapter.capabilities.dimensions else 2
            scene = Scene((ground(), Body("box", cube(HALF, dim), mass=M, position=(0.0, 0.0, HALF))),
                          material=Material(e=0.0, mu_s=0.5), dimension=dim)
            marks = [pytest.mark.slow] if leaves_out(adapter, TAGS, scene) else []
            if name in (known or {}):
                marks.append(pytest.mark.xfail(strict=True, reason=known[name]))
            out.append(pytest.param(name, marks=marks))
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


@pytest.mark.parametrize("engine", _engines(NOT_IMPULSES))
def test_the_forces_of_a_sliding_box_account_for_its_momentum(engine):
    mu, speed, angle, steps = 0.5, 2.0, math.radians(30.0), 100
    dim = 3 if 3 in registry.get(engine).capabilities.dimensions else 2
    direction = np.array([math.cos(angle), math.sin(angle), 0.0]) if dim == 3 else np.array([1.0, 0.0, 0.0])
    scene = _scene(engine, mu, tuple(speed * direction))
    impulse, friction_impulse = np.zeros(3), np.zeros(3)
    with registry.get(engine).build(scene, Settings(dt=DT)) as sim:
        v_start = sim.states()["box"][7:10].copy()
        for _ in range(steps):
            sim.step()
            normal, friction = _on_box(sim.contact_points())
            impulse += (normal + friction) * DT
            friction_impulse += friction * DT
        v_end = sim.states()["box"][7:10]
    gravity = M * np.array(scene.gravity) * steps * DT
    assert np.allclose(M * (v_end - v_start), impulse + gravity, atol=1e-4)
    assert float(friction_impulse @ direction) < -0.5 * mu * M * G * steps * DT, "no friction against the slip"


@pytest.mark.parametrize("engine", _engines())
def test_a_frictionless_scene_reports_no_friction(engine):
    velocity = (1.0, 0.0, 0.0)
    points, _ = _run(engine, _scene(engine, mu=0.0, velocity=velocity), 0.1)
    assert points
    assert all(np.all(p.f_t == 0.0) for p in points)


def test_pymunk_reads_the_same_through_its_public_properties(monkeypatch):
    """The Pymunk adapter reads arbiters through Chipmunk's C API (fast, but a private
    binding); without it, it falls back on Pymunk's public properties: same points."""
    if not registry.available("pymunk"):
        pytest.skip("pymunk is not installed")
    from adapters import pymunk_engine
    scene = _scene("pymunk", 0.5, (2.0, 0.0, 0.0))
    fast, _ = _run("pymunk", scene, 0.1)
    monkeypatch.setattr(pymunk_engine, "_chipmunk", None)
    public, _ = _run("pymunk", scene, 0.1)
    assert len(fast) == len(public) > 0
    for p, q in zip(fast, public):
        assert (p.a, p.b, p.f_n, p.gap) == (q.a, q.b, q.f_n, q.gap)
        assert np.array_equal(p.x, q.x) and np.array_equal(p.n, q.n) and np.array_equal(p.f_t, q.f_t)
