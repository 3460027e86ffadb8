"""Genesis' adapter: the registry names its extra when Genesis is missing; the sol_params it
writes are the MuJoCo adapter's contact spring-damper in Genesis' own form; a built scene
has the scene's mass, rolls as a rigid ball does, reports its weight as the contact force,
and declares the friction rows Genesis cannot leave out; joints carry no rotor inertia Genesis
would add, loads act every step, and a tree's start velocities are the scene's."""
from __future__ import annotations

import importlib.util
import math
import sys

import pytest

from adapters import registry

pytestmark = pytest.mark.engine("genesis")

INSTALLED = importlib.util.find_spec("genesis") is not None and importlib.util.find_spec("torch") is not None


def test_a_missing_genesis_names_its_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "genesis", None)  # as `import` treats a module that is not there
    monkeypatch.delitem(sys.modules, "adapters.genesis_engine", raising=False)
    for name in ("genesis", "genesis-defaults"):
        with pytest.raises(registry.EngineError, match=r"pip install '\.\[genesis\]'"):
            registry.get(name)


@pytest.mark.skipif(not INSTALLED, reason="Genesis is not installed (extra 'genesis')")
@pytest.mark.parametrize("e", [0.0, 0.3, 0.9])
def test_sol_params_are_the_mujoco_spring_damper(e):
    """Genesis reads (timeconst, dampratio) as MuJoCo's positive solref: b = 2 / (dmax tc),
    k = 1 / (dmax^2 tc^2 zeta^2) (genesis.utils.geom.default_solver_params); the MuJoCo
    adapter's direct solref (-K, -B) gives b = B / dmax, k = K / dmax^2. Equal to rounding."""
    from adapters.genesis_engine import solver_params
    from adapters.mujoco_engine import CONTACT_STEPS, SOLIMP, contact_spring_damper
    dt = 1e-3
    tc, zeta, *imp = solver_params(e, CONTACT_STEPS, dt)
    K, B = contact_spring_damper(e, CONTACT_STEPS, dt)
    assert B > 0  # e < 1: the damping is MuJoCo's own (e = 1: test_an_elastic_contact_keeps_the_least_damping)
    assert math.isclose(2.0 / tc, B, rel_tol=1e-12)
    assert math.isclose(1.0 / (tc * zeta) ** 2, K, rel_tol=1e-12)
    assert imp == list(SOLIMP)
    assert tc >= 2.0 * dt * (1 - 1e-12)  # Genesis' floor on timeconst (collider/contact.py): never raised by it


@pytest.mark.skipif(not INSTALLED, reason="Genesis is not installed (extra 'genesis')")
def test_an_elastic_contact_keeps_the_least_damping():
    """e = 1 asks for B = 0, which Genesis' positive form cannot write (timeconst = 2 / B): the
    row keeps LEAST_DAMPING, whose damping ratio costs the rebound pi zeta (< 1e-7 of it)."""
    from adapters.genesis_engine import LEAST_DAMPING, solver_params
    from adapters.mujoco_engine import CONTACT_STEPS, contact_spring_damper, restitution_of_damping_ratio
    tc, zeta, *_ = solver_params(1.0, CONTACT_STEPS, 1e-3)
    K, _ = contact_spring_damper(1.0, CONTACT_STEPS, 1e-3)
    assert tc == 2.0 / LEAST_DAMPING and math.isclose(1.0 / (tc * zeta) ** 2, K, rel_tol=1e-12)
    assert 1.0 - 1e-7 < restitution_of_damping_ratio(zeta) < 1.0


@pytest.mark.slow  # Genesis' import (~14 s of CPU) and a scene's kernels (~9 s with a full cache)
@pytest.mark.skipif(not INSTALLED, reason="Genesis is not installed (extra 'genesis')")
def test_a_ball_sliding_on_the_ground_rolls_at_five_sevenths_and_weighs_m_g():
    """A solid ball launched sliding at v0 on ground with friction ends rolling at 5/7 v0 and
    w = v / r (the rigid-body closed form, independent of mu); the contact force is m g.
    Tolerances: the compliant contact sinks the ball by m g / k (k = (pi / (16 dt))^2 per
    unit mass: 1e-4 m), which shortens the lever arm by as much (1e-3 of r); the force
    within 1e-3 m g (the solver's tolerance on a resting contact)."""
    from adapters.base import Settings
    from cases.scene import Body, Material, Scene, ball, ground
    r, v0, m, g = 0.1, 1.0, 1.0, 9.81
    scene = Scene(bodies=(ground(), Body("b", ball(r), mass=m, position=(0, 0, r), velocity=(v0, 0, 0))),
                  gravity=(0, 0, -g), material=Material(mu_s=0.5, e=0.0))
    sim = registry.get("genesis").build(scene, Settings(dt=1e-3))
    try:
        for _ in range(400):  # sliding stops after 2 v0 / (7 mu g) = 0.058 s
            sim.step()
        s = sim.states()["b"]
        assert abs(s[7] - 5.0 / 7.0 * v0) < 1e-3 * v0, s
        assert abs(s[11] - s[7] / r) < 2e-3 * s[7] / r, s
        (force,) = sim.contact_forces().values()
        assert abs(force - m * g) < 1e-3 * m * g
        assert "friction" in sim.effects and sim.knobs["RigidOptions"]["friction_cone"] == "elliptic"
    finally:
        sim.close()


@pytest.mark.skipif(not INSTALLED, reason="Genesis is not installed (extra 'genesis')")
def test_a_release_environment_gets_the_torch_installed_here(monkeypatch):
    """genesis-world imports torch without declaring it: a release's environment gets this
    environment's torch, the same build (a CPU build stays one: PyPI's default torch brings
    CUDA, 5.3 GB more), and the extra's where torch is not installed here."""
    import tomllib
    from importlib import metadata
    from pathlib import Path
    from packaging.requirements import Requirement
    import adapters.genesis_engine as genesis_engine
    genesis = registry.get("genesis")
    assert genesis.release_requirements("1.4.4") == ["genesis-world==1.4.4", f"torch=={metadata.version('torch')}"]
    extra = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["genesis"]
    torch = next(r for r in extra if Requirement(r).name == "torch")

    def version(name):
        if name == "torch":
            raise metadata.PackageNotFoundError(name)
        return metadata.version(name)
    monkeypatch.setattr(genesis_engine.metadata, "version", version)
    assert genesis.release_requirements("1.4.4") == ["genesis-world==1.4.4", torch]


@pytest.mark.slow  # Genesis' import (~14 s of CPU) and a scene's kernels (~9 s with a full cache)
@pytest.mark.skipif(not INSTALLED, reason="Genesis is not installed (extra 'genesis')")
def test_a_pulled_slider_accelerates_at_f_over_m_and_a_hinged_body_starts_at_its_rate():
    """Joints and loads. Genesis gives every revolute or prismatic joint an MJCF file leaves
    at armature 0 a rotor inertia of 0.1 unless told not to (adapters.genesis_engine.
    MJCF_OPTIONS); and it applies an external wrench for one step only. A 1 kg slider pulled
    with 2 N along a frictionless rail, no gravity, is at F t / m = 0.2 m/s after 0.1 s (with
    the armature 0.2 / 1.1; with the load applied once, 2e-3): to round-off, as a constant
    acceleration integrates exactly. A rod hinged to the world that starts turning at w reads
    back its start velocity w x (x - anchor) before any step (the tree's dofs in the order
    the adapter wrote them)."""
    from adapters.base import Settings
    from cases.scene import Body, Joint, Load, Scene, ball, cube
    w, anchor, x = 3.0, (5.0, 0.0, 1.0), (5.0, 0.0, 0.5)
    rod_v = (w * (x[2] - anchor[2]), 0.0, 0.0)  # (0, w, 0) x (0, 0, -0.5) = (-1.5, 0, 0)
    scene = Scene(bodies=(Body("slider", ball(0.05), mass=1.0, position=(0, 0, 1)),
                          Body("rod", cube(0.05), mass=2.0, position=x, velocity=rod_v, angular_velocity=(0, w, 0))),
                  gravity=(0, 0, 0), joints=(Joint("prismatic", "slider", None, anchor=(0, 0, 1), axis=(1, 0, 0)),
                                             Joint("revolute", "rod", None, anchor=anchor, axis=(0, 1, 0))),
                  loads=(Load("slider", force=(2.0, 0, 0)),))
    sim = registry.get("genesis").build(scene, Settings(dt=1e-3))
    try:
        rod = sim.states()["rod"]
        assert max(abs(rod[7:10] - rod_v).max(), abs(rod[10:13] - (0, w, 0)).max()) < 1e-12, rod
        for _ in range(100):
            sim.step()
        assert abs(sim.states()["slider"][7] - 0.2) < 1e-12
        assert {"joint", "load"} <= sim.effects and sim.knobs["morphs.MJCF"]["default_armature"] is None
    finally:
        sim.close()


@pytest.mark.slow  # Genesis' import and a scene's kernels
@pytest.mark.skipif(not INSTALLED, reason="Genesis is not installed (extra 'genesis')")
def test_a_body_held_from_rotating_keeps_its_turned_orientation():
    """A body held from rotating slides on three world-axis slide joints in a world-aligned
    frame, its geom and inertia turned to the body's orientation: Genesis' link never turns,
    so the adapter reports the body's own orientation (it read the link's identity before);
    exactly, as it never changes."""
    import math
    import numpy as np
    from adapters.base import Settings
    from cases.scene import Body, Material, Scene, cube, ground
    q = (math.cos(0.25), 0.0, 0.0, math.sin(0.25))  # 0.5 rad about z
    scene = Scene(bodies=(ground(), Body("box", cube(0.1), mass=1.0, position=(0, 0, 0.1), orientation=q,
                                         rotates=False)), gravity=(0, 0, -9.81), material=Material(mu_s=0.5, e=0.0))
    sim = registry.get("genesis").build(scene, Settings(dt=1e-3))
    try:
        sim.step()
        assert np.array_equal(sim.states()["box"][3:7], q)
    finally:
        sim.close()


@pytest.mark.slow  # Genesis' import and a scene's kernels
@pytest.mark.skipif(not INSTALLED, reason="Genesis is not installed (extra 'genesis')")
def test_a_cube_given_as_a_hull_rests_on_a_mesh_ground_with_its_weight():
    """Hulls and meshes: a cube given as the hull of its 8 corners (a mesh geom whose convex
    hull MuJoCo's compiler hands Genesis) set down on a ground given as two triangles (the
    MuJoCo adapter's triangle prisms) stays where it was put and presses with m g. Tolerances:
    the compliant contact sinks it by m g / k (k = (pi / (16 dt))^2 per unit mass: 2.6e-4 m
    at dt = 1e-3, 3e-4 allowed); the force within 1e-3 m g, the solver's tolerance at rest."""
    import itertools
    from adapters.base import Settings
    from cases.scene import Body, Hull, Material, Scene, mesh_ground
    h, m, g = 0.1, 2.0, 9.81
    cube = Hull(tuple(itertools.product((-h, h), repeat=3)))
    scene = Scene(bodies=(mesh_ground(1.0), Body("cube", cube, mass=m, position=(0.2, 0.1, h))),
                  gravity=(0, 0, -g), material=Material(mu_s=0.5, e=0.0))
    sim = registry.get("genesis").build(scene, Settings(dt=1e-3))
    try:
        for _ in range(300):
            sim.step()
        s = sim.states()["cube"]
        assert abs(s[0] - 0.2) < 1e-6 and abs(s[1] - 0.1) < 1e-6 and 0 <= h - s[2] < 3e-4, s
        (force,) = sim.contact_forces().values()
        assert abs(force - m * g) < 1e-3 * m * g, force
    finally:
        sim.close()


@pytest.mark.slow  # Genesis' import (~14 s of CPU) and a scene's kernels (~9 s with a full cache)
@pytest.mark.skipif(not INSTALLED, reason="Genesis is not installed (extra 'genesis')")
def test_a_planar_body_moves_and_turns_in_its_plane_from_its_start_state():
    """2D: the MuJoCo adapter's planar joints (slides along x and z, a hinge about y) in
    Genesis' MJCF. A rectangle tilted 30 deg about y, launched at (1, 0, 0.5) m/s turning at
    2 rad/s, no gravity and nothing to touch, is after 0.1 s where constant velocities put it,
    turned by 0.2 rad more (the link's turn after the orientation its geom carries), with its
    start velocities: to round-off (the joints integrate a constant rate exactly)."""
    import numpy as np
    from adapters.base import Settings
    from cases import rotations
    from cases.scene import Body, Rect, Scene, quat_about_y
    q0 = np.asarray(quat_about_y(np.radians(30.0)))
    scene = Scene(bodies=(Body("r", Rect((0.2, 0.1)), mass=1.0, position=(0, 0, 1), orientation=tuple(q0),
                               velocity=(1.0, 0.0, 0.5), angular_velocity=(0.0, 2.0, 0.0)),), gravity=(0, 0, 0), dimension=2)
    sim = registry.get("genesis").build(scene, Settings(dt=1e-3))
    try:
        for _ in range(100):
            sim.step()
        s = sim.states()["r"]
        np.testing.assert_allclose(s[0:3], (0.1, 0.0, 1.05), atol=1e-9)
        turned = rotations.multiply(quat_about_y(0.2), q0)
        assert min(np.abs(s[3:7] - turned).max(), np.abs(s[3:7] + turned).max()) < 1e-9, (s[3:7], turned)
        np.testing.assert_allclose(s[7:13], (1.0, 0.0, 0.5, 0.0, 2.0, 0.0), atol=1e-9)
        assert "rotation" in sim.effects
    finally:
        sim.close()
