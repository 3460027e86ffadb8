"""MJX collides only the geom pairs it has a function for (mjx/_src/collision_driver.py): a scene
with another pair is `unsupported`, naming its bodies, shapes and MJX's missing pair, before
any JAX array is made (so no compiling: about a second for importing JAX). Skipped where
mujoco-mjx is not installed."""
from __future__ import annotations

import pytest

from adapters.base import Settings, Unsupported
from cases.scene import Body, Box, Cylinder, Scene, Sphere, ground
from tests.helpers import adapter_or_skip

pytestmark = pytest.mark.engine("mujoco-mjx")


def _on_box(shape) -> Scene:
    """`shape` resting on a static box (not the plane, which MJX collides with every shape)."""
    return Scene(bodies=(Body("slab", Box((1.0, 1.0, 0.1)), static=True, position=(0.0, 0.0, -0.1)),
                         Body("top", shape, mass=1.0, position=(0.0, 0.0, 0.2))))


def test_a_cylinder_on_a_box_is_unsupported_with_mjxs_missing_pair():
    adapter = adapter_or_skip("mujoco-mjx")
    with pytest.raises(Unsupported) as caught:
        adapter.build(_on_box(Cylinder(0.1, 0.2)), Settings(dt=1e-3))
    why = str(caught.value)
    assert "box 'slab' against cylinder 'top'" in why or "cylinder 'top' against box 'slab'" in why, why
    assert ("box-cylinder" in why or "cylinder-box" in why) and "no collision function" in why, why


def test_mjxs_table_is_asked_not_a_copy_of_it():
    # a sphere on a box has MJX's sphere_convex: no reason, so the check does not refuse
    # what MJX collides (the same model MuJoCo C steps)
    adapter = adapter_or_skip("mujoco-mjx")
    from adapters.mjx_engine import missing_collision
    scene = _on_box(Sphere(0.1))
    model, _, _ = adapter.model(scene, Settings(dt=1e-3))
    assert missing_collision(model, scene) is None
    cylinder = _on_box(Cylinder(0.1, 0.2))
    assert missing_collision(adapter.model(cylinder, Settings(dt=1e-3))[0], cylinder) is not None


def test_a_cylinder_on_the_plane_is_collided():
    adapter = adapter_or_skip("mujoco-mjx")
    from adapters.mjx_engine import missing_collision
    scene = Scene(bodies=(ground(), Body("top", Cylinder(0.1, 0.2), mass=1.0, position=(0.0, 0.0, 0.2))))
    assert missing_collision(adapter.model(scene, Settings(dt=1e-3))[0], scene) is None
