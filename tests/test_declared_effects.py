"""What an engine declares it simulates, it simulates: every installed engine configuration
of the registry, every effect planted in a tiny scene.

For each effect an adapter can be asked for (restitution, friction, distinct static and
kinetic friction, rolling resistance, torsional friction) the scene is run twice, with the
effect and without it, and the reading the effect must move has to move by at least half
of what the closed form plants, unless the engine declares the scene unsupported (by its
capabilities or its build, with a reason). An engine that takes the values, reports the
effect as simulated, and whose solver drops the rows (pybullet's MLCP solvers and the
contact torques) fails here. Per-contact normal forces, where an engine declares it
reports them, are read in a V-groove of two frictionless planes, where each face carries
m g / (2 cos alpha): splitting the weight without the normals reads half that cos alpha.

Tiny scenes, tens of steps at dt = 1e-3: the whole file costs seconds of CPU."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import pytest

from adapters import registry
from adapters.base import Settings, Unsupported
from cases.scene import EFFECTS, Body, Material, Plane, Scene, ball, cube, ground
from tests.helpers import adapter_or_skip

G = 9.81
R = 0.1       # m, the balls' radius
DT = 1e-3     # s
MASS = 1.0    # kg


@dataclass(frozen=True)
class Plant:
    """An effect planted in a scene: `scene(dim, on)` with the effect (on) or without it,
    `steps` to run after `settle` steps, `read(states)` the number the effect moves, and
    `planted(dim)` how far the closed form moves it over `steps` (the check asks for at
    least half of it)."""
    scene: Callable[[int, bool], Scene]
    steps: int
    read: Callable[[dict], float]
    planted: Callable[[int], float]
    dimensions: tuple[int, ...] = (3, 2)
    # steps before the reading starts: MuJoCo's default soft contact (solref 0.02 s) takes
    # the ball's weight, and with it the torques' bound d N, over its first ~60 steps
    settle: int = 0


def _on_ground(body: Body, material: Material, dim: int, gravity=(0.0, 0.0, -G)) -> Scene:
    return Scene(bodies=(ground(), body), material=material, dimension=dim, gravity=gravity)


def _ball(dim: int, **state) -> Body:
    return Body("body", ball(R, dim), mass=MASS, position=(0, 0, R), **state)


# Restitution: a ball meeting the ground at 1 m/s, gravity off, leaves at e times that
# (e = 0.5), or stays (e = 0); read 40 steps later (a compliant contact takes ~16 of them).
RESTITUTION = Plant(
    scene=lambda dim, on: _on_ground(_ball(dim, velocity=(0, 0, -1.0)), Material(e=0.5 if on else 0.0), dim,
                                     gravity=(0.0, 0.0, 0.0)),
    steps=40, read=lambda s: s["body"][9], planted=lambda dim: 0.5)

def _box(dim: int) -> Body:
    """A box resting on the ground, sliding at 1 m/s."""
    return Body("body", cube(0.1, dim), mass=MASS, position=(0, 0, 0.1), velocity=(1.0, 0, 0))


# Friction: a box sliding at 1 m/s loses mu g t of it (mu = 0.5, 30 steps: 0.147 m/s).
FRICTION = Plant(
    scene=lambda dim, on: _on_ground(_box(dim), Material(mu_s=0.5 if on else 0.0), dim),
    steps=30, read=lambda s: s["body"][7], planted=lambda dim: 0.5 * G * 30 * DT)

# Kinetic friction apart from static: the sliding box brakes at mu_k g (0.3) instead of mu_s g
# (0.8): 0.147 m/s in 30 steps.
STATIC_KINETIC = Plant(
    scene=lambda dim, on: _on_ground(_box(dim), Material(mu_s=0.8, mu_k=0.3 if on else None), dim),
    steps=30, read=lambda s: s["body"][7], planted=lambda dim: 0.5 * G * 30 * DT)

# Rolling resistance d = 5 mm: a ball rolling at 1 m/s (w = v / R) slows at d g / R / (1 + I/(m R^2)),
# 5/7 of it for a sphere, 2/3 for a disc: 0.0175 m/s and 0.0164 m/s in 50 steps.
ROLLING = Plant(
    scene=lambda dim, on: _on_ground(_ball(dim, velocity=(1.0, 0, 0), angular_velocity=(0, 1.0 / R, 0)),
                                     Material(mu_s=0.5, rolling_resistance=0.005 if on else 0.0), dim),
    steps=50, read=lambda s: s["body"][7],
    planted=lambda dim: (5 / 7 if dim == 3 else 2 / 3) * 0.005 * G / R * 50 * DT, settle=100)

# Torsional friction d_t = 5 mm: a ball spinning at 10 rad/s about the normal slows at
# d_t m g / (2/5 m R^2): 0.61 rad/s in 50 steps (3D: a 2D body has no spin about a normal).
TORSION = Plant(
    scene=lambda dim, on: _on_ground(_ball(dim, angular_velocity=(0, 0, 10.0)),
                                     Material(mu_s=0.5, torsional_friction=0.005 if on else 0.0), dim),
    steps=50, read=lambda s: s["body"][12], planted=lambda dim: 0.005 * G / (0.4 * R * R) * 50 * DT,
    dimensions=(3,), settle=100)

PLANTS = {"restitution": RESTITUTION, "friction": FRICTION, "static_kinetic": STATIC_KINETIC,
          "rolling_resistance": ROLLING, "torsional_friction": TORSION}


def _run(adapter, scene: Scene, plant: Plant):
    """(the simulation's effects, how far plant.read moved over plant.steps after
    plant.settle), or None if the engine declares the scene unsupported (the reason must
    say something)."""
    why = adapter.capabilities.cannot_run(scene)
    if why is None:
        try:
            sim = adapter.build(scene, Settings(dt=DT))
        except Unsupported as exc:
            why = str(exc)
    if why is not None:
        assert why.strip(), f"{adapter.name}: an unsupported scene needs a reason"
        return None
    with sim:
        for _ in range(plant.settle):
            sim.step()
        start = plant.read(sim.states()) if plant.settle else 0.0  # both runs start alike
        for _ in range(plant.steps):
            sim.step()
        return sim.effects, plant.read(sim.states()) - start


@pytest.mark.parametrize("effect", list(PLANTS))
@pytest.mark.parametrize("engine", registry.engine_names())
def test_a_declared_effect_changes_what_the_engine_does(engine, effect):
    adapter = adapter_or_skip(engine)
    plant = PLANTS[effect]
    dims = [d for d in plant.dimensions if d in adapter.capabilities.dimensions]
    if not dims:
        pytest.skip(f"{engine} runs no {'/'.join(map(str, plant.dimensions))}D scene")
    ran = []
    for dim in dims:
        planted = _run(adapter, plant.scene(dim, True), plant)
        if planted is None:
            continue  # declared unsupported, with its reason
        ran.append(dim)
        plain = _run(adapter, plant.scene(dim, False), plant)
        assert plain is not None, f"{engine} runs the {dim}D scene with {effect} but not without it"
        if effect in EFFECTS:  # static_kinetic is a capability, not an effect a simulation reports
            assert effect in planted[0], f"{engine} ran the {dim}D scene with {effect} but does not report it"
        moved = abs(planted[1] - plain[1])
        assert moved >= 0.5 * plant.planted(dim), (
            f"{engine}, {dim}D: {effect} moves the reading by {moved:.3g}, but should by about "
            f"{plant.planted(dim):.3g}: the engine takes the values and does not simulate the effect "
            "(declare it unsupported, with the measured reason)")
    if not ran:  # a pass would claim a check that never ran
        pytest.skip(f"{engine} declares every {'/'.join(map(str, dims))}D scene with {effect} unsupported")


ALPHA = math.radians(45.0)  # each face of the groove tilted this far from level


def _groove(dim: int) -> Scene:
    """A ball resting in a V-groove of two frictionless planes tilted +-ALPHA, touching both."""
    faces = tuple(Body(name, Plane((s * math.sin(ALPHA), 0.0, math.cos(ALPHA)), 0.0), static=True)
                  for name, s in (("left", 1.0), ("right", -1.0)))
    body = Body("ball", ball(R, dim), mass=MASS, position=(0, 0, R / math.cos(ALPHA)))
    return Scene(bodies=faces + (body,), material=Material(), dimension=dim)


@pytest.mark.parametrize("engine", registry.engine_names())
def test_declared_per_contact_forces_are_each_contacts_own(engine):
    """Each face of the groove carries N = m g / (2 cos alpha) (6.94 N at 45 deg), read as the
    mean of steps 80-100 (a soft contact settles within them); within 2 %, against the
    wrong answer's 50 %."""
    adapter = adapter_or_skip(engine)
    if not adapter.capabilities.contact_forces:
        pytest.skip(f"{engine} declares no contact force read-out")
    dim = 3 if 3 in adapter.capabilities.dimensions else 2
    scene = _groove(dim)
    if adapter.capabilities.cannot_run(scene, frozenset({"contact_forces"})):
        pytest.skip(adapter.capabilities.cannot_run(scene, frozenset({"contact_forces"})))
    try:
        sim = adapter.build(scene, Settings(dt=DT))
    except Unsupported as exc:
        pytest.skip(str(exc))
    forces = []
    with sim:
        for k in range(100):
            sim.step()
            if k >= 80:
                f = sim.contact_forces()
                forces.append([f.get(("ball", "left"), 0.0), f.get(("ball", "right"), 0.0)])
    expected = MASS * G / (2 * math.cos(ALPHA))
    assert np.mean(forces, axis=0) == pytest.approx([expected, expected], rel=0.02), \
        f"{engine}: each face's normal force, but should be m g / (2 cos alpha) = {expected:.4g} N"


def test_an_effect_the_solver_drops_is_unsupported_with_the_engines_reason():
    """Capabilities.why_not: the reason an engine gives for an effect it has the values for
    but does not simulate is what cannot_run says; an unknown effect is refused."""
    from adapters.base import Capabilities
    caps = Capabilities(dimensions=frozenset({3}), shapes=frozenset({"sphere", "plane"}), native_restitution=True,
                        static_kinetic=True, contact_forces=True, iterations=True,
                        why_not=(("rolling_resistance", "the solver drops the rolling rows (measured)"),))
    scene = ROLLING.scene(3, True)
    assert caps.cannot_run(scene) == ("rolling resistance = 0.005 m for ground/body: the solver drops the rolling "
                                      "rows (measured)")
    assert "the engine has no torsional friction" in caps.cannot_run(TORSION.scene(3, True))
    with pytest.raises(ValueError, match="why_not"):
        Capabilities(**{**caps.__dict__, "why_not": (("rolling", "no"),)})


@pytest.mark.engine("pybullet-dantzig", "pybullet-pgs")
@pytest.mark.parametrize("engine", ["pybullet-dantzig", "pybullet-pgs"])
def test_pybullets_mlcp_solvers_say_why_3d_contact_torques_are_unsupported(engine):
    adapter = adapter_or_skip(engine)
    for plant in (ROLLING, TORSION):
        scene = plant.scene(3, True)
        why = adapter.capabilities.cannot_run(scene)
        if why is None:
            with pytest.raises(Unsupported) as exc:
                adapter.build(scene, Settings(dt=DT))
            why = str(exc.value)
        assert "MLCP solvers (Dantzig, PGS) drop the rolling and spinning rows" in why
