"""MJX's adapter: a run in jitted scans is bit for bit MJX's own step taken one at a time, the
model is MuJoCo's (its states within float32 of MuJoCo C's over the same steps), and a
frictionless elliptic-cone model steps as pyramidal (the knobs say so). Each test compiles MJX
for a model shape (8-12 s of CPU): slow."""
from __future__ import annotations

import numpy as np
import pytest

from adapters import registry
from tests.helpers import variant_scene

pytestmark = [pytest.mark.engine("mujoco-mjx"), pytest.mark.slow]

STEPS = 300  # a full scan of 256 steps and 44 single steps


@pytest.fixture(scope="module")
def adapter():
    try:
        return registry.get("mujoco-mjx")
    except registry.EngineError as exc:
        pytest.skip(str(exc))


def _states(adapter, bulk: bool) -> tuple[np.ndarray, dict]:
    scene, settings = variant_scene("central_impact", "drop,e=0.5")
    sim = adapter.build(scene, settings)
    out = np.empty((STEPS, sim.state_size()))
    if bulk:
        sim.run(STEPS, out)
    else:
        for i in range(STEPS):
            sim.step()
            sim.write_state(out[i])
    return out, sim.knobs


def test_a_run_in_scans_is_mjx_stepped_one_at_a_time(adapter):
    scanned, knobs = _states(adapter, bulk=True)
    stepped, _ = _states(adapter, bulk=False)
    assert np.array_equal(scanned, stepped)
    assert knobs["mjx"]["impl"] == "jax" and knobs["mjx"]["float_bits"] == 32


def test_mjx_steps_mujocos_model_to_float32(adapter):
    scanned, knobs = _states(adapter, bulk=True)
    c, _ = _states(registry.get("mujoco"), bulk=True)
    # a ball falling 1 m: float32 positions near 1 m round by 6e-8 a step; 300 steps of
    # accumulated round-off (measured 4e-5 over 2048 steps) stay below 1e-4
    assert np.abs(scanned - c).max() < 1e-4
    # the drop is frictionless: its elliptic cone steps as pyramidal (mjx_engine.FRICTIONLESS_CONE)
    assert "pyramidal" in knobs["mjx"]["changed"].get("cone", "")


def test_every_contact_mjx_solved_carries_its_force_into_the_read_out(adapter):
    # get_data_into leaves mjContact.exclude and .adhesion as the MjData's reallocation left
    # them (MJX has neither): read as they were, a lying cylinder at rest on its two line-end
    # contacts summed 4.905 of its 9.81 N. Its weight within float32's solve (measured
    # 1.4e-6 N off; 1e-4 is seventy times that and 100x below the half that went missing)
    sim, weight = _at_rest(adapter, "lying_cylinder", "L=0.5m", "cylinder")
    assert abs(sum(sim.contact_forces().values()) - weight) < 1e-4


def _at_rest(adapter, family: str, variant: str, body: str):
    """(the simulation of `family`'s `variant` after 300 steps, the weight of `body`)."""
    scene, settings = variant_scene(family, variant)
    sim = adapter.build(scene, settings)
    for _ in range(300):
        sim.step()
    return sim, -scene.gravity[2] * next(b for b in scene.bodies if b.name == body).mass


def test_a_planar_contact_reads_its_three_rows(adapter):
    # get_data_into deletes each row whose Jacobian is zero: in a 2D (planar) scene a contact's
    # tangent out of the plane, so each kept 2 of its 3 rows and the read-out, taking three,
    # ran past the last (IndexError) or read the next contact's normal as a friction force.
    # A resting square: its weight within resting_blocks' own force tolerance, 1e-3 N (at step
    # 300 float32's solve of the square, which walks 1.6 mm in 2 s, reads 2.9e-4 N over; the
    # next contact's normal read as friction would be newtons off), from the pair forces and
    # from the points, whose friction has nothing out of the plane (y)
    sim, weight = _at_rest(adapter, "resting_blocks", "n=1,2D", "box0")
    assert abs(sum(sim.contact_forces().values()) - weight) < 1e-3
    points = sim.contact_points()
    assert abs(sum(p.f_n for p in points) - weight) < 1e-3
    assert all(p.f_t[1] == 0.0 for p in points)


def test_a_process_drops_its_compiled_programs_only_past_its_share_of_the_map_limit(adapter, monkeypatch):
    """A worker that had run ~140 MJX jobs held 40-47 thousand memory mappings of Linux's 65530
    and died in XLA's compiler (adapters/mjx_engine.py, MAPS_SHARE): past the share a new
    scene first drops JAX's compiled programs, below it they stay loaded (a shape met again
    costs nothing). Judged on a counting stand-in for JAX, at shares the process is surely
    past (0) and surely under (the limit ten times over)."""
    from pathlib import Path
    from adapters import mjx_engine
    if not Path("/proc/self/maps").exists():
        pytest.skip("no /proc/self/maps: the memory-map limit is Linux's")
    cleared = []
    fake = type("Jax", (), {"clear_caches": staticmethod(lambda: cleared.append(1))})
    monkeypatch.setattr(mjx_engine, "MAPS_SHARE", 10.0)
    mjx_engine._release_programs_if_crowded(fake)
    assert cleared == []
    monkeypatch.setattr(mjx_engine, "MAPS_SHARE", 0.0)
    mjx_engine._release_programs_if_crowded(fake)
    assert cleared == [1]
    import jax  # and a scene's simulation asks before its model goes to JAX
    monkeypatch.setattr(jax, "clear_caches", lambda: cleared.append(2))
    adapter.build(*variant_scene("central_impact", "drop,e=0.5"))
    assert cleared == [1, 2]
