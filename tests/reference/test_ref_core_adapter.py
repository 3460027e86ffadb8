"""The reference adapter translates scenes faithfully and records what it set."""
from __future__ import annotations

import json
import math
import pickle

import numpy as np
import pytest

from adapters.base import Settings
from adapters.reference_engine import ReferenceAdapter
from cases.scene import Body, Box, Circle, Material, Rect, Scene, Sphere, ground, tilted_gravity

DT = 1e-3


def test_name_and_capabilities():
    adapter = ReferenceAdapter()
    assert adapter.name == "reference"
    caps = adapter.capabilities
    assert caps.dimensions == {2, 3}
    assert caps.shapes == {"sphere", "box", "plane", "circle", "rect", "capsule", "cylinder", "hull", "mesh"}
    assert caps.native_restitution and caps.static_kinetic and caps.contact_forces and caps.iterations
    with pytest.raises(ValueError, match="no_such"):
        ReferenceAdapter("no_such")


SCENES = {
    "impact": Scene(bodies=(Body("a", Sphere(0.1), mass=1.0, velocity=(1.0, 0, 0), rotates=False),
                            Body("b", Sphere(0.1), mass=1.0, position=(0.3, 0, 0), rotates=False)),
                    gravity=(0.0, 0.0, 0.0), material=Material(e=0.5)),
    "incline": Scene(bodies=(ground(), Body("box", Box((0.1, 0.1, 0.1)), mass=1.0, position=(0, 0, 0.1))),
                     gravity=tilted_gravity(0.3), material=Material(mu_s=0.5)),
    "free fall": Scene(bodies=(Body("ball", Sphere(0.1), mass=1.0, rotates=False),)),
    "2D": Scene(bodies=(ground(), Body("disc", Circle(0.1), mass=1.0, position=(0, 0, 0.3)),
                        Body("rect", Rect((0.1, 0.05)), mass=1.0, position=(0.5, 0, 0.3))),
                material=Material(e=0.3, mu_s=0.4, mu_k=0.2), dimension=2),
}


@pytest.mark.parametrize("name", list(SCENES))
def test_simulates_exactly_the_effects_the_scene_calls_for_and_prints_nothing(name, capfd):
    scene = SCENES[name]
    sim = ReferenceAdapter().build(scene, Settings(dt=DT))
    for _ in range(300):
        sim.step()
    assert sim.effects == scene.effects
    knobs = json.loads(json.dumps(sim.knobs))
    for key in ("formulation", "iterations", "tolerance", "beta", "slop", "warm_start", "stick_speed",
                "margin", "stages_ran"):
        assert key in knobs
    stages = set(knobs["stages_ran"])
    assert ("gravity" in stages) == ("gravity" in scene.effects)
    assert ("rotations" in stages) == ("rotation" in scene.effects)
    assert ("si:friction" in stages) <= ("friction" in scene.effects)
    assert capfd.readouterr() == ("", "")


def test_iterations_setting_is_the_solvers_sweep_cap():
    sim = ReferenceAdapter().build(SCENES["incline"], Settings(dt=DT, iterations=7))
    assert sim.iterations == 7 and sim.knobs["iterations"] == 7
    assert ReferenceAdapter().build(SCENES["incline"], Settings(dt=DT)).iterations >= 1


def test_a_2d_body_turned_out_of_the_plane_is_no_scene():
    """The vocabulary refuses it, so no engine has to (cases.scene validates 2D scenes)."""
    from cases.scene import SceneError
    tilted = (math.cos(0.1), math.sin(0.1), 0.0, 0.0)  # about x
    with pytest.raises(SceneError, match="a 2D body turns about y only"):
        Scene(bodies=(Body("rect", Rect((0.1, 0.1)), mass=1.0, orientation=tilted),), dimension=2)


def test_pair_materials_reach_their_pairs():
    # two balls dropped side by side, each with its own restitution against the ground
    scene = Scene(bodies=(ground(), Body("soft", Sphere(0.1), mass=1.0, position=(0, 0, 0.6), rotates=False),
                          Body("hard", Sphere(0.1), mass=1.0, position=(1.0, 0, 0.6), rotates=False)),
                  pairs=(("ground", "soft", Material(e=0.2)), ("ground", "hard", Material(e=0.8))))
    sim = ReferenceAdapter().build(scene, Settings(dt=DT))
    v = {"soft": [], "hard": []}
    for _ in range(400):
        sim.step()
        for k, row in sim.states().items():
            v[k].append(row[9])
    for name, e in (("soft", 0.2), ("hard", 0.8)):
        vz = np.array(v[name])
        k = int(np.argmax((vz[:-1] < 0) & (vz[1:] >= 0)))
        assert -vz[k + 1] / vz[k] == pytest.approx(e, rel=1e-12)


def test_a_static_box_carries_a_stack_like_the_ground():
    scene = Scene(bodies=(Body("table", Box((1.0, 1.0, 0.1)), static=True, position=(0, 0, -0.1)),
                          Body("box", Box((0.1, 0.1, 0.1)), mass=2.0, position=(0, 0, 0.1))),
                  material=Material(mu_s=0.5))
    sim = ReferenceAdapter().build(scene, Settings(dt=DT))
    forces = []
    for _ in range(500):
        sim.step()
        forces.append(sim.contact_forces()[("box", "table")])
    assert np.mean(forces[-100:]) == pytest.approx(2.0 * 9.81, rel=1e-9)
    assert sim.states()["box"][2] == pytest.approx(0.1, abs=1e-9)


def _stack_of_two(sim, steps: int) -> np.ndarray:
    """The bodies' states over `steps` steps (steps, 2 * 13)."""
    out = np.empty((steps, sim.state_size()))
    for k in range(steps):
        sim.step()
        sim.write_state(out[k])
    return out


def test_a_saved_world_continues_bit_for_bit_in_a_freshly_built_one():
    """World.save (the compiled state's body rows and warm start), pickled and restored into a new
    simulation of the same scene continues exactly as the one it was saved from; without
    the warm start (the contacts' impulses) the same restore does not: the warm start is
    part of what a step reads."""
    from reference_impl.contact import contact_arrays, new_contacts
    scene = Scene((ground(), Body("low", Box((0.1, 0.1, 0.1)), mass=1.0, position=(0.0, 0.0, 0.1)),
                   Body("high", Box((0.1, 0.1, 0.1)), mass=1.0, position=(0.01, 0.0, 0.3))),
                  material=Material(mu_s=0.5))
    first = ReferenceAdapter().build(scene, Settings(dt=DT))
    _stack_of_two(first, 25)
    saved = first.save_state()
    on = _stack_of_two(first, 25)
    again = ReferenceAdapter().build(scene, Settings(dt=DT))
    again.restore_state(pickle.loads(pickle.dumps(saved)))  # picklable, as the contract asks
    assert np.array_equal(_stack_of_two(again, 25), on)
    cold = ReferenceAdapter().build(scene, Settings(dt=DT))
    cold.restore_state(saved._replace(features={}, contacts=contact_arrays(new_contacts(0)),
                                      pairs=np.zeros((0, 2), np.int64), impulses=np.zeros(0)))
    assert not np.array_equal(_stack_of_two(cold, 25), on)


def test_the_step_halves_compiled_ahead_have_the_types_of_every_battery_world():
    """What the harness compiles ahead on a fresh install (ReferenceAdapter.uncompiled: the
    halves of a sample world's step, reference_impl.world.compile_half) is what the worlds
    of every family's variants then call: the same argument types, so their first step
    loads the halves and compiles nothing."""
    from numba import typeof

    from adapters.base import Unsupported
    from adapters.reference_engine import part_config
    from adapters.registry import engine_names, get
    from cases.registry import builtin_families
    from physval.core.jobs import scene_of
    from reference_impl.compiled import JIT
    from reference_impl.world import _half
    if not JIT:
        pytest.skip("compiled code only (numba installed, NUMBA_DISABLE_JIT unset)")
    built = 0
    for engine in (n for n in engine_names() if n.startswith("reference")):
        adapter = get(engine)
        for family in builtin_families().values():
            for variant in family.variants[:2]:
                scene = scene_of(family, variant)
                try:
                    world = adapter.world_of(scene, Settings(dt=DT))
                except Unsupported:
                    continue
                state = world._build()
                half = "end_joints" if world.joints else "end"
                # the config compile_part compiles under (the adapter's, without the scene's)
                config = part_config(adapter.part(half))
                sample_state, sample_stepper = _half(config, "begin")[1], _half(config, half)[1]
                assert typeof(state) == typeof(sample_state), f"{engine} {variant.test_id}: begin"
                assert typeof(world._stepper) == typeof(sample_stepper), f"{engine} {variant.test_id}: {half}"
                built += 1
    assert built > 300, built
