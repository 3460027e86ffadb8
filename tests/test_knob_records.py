"""The knob record of every engine configuration describes the solver that really ran.

An adapter records, under the engine's own names, every parameter it set (`Simulation.knobs`).
Here each installed configuration of the registry builds a tiny scene, steps it, and its
record is set against what the running engine says of itself: its own read-back where it
has one (MuJoCo's mjOption, DART's constraint solver, Drake's plant, Pymunk's space,
Rapier's integration parameters, Box2D's and Box3D's world), the formulation module that
ran for the reference (its record describes that formulation and no other: the
sequential impulses' disc cone once sat in every formulation's record, beside
reference-pgs's pyramid), and for PyBullet, which reads back no solver type, the
solver's mark in what it does: its default solver applies a 3D contact's rolling rows,
its MLCP solvers drop them."""
from __future__ import annotations

import pytest

from adapters import registry
from adapters.base import Settings, Unsupported
from cases.scene import Body, Compliance, Material, Scene, ball, ground
from tests.helpers import adapter_or_skip

DT = 1e-3


def _scenes(dim: int) -> list[Scene]:
    """A ball rolling at 1 m/s on the ground with friction; for the configurations that
    refuse friction, the ball without it; for the compliant ones, an elastic Hertz and a
    Hooke contact (the first scene a configuration takes is its test)."""
    body = Body("ball", ball(0.1, dim), mass=1.0, position=(0, 0, 0.1), velocity=(1.0, 0, 0),
                angular_velocity=(0, 10.0, 0))
    return [Scene(bodies=(ground(), body), material=material, dimension=dim)
            for material in (Material(mu_s=0.5), Material(),
                             Material(e=1.0, compliance=Compliance("hertz", E=2e11, nu=0.3)),
                             Material(e=1.0, compliance=Compliance("hooke", k=1e6)))]


def _build(adapter, dim: int):
    """The simulation of the first of _scenes the configuration takes (skip if none)."""
    reasons = []
    for scene in _scenes(dim):
        try:
            return adapter.build(scene, Settings(dt=DT))
        except Unsupported as exc:
            reasons.append(str(exc))
    pytest.skip(f"{adapter.name}: {'; '.join(reasons)}")


# --- read-backs: what the running engine says, by the record's path ----------------------------

def _reference(sim, record) -> dict:
    world = sim._world
    own = world.solver.knobs(world.config)
    out = {(key,): value for key, value in own.items()}
    out[("formulation",)] = world.config.formulation
    # the record holds the adapter's formulation-neutral entries and this formulation's own, nothing else
    neutral = {"formulation", "iterations", "tolerance", "beta", "slop", "position_iterations", "warm_start",
               "stick_speed", "margin", "params", "integrator", "gravity", "material", "pair_materials", "planar",
               "ground", "bodies", "stages_ran", "narrow_phase"}
    foreign = set(record) - neutral - set(own)
    assert not foreign, f"the record describes what {world.config.formulation} does not: {sorted(foreign)}"
    assert all(s.split(":")[0] == world.config.formulation for s in record["stages_ran"] if ":" in s)
    return out


def _pybullet(sim, record) -> dict:
    from adapters.pybullet_engine import p
    c = sim._client
    params = p.getPhysicsEngineParameters(physicsClientId=c)
    out = {("setPhysicsEngineParameter", key): params[key] for key in ("fixedTimeStep", "numSubSteps",
                                                                       "numSolverIterations")}
    out[("setGravity",)] = [params[f"gravityAcceleration{a}"] for a in "XYZ"]
    # No read-back of constraintSolverType: its mark is behavioural. Rolling friction set on the
    # ball after the build slows a 3D roll under the default solver and not under the MLCP ones.
    if not sim._planar:
        _, uid, link = sim._dynamic[0]
        before = p.getBaseVelocity(uid, physicsClientId=c)[0][0]
        p.changeDynamics(uid, link, rollingFriction=0.01, physicsClientId=c)
        for _ in range(50):
            sim.step()
        slowed = before - p.getBaseVelocity(uid, physicsClientId=c)[0][0] > 0.01  # d g t / r 5/7: 0.035 m/s
        out[("constraintSolverType",)] = (record["constraintSolverType"] if slowed == record["constraintSolverType"]
                                          .endswith("_SI") else f"not {record['constraintSolverType']}")
    return out


def _mujoco(sim, record) -> dict:
    import mujoco
    o = sim._model.opt
    return {("option", "timestep"): o.timestep, ("option", "solver"): mujoco.mjtSolver(o.solver).name[6:].title(),
            ("option", "cone"): mujoco.mjtCone(o.cone).name[7:].lower(), ("option", "impratio"): o.impratio,
            ("option", "iterations"): o.iterations, ("option", "tolerance"): o.tolerance,
            ("option", "integrator"): mujoco.mjtIntegrator(o.integrator).name[6:].title()}


def _dart(sim, record) -> dict:
    world = sim._world
    solver = world.getConstraintSolver()
    secondary = solver.getSecondaryBoxedLcpSolver()
    return {("World.setTimeStep",): world.getTimeStep(),
            ("BoxedLcpConstraintSolver.setBoxedLcpSolver",): type(solver.getBoxedLcpSolver()).__name__,
            ("BoxedLcpConstraintSolver.setSecondaryBoxedLcpSolver",):
                None if secondary is None else type(secondary).__name__,
            ("ConstraintSolver.setSplitImpulseEnabled",): solver.isSplitImpulseEnabled()}


def _drake(sim, record) -> dict:
    plant = sim._plant
    return {("MultibodyPlant", "time_step"): plant.time_step(),
            ("MultibodyPlant", "discrete_contact_approximation"):
                str(plant.get_discrete_contact_approximation()).split(".")[-1],
            ("MultibodyPlant", "contact_model"): str(plant.get_contact_model()).split(".")[-1],
            **_drake_integrator(sim, record)}


def _drake_integrator(sim, record) -> dict:
    """A continuous plant's integrator (drake-cenic), read back from the simulator."""
    if "Simulator" not in record:
        return {}
    from pydrake.systems.analysis import ExtractSimulatorConfig
    config = ExtractSimulatorConfig(sim._simulator)
    return {("Simulator", "integration_scheme"): config.integration_scheme,
            ("Simulator", "accuracy"): config.accuracy, ("Simulator", "max_step_size"): config.max_step_size,
            ("Simulator", "use_error_control"): config.use_error_control}


def _pymunk(sim, record) -> dict:
    space = sim._space
    return {("iterations",): space.iterations, ("collision_slop",): space.collision_slop,
            ("damping",): space.damping, ("gravity",): list(space.gravity)}


def _rapier(sim, record) -> dict:
    p = sim._world.integration_parameters
    return {(key,): getattr(p, key) for key in ("num_solver_iterations", "num_internal_pgs_iterations",
                                                 "num_internal_stabilization_iterations", "warmstart_coefficient")}


def _box2d(sim, record) -> dict:
    world = sim._world
    return {("gravity",): list(world.gravity), ("restitution_threshold",): world.restitution_threshold,
            ("enable_sleep",): world.sleeping_enabled, ("enable_continuous",): world.continuous_enabled}


def _box3d(sim, record) -> dict:
    from adapters.box3d_engine import lib
    g = lib.b3World_GetGravity(sim._world)
    return {("b3WorldDef", "gravity"): [g.x, g.y, g.z],
            ("b3WorldDef", "restitutionThreshold"): lib.b3World_GetRestitutionThreshold(sim._world),
            ("b3WorldDef", "maximumLinearSpeed"): lib.b3World_GetMaximumLinearSpeed(sim._world),
            ("b3WorldDef", "workerCount"): lib.b3World_GetWorkerCount(sim._world)}


NEWTON_SOLVERS = {"xpbd": "SolverXPBD", "semi-implicit": "SolverSemiImplicit", "featherstone": "SolverFeatherstone",
                  "vbd": "SolverVBD", "mujoco": "SolverMuJoCo", "kamino": "SolverKamino"}


def _newton(sim, record) -> dict:
    name = type(sim._solver).__name__
    return {("solver",): next((key for key, cls in NEWTON_SOLVERS.items() if cls == name), name)}


def _genesis(sim, record) -> dict:
    solver = sim._solver
    return {("SimOptions", "dt"): solver.dt,
            ("SimOptions", "gravity"): [float(g) for g in solver.get_gravity().reshape(-1)[:3]],
            ("RigidOptions", "friction_cone"): solver._options.friction_cone.name,
            ("RigidOptions", "contact_resolution"): solver._contact_resolution.name,  # as Genesis resolved it
            ("RigidOptions", "iterations"): solver._options.iterations,
            ("RigidOptions", "use_hibernation"): solver._options.use_hibernation}


# by the module of the simulation's class; None: no read-back written (said when skipped)
READ_BACK = {
    "adapters.reference_engine": _reference, "adapters.pybullet_engine": _pybullet,
    "adapters.mujoco_engine": _mujoco, "adapters.mujoco_warp_engine": _mujoco,  # the MjModel Warp was given
    "adapters.dart_engine": _dart, "adapters.drake_engine": _drake, "adapters.pymunk_engine": _pymunk,
    "adapters.rapier_engine": _rapier, "adapters.box2d_engine": _box2d, "adapters.box3d_engine": _box3d,
    "adapters.newton_engine": _newton, "adapters.genesis_engine": _genesis,
    "adapters.physx_engine": None,  # ovphysx is authored from USD; no read-back written (not installed here)
}


def _at(record: dict, path: tuple):
    for key in path:
        record = record[key]
    return record


@pytest.mark.parametrize("engine", registry.engine_names())
def test_the_knob_record_describes_the_solver_that_ran(engine):
    adapter = adapter_or_skip(engine)
    dim = 3 if 3 in adapter.capabilities.dimensions else 2
    with _build(adapter, dim) as sim:
        sim.step()
        module = type(sim).__module__
        if module not in READ_BACK:
            pytest.skip(f"{engine}: {module} is not a built-in adapter with a read-back here")
        if READ_BACK[module] is None:
            pytest.skip(f"{engine}: no read-back of {module}'s engine written")
        record = sim.knobs
        live = READ_BACK[module](sim, record)
    assert live, f"{engine}: the read-back reads nothing"
    for path, value in live.items():
        recorded = _at(record, path)
        if isinstance(value, float) or (isinstance(value, list) and value and isinstance(value[0], float)):
            assert recorded == pytest.approx(value, rel=1e-6), f"{engine}: knobs{list(path)}"
        else:
            assert recorded == value, f"{engine}: knobs{list(path)} = {recorded!r}, but the engine runs {value!r}"
