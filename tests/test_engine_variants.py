"""Engine variants are configurations users run (adapters/registry.py): each differs from its
engine's plain configuration in the knobs it names, and in nothing else.

Each test skips cleanly when its engine's package is missing."""
from __future__ import annotations

import pytest

from adapters import registry
from adapters.base import Settings, Unsupported
from cases.scene import Body, Material, Scene, ball, cube, ground
from tests.helpers import adapter_or_skip


def _scene(dim: int = 3) -> Scene:
    """A ball bouncing with e = 0.5 and a box resting with e = 0 and friction."""
    return Scene(bodies=(ground(), Body("ball", ball(0.1, dim), mass=1.0, position=(0, 0, 0.5)),
                         Body("box", cube(0.1, dim), mass=1.0, position=(1, 0, 0.1))),
                 pairs=(("ground", "ball", Material(e=0.5, mu_s=0.5)), ("ground", "box", Material(e=0.0, mu_s=0.5)),
                        ("ball", "box", Material(e=0.0, mu_s=0.25))), dimension=dim)


def _knobs(name, scene=None):
    sim = adapter_or_skip(name).build(scene or _scene(), Settings(dt=1e-3))
    try:
        return sim.knobs
    finally:
        sim.close()


@pytest.mark.engine("mujoco-defaults")
def test_mujoco_defaults_reverts_the_contact_tuning_and_keeps_what_the_scene_asks():
    """Cone, impratio, solimp, solreffriction and the solref of e = 0 pairs are MuJoCo's
    defaults; the e = 0.5 pair keeps its mapped solref, every pair its friction and condim,
    and the solver options and effect switches are the tuned adapter's."""
    tuned, plain = _knobs("mujoco"), _knobs("mujoco-defaults")
    from adapters import mujoco_engine as mj
    assert plain["option"]["cone"] == "pyramidal" and plain["option"]["impratio"] == 1.0
    assert {k: v for k, v in plain["option"].items() if k not in ("cone", "impratio")} == \
        {k: v for k, v in tuned["option"].items() if k not in ("cone", "impratio")}
    assert plain["flag"] == tuned["flag"]
    pairs, tuned_pairs = plain["pair"], tuned["pair"]
    assert pairs["ball|ground"]["solref"] == tuned_pairs["ball|ground"]["solref"]  # e = 0.5: mapped
    assert pairs["box|ground"]["solref"] == list(mj.DEFAULT_SOLREF)                # e = 0: MuJoCo's
    for key, pair in pairs.items():
        assert pair["solimp"] == list(mj.DEFAULT_SOLIMP)
        assert pair["condim"] == tuned_pairs[key]["condim"] and pair["friction"] == tuned_pairs[key]["friction"]
        if pair["condim"] == 3:
            assert pair["solreffriction"] == [0, 0]
    assert plain["mujoco_defaults"] == sorted(mj.DEFAULTABLE)


@pytest.mark.engine("mujoco", "mujoco-defaults")
def test_mujoco_reverts_one_knob_at_a_time_and_refuses_an_unknown_one():
    pytest.importorskip("mujoco")
    from adapters.mujoco_engine import MuJoCoAdapter
    sim = MuJoCoAdapter(defaults=("cone",)).build(_scene(), Settings(dt=1e-3))
    assert sim.knobs["option"]["cone"] == "pyramidal" and sim.knobs["option"]["impratio"] == 100.0
    with pytest.raises(ValueError, match="defaults"):
        MuJoCoAdapter(defaults=("tolerance",))


@pytest.mark.engine("pybullet-dantzig", "pybullet-pgs")
@pytest.mark.parametrize("name, solver", [("pybullet-dantzig", "DANTZIG"), ("pybullet-pgs", "PGS")])
def test_pybullet_solver_variants_change_the_solver_only(name, solver):
    tuned, variant = _knobs("pybullet"), _knobs(name)
    assert tuned["constraintSolverType"] == "CONSTRAINT_SOLVER_LCP_SI"
    assert variant["constraintSolverType"] == f"CONSTRAINT_SOLVER_LCP_{solver}"
    assert {k: v for k, v in variant.items() if k != "constraintSolverType"} == \
        {k: v for k, v in tuned.items() if k != "constraintSolverType"}


@pytest.mark.engine("pybullet-pgs")
def test_pybullet_pgs_turns_2d_scenes_away_with_the_reason():
    with pytest.raises(Unsupported, match="NaN"):
        adapter_or_skip("pybullet-pgs").build(_scene(2), Settings(dt=1e-3))


def _states(name: str, scene: Scene, steps: int = 300):
    """(the client the scene was built in, its state after each step as bytes)."""
    from physval.core.record import simulate
    sim = adapter_or_skip(name).build(scene, Settings(dt=1e-3))
    with sim:
        client = sim._client
        run = simulate(sim, scene, 1e-3, steps)
    return client, b"".join(run.trajectory.states[n].tobytes() for n in sorted(run.trajectory.states))


@pytest.mark.engine("pybullet")
def test_a_pybullet_client_kept_for_the_next_scene_steps_it_bit_for_bit_as_a_new_one():
    """PyBullet's clients are reset and kept for the next scene built alike (pybullet_engine._IDLE):
    the same scene stepped in a new client, then in that client kept after another
    configuration's scene (Dantzig's MLCP, a 2D scene) ran in its own, gives the same bits."""
    adapter_or_skip("pybullet")  # Python 3.12's all leaves PyBullet out
    from adapters import pybullet_engine
    pybullet_engine._IDLE.clear()
    first, before = _states("pybullet", _scene())
    _states("pybullet-dantzig", _scene())
    _states("pybullet", _scene(2))
    again, after = _states("pybullet", _scene())
    assert again == first and after == before

# --- continuous collision: configurations of their own, run by default on the "swept" families ---

CCD = {"pybullet-ccd": "pybullet", "mujoco-speculative": "mujoco", "rapier-ccd": "rapier", "box2d-bullet": "box2d",
       "box3d-bullet": "box3d", "physx-ccd": "physx"}


def _bullet_scene(dim: int = 3) -> Scene:
    """A 1 cm ball at 100 m/s and a resting 1 cm plate, no gravity (cases/robustness/tunnelling.py)."""
    from cases.robustness import tunnelling
    return tunnelling.scene({"v": 100.0, "dim": dim, "gap": tunnelling.FAR})


@pytest.mark.parametrize("name", sorted(CCD))
def test_a_continuous_collision_configuration_runs_the_swept_families_by_default(name):
    from cases.registry import builtin_families
    adapter = adapter_or_skip(name)
    assert adapter.default_tags == frozenset({"swept"})
    assert adapter_or_skip(CCD[name]).default_tags is None  # the plain engine runs everything
    assert any("swept" in f.tags for f in builtin_families().values())


@pytest.mark.parametrize("name", ["pybullet-ccd", "mujoco-speculative", "physx-ccd"])
def test_a_continuous_collision_configuration_takes_no_other_family_in_a_default_run(name):
    """Its compliant-law variants (hertz_impact's hooke ones: the engine models Hooke) and the
    invariance relations' scenes outside the swept families stay out of a default run: the
    configuration changes only the continuous collision, so they would repeat the plain
    engine's runs (a default run at 5e2c8c7 held them, 29 rows of them)."""
    from physval.core import Context
    from physval.core.plan import plan, relation_jobs
    from cases import relations
    adapter_or_skip(name)
    resolver = Context().resolver()
    families = resolver.families
    chosen = {f: list(families[f].variants) for f in ("hertz_impact", "newtons_cradle", "robustness_tunnelling")}
    jobs, _ = plan(chosen, [name, CCD[name]], resolver, False)
    ran = {(j.engine, j.family) for j in jobs}
    assert {f for e, f in ran if e == name} == {"robustness_tunnelling"}
    assert {"hertz_impact", "newtons_cradle"} <= {f for e, f in ran if e == CCD[name]}
    battery = relation_jobs([r.name for r in relations.RELATIONS], [name], resolver, False)
    assert all("swept" in families[j.family].tags for j in battery)


@pytest.mark.engine("pybullet-ccd")
def test_pybullet_ccd_sweeps_every_dynamic_body_and_the_plain_engine_none():
    adapter_or_skip("pybullet-ccd")  # Python 3.12's all leaves PyBullet out
    from adapters.pybullet_engine import SWEPT_SPHERE_FRACTION
    ccd, plain = _knobs("pybullet-ccd", _bullet_scene()), _knobs("pybullet", _bullet_scene())
    swept = {b: [c["ccdSweptSphereRadius"] for c in r["changeDynamics"] if "ccdSweptSphereRadius" in c][0]
             for b, r in ccd["bodies"].items()}
    assert swept == {"bullet": SWEPT_SPHERE_FRACTION * 0.01, "plate": SWEPT_SPHERE_FRACTION * 0.005}
    assert not any("ccdSweptSphereRadius" in c for r in plain["bodies"].values() for c in r["changeDynamics"])


@pytest.mark.parametrize("name, flag", [("box2d-bullet", "is_bullet"), ("box3d-bullet", "isBullet"),
                                        ("rapier-ccd", "ccd_enabled")])
def test_bullets_are_the_fast_bodies_only(name, flag):
    """Box2D and Box3D sweep no pair of two bullets, Rapier none of two CCD bodies (the bullet
    passed the plate, measured): the ball moving 10 cm a step gets it, the resting plate not."""
    scene = _bullet_scene(2 if name == "box2d-bullet" else 3)
    bodies = _knobs(name, scene)["bodies"]
    assert bodies["bullet"][flag] is True and bodies["plate"][flag] is False
    assert _knobs(CCD[name], scene)["bodies"]["bullet"][flag] is False


@pytest.mark.engine("physx-ccd")
def test_physx_ccd_sets_swept_ccd_on_the_scene_and_every_dynamic_body_and_nothing_else():
    """PhysX sweeps only with both flags (either alone, the ball passed the plate: measured):
    the scene's enableCCD and every dynamic body's, written into the USD layer and recorded;
    speculative CCD off in both; the plain engine has neither, and the two differ in nothing
    else."""
    for dim in (3, 2):
        on, off = _knobs("physx-ccd", _bullet_scene(dim)), _knobs("physx", _bullet_scene(dim))
        assert on["PhysicsScene"]["enableCCD"] is True and off["PhysicsScene"]["enableCCD"] is False
        for body in ("bullet", "plate"):
            assert on["bodies"][body]["enableCCD"] is True and off["bodies"][body]["enableCCD"] is False
            assert on["bodies"][body]["enableSpeculativeCCD"] is False is off["bodies"][body]["enableSpeculativeCCD"]
        strip = lambda k: {**k, "PhysicsScene": {**k["PhysicsScene"], "enableCCD": None},  # noqa: E731
                           "bodies": {b: {**r, "enableCCD": None} for b, r in k["bodies"].items()}}
        assert strip(on) == strip(off)
    sim = adapter_or_skip("physx-ccd").build(_bullet_scene(), Settings(dt=1e-3))
    try:
        with open(sim._file) as f:
            layer = f.read()
    finally:
        sim.close()
    assert "bool physxScene:enableCCD = 1" in layer
    assert layer.count("bool physxRigidBody:enableCCD = 1") == 2 and "enableSpeculativeCCD = 1" not in layer


@pytest.mark.engine("mujoco-speculative")
def test_mujoco_speculative_sets_the_flag_and_nothing_else():
    on, off = _knobs("mujoco-speculative", _bullet_scene()), _knobs("mujoco", _bullet_scene())
    assert on["flag"]["speculative"] == "enable" and off["flag"]["speculative"] == "disable"
    assert {k: v for k, v in on["flag"].items() if k != "speculative"} == \
        {k: v for k, v in off["flag"].items() if k != "speculative"}


def test_the_inscribed_radius_of_each_shape():
    from adapters.solids import inscribed_radius, starts_fast
    from cases.narrow_phase import CUBE
    from cases.scene import Box, Capsule, Cylinder, Hull, Polygon
    assert inscribed_radius(ball(0.1)) == 0.1 and inscribed_radius(Capsule(0.1, 0.5)) == 0.1
    assert inscribed_radius(Box((0.3, 0.2, 0.4))) == 0.2 and inscribed_radius(Cylinder(0.2, 0.1)) == 0.1
    assert inscribed_radius(Hull(CUBE)) == pytest.approx(0.5)
    assert inscribed_radius(Polygon(((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)))) == pytest.approx(0.5 ** 0.5)
    ball_at = lambda v: Body("b", ball(0.01), mass=1.0, velocity=(v, 0.0, 0.0))  # noqa: E731
    assert starts_fast(ball_at(11.0), 1e-3) and not starts_fast(ball_at(9.0), 1e-3)


def test_lemke_runs_every_grasp_and_rail_slide_in_a_default_run_and_on_demand_adds_none():
    """reference-lemke's pinch grasps, 3D and 2D, and its rail slide run in a default run, as
    the other formulations' do: the shipped cost table (physval/readings/costs.csv) prices
    each under the per-job limit (its 3D grasps at 2.1-6.6 s with one BLAS thread; at 119-125 s
    with BLAS threads oversubscribing the cores, they waited for --on-demand)."""
    from physval.core import Context
    from physval.core.plan import plan
    from physval.readings import cost
    resolver = Context().resolver()
    price = cost.pricer(resolver, cost.model_for(None))
    chosen = {f: list(resolver.families[f].variants) for f in ("pinch_grasp", "rail_slide")}
    jobs, later = plan(chosen, ["reference-lemke", "reference-pgs"], resolver, False, price=price)
    assert later == []
    ran = {(j.engine, j.family, j.variant.params.get("dim")) for j in jobs}
    assert {("reference-lemke", "pinch_grasp", 3), ("reference-lemke", "pinch_grasp", 2),
            ("reference-lemke", "rail_slide", 3), ("reference-pgs", "pinch_grasp", 3)} <= ran
    on_demand, later = plan(chosen, ["reference-lemke", "reference-pgs"], resolver, False, on_demand=True,
                            price=price)
    assert not later and {j.key for j in on_demand} == {j.key for j in jobs}


def test_the_float32_ports_of_mujoco_declare_mujoco_cs_capabilities_in_single_precision():
    """MJX and MuJoCo Warp build MuJoCo C's model and read its joint tree's states through
    MuJoCo C's kinematics: their capabilities (float32_capabilities, which needs neither port
    installed) are MuJoCo C's, joints and loads included, but for 32-bit floats and no
    threads or saved states; a port installed declares exactly those."""
    from dataclasses import fields
    from adapters.mujoco_engine import MuJoCoAdapter, float32_capabilities
    why = (("threads", "no thread pool here"),)
    port, c = float32_capabilities(why), MuJoCoAdapter.capabilities
    changed = {f.name for f in fields(port) if getattr(port, f.name) != getattr(c, f.name)}
    assert changed == {"float_bits", "modes", "why_not"}
    assert port.float_bits == 32 and not port.modes and port.why_not == why
    assert port.joints == c.joints and port.loads and port.coordinates == "reduced"
    assert port.contact_laws == c.contact_laws and port.contact_torques == c.contact_torques
    for name in ("mujoco-mjx", "mujoco-warp"):
        try:
            adapter = registry.get(name)
        except registry.EngineError:
            continue  # not installed: the registry lists it so (physval list --engines)
        assert adapter.capabilities == float32_capabilities()
