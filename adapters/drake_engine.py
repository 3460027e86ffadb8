"""Drake adapter: a scene becomes one discrete MultibodyPlant (with its SceneGraph) at dt.

Variants (adapters/registry.py): the discrete contact approximation (SAP, Similar,
Lagged, TAMSI) with point contact, and hydroelastic contact with Lagged (`drake`, Drake's
own default configuration, MultibodyPlantConfig) or SAP (`drake-hydro`).

Drake has no coefficient of restitution. Its contact is compliant, with a dissipation
whose law depends on the approximation (Drake docs, "Contact Modeling in Drake",
multibody/plant/contact_model_doxygen.h; the constraints in multibody/contact_solvers/sap/):
- SAP (SapFrictionConeConstraint): linear Kelvin-Voigt, gamma_n / dt = (-k phi - tau k v_n)+,
  tau the dissipation time scale (`relaxation_time`, s), phi = phi0 + dt v_n the signed
  distance at the END of the step;
- Similar, Lagged (SapHuntCrossleyConstraint) and TAMSI (tamsi_solver.h, eq. 8): Hunt &
  Crossley, gamma_n / dt = k (x0 + dt xdot)+ (1 + d xdot)+, d in s/m
  (`hunt_crossley_dissipation`), xdot = -v_n the penetration rate at the end of the step.
Hydroelastic contact applies the same laws to the pressure of each contact-surface face.
Both laws are implicit in the step's velocity: backward Euler on the spring (checked: a
drop on each approximation follows `discrete_rebound`'s recurrence to 2e-5 m/s). That
dissipates: an undamped contact lasting n steps returns only about exp(-pi^2 / 2n) of the
approach speed (0.750 at n = 16, 0.861 at 32, 0.927 at 64), so no e above that ceiling is
reachable at a given contact duration, and e = 1 never.

e is mapped onto the DISCRETE law (`restitution_dissipation`). The contact lasts about n
steps (`contact_steps`, a tunable): point contact gives each body the stiffness
k_i = m_i w^2, w = pi / (n dt), so every translational pair oscillates at w whatever its
masses (`_point_stiffness`); hydroelastic contact gives each body the modulus that makes
its contact as stiff (`_hydroelastic_modulus`). Each pair gets the dissipation (tau, or d)
whose rebound, averaged over where in a step the contact begins, is its e
(`rebound_ratio`). A Hunt & Crossley rebound depends on the impact speed (on d v_in
only; the bounce is at most 1/d): those variants map e at `impact_speed` (a tunable,
1 m/s), and other speeds rebound as Drake's law makes them. An e above the ceiling gets no
dissipation and the ceiling (`e_reached` per pair in the knobs); e = 0 gets the dissipation
whose rebound is E_FLOOR.

Combination rules (multibody/plant/contact_properties.h, coulomb_friction.h), each undone
per pair: stiffness in series k = k1 k2 / (k1 + k2) (static bodies RIGID_STIFFNESS, rigid
hydroelastic), Hunt & Crossley d = (k2 d1 + k1 d2) / (k1 + k2) (moduli for hydroelastic
contact), tau = tau1 + tau2, friction 2 mu1 mu2 / (mu1 + mu2) (adapters.combination
"harmonic"). Per-body values are solved so that each pair gets its own (`_per_body`),
or the scene is Unsupported.

Friction: discrete Drake resolves one (dynamic) coefficient and ignores the static one
(contact_model_doxygen.h: discrete models "cannot differentiate between static and dynamic
friction"): mu_s != mu_k is unsupported. Friction is regularised: SAP lets a sticking
contact slip at about sigma dt g (sigma = 1e-3, hard-coded), the others at the stiction
tolerance (`stiction_tolerance`, a tunable) or SAP's term if larger. The convex
approximations couple sliding to the normal force: SAP's cone projection pushes a sliding
contact as if it were mu |v_t| (dt + tau) deeper (SapFrictionConeConstraint::ProjectImpulse),
Similar evaluates the normal force at v_n - mu |v_t|; with the heavy dissipation e = 0 maps
to, sliding bodies hop (known deviations). Lagged bounds friction by the previous step's
normal impulse instead.

Point contact gives ONE point per pair of geometries, the deepest ("Choosing the Right
Collision Geometry"): a box on the ground rests on one corner at a time. Against a
half-space a Box still rests flat (its own routine), but a Convex, and a box on a mesh's
triangle prisms, rock from corner to corner (3-9 mm deep, up to 0.1 rad/s, measured).
Hydroelastic contact integrates a pressure field over a contact surface; every shape here
has one (dynamic bodies compliant, static ones rigid), so it is never unsupported for shapes.

Shapes (`_drake_shapes`): Capsule and Cylinder along the body's z, a hull (and a 2D
polygon's prism) a Convex of its corners; a static mesh under point contact one Convex
prism a triangle (point contact would take a Mesh's convex hull), under hydroelastic contact
a rigid Mesh of its triangles. Each body has the scene's mass and principal inertia.
Hydroelastic moduli for the new shapes: `_hydroelastic_modulus`.

2D scenes (x-z plane): a rotating body hangs on a PlanarJoint (z, x, angle about y), a
non-rotating one on prismatic joints along x and z; non-rotating 3D bodies on prismatic
joints along x, y and z (through massless bodies); circles are spheres (every contact of a
planar scene lies in y = 0, where the sphere's section is the disc), rects boxes as deep
along y as they are wide; the inertia is always the scene's.

Scene joints (adapters.joints.joint_tree): jointed bodies form a tree, each body on Drake's
joint of its kind (RevoluteJoint, PrismaticJoint, WeldJoint) whose frame F sits on its parent
body (or the world) at the anchor, world-aligned at the start; a tree's root is free
(floating) or planar as any body, so a chain floats. A body's start velocity relative to its
parent becomes the joint's rate (adapters.joints.start_rate, refused where the joint does not
allow it). A joint that would close a loop is a ball constraint (AddBallConstraint, which
SAP's solver holds, also under Similar and Lagged) where the loop is planar; so is a ball
joint, its body left free (BALL_JOINT: Drake's BallRpyJoint is singular at pitch pi/2). Bodies a joint
connects do not collide (a collision filter). Loads are ExternallyAppliedSpatialForces from a
constant source on the plant's applied spatial force port.
"""
from __future__ import annotations

import contextlib
import functools
import logging
import math
from importlib import metadata
from typing import TYPE_CHECKING

import numpy as np

from adapters.base import Adapter, Capabilities, Settings, SettingsError, Simulation, Tunable, Unsupported
from adapters.combination import per_body_values
from adapters.joints import TreeJoint, closing_ball_points, joint_tree, start_rate
from adapters.frames import about_y_many, state_row
from adapters.lazy import require
from adapters.solids import polygon_prism, triangle_normals, triangle_prisms, width_half_depth
from cases import rotations
from cases.scene import Body, Box, Capsule, Circle, Cylinder, Hull, Mesh, Plane, Polygon, Rect, Scene, Sphere, pair_key
from cases.trajectory import ContactPoint

# pydrake (0.15-0.2 s to import) is imported by the functions that build a scene: planning a
# run reads only the adapter's capabilities, and workers import their engines themselves.
require("pydrake")  # not installed: ImportError now, so the registry reports it
if TYPE_CHECKING:
    from pydrake.geometry import ProximityProperties
    from pydrake.math import RotationMatrix

# Contact lasts about n = 16 steps (w = pi / (n dt)), as in the MuJoCo adapter, so the two
# compliant engines penetrate alike (~ v n dt / pi: 23 mm at 4.4 m/s, dt = 1e-3). Implicit
# stepping caps e at 0.750 there (module notes); more steps raise the cap and the depth.
CONTACT_STEPS = 16
IMPACT_SPEED = 1.0          # m/s: where a Hunt & Crossley d gives the asked e
# Similar and Lagged: below SAP's own term mu sigma dt g (5e-6 m/s at mu = 0.5, dt = 1e-3),
# which then sets their regularisation. TAMSI regularises friction with it alone and its
# Newton iteration needs Drake's default 1e-4 m/s: at 1e-6 and 1e-5 a 4-box point-contact
# stack stops it at 1.9-2.1 s ("failed to converge"); at 1e-4 the 4-box stack runs (the
# 5-box one still fails, at 1.1 s). SAP has no such parameter (it regularises with sigma).
# CENIC: the continuous plant's regularisation (MultibodyPlant's default, 1e-4 m/s), measured
# beside 1e-6 (which costs it more steps and gives the same checks).
STICTION_TOLERANCE = {"similar": 1e-6, "lagged": 1e-6, "tamsi": 1e-4, "cenic": 1e-4}   # m/s
# CENIC's error target (SimulatorConfig.accuracy). With steps of at most dt = 1e-3 and a
# contact n = 16 steps long, error control first shortens a step at 1e-5: at 1e-4 and above
# CENIC takes the fixed steps of discrete ICF (an e = 1 impact rebounds 0.794 of its speed,
# as at 1e-1), at 1e-5 0.913, 1e-6 0.969 (406 steps for 300), 1e-7 0.992, 1e-8 0.9997 (1460
# steps); measured on central_impact[e=1.0,m=1:1]. The default, 1e-6, is where the rebound
# comes within 3 % at a third more steps; the accuracy-cost sweep takes ACCURACIES.
ACCURACY = 1e-6
ACCURACIES = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
# Drake's default near-rigid threshold beta (MultibodyPlantConfig): SAP clamps a contact
# stiffer than its time step resolves (period beta dt), i.e. where h k (h + tau) > 4 pi^2 m
# / beta^2. With k = m w^2, w h = pi / n, that is (pi / n)^2 (1 + tau / h) > 4 pi^2: 21 < 39
# for the most damped mapped contact (e = 0, n = 16), so it never acts on them.
NEAR_RIGID_THRESHOLD = 1.0
# A static body's point stiffness: the series rule then gives the partner's own k to
# rounding (k (1 - k / 1e30)). Infinity is not usable: Drake weights the contact point by
# kA / (kA + kB), NaN for two infinities' ratio (measured: the SAP solver fails).
RIGID_STIFFNESS = 1e30      # N/m
# e = 0 needs infinite dissipation; the mapping stops where the rebound is this small.
E_FLOOR = 1e-3
# Onset phases averaged over by `rebound_ratio`: where in a step the contact begins
# moves the discrete rebound by up to +-0.026 at n = 16 (SAP, e = 0.2; less for more steps).
PHASES = 32
# A continuous plant's bodies between prismatic joints (a body held from rotating) weigh this
# fraction of the body: Drake's articulated-body dynamics rejects massless ones ("Composite for
# body ... has zero mass"); the body then moves along x 2e-9 heavier (relative), along y 1e-9.
SLIDE_MASS = 1e-9
# 2D and hydroelastic geometry
HYDRO_RESOLUTION = 0.2      # resolution hint as a fraction of a sphere's radius

# Drake parameters pydrake does not expose (sap_solver.h, tamsi_solver.h,
# sap_driver.cc, discrete_update_manager.cc in Drake 1.51), stated.
ENGINE_CONSTANTS = {
    "SapSolverParameters.max_iterations": 100,
    "SapSolverParameters.rel_tolerance": 1e-6,
    "SapSolverParameters.abs_tolerance": 1e-14,
    "SAP friction regularisation sigma": 1e-3,
    "TamsiSolverParameters.max_iterations": 100,
    "TamsiSolverParameters.relative_tolerance": 1e-2,
    "default relaxation_time per geometry (overridden here)": 0.1,
    "point contact margin": "none: Drake's margin applies to hydroelastic contact only",
}

_APPROXIMATIONS = ("lagged", "sap", "similar", "tamsi")  # DiscreteContactApproximation.k<Name>
# drake-cenic's cost, measured with drake 1.51.1 on 2 workers (two repeats of `physval known
# drake-cenic --on-demand`): its 272 jobs over every family took 133-151 job-s, none over the
# per-job limit; the 71 of the core families and the conformance battery, which it runs in a
# default run as its Drake siblings do, 45-56 job-s, where drake-sap's 75 take 15.3,
# drake-lagged's 17.3 and drake-hydro's 29.7: resting stacks cost it most (resting_blocks 32-38
# job-s, SAP's 7.0). (An earlier measurement, 1771 job-s for 251 jobs on one loaded worker, which
# kept it on demand only, no longer holds.)
# a continuous plant (time_step 0) integrated by CENIC (SimulatorConfig integration_scheme)
CONTINUOUS = ("cenic",)
# The approximations whose solver takes a plant's constraints (AddBallConstraint): SAP's
# convex solver, which Similar and Lagged also use; TAMSI and CENIC's continuous plant refuse
# them (measured with pydrake 1.51.1).
CONSTRAINED = ("sap", "similar", "lagged")
# A scene's ball joint: Drake's tree joint for it is a BallRpyJoint, singular at a pitch of
# pi/2, where a swing of 90 deg stopped the simulator (measured); Drake has no quaternion ball
# joint (https://github.com/RobotLocomotion/drake/issues/12404). So the body stays free (its
# QuaternionFloatingJoint, no singularity) and AddBallConstraint holds the joint's point on
# both bodies, as a loop's closing joint: a constraint SAP's solver holds (CONSTRAINED).
BALL_JOINT = ("a ball joint is held as a ball constraint (AddBallConstraint) on the free body, as Drake's "
              "BallRpyJoint is singular at a pitch of pi/2 (a swing of 90 deg stopped the simulator, measured) and "
              "a quaternion ball joint is not in Drake (https://github.com/RobotLocomotion/drake/issues/12404)")
WORLD_ANCHOR = "physval:world anchor"  # the body welded to the world that holds a ball constraint's world side
LOOSE = frozenset({"ball"})
# A joint's dry friction: a joint actuator under SAP's implicit PD control (Drake's
# SapPdControllerConstraint) with gains p = 0 and d = FRICTION_KD, desired rate 0 and its
# effort limit the friction: the force -d qdot clamped to -+ friction, solved implicitly in the
# step, is Coulomb's law with the scene's constant bound once d |qdot| exceeds it (below
# friction / d, 5e-8 m/s for the rail's 4.9 N, it is a stiff damper that stops the joint in a
# step). Drake's own joint damping is viscous, not Coulomb. SAP alone solves it (CONSTRAINED):
# TAMSI ignores the PD gains (measured: the slider kept its 2 m/s); CENIC's continuous plant is
# not mapped with them (measured under SAP only).
FRICTION_KD = 1e8  # N s/m (N m s/rad)  # the joint kinds held as constraints between free bodies (joint_tree's loose)
_CONTACT_MODELS = ("hydroelastic", "point")              # ContactModel.k<Name>


# --- e onto Drake's discrete contact law ----------------------------------------------------
# A lone frictionless contact (a body of mass m on a rigid half-space, no gravity) in units
# of the approach speed v_in and the contact frequency w = sqrt(k / m): penetration X, its
# rate U (> 0 approaching), step a = w dt. One step of Drake's implicit law solves for the
# end-of-step rate U' (Drake's constraint docs, above):
#   SAP:            U' = U - a (X0 + (a + s) U')+,                     s = w tau
#   Hunt & Crossley: U' = U - a (X0 + a U')+ (1 + delta U')+,          delta = d v_in
# then X1 = X0 + a U' (positions move with the new velocity). The contact exists while
# X0 > 0; the body starts it with X0 in (0, a] (the phase) and leaves when X <= 0.
# As a -> 0, SAP is the spring-damper that cannot pull (damping ratio zeta = s / 2, the
# MuJoCo adapter's law) and Hunt & Crossley its continuous law, whose rebound depends on
# delta alone: G(delta) = G(-delta e), G(y) = y - ln(1 + y), for any elastic force.

def _sap_rate(X0: float, U: float, a: float, s: float) -> float:
    """SAP: linear in U' where the force is positive; else no force."""
    if X0 <= 0.0:
        return U
    U1 = (U - a * X0) / (1.0 + a * (a + s))
    return U1 if X0 + (a + s) * U1 > 0.0 else U


def _hunt_crossley_rate(X0: float, U: float, a: float, delta: float) -> float:
    """Hunt & Crossley: the force vanishes for U' at or below max(-X0/a, -1/delta); above,
    U' - U + a (X0 + a U')(1 + delta U') = 0 is a quadratic with one root there (the
    left side increases with U')."""
    if X0 <= 0.0:
        return U
    kink = max(-X0 / a, -1.0 / delta if delta > 0.0 else -math.inf)
    if U <= kink:
        return U
    A, B, C = a * a * delta, 1.0 + a * a + a * X0 * delta, a * X0 - U
    return -C / B if A == 0.0 else -2.0 * C / (B + math.sqrt(B * B - 4.0 * A * C))


_RATES = {"sap": _sap_rate, "hunt_crossley": _hunt_crossley_rate}


def discrete_rebound(law: str, a: float, p: float, phase: float) -> float:
    """Rebound ratio of Drake's discrete `law` ("sap": p = s = w tau; "hunt_crossley":
    p = delta = d v_in) for a contact that begins with X0 = phase a, 0 < phase <= 1."""
    rate = _RATES[law]
    X, U = phase * a, 1.0
    for _ in range(1_000_000):
        U = rate(X, U, a, p)
        X += a * U
        if X <= 0.0:
            return -U
    raise RuntimeError(f"{law} contact did not end (a = {a}, p = {p})")


@functools.lru_cache(maxsize=None)
def rebound_ratio(law: str, a: float, p: float) -> float:
    """Mean discrete rebound ratio over PHASES evenly spread onset phases."""
    return sum(discrete_rebound(law, a, p, (j + 0.5) / PHASES) for j in range(PHASES)) / PHASES


@functools.lru_cache(maxsize=None)
def restitution_dissipation(law: str, e: float, a: float) -> tuple[float, float]:
    """(p, e reached): the dissipation p >= 0 (s for SAP, delta for Hunt & Crossley) whose
    mean rebound at step a = w dt is e, by bisection (the rebound falls as p grows).
    Above the undamped ceiling rebound_ratio(law, a, 0): p = 0 and the ceiling; below
    E_FLOOR (e = 0 needs infinite dissipation): the p that rebounds E_FLOOR."""
    ceiling = rebound_ratio(law, a, 0.0)
    if e >= ceiling:
        return 0.0, ceiling
    target = max(e, E_FLOOR)
    lo, hi = 0.0, 1.0
    while rebound_ratio(law, a, hi) > target:
        lo, hi = hi, 2.0 * hi
    while hi - lo > 1e-9 * hi:
        mid = 0.5 * (lo + hi)
        if rebound_ratio(law, a, mid) > target:
            lo = mid
        else:
            hi = mid
    p = 0.5 * (lo + hi)
    return p, rebound_ratio(law, a, p)


def _g(y: float) -> float:
    return y - math.log1p(y)


@functools.lru_cache(maxsize=None)
def continuous_hunt_crossley(e: float) -> tuple[float, float]:
    """(delta, e reached) of Hunt & Crossley's continuous law, which CENIC integrates to its
    accuracy: the rebound of a contact hit at v_in with dissipation d depends on delta = d
    v_in alone, through G(delta) = G(-delta e), G(y) = y - ln(1 + y) (module notes). Solved by
    bisection over delta in (0, 1/e), where G(delta) - G(-delta e) falls from positive to
    -infinity. e >= 1: no dissipation; below E_FLOOR: the delta that rebounds E_FLOOR."""
    if e >= 1.0:
        return 0.0, 1.0
    target = max(e, E_FLOOR)
    lo, hi = 0.0, 1.0 / target
    while hi - lo > 1e-13 * hi:
        mid = 0.5 * (lo + hi)
        if _g(mid) - _g(-mid * target) > 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi), target


# --- per-body values for Drake's combination rules ------------------------------------------

def _per_body(names: list[str], rows: list[tuple[str, str, float, float, float]], what: str) -> dict[str, float]:
    """Values x with c_a x_a + c_b x_b = rhs for every (a, b, c_a, c_b, rhs) row, x >= 0:
    the least-norm solution, used only if it is exact (Drake's combination rules below are
    all linear in a suitable variable)."""
    if not rows:
        return {n: 0.0 for n in names}
    index = {n: i for i, n in enumerate(names)}
    A = np.zeros((len(rows), len(names)))
    rhs = np.empty(len(rows))
    for r, (a, b, ca, cb, value) in enumerate(rows):
        A[r, index[a]] += ca
        A[r, index[b]] += cb
        rhs[r] = value
    x = np.linalg.lstsq(A, rhs, rcond=None)[0]
    x[np.abs(x) < 1e-15 * max(1.0, np.abs(rhs).max())] = 0.0
    # a pair asking 0 (e above the ceiling: no dissipation) is met to round-off of the others
    if not np.allclose(A @ x, rhs, rtol=1e-10, atol=1e-12 * max(np.abs(rhs).max(), 1e-300)):
        raise Unsupported(f"the pairs' {what} cannot be split into per-geometry values under Drake's "
                          f"combination rule: no per-geometry values give all {len(rows)} pairs theirs")
    negative = [n for n, v in zip(names, x) if v < 0.0]
    if negative:
        # a unique split (as many pairs as geometries) or the least-norm one is negative
        raise Unsupported(f"the pairs' {what} cannot be split into per-geometry values under Drake's "
                          f"combination rule: the split asks a negative value of {', '.join(negative)}")
    return {n: float(v) for n, v in zip(names, x)}


# --- the simulation -------------------------------------------------------------------------

@contextlib.contextmanager
def _quiet_drake_warnings():
    """Drake logs through the Python logger "drake"; hold it at ERROR for one call."""
    logger = logging.getLogger("drake")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def _rotation(q) -> RotationMatrix:
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RotationMatrix
    return RotationMatrix(Quaternion(np.asarray(q, float) / np.linalg.norm(q)))


# The PlanarJoint's frame F: x_F = world z, y_F = world x, so z_F = world y and the joint's
# coordinates are (z, x, angle about +y).
_R_WF_PLANAR = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


class DrakeSimulation(Simulation):
    def __init__(self, scene: Scene, settings: Settings, approximation: str, contact_model: str,
                 options: dict):
        self.iterations = None  # pydrake exposes no iteration count (ENGINE_CONSTANTS)
        self._planar = scene.dimension == 2
        self._hydro = contact_model == "hydroelastic"
        self._simulator = None
        continuous = self._continuous = approximation in CONTINUOUS
        from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, ContactModel, DiscreteContactApproximation
        from pydrake.systems.analysis import Simulator
        from pydrake.systems.framework import DiagramBuilder
        builder = DiagramBuilder()
        # CENIC takes a continuous plant named "plant" (AddMultibodyPlantSceneGraph's name)
        plant, scene_graph = AddMultibodyPlantSceneGraph(builder, time_step=0.0 if continuous else settings.dt)
        if not continuous:
            plant.set_discrete_contact_approximation(
                getattr(DiscreteContactApproximation, f"k{approximation.capitalize()}"))
            plant.set_sap_near_rigid_threshold(NEAR_RIGID_THRESHOLD)
        plant.set_contact_model(getattr(ContactModel, f"k{contact_model.capitalize()}"))
        if approximation != "sap":
            plant.set_stiction_tolerance(options["stiction_tolerance"])
        # collisions between bodies joined by a joint (a planar body and the world, where
        # the ground lives) are filtered by default
        plant.set_adjacent_bodies_collision_filters(False)
        plant.mutable_gravity_field().set_gravity_vector(np.asarray(scene.gravity, float))
        self.knobs = {
            "MultibodyPlant": {
                "time_step": 0.0 if continuous else settings.dt,
                # a continuous plant keeps Drake's default (kLagged), which CENIC's ICF also is
                "discrete_contact_approximation": "kLagged" if continuous else f"k{approximation.capitalize()}",
                "contact_model": f"k{'Hydroelastic' if self._hydro else 'Point'}",
                "stiction_tolerance": options.get("stiction_tolerance", "unused by SAP (it regularises with sigma)"),
                "sap_near_rigid_threshold": "unused: a continuous plant" if continuous else NEAR_RIGID_THRESHOLD,
                "adjacent_bodies_collision_filters": False,
                "gravity": [float(g) for g in scene.gravity],
                "penetration_allowance": "unused: every geometry has its own stiffness",
            },
            "engine_constants (not settable from pydrake)": dict(ENGINE_CONSTANTS),
            "contact_map": {}, "joints": {}, "inertia": {},
        }
        material = _materials(scene, settings.dt, approximation, contact_model, options, self.knobs["contact_map"])
        self._geometry_name: dict[int, str] = {}
        self._geometry_ids: list = []  # (GeometryId, body name)
        self._tree, closing = joint_tree(scene, LOOSE)
        self._drives = 0  # the joints' friction drives (_joint)
        self._rigid: dict[str, object] = {}
        # a tree joint's parent before its body (the joint's frame F lives on the parent)
        order = [b for b in scene.bodies if b.name not in self._tree] + [scene.body(n) for n in self._tree]
        plan = {b.name: self._add_body(plant, b, scene, material) for b in order}
        self._close_loops(plant, scene, closing)
        plant.Finalize()
        self._hold_drives(builder, plant)
        self._filter_joined(scene_graph, scene)
        self._plant = plant
        self._apply_loads(builder, plant, scene)
        diagram = builder.Build()
        with _quiet_drake_warnings():  # allocating the context warns that a half-space has no
            self._simulator = Simulator(diagram)  # deformable contact (there are no deformables)
        if continuous:
            self.knobs["Simulator"] = self._integrate_with_cenic(settings.dt, options["accuracy"])
        root = self._simulator.get_mutable_context()
        self._context = plant.GetMyMutableContextFromRoot(root)
        self._readers = self._set_start(scene, plan)
        self._simulator.Initialize()
        self._results_port = plant.get_contact_results_output_port()
        self._steps = 0
        self._dt = settings.dt
        self.effects = _effects(scene, material, plan, self._hydro) | ({"load"} if self._loaded else set()) \
            | ({"joint_friction"} if self._drives else set())

    def _integrate_with_cenic(self, dt: float, accuracy: float) -> dict:
        """CENIC on the simulator (Drake's SimulatorConfig): error control on at `accuracy`,
        steps of at most dt (the output interval: each step() advances dt, within which
        CENIC chooses its own steps); its convex solver's parameters are Drake's defaults."""
        from pydrake.systems.analysis import ApplySimulatorConfig, SimulatorConfig
        config = SimulatorConfig(integration_scheme="cenic", accuracy=accuracy, max_step_size=dt,
                                 use_error_control=True)
        if hasattr(config, "publish_every_time_step"):  # gone from SimulatorConfig by 1.58.0 (no publishing)
            config.publish_every_time_step = False
        ApplySimulatorConfig(config, self._simulator)
        from pydrake.multibody.contact_solvers import IcfSolverParameters
        return {"integration_scheme": config.integration_scheme, "accuracy": accuracy, "max_step_size": dt,
                "use_error_control": True, "IcfSolverParameters (Drake's defaults)": repr(IcfSolverParameters())}

    # --- building -----------------------------------------------------------------------

    def _add_body(self, plant, body: Body, scene: Scene, material: dict):
        """Register the body's geometry (on the world body if static) and its joints;
        returns how its state is read ("static", ("free", body), ("planar", joint), or
        ("slides", [(joint, axis)]))."""
        from pydrake.math import RigidTransform, RotationMatrix
        from pydrake.multibody.tree import (FixedOffsetFrame, PlanarJoint, PrismaticJoint, RotationalInertia,
                                            SpatialInertia)
        geometries = _drake_shapes(body, self._hydro)
        props = material["props"][body.name]
        record = _shape_record(body, self._hydro)
        if record:
            self.knobs.setdefault("shapes", {})[body.name] = record
        if body.static:
            X_WB = RigidTransform(_rotation(body.orientation), np.asarray(body.position, float))
            for name, shape, X_BG in geometries:
                X = X_BG if isinstance(body.shape, Plane) else X_WB.multiply(X_BG)
                gid = plant.RegisterCollisionGeometry(plant.world_body(), X, shape, name, props)
                self._geometry_name[gid.get_value()] = body.name
                self._geometry_ids.append((gid, body.name))
            self.knobs["joints"][body.name] = "world"
            return "static"
        [(_, shape, X_BG)] = geometries
        inertia = SpatialInertia.MakeFromCentralInertia(
            body.mass, np.zeros(3), RotationalInertia(*body.principal_inertia))
        rigid = self._rigid[body.name] = plant.AddRigidBody(body.name, inertia)
        self.knobs["inertia"][body.name] = {"mass": float(body.mass),
                                            "principal_moments": list(body.principal_inertia)}
        gid = plant.RegisterCollisionGeometry(rigid, X_BG, shape, body.name, props)
        self._geometry_name[gid.get_value()] = body.name
        self._geometry_ids.append((gid, body.name))
        dimension = scene.dimension
        if body.name in self._tree:
            return self._joint(plant, scene, body, rigid, self._tree[body.name])
        if dimension == 3 and body.rotates:
            self.knobs["joints"][body.name] = "QuaternionFloatingJoint (free body)"
            return ("free", rigid)
        R_B0 = _rotation(body.orientation)
        if dimension == 2 and body.rotates:
            F = plant.AddFrame(FixedOffsetFrame(f"{body.name}:F", plant.world_frame(),
                                                RigidTransform(RotationMatrix(_R_WF_PLANAR))))
            M = plant.AddFrame(FixedOffsetFrame(f"{body.name}:M", rigid.body_frame(),
                                                RigidTransform(R_B0.transpose().multiply(RotationMatrix(_R_WF_PLANAR)))))
            joint = plant.AddJoint(PlanarJoint(f"{body.name}:planar", F, M, np.zeros(3)))
            self.knobs["joints"][body.name] = {"PlanarJoint": "(z, x, angle about +y)", "damping": [0, 0, 0]}
            return ("planar", joint)
        # held from rotating: prismatic joints along world axes through massless bodies
        axes = "xyz" if dimension == 3 else "xz"
        parent = plant.world_frame()
        slides = []
        for i, axis in enumerate(axes):
            last = i == len(axes) - 1
            if last:
                child = plant.AddFrame(FixedOffsetFrame(f"{body.name}:M", rigid.body_frame(),
                                                        RigidTransform(R_B0.transpose())))
            else:
                child = plant.AddRigidBody(f"{body.name}:slide{axis}", self._slide_inertia(body)).body_frame()
            joint = plant.AddJoint(PrismaticJoint(f"{body.name}:{axis}", parent, child, _AXES[axis], damping=0.0))
            slides.append((joint, _AXES[axis]))
            parent = child
        self.knobs["joints"][body.name] = {"PrismaticJoint": list(axes), "damping": 0.0, "limits": "none",
                                           "intermediate bodies": "massless" if not self._continuous else
                                           f"point masses of {SLIDE_MASS:g} of the body's (continuous plant)"}
        return ("slides", slides)

    def _slide_inertia(self, body: Body):
        """The inertia of a body between two prismatic joints: none on a discrete plant; a
        point mass of SLIDE_MASS of the body's on a continuous one, whose forward dynamics
        (articulated bodies) cannot invert a massless body's composite inertia."""
        from pydrake.multibody.tree import RotationalInertia, SpatialInertia
        return SpatialInertia.MakeFromCentralInertia(SLIDE_MASS * body.mass, np.zeros(3), RotationalInertia(0, 0, 0)) \
            if self._continuous else SpatialInertia.Zero()

    def _joint(self, plant, scene: Scene, body: Body, rigid, tj: TreeJoint):
        """Hang the body on its tree joint: frame F on the parent (the world, or the parent
        body's frame) at the anchor, world-aligned at the start, frame M on the body at the
        same point, so the joint's coordinate is 0 at the start and the axis is the scene's
        (in F); no damping, no limits."""
        from pydrake.math import RigidTransform
        from pydrake.multibody.tree import FixedOffsetFrame, PrismaticJoint, RevoluteJoint, WeldJoint
        joint = tj.joint
        anchor, R_B0 = np.asarray(joint.anchor, float), _rotation(body.orientation)
        if tj.parent is None:
            X_PF, on = RigidTransform(anchor), plant.world_frame()
        else:  # X_PF = X_WP0^-1 X_WF, X_WF = (I, anchor)
            up = scene.body(tj.parent)
            R_P0 = _rotation(up.orientation)
            X_PF = RigidTransform(R_P0.transpose(), R_P0.transpose().multiply(anchor - np.asarray(up.position, float)))
            on = self._rigid[tj.parent].body_frame()
        F = plant.AddFrame(FixedOffsetFrame(f"{body.name}:F", on, X_PF))
        M = plant.AddFrame(FixedOffsetFrame(f"{body.name}:M", rigid.body_frame(), RigidTransform(
            R_B0.transpose(), R_B0.transpose().multiply(anchor - np.asarray(body.position, float)))))
        axis = np.asarray(joint.unit_axis, float)
        name = f"{body.name}:{joint.kind}"
        made = {"revolute": lambda: RevoluteJoint(name, F, M, axis, damping=0.0),
                "prismatic": lambda: PrismaticJoint(name, F, M, axis, damping=0.0),
                "fixed": lambda: WeldJoint(name, F, M, RigidTransform())}[joint.kind]()
        made = plant.AddJoint(made)  # the plant's own joint (the built one was moved into it)
        record = {"on": tj.parent or "world", "anchor": anchor.tolist(), "axis": axis.tolist(), "damping": 0.0,
                  "limits": "none"}
        if joint.friction > 0:  # dry friction: SAP's implicit PD drive at rate 0, its effort bounded (FRICTION_KD)
            from pydrake.multibody.tree import PdControllerGains
            drive = plant.AddJointActuator(f"{name}:friction", made, effort_limit=float(joint.friction))
            drive.set_controller_gains(PdControllerGains(p=0.0, d=FRICTION_KD))
            self._drives += 1
            record["friction"] = {"AddJointActuator": {"effort_limit": joint.friction},
                                  "PdControllerGains": {"p": 0.0, "d": FRICTION_KD}, "desired state": "0 (rate 0)"}
        self.knobs["joints"][body.name] = {type(made).__name__: record}
        return ("jointed", rigid, made, tj)

    def _hold_drives(self, builder, plant) -> None:
        """The desired state of the friction drives (_joint): rate 0 (and position 0, which
        gain p = 0 ignores), from a constant source on the plant's desired state port."""
        if not self._drives:
            return
        from pydrake.multibody.tree import default_model_instance
        from pydrake.systems.primitives import ConstantVectorSource
        port = plant.get_desired_state_input_port(default_model_instance())
        source = builder.AddSystem(ConstantVectorSource(np.zeros(port.size())))
        builder.Connect(source.get_output_port(), port)

    def _filter_joined(self, scene_graph, scene: Scene) -> None:
        """Two bodies a scene joint connects do not collide (Scene.contact_pairs leaves them
        out): their geometries are excluded from each other (a CollisionFilterDeclaration).
        Drake's own filter of adjacent bodies is off (a planar body's parent is the world,
        where the ground lives) and would miss a body jointed to a static body."""
        from pydrake.geometry import CollisionFilterDeclaration, GeometrySet
        ids: dict[str, list] = {}
        for gid, name in self._geometry_ids:
            ids.setdefault(name, []).append(gid)
        joined = []
        for joint in scene.joints:
            if joint.parent is not None:
                declaration = CollisionFilterDeclaration().ExcludeBetween(GeometrySet(ids[joint.body]),
                                                                          GeometrySet(ids[joint.parent]))
                scene_graph.collision_filter_manager().Apply(declaration)
                joined.append([joint.body, joint.parent])
        if joined:
            self.knobs["collision filter: jointed pairs excluded"] = joined

    def _close_loops(self, plant, scene: Scene, closing: list) -> None:
        """Each joint that closes a loop (joint_tree), and each ball joint (BALL_JOINT), as
        Drake's ball constraint (MultibodyPlant.AddBallConstraint, solved by SAP), at the
        joint's point on both bodies (closing_ball_points: planar loops' revolute joints, or
        ball joints)."""
        anchor = None
        for j, body_name, p_AP, parent, p_BQ in closing_ball_points(scene, closing, "Drake's AddBallConstraint"):
            if parent is None and anchor is None:
                anchor = self._world_anchor(plant)
            B = anchor if parent is None else self._rigid[parent]
            plant.AddBallConstraint(self._rigid[body_name], p_AP, B, p_BQ)
            self.knobs.setdefault("loop", {})[f"joints[{j}]"] = {
                "AddBallConstraint": {"body_A": body_name, "p_AP": p_AP.tolist(),
                                      "body_B": parent or f"{WORLD_ANCHOR} (welded to the world at its origin)",
                                      "p_BQ": p_BQ.tolist()}}

    def _world_anchor(self, plant):
        """A massless body welded to the world at its origin, the world's side of a ball
        constraint: AddBallConstraint(body, p, world_body(), q) stops the simulator with a
        segmentation fault at the first step (pydrake 1.51.1, measured on a free body on one
        such constraint; between two bodies, or against a welded body, it runs)."""
        from pydrake.math import RigidTransform
        from pydrake.multibody.tree import SpatialInertia, WeldJoint
        anchor = plant.AddRigidBody(WORLD_ANCHOR, SpatialInertia.Zero())
        plant.AddJoint(WeldJoint(f"{WORLD_ANCHOR}:weld", plant.world_frame(), anchor.body_frame(), RigidTransform()))
        return anchor

    def _apply_loads(self, builder, plant, scene: Scene) -> None:
        """The scene's constant loads as one ExternallyAppliedSpatialForce a body (world frame,
        at its centre of mass, the body frame's origin here) from a constant source on the
        plant's applied spatial force input port."""
        loads = [load for load in scene.loads if load.acts]
        self._loaded = bool(loads)
        if not loads:
            return
        from pydrake.common.value import AbstractValue
        from pydrake.multibody.math import SpatialForce
        from pydrake.multibody.plant import ExternallyAppliedSpatialForce
        from pydrake.systems.primitives import ConstantValueSource
        forces = []
        for load in loads:
            f = ExternallyAppliedSpatialForce()
            f.body_index = self._rigid[load.body].index()
            f.p_BoBq_B = np.zeros(3)
            f.F_Bq_W = SpatialForce(np.asarray(load.torque, float), np.asarray(load.force, float))
            forces.append(f)
        source = builder.AddSystem(ConstantValueSource(AbstractValue.Make(forces)))
        builder.Connect(source.get_output_port(0), plant.get_applied_spatial_force_input_port())
        self.knobs["loads"] = {load.body: {"force": list(load.force), "torque": list(load.torque)} for load in loads}
        self.knobs["loads (how)"] = ("ExternallyAppliedSpatialForce at the centre of mass, world frame, from a "
                                     "ConstantValueSource on the applied spatial force input port")

    def _set_start(self, scene: Scene, plan: dict):
        """Start pose and velocity of every dynamic body; returns the state readers."""
        plant, ctx = self._plant, self._context
        q, v = plant.GetPositions(ctx).copy(), plant.GetVelocities(ctx).copy()
        readers = []
        for body in scene.dynamic_bodies:
            kind = plan[body.name]
            p0, q0 = np.asarray(body.position, float), np.asarray(body.orientation, float)
            v0, w0 = np.asarray(body.velocity, float), np.asarray(body.angular_velocity, float)
            if kind[0] == "jointed":  # at its start pose (every joint coordinate 0), at its start rate
                rate = start_rate(scene, kind[3])
                vs = kind[2].velocity_start()
                v[vs:vs + len(rate)] = rate
                readers.append((body.name, "jointed", kind[1], None, None))
            elif kind[0] == "free":
                qs, vs = kind[1].floating_positions_start(), kind[1].floating_velocities_start_in_v()
                q[qs:qs + 4], q[qs + 4:qs + 7] = q0 / np.linalg.norm(q0), p0
                v[vs:vs + 3], v[vs + 3:vs + 6] = w0, v0   # angular velocity in the world frame
                readers.append((body.name, "free", qs, vs, None))
            elif kind[0] == "planar":
                qs, vs = kind[1].position_start(), kind[1].velocity_start()
                q[qs:qs + 3] = (p0[2], p0[0], 0.0)
                v[vs:vs + 3] = (v0[2], v0[0], w0[1])
                readers.append((body.name, "planar", qs, vs, q0 / np.linalg.norm(q0)))
            else:
                rows = []
                for joint, axis in kind[1]:
                    qs, vs = joint.position_start(), joint.velocity_start()
                    q[qs], v[vs] = p0 @ axis, v0 @ axis
                    rows.append((qs, vs))
                axes = np.array([axis for _, axis in kind[1]])
                readers.append((body.name, "slides", rows, axes, q0 / np.linalg.norm(q0)))
        plant.SetPositions(ctx, q)
        plant.SetVelocities(ctx, v)
        return readers

    # --- running ------------------------------------------------------------------------

    def step(self) -> None:
        self._steps += 1
        self._simulator.AdvanceTo(self._steps * self._dt)

    def states(self) -> dict[str, np.ndarray]:
        q, v = self._plant.GetPositions(self._context), self._plant.GetVelocities(self._context)
        out = {}
        for name, kind, a, b, q0 in self._readers:
            if kind == "jointed":  # the body's pose and spatial velocity from the plant's kinematics
                X, V = self._plant.EvalBodyPoseInWorld(self._context, a), \
                    self._plant.EvalBodySpatialVelocityInWorld(self._context, a)
                out[name] = state_row(X.translation(), X.rotation().ToQuaternion().wxyz(), V.translational(),
                                      V.rotational())
            elif kind == "free":  # q: w, x, y, z, position; v: world angular, linear
                out[name] = state_row(q[a + 4:a + 7], q[a:a + 4], v[b + 3:b + 6], v[b:b + 3])
            elif kind == "planar":  # (z, x, angle about +y)
                th = q[a + 2]
                turn = np.array([math.cos(th / 2), 0.0, math.sin(th / 2), 0.0])
                out[name] = state_row((q[a + 1], 0.0, q[a]), rotations.multiply(turn, q0),
                                      (v[b + 1], 0.0, v[b]), (0.0, v[b + 2], 0.0))
            else:
                qi, vi = [r[0] for r in a], [r[1] for r in a]
                out[name] = state_row(q[qi] @ b, q0, v[vi] @ b, np.zeros(3))
        return out

    # Bulk reads (adapters.base): the plant's q and v in one call (GetPositionsAndVelocities),
    # decoded per body as states() maps them.
    def body_order(self) -> list[str]:
        return [r[0] for r in self._readers]

    def state_size(self) -> int:
        if self._tree:  # a jointed body's state is read through the plant's kinematics (states)
            return 13 * len(self._readers)
        return self._plant.num_positions() + self._plant.num_velocities()

    def write_state(self, out: np.ndarray) -> None:
        if self._tree:
            Simulation.write_state(self, out)
            return
        out[:] = self._plant.GetPositionsAndVelocities(self._context)

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        if self._tree:
            return Simulation.decode_states(self, raw)
        nq = self._plant.num_positions()
        q, v = raw[:, :nq], raw[:, nq:]
        out = np.zeros((len(raw), len(self._readers), 13))
        for i, (_, kind, a, b, q0) in enumerate(self._readers):
            row = out[:, i]
            if kind == "free":
                row[:, 0:3], row[:, 3:7] = q[:, a + 4:a + 7], q[:, a:a + 4]
                row[:, 7:10], row[:, 10:13] = v[:, b + 3:b + 6], v[:, b:b + 3]
            elif kind == "planar":
                row[:, 0], row[:, 2] = q[:, a + 1], q[:, a]
                row[:, 3:7] = rotations.multiply(about_y_many(q[:, a + 2]), q0)
                row[:, 7], row[:, 9], row[:, 11] = v[:, b + 1], v[:, b], v[:, b + 2]
            else:
                qi, vi = [r[0] for r in a], [r[1] for r in a]
                row[:, 0:3], row[:, 3:7], row[:, 7:10] = q[:, qi] @ b, q0, v[:, vi] @ b
        return out

    # Drake's conventions (multibody/plant/contact_results.h, point_pair_contact_info.h,
    # geometry/query_results/penetration_as_point_pair.h): PointPairContactInfo.
    # contact_force() is f_Bc_W, the force on body B at the contact point C, expressed in
    # the world; point_pair().nhat_BA_W the unit normal pointing from B into A; depth > 0
    # the penetration. So the force on A is -f_Bc_W, its normal part (-f_Bc_W) . nhat_BA_W
    # >= 0 pushes A away from B: A is the contract's a, nhat_BA_W its n. contact_point()
    # is C, where the solver applied the force (between the witness points, weighted by
    # stiffness: on the static body's surface here). The plant's output ports are sampled
    # (use_sampled_output_ports, the default): the results are those of the last step.
    # Hydroelastic: HydroelasticContactInfo.F_Ac_W is the spatial force on the body of
    # the surface's geometry M at the surface centroid, and the surface's face normals
    # point out of geometry N into M (geometry/query_results/contact_surface.h).

    def _results(self):
        return self._results_port.Eval(self._context)

    def contact_forces(self) -> dict[tuple[str, str], float]:
        out: dict[tuple[str, str], float] = {}
        for a, b, _, n, f_a in self._resultants(self._results()):
            key = pair_key(a, b)
            out[key] = out.get(key, 0.0) + float(f_a @ n)
        return out

    def _resultants(self, results):
        """(a, b, point, n from b into a, force on a) per point pair or contact surface."""
        name = self._geometry_name
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            pp = info.point_pair()
            yield (name[pp.id_A.get_value()], name[pp.id_B.get_value()], info.contact_point(),
                   pp.nhat_BA_W, -info.contact_force())
        for i in range(results.num_hydroelastic_contacts()):
            info = results.hydroelastic_contact_info(i)
            surface = info.contact_surface()
            normals = np.array([surface.face_normal(f) for f in range(surface.num_faces())])
            areas = np.array([surface.area(f) for f in range(surface.num_faces())])
            n = areas @ normals if len(areas) else np.zeros(3)
            length = np.linalg.norm(n)
            if length == 0.0:  # a surface of no area carries no pressure
                continue
            yield (name[surface.id_M().get_value()], name[surface.id_N().get_value()], surface.centroid(),
                   n / length, info.F_Ac_W().translational())

    def contact_points(self) -> list[ContactPoint]:
        """One point per point pair Drake solved (point contact: one per touching pair of
        geometries), a = Drake's body A, with the conventions above; gap = -depth. 2D
        scenes: y components dropped (the planar joints take them up)."""
        results = self._results()
        name = self._geometry_name
        points = []
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            pp = info.point_pair()
            n = np.array(pp.nhat_BA_W, float)
            f = -np.asarray(info.contact_force(), float)
            x = np.array(info.contact_point(), float)
            if self._planar:
                x[1] = n[1] = f[1] = 0.0
                n /= np.linalg.norm(n)
            f_n = float(f @ n)
            points.append(ContactPoint(name[pp.id_A.get_value()], name[pp.id_B.get_value()], x, n, f_n,
                                       f - f_n * n, -float(pp.depth)))
        return points

    def close(self) -> None:
        self._simulator = self._plant = self._context = self._results_port = None


# --- materials --------------------------------------------------------------------------------

def _drake_shapes(body: Body, hydro: bool) -> list:
    """(name, Drake shape, pose in the body frame (a plane's: in the world)) for each
    geometry of a body: one, but a static Mesh under point contact. A capsule and a cylinder
    are Drake's own, whose axis is the body's z, as the scene's (`length`: the cylindrical
    part's, 2 half_length; the whole length for a cylinder). A hull and a polygon's prism are
    Convex shapes of their corners (Drake takes their convex hull: the shape itself).
    A static Mesh: point contact collides a Mesh as its convex hull ("Choosing the Right
    Collision Geometry"; measured: a ball placed in a V-shaped trough falls through it), so
    there each triangle is a Convex of its own, its prism into the solid
    (adapters.solids.triangle_prisms), as MuJoCo's adapter does; hydroelastic contact
    takes the triangles themselves as a rigid Mesh (an in-memory OBJ)."""
    from pydrake.geometry import (Box as DrakeBox, Capsule as DrakeCapsule, Convex, Cylinder as DrakeCylinder,
                                  HalfSpace, Sphere as DrakeSphere)
    from pydrake.math import RigidTransform
    s = body.shape
    if isinstance(s, (Sphere, Circle)):
        return [(body.name, DrakeSphere(s.radius), RigidTransform())]
    if isinstance(s, Box):
        return [(body.name, DrakeBox(*(2.0 * np.asarray(s.half_extents, float))), RigidTransform())]
    if isinstance(s, Rect):
        a, c = s.half_extents
        return [(body.name, DrakeBox(2.0 * a, 2.0 * a, 2.0 * c), RigidTransform())]
    if isinstance(s, Plane):  # solid below n . x = offset
        n = np.asarray(s.normal, float)
        return [(body.name, HalfSpace(), HalfSpace.MakePose(n, s.offset * n))]
    if isinstance(s, Capsule):
        return [(body.name, DrakeCapsule(s.radius, 2.0 * s.half_length), RigidTransform())]
    if isinstance(s, Cylinder):
        return [(body.name, DrakeCylinder(s.radius, 2.0 * s.half_length), RigidTransform())]
    if isinstance(s, (Hull, Polygon)):
        points, _ = _convex_points(s)
        return [(body.name, Convex(np.asarray(points, float).T, body.name), RigidTransform())]
    if hydro:  # a static Mesh: its triangles, rigid
        from pydrake.common import MemoryFile
        from pydrake.geometry import InMemoryMesh, Mesh as DrakeMesh
        text = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in np.asarray(s.vertices, float).tolist())
        text += "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in s.triangles)
        mesh = DrakeMesh(InMemoryMesh(mesh_file=MemoryFile(text, ".obj", body.name)))
        return [(body.name, mesh, RigidTransform())]
    prisms, _ = triangle_prisms(s.vertices, s.triangles)
    return [(f"{body.name}#{k}", Convex(prism.T, f"{body.name}#{k}"), RigidTransform())
            for k, prism in enumerate(prisms)]


def _convex_points(s) -> tuple[np.ndarray, np.ndarray]:
    """A Hull's corners and faces (triangles wound outward), or a Polygon's prism's, as deep
    along y as it is wide (a Rect's box is as deep as it is wide)."""
    if isinstance(s, Hull):
        return np.asarray(s.vertices, float), s.faces
    return polygon_prism(s.corners, width_half_depth(s.corners))


def _shape_record(body: Body, hydro: bool) -> dict:
    """How a body's shape went to Drake, for the knobs."""
    s = body.shape
    if isinstance(s, Capsule):
        return {"Capsule": {"radius": s.radius, "length": 2.0 * s.half_length}}
    if isinstance(s, Cylinder):
        return {"Cylinder": {"radius": s.radius, "length": 2.0 * s.half_length}}
    if isinstance(s, (Hull, Polygon)):
        return {"Convex": f"{len(_convex_points(s)[0])} corners of the scene's {s.kind}, body frame, scale 1"}
    if isinstance(s, Mesh) and hydro:
        return {"Mesh": f"{len(s.triangles)} triangles of the scene's mesh (in-memory OBJ), scale 1, rigid"}
    if isinstance(s, Mesh):
        _, depths = triangle_prisms(s.vertices, s.triangles)
        return {"Convex": f"{len(depths)} triangle prisms {body.name}#0..#{len(depths) - 1}, scale 1",
                "prism depth, m": {"largest": max(depths), "least": min(depths)}}
    return {}


def _point_stiffness(scene: Scene, w: float) -> dict[str, float]:
    """Per-body point stiffness. Without compliant laws: k_i = m_i w^2 (static bodies
    RIGID_STIFFNESS), so a pair's series stiffness k_a k_b / (k_a + k_b) = m* w^2 with
    m* = m_a m_b / (m_a + m_b): every translational pair oscillates at w. Hooke pairs take
    the scene's k: compliances 1/k_i solved so that 1/k_a + 1/k_b = 1/k for each pair."""
    if "hooke" not in scene.contact_laws:
        return {b.name: RIGID_STIFFNESS if b.static else b.mass * w * w for b in scene.bodies}
    rows = []
    for a, b in scene.contact_pairs():
        c = scene.material_of(a.name, b.name).compliance
        target = 1.0 / c.k if c is not None else sum(0.0 if x.static else 1.0 / (x.mass * w * w) for x in (a, b))
        rows.append((a.name, b.name, 1.0, 1.0, target))
    compliance = _per_body([b.name for b in scene.bodies], rows, "Hooke stiffnesses")
    return {n: RIGID_STIFFNESS if c == 0.0 else 1.0 / c for n, c in compliance.items()}


def _materials(scene: Scene, dt: float, approximation: str, contact_model: str, options: dict,
               record: dict) -> dict:
    """ProximityProperties per body, from each pair's e, mu and compliance (module notes),
    and the record of the mapping."""
    from pydrake.geometry import ProximityProperties
    from pydrake.multibody.plant import CoulombFriction
    names = [b.name for b in scene.bodies]
    n = options["contact_steps"]
    w = math.pi / (n * dt)
    law = {"sap": "sap", "cenic": "continuous_hunt_crossley"}.get(approximation, "hunt_crossley")
    v_ref = options.get("impact_speed", IMPACT_SPEED)
    hydro = contact_model == "hydroelastic"
    k = _point_stiffness(scene, w)
    E = {b.name: _hydroelastic_modulus(b, w, v_ref) for b in scene.bodies} if hydro else None
    record.update({"contact_steps_n": n, "w": w, "law": law, "pairs": {}})
    if hydro:
        record["hydroelastic_modulus"] = ("largest face m w^2 stiff (boxes, cylinders' ends, hulls and polygons' prisms); "
                                          "contact n dt long at impact_speed (spheres, capsules' caps)")
    else:
        record["point_contact_stiffness"] = "m w^2 per body (static: RIGID_STIFFNESS)"
    if law != "sap" or hydro:
        record["impact_speed"] = v_ref
    # Hunt & Crossley d combines weighted by the partner's stiffness (point) or modulus
    # (hydroelastic): d = (k_b d_a + k_a d_b) / (k_a + k_b) = (c_a d_a + c_b d_b) / (c_a + c_b)
    # in compliances c = 1/k (0 for a rigid body); SAP's tau = tau_a + tau_b.
    compliance = {nm: 1.0 / x if math.isfinite(x) else 0.0 for nm, x in (E or k).items()}
    rows = []
    for pa, pb in scene.contact_pairs():
        mat = scene.material_of(pa.name, pb.name)
        entry = {"e": mat.e, "mu": mat.mu_s}
        if mat.compliance is not None:  # Hooke, elastic (_unrepresentable keeps the rest out)
            value = 0.0
            entry.update(law="hooke", k=mat.compliance.k)
        elif law == "continuous_hunt_crossley":
            p, reached = continuous_hunt_crossley(float(mat.e))
            value = p / v_ref
            entry.update(delta=p, d=value, e_reached=reached)
        else:
            p, reached = restitution_dissipation(law, float(mat.e), w * dt)
            value = p / v_ref if law == "hunt_crossley" else p / w
            entry.update({"delta": p, "d": value} if law == "hunt_crossley" else {"s": p, "tau": value})
            entry["e_reached"] = reached
        record["pairs"]["|".join(pair_key(pa.name, pb.name))] = entry
        if law != "sap":
            ca, cb = compliance[pa.name], compliance[pb.name]
            rows.append((pa.name, pb.name, ca / (ca + cb), cb / (ca + cb), value))
        else:
            rows.append((pa.name, pb.name, 1.0, 1.0, value))
    dissipation = _per_body(names, rows, "dissipation")
    mu = per_body_values(scene, lambda m: m.mu_s, "harmonic", "friction") if "friction" in scene.effects \
        else {nm: 0.0 for nm in names}
    props, geometry = {}, {}
    for body in scene.bodies:
        # both dissipations are set: the approximation reads its own, the other is 0
        d = dissipation[body.name] if law != "sap" else 0.0
        tau = dissipation[body.name] if law == "sap" else 0.0
        g = {"coulomb_friction": [mu[body.name], mu[body.name]], "point_contact_stiffness": k[body.name],
             "hunt_crossley_dissipation": d, "relaxation_time": tau}
        pr = ProximityProperties()
        pr.AddProperty("material", "coulomb_friction", CoulombFriction(mu[body.name], mu[body.name]))
        for prop in ("point_contact_stiffness", "hunt_crossley_dissipation", "relaxation_time"):
            pr.AddProperty("material", prop, float(g[prop]))
        if hydro:
            g.update(_hydroelastic(body, pr, E[body.name]))
        props[body.name], geometry[body.name] = pr, g
    record["geometry"] = geometry
    return {"props": props, "mu": mu}


# I_2 = int_0^1 (1 - u^3)^(-1/2) du = Gamma(1/3) Gamma(1/2) / (3 Gamma(5/6)): a contact
# force C x^2 returns a body that hit at v after 2 I_2 x_max / v, x_max = (3 m v^2 / 2C)^(1/3).
_I2 = math.gamma(1 / 3) * math.gamma(1 / 2) / (3 * math.gamma(5 / 6))


def _hydroelastic_modulus(body: Body, w: float, v_ref: float) -> float:
    """E (Pa) of a compliant body (static ones are rigid: infinity). Drake's pressure
    fields (geometry/proximity/make_*_field.h) are E times a depth below the surface over a
    length: a box's E d / H (d the depth below the nearest face, H the smallest half-size),
    a cylinder's the same with H = min(radius, half-length), a Convex's E d / d_f in the
    tetrahedron of each face f (the field is 0 on the faces, E at the volume centroid, d_f the
    face's distance from it). So a flat face of area A pressed x into a rigid plane pushes
    with E A x / H: E = m w^2 H / A on the largest face (a cylinder's end) makes it the point
    contact's m w^2 spring. A sphere's field is E (1 - r / R), a capsule's the same about its
    segment, which pressed x into a rigid plane by a cap pushes with pi E x^2 (to leading order
    in x / R): E such that an impact at impact_speed lasts pi / w, i.e.
    x_max = pi v / (2 I_2 w). (A cylinder or capsule lying on its side is stiffer as the line
    contact widens, as a sphere's contact is: these moduli make its flattest contact, and a
    capsule's cap, the point contact's.)"""
    if body.static:
        return math.inf
    s = body.shape
    if isinstance(s, (Sphere, Circle, Capsule)):
        x_max = math.pi * v_ref / (2.0 * _I2 * w)
        return 3.0 * body.mass * v_ref**2 / (2.0 * math.pi * x_max**3)
    if isinstance(s, Cylinder):
        return body.mass * w * w * min(s.radius, s.half_length) / (math.pi * s.radius**2)
    if isinstance(s, (Hull, Polygon)):
        area, distance = _largest_face(*_convex_points(s))
        return body.mass * w * w * distance / area
    half = sorted(_box_half_extents(s))
    return body.mass * w * w * half[0] / (4.0 * half[1] * half[2])


def _largest_face(points: np.ndarray, triangles: np.ndarray) -> tuple[float, float]:
    """(area, distance from the origin) of the largest face of a convex polyhedron about
    the origin, its coplanar triangles taken together."""
    normals = triangle_normals(points, triangles)
    a, b, c = points[triangles[:, 0]], points[triangles[:, 1]], points[triangles[:, 2]]
    areas = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    offsets = np.einsum("ij,ij->i", normals, a)
    size = float(np.ptp(points, axis=0).max())
    planes: dict[tuple, list[float]] = {}
    for n, d, area in zip(normals, offsets, areas):
        key = tuple(np.round(np.append(n, d / size), 9))  # coplanar to rounding
        planes.setdefault(key, [0.0, float(d)])[0] += float(area)
    area, distance = max(planes.values())
    return area, distance


def _box_half_extents(s) -> tuple[float, float, float]:
    """A Box's half-extents; a Rect's as the adapter embeds it (as deep along y as wide)."""
    if isinstance(s, Rect):
        a, c = s.half_extents
        return (a, a, c)
    return tuple(s.half_extents)


def _hydroelastic(body: Body, props: ProximityProperties, modulus: float) -> dict:
    """Static bodies rigid, dynamic ones compliant with modulus E; spheres, capsules and
    cylinders tessellated at HYDRO_RESOLUTION of their radius (boxes, Convex shapes, meshes
    and half-spaces are not tessellated by a hint: a Convex's volume mesh is its faces and
    its centroid, a Mesh is its triangles). No margin (Drake's speculative contact,
    hydroelastic only)."""
    from pydrake.geometry import AddCompliantHydroelasticProperties, AddRigidHydroelasticProperties
    s = body.shape
    hint = HYDRO_RESOLUTION * s.radius if isinstance(s, (Sphere, Circle, Capsule, Cylinder)) else 1.0
    if body.static:
        AddRigidHydroelasticProperties(hint, props)
        return {"compliance_type": "rigid", "resolution_hint": hint}
    AddCompliantHydroelasticProperties(hint, modulus, props)
    props.AddProperty("hydroelastic", "margin", 0.0)
    return {"compliance_type": "compliant", "hydroelastic_modulus": modulus, "resolution_hint": hint,
            "margin": 0.0}


def _effects(scene: Scene, material: dict, plan: dict, hydro: bool = False) -> frozenset[str]:
    """What the built plant simulates, read from what was given to Drake. Hydroelastic
    contact is a pressure patch, not a point: with friction on it, a body that turns meets
    friction over the patch's area, which resists spin about the normal (a patch of radius a:
    2/3 mu a N; a 2D body cannot spin about an in-plane normal), and the patch's damped
    pressure, higher where it is being compressed, resists rolling. The scene asks for
    neither: both are reported, so the effect manifest shows them (measured sizes:
    adapters/xfails/drake.txt, cases/rolling_resistance.py and cases/spin_down.py)."""
    fx = set()
    if any(g != 0.0 for g in scene.gravity):
        fx.add("gravity")
    pairs = scene.contact_pairs()
    if pairs:
        fx.add("contact")
        if any(scene.material_of(a.name, b.name).e > 0.0 for a, b in pairs):
            fx.add("restitution")  # the mapped dissipation leaves a rebound (E_FLOOR for e = 0)
        mu = material["mu"]
        if any(mu[a.name] * mu[b.name] > 0.0 for a, b in pairs):
            fx.add("friction")
    if any(kind != "static" and kind[0] in ("free", "planar") for kind in plan.values()):
        fx.add("rotation")
        if hydro and "friction" in fx:
            fx.add("rolling_resistance")
            if any(kind != "static" and kind[0] == "free" for kind in plan.values()):
                fx.add("torsional_friction")
    if any(kind != "static" and kind[0] == "jointed" for kind in plan.values()):
        fx.add("joint")
        if any(j.kind == "revolute" for j in scene.joints):
            fx.add("rotation")
    return frozenset(fx)


def _unrepresentable(scene: Scene, contact_model: str) -> str | None:
    for a, b in scene.contact_pairs():
        mat = scene.material_of(a.name, b.name)
        if mat.compliance is None:
            continue
        if contact_model == "hydroelastic":
            return (f"{a.name}/{b.name}: Hooke contact asked for: hydroelastic contact integrates a "
                    "pressure field, its force is not k xi")
        if mat.e != 1.0:
            return (f"{a.name}/{b.name}: Hooke contact with e = {mat.e:g}: F = k xi is elastic (e = 1); "
                    "a damped compliant contact is another law")
    return None


def _require_tamsi() -> None:
    """registry.EngineError (the configuration is not available here) where the installed
    Drake has no TAMSI approximation: 1.51.1 has DiscreteContactApproximation.kTamsi,
    1.58.0 (Python 3.12's release) has it no more."""
    from pydrake.multibody.plant import DiscreteContactApproximation
    if not hasattr(DiscreteContactApproximation, "kTamsi"):
        from adapters.registry import EngineError
        raise EngineError(f"engine 'drake-tamsi' is not available: Drake {metadata.version('drake')} has no TAMSI "
                          "approximation (DiscreteContactApproximation.kTamsi, in Drake 1.51.1: its release for "
                          "Python 3.11)")


class DrakeAdapter(Adapter):
    package = "drake"
    # the release the conformance battery ran on; the next major (minor for 0.x) may change the API
    supported = ">=1.51.1,<2"

    def __init__(self, approximation: str = "sap", contact_model: str = "point", name: str | None = None):
        if approximation not in _APPROXIMATIONS + CONTINUOUS or contact_model not in _CONTACT_MODELS:
            raise ValueError(f"approximation {approximation!r}, contact model {contact_model!r}: choose from "
                             f"{sorted(_APPROXIMATIONS + CONTINUOUS)} and {sorted(_CONTACT_MODELS)}")
        if approximation == "tamsi":
            _require_tamsi()
        self.approximation, self.contact_model = approximation, contact_model
        self.name = name or ("drake-hydro" if contact_model == "hydroelastic" else f"drake-{approximation}")
        # Drake steps 0.1-0.8 ms a body: in a default run the other contact models and
        # approximations (CENIC's continuous plant too) take the core families and the
        # conformance battery (like the reference's formulations); named, they run everything
        self.default_tags = None if self.name == "drake" else frozenset({"core", "conformance"})
        point = contact_model == "point"
        self.capabilities = Capabilities(
            dimensions=frozenset({2, 3}),
            # every kind (_drake_shapes); a static mesh as triangle prisms under point contact
            shapes=frozenset({"sphere", "box", "plane", "circle", "rect", "capsule", "cylinder", "hull", "polygon",
                              "mesh"}),
            native_restitution=False,   # e is mapped onto the contact's dissipation
            static_kinetic=False,       # discrete Drake resolves one (dynamic) coefficient
            contact_forces=True,
            iterations=False,           # the solvers' iteration caps are not exposed
            contact_points=point,       # hydroelastic: one resultant per surface only
            contact_laws=frozenset({"hooke"}) if point else frozenset(),
            impact_model="compliant",
            # jointed bodies are a tree (adapters.joints.joint_tree): each hangs on Drake's joint
            # of its kind on its parent body or the world (DrakeSimulation._joint), a tree's root
            # free or planar; a loop, and a ball joint (BALL_JOINT), is a ball constraint on free
            # bodies under SAP: reduced coordinates
            joints=frozenset({"revolute", "prismatic", "fixed"} | ({"ball"} if approximation in CONSTRAINED else set())),
            joint_friction=approximation in CONSTRAINED,  # SAP's PD drive at rate 0, effort-limited (FRICTION_KD)
            coordinates="reduced",
            loads=True,  # ExternallyAppliedSpatialForce from a constant source (DrakeSimulation._apply_loads)
            why_not=(("joint", BALL_JOINT + f"; the {approximation} approximation takes no constraints"),
                     ("joint_friction", "a joint's dry friction is an effort-limited PD drive at rate 0, which SAP "
                                        f"solves implicitly; {approximation} "
                                        + ("ignores the drive's gains (measured: the rail's slider kept its 2 m/s)"
                                           if approximation == "tamsi" else "is not mapped with it (the drive was measured under SAP only)")
                                        + "; Drake's joint damping is viscous, not Coulomb"),
                     ("limit", "joint limits are not mapped (Drake enforces them only under SAP)")),
        )
        tunables = {
            "contact_steps": Tunable(2.0, 1000.0, float(CONTACT_STEPS),
                                     "contact duration in time steps n: point stiffness m (pi / (n dt))^2"),
        }
        if approximation != "sap" or not point:
            tunables["impact_speed"] = Tunable(0.01, 100.0, IMPACT_SPEED,
                                               "impact speed (m/s) at which a Hunt & Crossley d gives e, and "
                                               "a sphere's hydroelastic contact lasts n steps")
        if approximation != "sap":
            tunables["stiction_tolerance"] = Tunable(1e-8, 1e-2, STICTION_TOLERANCE[approximation],
                                                     "friction regularisation: slip speed (m/s) at full stiction")
        if approximation in CONTINUOUS:
            tunables["accuracy"] = Tunable(1e-8, 0.5, ACCURACY, "CENIC's error target (SimulatorConfig.accuracy)",
                                           sweep=ACCURACIES)
        self.tunables = tunables

    def version(self) -> str:
        return metadata.version("drake")

    def _options(self, settings: Settings) -> dict:
        options = {name: t.default for name, t in self.tunables.items()}
        for name, value in settings.options.items():
            t = self.tunables.get(name)
            if t is None:
                raise SettingsError(f"options[{name!r}]: {self.name} understands {', '.join(self.tunables)}")
            if not t.low <= value <= t.high:
                raise SettingsError(f"options[{name!r}] = {value!r}: must lie in [{t.low:g}, {t.high:g}]")
            options[name] = float(value)
        return options

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene) or _unrepresentable(scene, self.contact_model)
        if reason:
            raise Unsupported(reason)
        _, closing = joint_tree(scene, LOOSE)  # Unsupported for the joints the adapter does not map
        if closing:
            if self.approximation not in CONSTRAINED:
                j, joint = closing[0]
                what = "is a ball joint" if joint.kind in LOOSE else "closes a loop: Drake's tree holds no loop joint"
                raise Unsupported(f"joints[{j}] {what}, and its ball constraint (AddBallConstraint) is solved by SAP "
                                  f"only ({', '.join(CONSTRAINED)}), not by {self.approximation}")
            closing_ball_points(scene, closing, "Drake's AddBallConstraint")
        return DrakeSimulation(scene, settings, self.approximation, self.contact_model, self._options(settings))
