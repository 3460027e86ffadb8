"""MuJoCo Warp's adapter: one step replayed as a Warp graph is bit for bit MuJoCo Warp's own
step, the contacts read from Warp's arrays are what mujoco_warp.get_data_into exports, and the
model is MuJoCo's (the same MJCF knobs); float32 declared."""
from __future__ import annotations

import numpy as np
import pytest

from adapters import registry
from tests.helpers import variant_scene

pytestmark = pytest.mark.engine("mujoco-warp")


@pytest.fixture(scope="module")
def adapter():
    try:
        return registry.get("mujoco-warp")
    except registry.EngineError as exc:
        pytest.skip(str(exc))


def _built(adapter, family: str, variant: str):
    scene, settings = variant_scene(family, variant)
    return scene, settings, adapter.build(scene, settings)


def test_the_replayed_graph_is_mujoco_warps_own_step(adapter):
    import mujoco_warp as mjw
    scene, settings, a = _built(adapter, "central_impact", "drop,e=0.5")
    b = adapter.build(scene, settings)
    ra, rb = np.zeros(a.state_size()), np.zeros(b.state_size())
    for _ in range(600):  # the fall and the impact
        a.step()
        mjw.step(b._wm, b._wd)
        a.write_state(ra)
        b.write_state(rb)
        assert np.array_equal(ra, rb)


def test_contacts_read_from_warp_are_what_get_data_into_exports(adapter):
    from adapters.mujoco_engine import MuJoCoSimulation
    _, _, sim = _built(adapter, "resting_blocks", "n=3")
    for _ in range(200):
        sim.step()
    lean = sim.contact_forces()
    points = sim.contact_points()
    sim._mjw.get_data_into(sim._data, sim._model, sim._wd)
    sim._contacts = lambda: sim._data  # MuJoCo C's read-out of the exported MjData
    assert lean == MuJoCoSimulation.contact_forces(sim)
    full = MuJoCoSimulation.contact_points(sim)
    assert len(points) == len(full) > 0
    for p, q in zip(points, full):
        assert (p.a, p.b, p.f_n) == (q.a, q.b, q.f_n)
        assert np.array_equal(p.x, q.x) and np.array_equal(p.f_t, q.f_t)


def test_the_model_is_mujocos_and_the_floats_are_32_bits(adapter):
    mujoco = registry.get("mujoco")
    scene, settings, sim = _built(adapter, "central_impact", "drop,e=0.5")
    assert adapter.capabilities.float_bits == 32 and not adapter.capabilities.substeps
    _, knobs, _ = mujoco.model(scene, settings)
    assert {k: v for k, v in sim.knobs.items() if k != "mujoco_warp"} == knobs
    assert sim.knobs["mujoco_warp"]["device"] == "cpu"
    assert "mjDSBL_AUTORESET" in sim.knobs["mujoco_warp"]["cleared_flags"]
    assert adapter.version().endswith(", cpu)")


def test_the_device_comes_from_the_environment_and_names_the_version(adapter, monkeypatch):
    from adapters.mujoco_warp_engine import DEVICE_ENV, MuJoCoWarpAdapter
    monkeypatch.setenv(DEVICE_ENV, "cuda:0")
    gpu = MuJoCoWarpAdapter()
    assert gpu.device == "cuda:0" and gpu.version().endswith(", cuda:0)")
    assert MuJoCoWarpAdapter(device="cpu").device == "cpu"
    monkeypatch.delenv(DEVICE_ENV)
    assert MuJoCoWarpAdapter().device == "cpu"

