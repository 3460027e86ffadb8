"""PyBullet (Bullet 3) adapter: one `p.connect(p.DIRECT)` engine per built scene, its client
reset and kept for the next scene built alike (`_IDLE`).

Bullet has two body models and neither suits every scene (measured with pybullet 3.2.7,
dt = 1e-3, worst over ten contact phases):
- maximal coordinates (btRigidBody) with split impulse, whose push-out moves positions
  and leaves velocities alone, apply Newton's law v_n+ = -e v_n (002 Cornell "09
  Collision response", Restitution) to machine precision in a central impact; but their
  friction is wrong (-0.01 to -0.3 m/s^2 on an incline, creep up to 0.12 mm/s below the
  threshold);
- reduced coordinates (btMultiBody) with cone friction and friction anchors slide to
  <= 7e-4 m/s^2 and hold without creep; but they have no split impulse (penetration is
  pushed out through the velocity, the bias beta/dt * delta of 001 "CG3 Collisions",
  sequential impulses, which adds bounce) and restitution acts on the velocity after
  gravity, a bias of +e g dt / v in the bounce ratio.
So frictionless 3D scenes without joints or loads use maximal coordinates and the others reduced coordinates;
2D scenes need joints to stay in the x-z plane, which only reduced coordinates have.
Every parameter set is recorded in `knobs` under pybullet's own name.

Configurations users run are named engine variants (adapters/registry.py), each a
constructor argument recorded in `knobs`; the plain "pybullet" keeps the choices above:
- `bodies="rigid"` ("pybullet-rigid"): maximal coordinates for every scene, friction
  included, with warm starting (WARM_STARTING_FACTOR, Bullet's own library default):
  what a scene of free rigid bodies gets in PyBullet, at the price of the friction
  errors above; 3D only (no planar joints without reduced coordinates);
- `friction_anchor=False` ("pybullet-noanchor"): no friction anchors, the other side of
  their trade-off (creep instead of spring-back);
- `ground="box"` ("pybullet-boxground"): a scene's plane built as a large box whose top
  face is the plane instead of a GEOM_PLANE. Bullet's convex-plane algorithm adds one
  manifold point per step (the deepest vertex), so a box landing flat on a GEOM_PLANE is
  struck at one corner first and flips (19 rad/s for a 0.2 m cube from 0.3 m, e = 0.5,
  measured); the box-box detector gives all four corners in the first step. But on the
  box the friction anchors no longer hold a box near the friction limit (creep 0.16-0.45
  mm/s, 0 on the plane) and a disc is found only once 4 mm inside it (no speculative
  point), so the plane stays the default;
- `solver="dantzig"` / `"pgs"` ("pybullet-dantzig", "pybullet-pgs"): PyBullet's other
  constraint solvers (`SOLVERS`), the MLCP solver that bounds friction by a square and
  ignores a Hooke contact's spring (adapters/xfails/pybullet-dantzig.txt, -pgs.txt), and
  drops the rolling and spinning rows of 3D contacts, so those scenes are unsupported
  (`MLCP_DROPS_TORQUES`);
- `ccd=True` ("pybullet-ccd"): Bullet's continuous collision, a sphere swept along each
  dynamic body's motion in a step (ccdSweptSphereRadius, `swept_sphere_radius`), which
  stops a fast body at the first thing it would pass. Bullet sweeps only maximal-coordinate
  bodies (btDiscreteDynamicsWorld::integrateTransforms): a multibody link (2D scenes,
  friction, joints) gets the radius and is not swept. It matters only for bodies that move
  more than the radius in a step, so in a default run the variant takes the families
  tagged "swept" (cases/robustness/tunnelling.py; `default_tags`); named, it runs every family.

Shapes (`_collision_shape`): capsules and cylinders are Bullet's own, along the body's z;
a hull is a btConvexHullShape of its corners, a 2D polygon the same of its prism along y, a
static mesh a btBvhTriangleMeshShape of its triangles; each with the scene's mass and
principal inertia (changeDynamics), never Bullet's from the shape. Bullet's collision margin
would inflate hulls and triangles by 1 mm and round cylinder rims: those shapes get none
(COLLISION_MARGIN). Bullet's own behaviour stays: a hull meets a box or another hull through
GJK/EPA, one new manifold point a step (the persistent manifold keeps up to four), as a box
meets a plane here; triangle seams give their own contacts (no internal-edge table).

Compliant contact, Hooke's law F = k xi (cases.scene.Compliance "hooke"): changeDynamics
contactStiffness and contactDamping set btCollisionObject::setContactStiffnessAndDamping;
a contact point takes the series stiffness 1/(1/k_A + 1/k_B) and the summed damping
d_A + d_B of its two colliders (btManifoldResult::calculateCombinedContactStiffness/
-Damping; every collider's own default damping is 0.1, so every body gets damping 0) and
both solvers turn them into erp = h k / (h k + d), cfm = 1 / (h (h k + d))
(btSequentialImpulseConstraintSolver::setupContactConstraint,
btMultiBodyConstraintSolver::setupMultiBodyContactConstraint). With d = 0 that is erp 1,
cfm 1 / (h^2 k): the unilateral row solves m (v' - v) = -h k (xi + h v'), i.e. the force
is k xi at the end of the step -- backward Euler on an undamped spring, nothing else.
Measured (two steel spheres, k = 1e7 N/m, h = 1e-4, both body models): forces equal a
backward-Euler integration of F = k xi to 2e-10 N, overlaps to 5e-17 m. What stands in the
way, and is switched off for such scenes: split impulse (it moves the penetration term
into a position-only push-out, so the spring never acts on velocities: no rebound at all,
measured), restitution (its target velocity -e v_n adds to the spring's: e_eff 0.68
instead of 0.77 at h = 1e-4), speculative points (per the solver source a point ahead of
contact holds the closing speed to gap/h, a force before touching; no effect measured here,
the spheres start touching). Backward Euler's own dissipation stays:
each step scales the oscillation by 1/sqrt(1 + (w h)^2), w^2 = k/m*, so an impact returns
about exp(-pi w h / 2) of the closing speed (0.773 at w h = 0.165), first order in h.
"""
from __future__ import annotations

import contextlib
import math
import os
import sys
from importlib import metadata
from dataclasses import replace
from itertools import chain

import numpy as np

from adapters.base import Adapter, Capabilities, Settings, Simulation, Unsupported
from adapters.combination import per_body_values
from adapters.frames import require_turn_about_y, state_row, wxyz_to_xyzw, xyzw_to_wxyz, z_to
from adapters.joints import closing_ball_points, joint_tree, start_rate
from adapters.solids import inscribed_radius, polygon_prism
from cases.scene import Body, Scene, pair_key
from cases.trajectory import ContactPoint


@contextlib.contextmanager
def _silenced(fd: int):
    """Hold C-level file descriptor `fd` on /dev/null (pybullet prints from C)."""
    (sys.stdout if fd == 1 else sys.stderr).flush()
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), fd)
            yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


def _import_pybullet():
    """pybullet's module init prints its build time on the C-level stderr: hold fd 2 on
    /dev/null while it loads (an ImportError still propagates)."""
    with _silenced(2):
        import pybullet
    return pybullet


p = _import_pybullet()

DEFAULT_ITERATIONS = 50  # the engine's own default numSolverIterations
CONTACT_ERP = 0.08       # the engine's default contactERP, stated: it is the push-out rate
FRICTION_ERP = 0.2       # the engine's default frictionERP: the friction anchors' spring
RESIDUAL = 1e-7          # the engine's default solverResidualThreshold: iterations stop below it
EVERY_POINT = 1e30       # contactProcessingThreshold that keeps speculative points (BT_LARGE_FLOAT)
# pybullet sets warmStartingFactor 0.1 at connect (PhysicsServerCommandProcessor; Bullet's
# own btContactSolverInfo default is 0.85); it acts on maximal-coordinate contacts only
# (the multibody solver warm starts only when articulatedWarmStartingFactor is set).
PYBULLET_WARM_STARTING_FACTOR = 0.1
# The "rigid" variant's factor: Bullet's library default. At 60 Hz a stack of 0.2 m boxes
# stands 5 high with it (20 and 50 iterations; 10 boxes fall), 2 high at pybullet's 0.1;
# its friction errors are the same at 0, 0.1 and 0.85 (measured).
WARM_STARTING_FACTOR = 0.85
# ground="box": a scene Plane becomes a static box this large, its top face on the plane
GROUND_HALF_WIDTH = 100.0     # m: wider than any scene travels
GROUND_HALF_THICKNESS = 1.0   # m: thicker than any body moves in one step
NO_VELOCITY_CLAMP = 1e30  # maxJointVelocity: btMultiBody clamps every dof to 100 by default
LOCK_CREATION_MASS = 1e30  # see _add_body: a non-rotating maximal body is created this heavy
# Rotation about +x by -90 deg (x, y, z, w): takes the cylinder's z axis onto y.
Z_TO_Y = [-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)]
AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}
# A loop's closing JOINT_POINT2POINT constraint may apply any force that holds it:
# createConstraint's default maxForce (500 N) would cap it, so it is set beyond reach.
LOOP_MAX_FORCE = 1e12   # N
GEOM_NAMES = {p.GEOM_SPHERE: "GEOM_SPHERE", p.GEOM_BOX: "GEOM_BOX", p.GEOM_PLANE: "GEOM_PLANE",
              p.GEOM_CYLINDER: "GEOM_CYLINDER", p.GEOM_CAPSULE: "GEOM_CAPSULE", p.GEOM_MESH: "GEOM_MESH"}
# Bullet's collision margin. pybullet gives every shape it makes m_defaultCollisionMargin,
# 1 mm (PhysicsServerCommandProcessor). Where it lies differs by shape: a hull's and a
# triangle mesh's margin lies OUTSIDE their points (btConvexHullShape's and btTriangleShape's
# support mapping add it), so with it a hull box rests 1 mm high on the plane and 2 mm high on
# a triangle-mesh ground (measured); a box's and a cylinder's lies inside their extents and
# rounds their edges and rims by 1 mm where GJK meets them (not in Bullet's box-box, sphere-box
# and convex-plane routines); a sphere's and a capsule's margin is their radius (setMargin
# leaves it). The shapes the scene vocabulary added last get COLLISION_MARGIN (`_no_margin`),
# so a cylinder, a hull, a polygon and a mesh are the scene's; spheres, boxes, planes, circles
# and rects keep pybullet's default, as they always ran here (a box's edges are therefore
# rounded by 1 mm against a hull, a cylinder or a capsule).
COLLISION_MARGIN = 0.0
PYBULLET_DEFAULT_MARGIN = 0.001


# Constraint solvers (setPhysicsEngineParameter constraintSolverType). "si" is pybullet's
# own default, btMultiBodyConstraintSolver's sequential impulses; "dantzig" and "pgs" make
# PhysicsServerCommandProcessor install a btMultiBodyMLCPConstraintSolver around Bullet's
# btDantzigSolver (a direct pivoting LCP solver) or btSolveProjectedGaussSeidel. The other
# values the C API names (4 Lemke, 5 NNCG, 6 block PGS) are accepted and ignored by pybullet
# 3.2.7: a five-box stack, both body models, ends bit for bit where the default leaves it
# after 2 s (measured), so they are no configuration of their own. "pgs" cannot run 2D
# scenes: the step in which a contact first acts on a planar joint chain (2D bodies slide
# and turn on joints, below) leaves NaN in the state, in every 2D scene of the core
# families (measured), while "dantzig" runs them; so does the step in which a contact first
# acts on a jointed body's link (hinged_rod_stop, 3D: NaN at the impact, measured).
SOLVERS = {"si": p.CONSTRAINT_SOLVER_LCP_SI, "dantzig": p.CONSTRAINT_SOLVER_LCP_DANTZIG,
           "pgs": p.CONSTRAINT_SOLVER_LCP_PGS}
# What the MLCP solvers do with the contact torques' rows, measured (pybullet 3.2.7, dt = 1e-3,
# 50 steps, a 0.1 m, 1 kg ball on the plane, mu 0.5): btMultiBodyMLCPConstraintSolver takes the
# contact and friction rows into its LCP and drops the rolling and spinning ones. In 3D a ball
# rolling at 1 m/s with rolling resistance 0.005 m, or spinning at 10 rad/s with torsional
# friction 0.005 m, keeps its speed to the last digit under both (the default solver slows them
# to 0.9823 m/s and 9.387 rad/s, the closed forms' 0.9825 and 9.387). On the 2D planar joint
# chain Dantzig's solver does apply the rolling rows (0.9838 m/s; 2D disc: 0.9836); there is no
# spin about a normal in the x-z plane.
MLCP_DROPS_TORQUES = ("pybullet's MLCP solvers (Dantzig, PGS) drop the rolling and spinning rows of a 3D "
                      "contact: a ball rolls and spins on as if the pair had none (measured)")
# Measured (pybullet 3.2.7): a btRigidBody's first step turns it with the inverse inertia of
# the shape it was created with, not the scene's set by changeDynamics (localInertiaDiagonal)
# after it: a free ball (I = 0.01 kg m^2, its shape's 0.004) under a constant torque of
# 0.01 N m reaches 0.1015 rad/s in 100 steps of 1 ms, not 0.1 (the first step's 2.5 for 1
# x 1e-3); a multibody takes the scene's from the start. So loads go on multibodies only.
MAXIMAL_FIRST_STEP_INERTIA = ("a maximal-coordinate btRigidBody's first step uses the inverse inertia of the shape "
                              "it was created with, not the scene's: a constant torque's first step is off "
                              "(loads go on multibodies only)")
BODY_MODELS = ("auto", "rigid")
GROUNDS = ("plane", "box")
# The "ccd" variant's swept sphere, as a fraction of the body's inscribed radius. Bullet
# sweeps a sphere of ccdSweptSphereRadius along a body's motion when the body moves more
# than ccdMotionThreshold in a step (pybullet sets both to the radius given) and stops the
# motion at the first hit (btDiscreteDynamicsWorld::integrateTransforms); the contact is
# then found in the next step. Measured (robustness_tunnelling, 10 g ball of r = 1 cm at 50
# and 100 m/s into a 1 kg plate, e = 1): at 0.5 r the rebound is exact to 1e-15 in energy;
# at 1.0 r the swept sphere stops the ball touching, its contact is found at 0 distance and
# the bounce keeps 1 - 4e-4 of the energy.
SWEPT_SPHERE_FRACTION = 0.5


def swept_sphere_radius(body: Body) -> float:
    """The "ccd" variant's ccdSweptSphereRadius for `body`: SWEPT_SPHERE_FRACTION of the
    radius of the ball its shape holds about its centre (adapters.solids.inscribed_radius)."""
    return SWEPT_SPHERE_FRACTION * inscribed_radius(body.shape)


class PyBulletAdapter(Adapter):
    name = "pybullet"
    package = "pybullet"
    # the release the conformance battery ran on; the next major (minor for 0.x) may change the API
    supported = ">=3.2.7,<4"
    capabilities = Capabilities(
        dimensions=frozenset({2, 3}),
        # every kind (_collision_shape); meshes static, as the scene has them
        shapes=frozenset({"sphere", "box", "plane", "circle", "rect", "capsule", "cylinder", "hull", "polygon",
                          "mesh"}),
        native_restitution=True,
        static_kinetic=False,   # one lateralFriction per body
        contact_forces=True,
        iterations=True,
        contact_points=True,
        contact_laws=frozenset({"hooke"}),  # see the module notes; "hertz" is not linear in xi
        # one solve over all the step's contacts, restitution from each contact's own
        # approach velocity (cases/column_impact.py: two pressed balls leave the ground
        # together at e v, a struck row of two leaves as one body, both paths)
        impact_model="simultaneous",
        contact_torques=frozenset({"rolling_resistance", "torsional_friction"}),  # TORQUE_KNOBS
        # one multibody per connected jointed group (adapters.joints.joint_tree): a fixed base
        # at the root's anchor or the free root as its base, each body a link on its scene
        # joint (PyBulletSimulation._add_tree); a loop closed by a JOINT_POINT2POINT
        # constraint: Featherstone's reduced coordinates
        joints=frozenset({"revolute", "prismatic", "ball", "fixed"}),
        joint_limits=True,
        joint_friction=True,  # a velocity motor at 0 bounded by the friction (PyBulletSimulation._add_tree)
        coordinates="reduced",
        loads=True,  # applyExternalForce and applyExternalTorque before each step (pybullet clears them)
        why_not=(("limit_restitution", "a multibody joint's limit takes a range only (changeDynamics jointLowerLimit, "
                                       "jointUpperLimit): Bullet's limit rows have no restitution"),),
    )
    # planted changes (PyBulletSimulation.plant)
    plantable = frozenset({"square friction cone", "velocity damping", "restitution threshold"})

    def __init__(self, name: str = "pybullet", bodies: str = "auto", friction_anchor: bool = True,
                 ground: str = "plane", solver: str = "si", ccd: bool = False):
        """bodies: "auto" (maximal coordinates for frictionless 3D scenes, reduced
        otherwise) or "rigid" (maximal coordinates with warm starting for every scene);
        friction_anchor: frictionAnchor on every frictional contact; ground: a scene
        Plane as a GEOM_PLANE ("plane") or a large box ("box"); solver: the constraint
        solver (`SOLVERS`); ccd: Bullet's swept-sphere continuous collision on every
        dynamic body (`swept_sphere_radius`). See the module notes."""
        if bodies not in BODY_MODELS:
            raise ValueError(f"bodies = {bodies!r}: must be one of {', '.join(BODY_MODELS)}")
        if ground not in GROUNDS:
            raise ValueError(f"ground = {ground!r}: must be one of {', '.join(GROUNDS)}")
        if solver not in SOLVERS:
            raise ValueError(f"solver = {solver!r}: must be one of {', '.join(SOLVERS)}")
        self.name = name
        self.config = {"bodies": bodies, "friction_anchor": bool(friction_anchor), "ground": ground,
                       "solver": solver, "ccd": self.continuous_collision(ccd)}
        if bodies == "rigid":  # 2D bodies stay in their plane on joints, which need reduced coordinates
            self.capabilities = replace(
                self.capabilities, dimensions=frozenset({3}), joints=frozenset(), joint_limits=False,
                joint_friction=False, coordinates=None, loads=False,
                why_not=self.capabilities.why_not + (
                    ("joint", "the rigid variant keeps every body a maximal-coordinate btRigidBody: a scene joint "
                              "would be a Bullet constraint (createConstraint), not mapped"),
                    ("load", MAXIMAL_FIRST_STEP_INERTIA)))
        if solver != "si":  # the MLCP solvers: rolling rows only on Dantzig's 2D path (MLCP_DROPS_TORQUES)
            self.capabilities = replace(
                self.capabilities, contact_torques=frozenset({"rolling_resistance"} if solver == "dantzig" else ()),
                why_not=self.capabilities.why_not + tuple((effect, MLCP_DROPS_TORQUES) for effect in TORQUE_KNOBS))

    def version(self) -> str:
        return metadata.version("pybullet")

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene) or self._spin_without_roll(scene) or self._mlcp_torques(scene)
        if reason:
            raise Unsupported(reason)
        closing_ball_points(scene, joint_tree(scene)[1], "pybullet's JOINT_POINT2POINT constraint")  # loops not mapped
        if self.config["solver"] == "pgs" and scene.dimension == 2:
            raise Unsupported("2D scene: pybullet's MLCP projected Gauss-Seidel leaves NaN in the state in the "
                              "first step a contact acts on the planar joint chain of a 2D body (SOLVERS)")
        jointed = {j.body for j in scene.joints}
        if self.config["solver"] == "pgs" and any(a.name in jointed or b.name in jointed
                                                  for a, b in scene.contact_pairs()):
            raise Unsupported("a jointed body that may touch another: pybullet's MLCP projected Gauss-Seidel leaves "
                              "NaN in the state in the first step a contact acts on a multibody's link (SOLVERS)")
        return PyBulletSimulation(scene, settings, **self.config)

    def _mlcp_torques(self, scene: Scene) -> str | None:
        """Dantzig's MLCP applies rolling rows in 2D only (MLCP_DROPS_TORQUES)."""
        if self.config["solver"] == "si" or scene.dimension == 2:
            return None
        for effect in TORQUE_KNOBS:
            if effect in scene.effects:
                return f"{effect.replace('_', ' ')} in a 3D scene: {MLCP_DROPS_TORQUES}"
        return None

    def _spin_without_roll(self, scene: Scene) -> str | None:
        """Maximal coordinates (btSequentialImpulseConstraintSolver::convertContact) add a
        contact's spinning row only inside `if (cp.m_combinedRollingFriction > 0)`: torsional
        friction without rolling resistance is dropped (measured: a ball spinning on the
        ground with spinningFriction alone never slows)."""
        if self.config["bodies"] != "rigid":
            return None  # reduced coordinates add the two independently (btMultiBodyConstraintSolver)
        for a, b in scene.contact_pairs():
            mat = scene.material_of(a.name, b.name)
            if mat.torsional_friction > 0 and mat.rolling_resistance == 0:
                return (f"torsional friction without rolling resistance for {a.name}/{b.name}: Bullet's maximal-"
                        "coordinate solver adds the spinning row only where the pair's rollingFriction is > 0")
        return None


def _solver_parameters(scene: Scene, settings: Settings, maximal: bool, hooke: bool,
                       warm_starting_factor: float = PYBULLET_WARM_STARTING_FACTOR) -> dict:
    """setPhysicsEngineParameter arguments, by path (see the module notes)."""
    common = dict(
        fixedTimeStep=settings.dt,
        numSubSteps=0,
        numSolverIterations=settings.iterations or DEFAULT_ITERATIONS,
        restitutionVelocityThreshold=0.0,  # default 0.2 m/s: slower impacts lose all bounce
        contactSlop=0.0,                    # default 1e-5 m of tolerated overlap
        frictionERP=FRICTION_ERP,
        solverResidualThreshold=RESIDUAL,  # so numSolverIterations is an upper bound
        warmStartingFactor=warm_starting_factor,  # maximal-coordinate contacts only
    )
    if maximal and hooke:
        # split impulse would carry the spring's term (erp 1) as a position-only push-out
        # and the contact would never act on the velocities (module notes)
        return {**common, "useSplitImpulse": 0, "contactERP": CONTACT_ERP}
    if maximal:
        # split impulse: the push-out changes positions only, never the velocity that
        # restitution and the next step see
        return {**common, "useSplitImpulse": 1, "splitImpulsePenetrationThreshold": 0.0,
                "contactERP": CONTACT_ERP}
    # multibody: no split impulse; with restitution the push-out would add bounce, so it
    # is switched off (penetration then stays until the bodies separate)
    bouncy = "restitution" in scene.effects
    return {**common, "enableConeFriction": 1, "contactERP": 0.0 if bouncy else CONTACT_ERP}


def _hooke_stiffness(scene: Scene) -> dict[str, float] | None:
    """Per-body contactStiffness whose series combination 1/(1/k_a + 1/k_b) (Bullet's rule)
    gives each pair's Hooke k, i.e. compliances c = 1/k with c_a + c_b = 1/k_ab over every
    pair that may touch (the least-norm solution); None for a scene without Hooke contact."""
    pairs = scene.contact_pairs()
    laws = [scene.material_of(a.name, b.name).compliance for a, b in pairs]
    if not any(c is not None and c.law == "hooke" for c in laws):
        return None
    if any(c is None or c.law != "hooke" for c in laws):
        raise Unsupported("some pairs ask for Hooke contact and others not: every contact in the "
                          "world is then a spring (split impulse off, restitution 0), so rigid "
                          "pairs cannot share it")
    names = [b.name for b in scene.bodies]
    index = {n: i for i, n in enumerate(names)}
    A = np.zeros((len(pairs), len(names)))
    rhs = np.empty(len(pairs))
    for row, ((a, b), c) in enumerate(zip(pairs, laws)):
        A[row, index[a.name]] = A[row, index[b.name]] = 1.0
        rhs[row] = 1.0 / c.k
    compliance = np.linalg.lstsq(A, rhs, rcond=None)[0]
    if not (np.all(compliance > 0) and np.allclose(A @ compliance, rhs, rtol=1e-12, atol=0.0)):
        raise Unsupported("the pairs' Hooke stiffnesses cannot be split into per-body contactStiffness "
                          "values under Bullet's series rule 1/(1/k_a + 1/k_b)")
    return {n: 1.0 / c for n, c in zip(names, compliance)}


def _contact_processing_threshold(scene: Scene) -> float:
    """Whether the solver sees speculative points (up to ~3.5 mm apart) or only touching
    ones (0). A speculative point holds the gap closing speed to gap/dt, which makes a
    resting contact exact and an inelastic impact stop at the surface, but takes gap/dt
    off every bounce (up to all of it, depending on the contact phase). So they go only
    when restitution matters; without them a resting box chatters in and out of contact
    (creep 0.1-0.35 mm/s below the friction limit, rocking on a frictionless plane)."""
    return 0.0 if "restitution" in scene.effects or scene.contact_laws else EVERY_POINT


def _material_values(scene: Scene) -> tuple[dict[str, float], dict[str, float]]:
    """Per-body lateralFriction and restitution whose products give each pair's values;
    0 everywhere for an effect the scene does not call for. A compliant scene's bounce is
    its spring's: restitution 0 (a coefficient would add -e v_n to the spring's target)."""
    names = [b.name for b in scene.bodies]

    def values(effect, value_of, what):
        if effect not in scene.effects:
            return {n: 0.0 for n in names}
        return per_body_values(scene, value_of, "product", what)

    friction = values("friction", lambda m: m.mu_s, "friction")
    if scene.contact_laws:
        restitution = {n: 0.0 for n in names}
    else:
        restitution = values("restitution", lambda m: m.e, "restitution")
    return friction, restitution


# Contact torques (cases.scene.Material.rolling_resistance, torsional_friction). Bullet's
# rollingFriction and spinningFriction are lengths: both solvers bound the torque impulse
# of the rolling rows (about the two tangent directions) and of the spinning row (about
# the normal) by the pair's combined value times the normal impulse. A pair combines them
# with the partner's lateralFriction, r_a mu_b + r_b mu_a, clamped to 10
# (btManifoldResult::calculateCombinedRollingFriction / -SpinningFriction); the adapter
# undoes that rule as it undoes the product rule of lateralFriction (`_torque_values`).
TORQUE_KNOBS = {"rolling_resistance": "rollingFriction", "torsional_friction": "spinningFriction"}


def _torque_values(scene: Scene, friction: dict[str, float], effect: str) -> dict[str, float]:
    """Per-body values r (rollingFriction or spinningFriction) with r_a mu_b + r_b mu_a equal
    to each touching pair's lever arm, mu the bodies' lateralFriction: static bodies 0 if
    the dynamic ones can carry every pair, else every body; 0 everywhere when the scene does
    not ask for the torque. Unsupported when no non-negative r fits (a torque on a
    frictionless pair: Bullet multiplies it by the partner's friction)."""
    names = [b.name for b in scene.bodies]
    if effect not in scene.effects:
        return {n: 0.0 for n in names}
    pairs = [(a.name, b.name, scene.material_of(a.name, b.name).torque(effect)) for a, b in scene.contact_pairs()]
    for free in ([b.name for b in scene.bodies if b.dynamic], names):
        A = np.zeros((len(pairs), len(free)))
        for row, (a, b, _) in enumerate(pairs):
            for name, partner in ((a, b), (b, a)):
                if name in free:
                    A[row, free.index(name)] += friction[partner]
        target = np.array([d for _, _, d in pairs])
        r = np.linalg.lstsq(A, target, rcond=None)[0]
        if np.allclose(A @ r, target, rtol=1e-12, atol=1e-15) and np.all(r >= 0.0) and np.all(target <= 10.0):
            return {n: float(r[free.index(n)]) if n in free else 0.0 for n in names}
    raise Unsupported(f"the scene's pair {effect.replace('_', ' ')} values cannot be expressed as per-body "
                      f"{TORQUE_KNOBS[effect]} under Bullet's rule r_a mu_b + r_b mu_a (with its lateralFriction)")


def _collision_shape(body: Body, client: int, ground: str = "plane",
                     frame: tuple[list, list] | None = None) -> tuple[int, dict]:
    """The engine shape of a body and the record of how it was made. Capsules and
    cylinders are pybullet's btCapsuleShapeZ and btCylinderShapeZ, whose axis is the body's
    z, as the scene's; `height` is the length of the cylindrical part (2 half_length). A
    hull, a 2D polygon and a static mesh are GEOM_MESH shapes: from vertices alone a
    btConvexHullShape of the corners, with indices a btBvhTriangleMeshShape (double-sided:
    a triangle is met from either side), each inside a btCompoundShape (`_mesh_shape`).
    `frame` (position, xyzw orientation): the body's frame in the frame of the link that
    holds the shape (a jointed body's link frame is the joint's, `_add_tree`); None:
    the two coincide."""
    at = {} if frame is None else {"collisionFramePosition": list(frame[0]),
                                   "collisionFrameOrientation": list(frame[1])}
    s = body.shape
    if s.kind == "plane" and ground == "box":
        half, _, _ = _ground_box(s)
        kw = dict(shapeType=p.GEOM_BOX, halfExtents=half, **at)
    elif s.kind == "sphere":
        kw = dict(shapeType=p.GEOM_SPHERE, radius=s.radius, **at)
    elif s.kind == "box":
        kw = dict(shapeType=p.GEOM_BOX, halfExtents=list(s.half_extents), **at)
    elif s.kind == "plane":
        kw = dict(shapeType=p.GEOM_PLANE, planeNormal=list(s.normal), **at)
    elif s.kind == "circle":  # a cylinder along y; its depth only spreads the contact points
        turn = Z_TO_Y if frame is None else list(p.multiplyTransforms([0, 0, 0], frame[1], [0, 0, 0], Z_TO_Y)[1])
        kw = dict(shapeType=p.GEOM_CYLINDER, radius=s.radius, height=2 * s.radius,
                  **{**at, "collisionFrameOrientation": turn})
    elif s.kind == "rect":  # a box as deep along y as its larger half-extent
        a, c = s.half_extents
        kw = dict(shapeType=p.GEOM_BOX, halfExtents=[a, max(a, c), c], **at)
    elif s.kind == "capsule":  # its margin is its radius: nothing to clear
        kw = dict(shapeType=p.GEOM_CAPSULE, radius=s.radius, height=2.0 * s.half_length, **at)
    elif s.kind == "cylinder":
        kw = dict(shapeType=p.GEOM_CYLINDER, radius=s.radius, height=2.0 * s.half_length, **at)
        return _no_margin(client, p.createCollisionShape(physicsClientId=client, **kw),
                          {**kw, "shapeType": "GEOM_CYLINDER"})
    elif s.kind == "hull":
        return _mesh_shape(client, s.vertices, what=f"{len(s.vertices)} corners of the scene's hull, body frame", at=at)
    elif s.kind == "polygon":  # a prism as deep along y as its larger half-extent, as a rect
        half_depth = float(np.ptp(s.corners, axis=0).max()) / 2.0
        what = f"{len(s.corners)} corners of the scene's polygon at y = -+{half_depth:g} m, body frame"
        return _mesh_shape(client, polygon_prism(s.corners, half_depth)[0], what=what, at=at)
    else:  # mesh
        return _mesh_shape(client, s.vertices, s.triangles,
                           what=f"{len(s.vertices)} vertices of the scene's mesh, body frame", at=at)
    margin = s.radius if s.kind in ("sphere", "capsule") else PYBULLET_DEFAULT_MARGIN
    record = {**kw, "shapeType": GEOM_NAMES[kw["shapeType"]], "collisionMargin (pybullet's own)": margin}
    return p.createCollisionShape(physicsClientId=client, **kw), record


def _mesh_shape(client: int, vertices, triangles=None, what: str = "", at: dict | None = None) -> tuple[int, dict]:
    """A GEOM_MESH shape of `vertices` (a convex hull) or of `triangles` over them (a static
    triangle mesh), at meshScale 1, without collision margin (`_no_margin`).
    GEOM_CONCAVE_INTERNAL_EDGE is not set: pybullet would build the edge table but adjusts
    contacts by it only on bodies with CF_CUSTOM_MATERIAL_CALLBACK, which it never sets, so
    seams between triangles give their own contacts, as in Bullet."""
    kw = dict(shapeType=p.GEOM_MESH, vertices=[[float(c) for c in v] for v in vertices], meshScale=[1.0, 1.0, 1.0],
              **(at or {}))
    record = {"shapeType": "GEOM_MESH", "vertices": what, "meshScale": [1.0, 1.0, 1.0], **(at or {})}
    if triangles is None:
        record["engine shape"] = "btConvexHullShape of the vertices, in a btCompoundShape"
    else:
        kw["indices"] = [int(i) for t in triangles for i in t]
        record.update(indices=f"{len(triangles)} triangles of the scene's mesh", flags=0,
                      **{"engine shape": "btBvhTriangleMeshShape, in a btCompoundShape"})
    return _no_margin(client, p.createCollisionShape(physicsClientId=client, **kw), record)


def _no_margin(client: int, shape: int, record: dict) -> tuple[int, dict]:
    """`shape` with collision margin COLLISION_MARGIN on itself and, for the btCompoundShape
    pybullet wraps a GEOM_MESH in, on its children. changeDynamics' collisionMargin is the
    one way to set it, and it reaches a compound's children only on a multibody's base; on a
    link (a 2D body) it cannot be used at all: b3ChangeDynamicsInfoSetCollisionMargin resets
    the call's linkIndex to -1, so every value of that call goes to the base (measured: a 2D
    disc then bounces with e = 0). So the margin is cleared once on a throwaway base holding
    the shape: the shape keeps it whatever body then holds it."""
    holder = p.createMultiBody(0.0, shape, physicsClientId=client)
    p.changeDynamics(holder, -1, collisionMargin=COLLISION_MARGIN, physicsClientId=client)
    p.removeBody(holder, physicsClientId=client)
    return shape, {**record, "collisionMargin (the shape's and a compound's children's)": COLLISION_MARGIN}


def _planar_joints(body: Body) -> list[str]:
    """Joints that keep a 2D body in the x-z plane: slide along x and z, turn about y."""
    require_turn_about_y(body, "so it cannot turn about y only")
    return ["prismatic x", "prismatic z"] + (["revolute y"] if body.rotates else [])


def _ground_box(plane, scene=None) -> tuple[list, list, list]:
    """(half extents, position, orientation xyzw) of the static box whose top face is the
    plane n . x = offset: centred GROUND_HALF_THICKNESS below the plane's point nearest
    the origin (moved under the bodies where they are far from it: Plane.centre_under),
    its z axis along n."""
    n = np.asarray(plane.normal, float)
    centre = (plane.offset - GROUND_HALF_THICKNESS) * n
    if scene is not None:  # + 0 (bit for bit the same) for a scene near the origin
        centre = centre + (plane.centre_under(scene, GROUND_HALF_WIDTH) - plane.offset * n)
    return [GROUND_HALF_WIDTH, GROUND_HALF_WIDTH, GROUND_HALF_THICKNESS], list(centre), wxyz_to_xyzw(z_to(n))


# Idle DIRECT clients of this process, by what their world was set up with: the solver and
# the names setPhysicsEngineParameter was given (`_client_for`). A scene's world is made in a
# client of the same kind after p.resetSimulation, which deletes the world and makes it anew
# as p.connect does (measured: 0.5 ms of CPU against 3-4 ms for a connect and a disconnect,
# pybullet 3.2.7), and every parameter the build sets it sets again; the kind keeps a
# parameter this build does not name (the MLCP solver, split impulse off) from reaching it
# from another configuration's world. A planted change's client is not kept (`plant`).
_IDLE: dict[tuple, list[int]] = {}


def _client_for(kind: tuple) -> int:
    """An idle client of `kind` (a reset world), or a new one."""
    idle = _IDLE.get(kind)
    while idle:
        c = idle.pop()
        if p.isConnected(physicsClientId=c):
            return c
    return p.connect(p.DIRECT)


class PyBulletSimulation(Simulation):
    def __init__(self, scene: Scene, settings: Settings, bodies: str = "auto", friction_anchor: bool = True,
                 ground: str = "plane", solver: str = "si", ccd: bool = False):
        self._client = None
        self._kind = None  # what the client's world was set up with (_IDLE); None: not to be kept
        self._solver = solver
        self._ccd = ccd
        self._rigid = bodies == "rigid"
        self._anchor = friction_anchor
        self._ground = ground
        try:
            self._build(scene, settings)
        except BaseException:
            self.close()
            raise

    # --- building -----------------------------------------------------------------------

    def _build(self, scene: Scene, settings: Settings) -> None:
        # a scene with joints or loads is all multibody: its contacts on a jointed link are the
        # multibody solver's, which has no split impulse, so the maximal path's settings
        # would push out through the velocity there (contactERP) and add bounce
        self._maximal = self._rigid or ("friction" not in scene.effects and scene.dimension == 3 and not scene.joints
                                        and "load" not in scene.effects)  # MAXIMAL_FIRST_STEP_INERTIA
        self._planar = scene.dimension == 2
        self._stiffness = _hooke_stiffness(scene)
        warm = WARM_STARTING_FACTOR if self._rigid else PYBULLET_WARM_STARTING_FACTOR
        engine = _solver_parameters(scene, settings, self._maximal, self._stiffness is not None, warm)
        kind = (self._solver, tuple(sorted(engine)))
        c = self._client = _client_for(kind)
        self._kind = kind
        if self._solver != "si":  # the switch prints two lines from C on stdout
            with _silenced(1):
                p.setPhysicsEngineParameter(constraintSolverType=SOLVERS[self._solver], physicsClientId=c)
        p.setPhysicsEngineParameter(physicsClientId=c, **engine)
        p.setGravity(*scene.gravity, physicsClientId=c)
        self._threshold = _contact_processing_threshold(scene)
        friction, restitution = _material_values(scene)
        self._frictional = "friction" in scene.effects
        self._torques = {knob: _torque_values(scene, friction, effect) for effect, knob in TORQUE_KNOBS.items()}

        self.iterations = engine["numSolverIterations"]
        self.knobs = {
            "setPhysicsEngineParameter": engine,
            "setGravity": list(scene.gravity),
            "useMaximalCoordinates": self._maximal,
            "body_model": "rigid (maximal coordinates, every scene)" if self._rigid else "auto",
            "ground": self._ground,
            "constraintSolverType": f"CONSTRAINT_SOLVER_LCP_{self._solver.upper()}",
            "ccd": (f"ccdSweptSphereRadius {SWEPT_SPHERE_FRACTION:g} x the inscribed radius of every dynamic body "
                    "(ccdMotionThreshold the same, pybullet's pairing)") if self._ccd else "off (ccdSweptSphereRadius 0)",
            "bodies": {},
        }
        self._tree, closing = joint_tree(scene)
        self._dry: list[str] = []  # the bodies whose scene joint has a dry friction (its motor holds speed 0)
        self._ids: dict[tuple[int, int], str] = {}  # (body unique id, link index) -> name
        self._dynamic: list[tuple[str, int, int]] = []  # (name, body id, link index or -1)
        # one multibody per connected jointed group: its root and the bodies hanging on it
        groups: dict[str, list[str]] = {}
        for name, tj in self._tree.items():  # parents first
            groups.setdefault(self._root_of(name), []).append(name)
        for body in scene.bodies:
            if body.name in self._tree and self._tree[body.name].parent is not None:
                continue  # built with its group's root
            if body.name in groups or body.name in self._tree:
                members = [n for n in groups.get(body.name, []) if n != body.name]
                self._add_tree(body, members, scene, friction, restitution)
            else:
                self.knobs["bodies"][body.name] = self._add_body(body, scene, friction[body.name],
                                                                 restitution[body.name])
        self._separate_joined(scene, closing)
        # the scene's constant loads: pybullet clears external forces after each step, so
        # step() applies them again before each, the force at the body's centre of mass
        where = {name: (uid, link) for name, uid, link in self._dynamic}
        self._loads = [(*where[load.body], list(load.force), list(load.torque)) for load in scene.loads if load.acts]
        if self._loads:
            self.knobs["loads"] = {load.body: {"applyExternalForce": list(load.force), "posObj": "centre of mass",
                                               "applyExternalTorque": list(load.torque), "flags": "WORLD_FRAME",
                                               "when": "before each stepSimulation"}
                                   for load in scene.loads if load.acts}
        self.effects = self._built_effects(scene, friction, restitution)

    def _root_of(self, name: str) -> str:
        while name in self._tree and self._tree[name].parent is not None:
            name = self._tree[name].parent
        return name

    def _add_body(self, body: Body, scene: Scene, mu: float, e: float) -> dict:
        dimension = scene.dimension
        c = self._client
        shape, shape_record = _collision_shape(body, c, self._ground)
        position, orientation = list(body.position), wxyz_to_xyzw(body.orientation)
        if body.shape.kind == "plane" and self._ground == "box":
            _, position, orientation = _ground_box(body.shape, scene)
        elif body.shape.kind == "plane":  # n.x = offset in the world frame: through offset*n
            position = [body.shape.offset * n for n in body.shape.normal]
            orientation = [0.0, 0.0, 0.0, 1.0]
        record = {"createCollisionShape": shape_record}
        if dimension == 2 and body.dynamic:
            uid, link, record["createMultiBody"] = self._planar_body(body, shape)
        else:
            mass = 0.0 if body.static else body.mass
            if self._maximal and body.dynamic and not body.rotates:
                # btRigidBody caches its world inverse inertia from the creation mass and
                # refreshes it only after the first step; created this heavy, that cache is
                # ~1e-31 and the first step cannot spin a body whose rotation is locked
                mass = LOCK_CREATION_MASS
            uid = p.createMultiBody(mass, shape, basePosition=position, baseOrientation=orientation,
                                    useMaximalCoordinates=self._maximal, physicsClientId=c)
            link = -1
            record["createMultiBody"] = {"baseMass": mass, "useMaximalCoordinates": self._maximal}
            if body.dynamic:
                omega = body.angular_velocity if body.rotates else (0.0, 0.0, 0.0)
                p.resetBaseVelocity(uid, list(body.velocity), list(omega), physicsClientId=c)
        record["changeDynamics"] = self._set_dynamics(body, uid, link, mu, e)
        self._ids[(uid, link)] = body.name
        if body.dynamic:
            self._dynamic.append((body.name, uid, link))
        return record

    def _planar_body(self, body: Body, shape: int) -> tuple[int, int, dict]:
        """A fixed, shapeless base at the start position and a chain of massless links
        sliding along x and z and turning about y (if the body rotates); the last link is
        the body. Joint axes are given in each link's own frame."""
        c = self._client
        joints = _planar_joints(body)
        n = len(joints)
        # the last link's frame is the body's; the others are world-aligned
        R = np.reshape(p.getMatrixFromQuaternion(wxyz_to_xyzw(body.orientation)), (3, 3))
        axes = [list(AXES[j[-1]]) for j in joints]
        axes[-1] = list(R.T @ np.array(AXES[joints[-1][-1]]))
        types = [p.JOINT_PRISMATIC if j.startswith("prismatic") else p.JOINT_REVOLUTE for j in joints]
        masses = [0.0] * (n - 1) + [body.mass]
        uid = p.createMultiBody(
            0.0, -1, basePosition=list(body.position),
            linkMasses=masses,
            linkCollisionShapeIndices=[-1] * (n - 1) + [shape],
            linkVisualShapeIndices=[-1] * n,
            linkPositions=[[0.0, 0.0, 0.0]] * n,
            linkOrientations=[[0.0, 0.0, 0.0, 1.0]] * (n - 1) + [wxyz_to_xyzw(body.orientation)],
            linkInertialFramePositions=[[0.0, 0.0, 0.0]] * n,
            linkInertialFrameOrientations=[[0.0, 0.0, 0.0, 1.0]] * n,
            linkParentIndices=list(range(n)),
            linkJointTypes=types, linkJointAxis=axes, physicsClientId=c)
        start = {"prismatic x": body.velocity[0], "prismatic z": body.velocity[2],
                 "revolute y": body.angular_velocity[1]}
        for j, joint in enumerate(joints):
            # createMultiBody gives every joint a velocity motor: release it
            p.setJointMotorControl2(uid, j, p.VELOCITY_CONTROL, force=0.0, physicsClientId=c)
            p.resetJointState(uid, j, 0.0, start[joint], physicsClientId=c)
        record = {"baseMass": 0.0, "linkMasses": masses, "useMaximalCoordinates": False,
                  "linkJointTypes": ["JOINT_PRISMATIC" if t == p.JOINT_PRISMATIC else "JOINT_REVOLUTE"
                                     for t in types],
                  "linkJointAxis": axes,
                  "setJointMotorControl2": {"controlMode": "VELOCITY_CONTROL", "force": 0.0}}
        return uid, n - 1, record

    def _add_tree(self, root: Body, members: list[str], scene: Scene, friction: dict, restitution: dict) -> None:
        """One multibody of a connected jointed group (Featherstone's reduced coordinates,
        whatever the scene's friction): its base is the root's anchor (a fixed, shapeless
        base, the root the first link on its scene joint), or the root itself, free (3D: a
        base of the root's mass; 2D: the last link of `_planar_body`'s chain). Each other
        body is a link on its scene joint to its parent's link: a link's frame is its joint's
        (world-aligned at the anchor at the start; a multibody joint turns about its link
        frame's origin, its axis the scene's), its inertial frame the body's centre and
        axes, its shape made in that frame (`_collision_shape`), so every joint coordinate
        is 0 at the start; the joint's rate is the bodies' start velocities' (start_rate),
        its motor released (force 0).
        Not a body welded (JOINT_FIXED) to a massless link on the joint, which holds the
        same motion: pybullet 3.2.7 solves no contact between such a welded link and a static
        body (a hinged rod fell through a fixed ball, getContactPoints reporting the overlap
        with normal force 0; the same link on a prismatic joint, or on the hinge itself, is
        stopped; tests/test_joints.py)."""
        c = self._client
        tree = self._tree
        chain = ([root.name] if root.name in tree else []) + members  # the bodies on scene joints, parents first
        link_of: dict[str, int] = {}
        frame_of: dict = {}  # a link's frame at the start: origin, rotation, its quaternion x-y-z-w
        links: list[dict] = []
        record: dict = {}
        if root.name in tree:  # a fixed base at the root's anchor
            base = {"baseMass": 0.0, "baseCollisionShapeIndex": -1, "basePosition": list(tree[root.name].joint.anchor)}
            frame_of[None] = (np.asarray(tree[root.name].joint.anchor, float), np.eye(3), [0.0, 0.0, 0.0, 1.0])
            first = 0
        elif scene.dimension == 2:  # the planar chain's links, the root the last
            joints = _planar_joints(root)
            R = np.reshape(p.getMatrixFromQuaternion(wxyz_to_xyzw(root.orientation)), (3, 3))
            shape, record["createCollisionShape"] = _collision_shape(root, c, self._ground)
            base = {"baseMass": 0.0, "baseCollisionShapeIndex": -1, "basePosition": list(root.position)}
            axes = [list(AXES[j[-1]]) for j in joints]
            axes[-1] = list(R.T @ np.array(AXES[joints[-1][-1]]))
            for k, j in enumerate(joints):
                last = k == len(joints) - 1
                links.append({"mass": root.mass if last else 0.0, "shape": shape if last else -1,
                              "position": [0.0, 0.0, 0.0],
                              "orientation": wxyz_to_xyzw(root.orientation) if last else [0.0, 0.0, 0.0, 1.0],
                              "inertial": [0.0, 0.0, 0.0], "inertial_turn": [0.0, 0.0, 0.0, 1.0], "parent": k,
                              "type": p.JOINT_PRISMATIC if j.startswith("prismatic") else p.JOINT_REVOLUTE,
                              "axis": axes[k], "planar": j})
            link_of[root.name] = len(joints) - 1
            frame_of[root.name] = (np.asarray(root.position, float), R, wxyz_to_xyzw(root.orientation))
            first = len(joints)
        elif root.rotates:  # the root is the free base
            R = np.reshape(p.getMatrixFromQuaternion(wxyz_to_xyzw(root.orientation)), (3, 3))
            shape, record["createCollisionShape"] = _collision_shape(root, c, self._ground)
            base = {"baseMass": root.mass, "baseCollisionShapeIndex": shape, "basePosition": list(root.position),
                    "baseOrientation": wxyz_to_xyzw(root.orientation)}
            link_of[root.name] = -1
            frame_of[root.name] = (np.asarray(root.position, float), R, wxyz_to_xyzw(root.orientation))
            first = 0
        else:
            raise Unsupported(f"{root.name!r} held from rotating (rotates=False) carries jointed bodies: not mapped "
                              "(its slides would need the multibody's frames)")
        shapes = {}
        for k, name in enumerate(chain):
            body, tj = scene.body(name), tree[name]
            anchor = np.asarray(tj.joint.anchor, float)
            offset = np.asarray(body.position, float) - anchor
            shapes[name] = _collision_shape(body, c, self._ground, (list(offset), wxyz_to_xyzw(body.orientation)))
            up = tj.parent if tj.parent is not None else None
            origin, R_L, q_L = frame_of[up]
            turn = [-q_L[0], -q_L[1], -q_L[2], q_L[3]]  # R_L^T: a world-aligned link frame at the start
            links.append({"mass": body.mass, "shape": shapes[name][0], "position": list(R_L.T @ (anchor - origin)),
                          "orientation": turn, "inertial": list(offset), "inertial_turn": wxyz_to_xyzw(body.orientation),
                          "parent": (link_of[up] + 1) if up is not None else 0,
                          "type": {"revolute": p.JOINT_REVOLUTE, "prismatic": p.JOINT_PRISMATIC,
                                   "ball": p.JOINT_SPHERICAL, "fixed": p.JOINT_FIXED}[tj.joint.kind],
                          "axis": list(tj.joint.unit_axis), "scene": tj})
            link_of[name] = first + k
            frame_of[name] = (anchor, np.eye(3), [0.0, 0.0, 0.0, 1.0])
        uid = p.createMultiBody(
            base["baseMass"], base["baseCollisionShapeIndex"], basePosition=base["basePosition"],
            baseOrientation=base.get("baseOrientation", [0.0, 0.0, 0.0, 1.0]),
            linkMasses=[k["mass"] for k in links], linkCollisionShapeIndices=[k["shape"] for k in links],
            linkVisualShapeIndices=[-1] * len(links), linkPositions=[k["position"] for k in links],
            linkOrientations=[k["orientation"] for k in links],
            linkInertialFramePositions=[k["inertial"] for k in links],
            linkInertialFrameOrientations=[k["inertial_turn"] for k in links],
            linkParentIndices=[k["parent"] for k in links], linkJointTypes=[k["type"] for k in links],
            linkJointAxis=[k["axis"] for k in links], useMaximalCoordinates=False, physicsClientId=c)
        names = {0: "JOINT_REVOLUTE", 1: "JOINT_PRISMATIC", 2: "JOINT_SPHERICAL", 4: "JOINT_FIXED"}
        record["createMultiBody"] = {**{k: v for k, v in base.items() if k != "baseCollisionShapeIndex"},
                                     "linkMasses": [k["mass"] for k in links],
                                     "linkJointTypes": [names.get(k["type"], k["type"]) for k in links],
                                     "linkJointAxis": [k["axis"] for k in links],
                                     "linkParentIndices": [k["parent"] for k in links],
                                     "linkPositions": [k["position"] for k in links],
                                     "linkInertialFramePositions": [k["inertial"] for k in links],
                                     "useMaximalCoordinates": False, "motor": "released (force 0)"}
        if link_of.get(root.name) == -1:  # the free base: the root's own velocity
            p.resetBaseVelocity(uid, list(root.velocity), list(root.angular_velocity), physicsClientId=c)
        for k, spec in enumerate(links):
            if spec["type"] == p.JOINT_SPHERICAL:
                p.setJointMotorControlMultiDof(uid, k, p.POSITION_CONTROL, targetPosition=[0, 0, 0, 1],
                                               positionGain=0, velocityGain=0, force=[0, 0, 0], physicsClientId=c)
            elif spec["type"] != p.JOINT_FIXED:
                # the default motor released (force 0), or, for a joint's dry friction, held at
                # speed 0 with its force bounded by the friction: a row whose impulse lies within
                # -+ friction dt, Coulomb's law with the scene's constant bound (cases.scene.Joint)
                dry = spec["scene"].joint.friction if "scene" in spec else 0.0
                p.setJointMotorControl2(uid, k, p.VELOCITY_CONTROL, targetVelocity=0.0, force=dry, physicsClientId=c)
                if dry > 0:
                    self._dry.append(spec["scene"].joint.body)
                    record.setdefault("joint friction", {})[spec["scene"].joint.body] = {
                        "setJointMotorControl2": {"controlMode": "VELOCITY_CONTROL", "targetVelocity": 0.0,
                                                  "force": dry}}
            if "planar" in spec:
                v, w = root.velocity, root.angular_velocity
                rate = {"prismatic x": v[0], "prismatic z": v[2], "revolute y": w[1]}[spec["planar"]]
                p.resetJointState(uid, k, 0.0, rate, physicsClientId=c)
            elif "scene" in spec:
                tj = spec["scene"]
                rate = start_rate(scene, tj)
                if tj.joint.kind == "ball" and any(rate):
                    raise Unsupported(f"joints[{tj.index}]: {tj.joint.body!r} starts turning on a ball joint: a "
                                      "spherical joint's start rate is not mapped")
                if tj.joint.kind in ("revolute", "prismatic"):
                    p.resetJointState(uid, k, 0.0, float(rate[0]), physicsClientId=c)
                if tj.joint.limits is not None:
                    p.changeDynamics(uid, k, jointLowerLimit=float(tj.joint.limits[0]),
                                     jointUpperLimit=float(tj.joint.limits[1]), physicsClientId=c)
                    record.setdefault("changeDynamics (limits)", {})[tj.joint.body] = {
                        "jointLowerLimit": tj.joint.limits[0], "jointUpperLimit": tj.joint.limits[1]}
        for name in [root.name] + members:
            body, link = scene.body(name), link_of[name]
            entry = {"multibody": root.name, "link": link} if name != root.name else dict(record)
            if name in shapes:
                entry["createCollisionShape"] = shapes[name][1]
            entry["changeDynamics"] = self._set_dynamics(body, uid, link, friction[name], restitution[name])
            self.knobs["bodies"][name] = entry
            self._ids[(uid, link)] = name
            self._dynamic.append((name, uid, link))

    def _separate_joined(self, scene: Scene, closing: list) -> None:
        """Bodies a joint connects do not collide (Scene.contact_pairs): a parent and its
        child link are not checked within a multibody; a pair in two multibodies (a joint to
        a static body, a loop's closing joint) gets setCollisionFilterPair 0. A joint that
        closes a loop is a JOINT_POINT2POINT constraint between the two links at its anchor
        (closing_ball_points: planar loops' hinges and ball joints)."""
        c = self._client
        where = {name: (uid, link) for (uid, link), name in self._ids.items()}
        for joint in scene.joints:
            if joint.parent is None:
                continue
            (ua, la), (ub, lb) = where[joint.body], where[joint.parent]
            if ua != ub:
                p.setCollisionFilterPair(ua, ub, la, lb, 0, physicsClientId=c)
                self.knobs.setdefault("setCollisionFilterPair 0", []).append([joint.body, joint.parent])
        for j, body, p_AP, parent, p_BQ in closing_ball_points(scene, closing, "pybullet's JOINT_POINT2POINT constraint"):
            ua, la = where[body]
            ub, lb = where[parent] if parent is not None else (-1, -1)
            cid = p.createConstraint(ua, la, ub, lb, p.JOINT_POINT2POINT, [0.0, 0.0, 0.0], list(p_AP), list(p_BQ),
                                     physicsClientId=c)
            p.changeConstraint(cid, maxForce=LOOP_MAX_FORCE, physicsClientId=c)
            self.knobs.setdefault("loop", {})[f"joints[{j}]"] = {
                "createConstraint": {"JOINT_POINT2POINT": [body, parent or "world"], "parentFramePosition": list(p_AP),
                                     "childFramePosition": list(p_BQ)}, "changeConstraint": {"maxForce": LOOP_MAX_FORCE}}

    def _set_dynamics(self, body: Body, uid: int, link: int, mu: float, e: float) -> list[dict]:
        """Two changeDynamics calls, recorded as made: the collider's own values, then the
        whole body's. They must not share a call: given with a link's mass, the
        body-wide ones also set the chain's fixed base to that mass and set it free."""
        collider = dict(lateralFriction=mu, restitution=e,
                        **{knob: values[body.name] for knob, values in self._torques.items()},
                        contactProcessingThreshold=self._threshold)
        if self._frictional or not self._maximal:
            # a box resting on an incline crept 0.1 mm/s; with the anchor, not at all
            collider["frictionAnchor"] = int(self._anchor)
        if self._stiffness is not None:
            # the pair's spring (series rule); damping 0 here and on the partner, whose
            # default 0.1 would otherwise add (module notes)
            collider.update(contactStiffness=self._stiffness[body.name], contactDamping=0.0)
        calls = [(link, collider)]
        if body.dynamic:
            # localInertiaDiagonal 0 is an infinite inertia (btRigidBody::setMassProps,
            # btMultiBody::solveImatrix): the exact lock for a body that does not rotate.
            # mass goes with it: pybullet's maximal path otherwise uses an unset mass.
            inertia = list(body.principal_inertia) if body.rotates else [0.0, 0.0, 0.0]
            collider.update(mass=body.mass, localInertiaDiagonal=inertia)
            whole = dict(linearDamping=0.0, angularDamping=0.0,  # default 0.04 each
                         activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING)
            if self._ccd:
                collider["ccdSweptSphereRadius"] = swept_sphere_radius(body)
            if not self._maximal:
                whole["maxJointVelocity"] = NO_VELOCITY_CLAMP
            calls.append((-1, whole))
            calls += [(j, {"jointDamping": 0.0}) for j in range(link + 1)]
        for index, kw in calls:
            p.changeDynamics(uid, index, physicsClientId=self._client, **kw)
        record = []
        for index, kw in calls:
            if "activationState" in kw:
                kw = {**kw, "activationState": "ACTIVATION_STATE_DISABLE_SLEEPING"}
            record.append({"linkIndex": index, **kw})
        return record

    def _built_effects(self, scene: Scene, friction: dict, restitution: dict) -> frozenset[str]:
        """What the built world simulates, read from the values given to the engine."""
        fx = set()
        if any(g != 0.0 for g in scene.gravity):
            fx.add("gravity")
        pairs = scene.contact_pairs()
        if pairs:
            fx.add("contact")
        if any(restitution[a.name] * restitution[b.name] > 0 for a, b in pairs):
            fx.add("restitution")
        if self._stiffness is not None and pairs:
            fx.add("restitution")  # an undamped spring gives the energy back: the bounce
        if any(friction[a.name] * friction[b.name] > 0 for a, b in pairs):
            fx.add("friction")
        for effect, knob in TORQUE_KNOBS.items():  # Bullet's combination of the values given
            r = self._torques[knob]
            if any(r[a.name] * friction[b.name] + r[b.name] * friction[a.name] > 0 for a, b in pairs):
                fx.add(effect)
        if any(b.rotates for b in scene.dynamic_bodies):
            fx.add("rotation")
        if self._tree:
            fx.add("joint")
        if any(tj.joint.limits is not None for tj in self._tree.values()):
            fx.add("limit")
        if self._dry:
            fx.add("joint_friction")
        if self._loads:
            fx.add("load")
        return frozenset(fx)

    # --- running ------------------------------------------------------------------------

    def step(self) -> None:
        c = self._client
        for uid, link, force, torque in self._loads:
            centre = (p.getBasePositionAndOrientation(uid, physicsClientId=c)[0] if link < 0
                      else p.getLinkState(uid, link, computeForwardKinematics=1, physicsClientId=c)[0])
            p.applyExternalForce(uid, link, force, centre, p.WORLD_FRAME, physicsClientId=c)
            p.applyExternalTorque(uid, link, torque, p.WORLD_FRAME, physicsClientId=c)
        p.stepSimulation(physicsClientId=c)

    def states(self) -> dict[str, np.ndarray]:
        c = self._client
        out = {}
        for name, uid, link in self._dynamic:
            if link < 0:
                pos, quat = p.getBasePositionAndOrientation(uid, physicsClientId=c)
                vel, omega = p.getBaseVelocity(uid, physicsClientId=c)  # both world frame
            else:
                s = p.getLinkState(uid, link, computeLinkVelocity=1, computeForwardKinematics=1,
                                   physicsClientId=c)
                pos, quat, vel, omega = s[0], s[1], s[6], s[7]  # centre of mass, world frame
            out[name] = state_row(pos, xyzw_to_wxyz(quat), vel, omega)
        return out

    # Bulk reads (adapters.base): per body Bullet's own position, quaternion x-y-z-w,
    # velocity and world angular velocity, copied as they come; reordered when decoded.
    def body_order(self) -> list[str]:
        return [name for name, _, _ in self._dynamic]

    def write_state(self, out: np.ndarray) -> None:
        c, i = self._client, 0
        for name, uid, link in self._dynamic:
            if link < 0:
                pos, quat = p.getBasePositionAndOrientation(uid, physicsClientId=c)
                vel, omega = p.getBaseVelocity(uid, physicsClientId=c)
                out[i:i + 13] = pos + quat + vel + omega
            else:
                s = p.getLinkState(uid, link, computeLinkVelocity=1, computeForwardKinematics=1, physicsClientId=c)
                out[i:i + 13] = s[0] + s[1] + s[6] + s[7]
            i += 13

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        out = raw.reshape(len(raw), -1, 13).copy()
        out[:, :, 3:7] = out[:, :, [6, 3, 4, 5]]  # x-y-z-w -> w-x-y-z
        return out

    def _solved_points(self):
        """(a, b, row) for each getContactPoints row the solver processed this step: both
        bodies are the scene's and distance <= contactProcessingThreshold. The others keep
        a stale impulse from an earlier step (convertContact of btSequentialImpulse-
        ConstraintSolver skips them untouched; btMultiBodyConstraintSolver::
        convertMultiBodyContact zeroes their normal impulse, never the lateral ones).
        Points at a small positive distance do count on the speculative path: a resting box
        there carries half its weight on a point 0.2 um above the plane."""
        for row in p.getContactPoints(physicsClientId=self._client):
            a = self._ids.get((row[1], row[3]))
            b = self._ids.get((row[2], row[4]))
            if a is not None and b is not None and row[8] <= self._threshold:
                yield a, b, row

    def contact_forces(self) -> dict[tuple[str, str], float]:
        """Sum of normalForce over each pair's solved points (_solved_points)."""
        forces: dict[tuple[str, str], float] = {}
        for a, b, row in self._solved_points():
            key = pair_key(a, b)
            forces[key] = forces.get(key, 0.0) + row[9]
        return forces

    def contact_points(self) -> list[ContactPoint]:
        """One ContactPoint per solved manifold point (_solved_points), Bullet's body A as a.

        Conventions (bullet3 examples/SharedMemory/PhysicsServerCommandProcessor.cpp,
        CONTACT_QUERY_MODE_REPORT_EXISTING_CONTACT_POINTS, no body filter so no swap): row 7
        is the manifold point's m_normalWorldOnB, which points from B into A; row 9 is
        getAppliedImpulse() / fixedTimeStep, rows 10/12 m_appliedImpulseLateral1/2 /
        fixedTimeStep along rows 11/13, m_lateralFrictionDir1/2. Both solvers apply a
        positive row impulse along its axis to A and against it to B
        (btSequentialImpulseConstraintSolver: m_contactNormal1 = axis, m_contactNormal2 =
        -axis; btMultiBodyConstraintSolver::setupMultiBodyContactConstraint: Jacobian of
        link A along +axis, of link B along -axis), so the contract's n, f_n and f_t are
        the engine's own, unchanged. Checked on a box sliding at 30 deg, mu 0.5, on both
        body models: f_t sums to -0.5 f_n along the slip. (With a body-A filter that swaps
        the pair, pybullet negates the normal but not the friction directions: this reads
        unfiltered.) x is positionOnA, where the solver applies the impulse to A (its
        Jacobian point; I dw/dt of a sliding box matches the torques about it to 1e-15 N m);
        B takes it at positionOnB, which on a persistent point of a sliding pair lies up to
        the contact breaking threshold away sideways (3.5 mm measured). gap is the distance
        collision detection gave the solver. btMultiBodyDynamicsWorld turns on
        SOLVER_USE_2_FRICTION_DIRECTIONS, so both lateral rows are this step's on both
        paths. 2D scenes: the y components (the extruded shapes' depth, friction the
        planar joints take up) are dropped."""
        solved = list(self._solved_points())
        if not solved:
            return []
        # one array for all points (numpy calls per point cost 14 us a point); columns:
        # positionOnA 0:3, normal 3:6, friction directions 6:9 and 9:12, distance 12,
        # normalForce 13, lateralFriction1 14, lateralFriction2 15
        flat = chain.from_iterable(r[5] + r[7] + r[11] + r[13] + (r[8], r[9], r[10], r[12])
                                   for _, _, r in solved)
        rows = np.fromiter(flat, float, 16 * len(solved)).reshape(-1, 16)
        x = rows[:, 0:3]
        n = rows[:, 3:6]
        f_t = rows[:, 14:15] * rows[:, 6:9] + rows[:, 15:16] * rows[:, 9:12]
        if self._planar:
            x[:, 1] = n[:, 1] = f_t[:, 1] = 0.0
            n = n / np.linalg.norm(n, axis=1, keepdims=True)
        f_n, gap = rows[:, 13].tolist(), rows[:, 12].tolist()
        return [ContactPoint(a, b, xi, ni, fni, fti, gi)
                for (a, b, _), xi, ni, fni, fti, gi in zip(solved, list(x), list(n), f_n, list(f_t), gap)]

    def close(self) -> None:
        """The client's world reset and kept for the next scene of its kind (_IDLE), or
        disconnected (a planted change's)."""
        if self._client is not None:
            if p.isConnected(physicsClientId=self._client):
                if self._kind is not None:
                    p.resetSimulation(physicsClientId=self._client)
                    _IDLE.setdefault(self._kind, []).append(self._client)
                else:
                    p.disconnect(physicsClientId=self._client)
            self._client = None

    # --- planted faults (adapters/planting.py) ------------------------------------------

    def plant(self, change: str, size: float | None = None) -> Simulation:
        """PyBullet's planted changes (PyBulletAdapter.plantable), each a Bullet default the
        adapter switches off, set back: "square friction cone" is enableConeFriction = 0
        (Bullet's pair of independent friction rows); "velocity damping" is linearDamping =
        angularDamping = `size` on every dynamic body (Bullet's default 0.04; it scales
        velocities by (1 - c)^dt each step); "restitution threshold" is
        restitutionVelocityThreshold = `size` (Bullet's default 0.2 m/s). The client is
        then not kept for another scene (close disconnects it)."""
        c, self._kind = self._client, None
        if change == "square friction cone":
            p.setPhysicsEngineParameter(enableConeFriction=0, physicsClientId=c)
        elif change == "velocity damping":
            for _, uid, _ in self._dynamic:
                p.changeDynamics(uid, -1, linearDamping=size, angularDamping=size, physicsClientId=c)
        elif change == "restitution threshold":
            p.setPhysicsEngineParameter(restitutionVelocityThreshold=size, physicsClientId=c)
        else:
            return super().plant(change, size)
        return self
