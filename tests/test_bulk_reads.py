"""Every adapter's bulk state read (write_state per step, decode_states after) gives exactly
what states() gives, on 3D and 2D bodies that tumble, slide, spin and are held from
rotating: the fast recording path cannot change a measurement."""
from __future__ import annotations

import numpy as np
import pytest

from adapters import registry
from adapters.base import Settings
from cases.scene import Body, Box, Circle, Material, Rect, Scene, Sphere, ground, quat_about_y

TUMBLE = (0.9, 0.3, -0.2, 0.25)
TUMBLE = tuple(np.asarray(TUMBLE) / np.linalg.norm(TUMBLE))

SCENES = {
    "3D": Scene(bodies=(ground(),
                        Body("box", Box((0.1, 0.2, 0.05)), mass=1.0, position=(0, 0, 0.5), orientation=TUMBLE,
                             velocity=(0.3, -0.2, 0.5), angular_velocity=(1.0, 2.0, -3.0)),
                        Body("ball", Sphere(0.1), mass=2.0, position=(1, 0, 0.1), velocity=(1.0, 0.5, 0.0),
                             rotates=False)),
                gravity=(0, 0, -9.81), material=Material(e=0.5, mu_s=0.5)),
    "2D": Scene(bodies=(ground(),
                        Body("rect", Rect((0.1, 0.05)), mass=1.0, position=(0, 0, 0.4), orientation=quat_about_y(0.3),
                             velocity=(0.5, 0, 1.0), angular_velocity=(0, 4.0, 0)),
                        Body("disc", Circle(0.1), mass=1.0, position=(1, 0, 0.1), velocity=(-1.0, 0, 0), rotates=False)),
                gravity=(0, 0, -9.81), material=Material(e=0.3, mu_s=0.4), dimension=2),
}


ENGINES = ["reference", "pybullet", "mujoco", "pymunk", "dart", "drake", "box2d", "rapier"]


def adapter_for(engine: str, scene: Scene):
    """The engine's adapter, or a skip if it is not installed or cannot run the scene."""
    try:
        adapter = registry.get(engine)
    except registry.EngineError as exc:
        pytest.skip(str(exc))
    if adapter.capabilities.cannot_run(scene):
        pytest.skip(adapter.capabilities.cannot_run(scene))
    return adapter


@pytest.mark.parametrize("dim", ["3D", "2D"])
@pytest.mark.parametrize("engine", ENGINES)
def test_bulk_reads_equal_states(engine, dim):
    scene = SCENES[dim]
    with adapter_for(engine, scene).build(scene, Settings(dt=1e-3)) as sim:
        names = sim.body_order()
        raw = np.empty((80, sim.state_size()))
        expected = []
        for k in range(80):
            sim.step()
            sim.write_state(raw[k])
            expected.append(sim.states())
        got = sim.decode_states(raw)
    assert got.shape == (80, len(names), 13)
    for k in range(80):
        for i, name in enumerate(names):
            np.testing.assert_allclose(got[k, i], expected[k][name], rtol=0, atol=1e-12,
                                       err_msg=f"{engine} {dim} step {k + 1} {name}")


@pytest.mark.parametrize("dim", ["3D", "2D"])
@pytest.mark.parametrize("engine", ENGINES)
def test_stepping_in_blocks_is_bit_for_bit_stepping_in_turn(engine, dim):
    """An adapter's run() (many steps in one call) gives exactly step() and write_state() in turn."""
    scene = SCENES[dim]
    adapter = adapter_for(engine, scene)
    with adapter.build(scene, Settings(dt=1e-3)) as sim:
        if sim.run is None:
            pytest.skip(f"{engine} steps one step at a time")
        blocks = np.empty((600, sim.state_size()))
        for k0 in range(0, 600, 256):
            sim.run(min(256, 600 - k0), blocks[k0:k0 + 256])
    with adapter.build(scene, Settings(dt=1e-3)) as sim:
        turns = np.empty((600, sim.state_size()))
        for k in range(600):
            sim.step()
            sim.write_state(turns[k])
    assert np.array_equal(blocks, turns)
