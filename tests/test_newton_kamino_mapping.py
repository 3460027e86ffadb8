"""newton-kamino (adapters/newton_engine.py): SolverKamino's LOX backend with implicit
restitution where the scene asks for e > 0, the pair's mu and e by the arithmetic mean; a body
held from rotating has a huge inertia, not a singular one (LOX refuses those); and one step
replayed as a Warp graph is bit for bit the unrecorded collision detection and step. Slow:
Newton and Warp start in ~10 s a process with a full kernel cache."""
from __future__ import annotations

import numpy as np
import pytest

from adapters import registry
from tests.helpers import variant_scene

pytestmark = [pytest.mark.engine("newton-kamino"), pytest.mark.slow]


@pytest.fixture(scope="module")
def adapter():
    try:
        return registry.get("newton-kamino")
    except registry.EngineError as exc:
        pytest.skip(str(exc))


@pytest.mark.parametrize("variant, restitution", [("drop,e=0.5", True), ("drop,e=0.0", False)])
def test_implicit_restitution_is_on_where_the_scene_asks_for_it(adapter, variant, restitution):
    sim = adapter.build(*variant_scene("central_impact", variant))
    assert sim.knobs["dynamics_solver"] == "lox"
    assert sim.knobs["contact_implicit_restitution"] is restitution
    assert ("restitution" in sim.effects) is restitution
    assert sim.knobs["friction_mix_mode"] == sim.knobs["restitution_mix_mode"] == "average"


def test_a_body_held_from_rotating_has_a_huge_inertia_not_a_singular_one(adapter):
    scene, settings = variant_scene("conformance", "locked_rotation_stays_locked,3D")
    sim = adapter.build(scene, settings)
    held = sim._still[0]
    inverse = sim._model.body_inv_inertia.numpy()[held]
    assert 0.0 < np.abs(inverse).max() < 1e-9


def test_the_replayed_graph_is_the_unrecorded_step(adapter):
    scene, settings = variant_scene("resting_blocks", "n=3")  # contacts from the first step
    a, b = adapter.build(scene, settings), adapter.build(scene, settings)
    ra, rb = np.zeros(13 * 3), np.zeros(13 * 3)
    for _ in range(200):
        a.step()
        b._s0.clear_forces()
        b._pipeline.collide(b._s0, b._contacts)
        b._solver.step(b._s0, b._s1, b._control, b._contacts, b._dt, observables=b._observables)
        b._s0, b._s1 = b._s1, b._s0
        a.write_state(ra)
        b.write_state(rb)
        assert np.array_equal(ra, rb)
