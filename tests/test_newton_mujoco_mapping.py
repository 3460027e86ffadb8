"""newton-mujoco (adapters/newton_engine.py): the MjModel Newton's SolverMuJoCo compiles carries
the MuJoCo adapter's own contact model (its pairs' solref, solimp, friction, condim and
solreffriction; its cone, impratio and integrator), every geom colliding through its pairs
alone; and one step replayed as a Warp graph is bit for bit SolverMuJoCo's own step. Slow:
Newton and Warp start in ~10 s a process with a full kernel cache."""
from __future__ import annotations

import numpy as np
import pytest

from adapters import registry
from adapters.base import Settings
from cases.registry import builtin_families
from tests.helpers import variant_scene

pytestmark = [pytest.mark.engine("newton-mujoco"), pytest.mark.slow]


@pytest.fixture(scope="module")
def adapter():
    try:
        return registry.get("newton-mujoco")
    except registry.EngineError as exc:
        pytest.skip(str(exc))


@pytest.mark.parametrize("family, variant", [("central_impact", "drop,e=0.5"), ("incline_threshold", "mu=0.5,theta=atan(mu_s)+1deg"),
                                             ("resting_blocks", "n=3")])
def test_the_compiled_model_is_the_mujoco_adapters(adapter, family, variant):
    import mujoco
    scene, settings = variant_scene(family, variant)
    sim = adapter.build(scene, settings)
    ours = sim._solver.mj_model
    theirs = registry.get("mujoco").build(scene, settings)._model
    assert ours.npair == theirs.npair > 0
    # pairs by the scene's body names (Newton names a geom label_shapeindex)
    def pairs(m, name):
        return {tuple(sorted((name(m.pair_geom1[i]), name(m.pair_geom2[i])))): i for i in range(m.npair)}
    name_ours = lambda g: mujoco.mj_id2name(ours, mujoco.mjtObj.mjOBJ_GEOM, g).rsplit("_", 1)[0]
    name_theirs = lambda g: mujoco.mj_id2name(theirs, mujoco.mjtObj.mjOBJ_GEOM, g)
    po, pt = pairs(ours, name_ours), pairs(theirs, name_theirs)
    assert po.keys() == pt.keys()
    for key, i in po.items():
        j = pt[key]
        assert ours.pair_dim[i] == theirs.pair_dim[j]
        for field in ("pair_solref", "pair_solimp", "pair_friction", "pair_solreffriction", "pair_margin", "pair_gap"):
            # Newton keeps the values in float32 on their way to MjSpec
            np.testing.assert_allclose(getattr(ours, field)[i], getattr(theirs, field)[j], rtol=1e-7, atol=0,
                                       err_msg=f"{key} {field}")
    assert not ours.geom_contype.any() and not ours.geom_conaffinity.any()
    for option in ("cone", "impratio", "integrator", "solver", "iterations", "ls_iterations", "tolerance"):
        assert getattr(ours.opt, option) == getattr(theirs.opt, option), option
    assert ours.neq == 0  # no inactive weld per free body (kinematic_switchable_roots=False)
    assert not ours.dof_damping.any() and not ours.dof_armature.any() and not ours.dof_frictionloss.any()


def test_the_replayed_graph_is_solver_mujocos_own_step(adapter):
    scene, settings = variant_scene("central_impact", "drop,e=0.5")
    a, b = adapter.build(scene, settings), adapter.build(scene, settings)
    ra, rb = np.zeros(13), np.zeros(13)
    for _ in range(600):  # the fall and the impact
        a.step()
        b._solver.step(b._s0, b._s1, b._control, b._contacts, b._dt, observables=b._observables)
        b._s0, b._s1 = b._s1, b._s0
        a.write_state(ra)
        b.write_state(rb)
        assert np.array_equal(ra, rb)


def test_a_pyramid_keeps_every_contact(adapter):
    """MuJoCo Warp's contact buffer is sized as the mujoco-warp adapter sizes its own
    (CONTACTS_PER_PAIR a pair, at most CONTACTS_PER_BODY a body): Newton's default of 256
    contacts dropped some of a 55-box pyramid's (a warning, then an IndexError reading the
    forces); now its steps keep every contact and read every force."""
    from adapters.mujoco_warp_engine import contact_capacity
    fam = builtin_families()["robustness_stacks"]
    params = {"structure": "pyramid", "n": 10, "dim": 3, "T": 0.03}
    sim = adapter.build(fam.scene(params), Settings(dt=1e-3))
    nconmax, _ = contact_capacity(sim._solver.mj_model, 55)
    assert sim.knobs["nconmax"] == nconmax > 256
    most = 0
    for _ in range(40):  # the boxes settle onto more corners: over 256 contacts within 40 steps
        sim.step()
        most = max(most, int(sim._nacon[0]))
    assert 256 < most <= sim._naconmax
    forces = sim.contact_forces()
    assert sum(forces.values()) > 0.9 * 55 * 9.81 * min(b.mass for b in fam.scene(params).dynamic_bodies)
