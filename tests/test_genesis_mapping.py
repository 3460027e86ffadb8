"""Genesis' adapter: the registry names its extra when Genesis is missing; the sol_params it
writes are the MuJoCo adapter's contact spring-damper in Genesis' own form; a built scene
has the scene's mass, rolls as a rigid ball does, reports its weight as the contact force,
and declares the friction rows Genesis cannot leave out."""
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
        assert "friction" in sim.effects and sim.knobs["RigidOptions"]["friction_cone"] == "pyramidal"
    finally:
        sim.close()


@pytest.mark.skipif(not INSTALLED, reason="Genesis is not installed (extra 'genesis')")
def test_a_release_environment_gets_the_torch_genesis_does_not_declare():
    import tomllib
    from pathlib import Path
    from packaging.requirements import Requirement
    extra = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["genesis"]
    torch = next(r for r in extra if Requirement(r).name == "torch")
    assert registry.get("genesis").release_requirements("1.4.4") == ["genesis-world==1.4.4", torch]
