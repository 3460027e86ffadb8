"""Rapier (rapier3d Python bindings, 3D, float32) behind the engine contract.

One `rapier3d.PhysicsWorld` per built scene. 2D scenes are embedded in the x-z plane as
for the other 3D engines: every dynamic body has its rotations about x and z locked
(`LockedAxes`), a disc is a cylinder along y, a rectangle a box as deep along y as its
larger half-extent (the depth only spreads the contact points, symmetrically about y = 0).
The y translation is locked only in frictionless scenes: with it and two rotations locked
Rapier applies no friction at all (measured with 0.36.1: a box sliding at 1 m/s with
mu = 0.5 keeps its speed whenever a translation and two rotations are locked; any one lock
alone, or the rotations alone, decelerate it at mu g). Nothing in a 2D scene pushes along
y, so a free y stays 0 up to the contact manifolds' float32 noise: below 4e-7 m in every
frictional 2D scene of the library, but 1.9e-4 m in the frictionless cradle between walls
(where the lock then costs nothing).

Gyroscopic forces are switched on (omega x I omega, the free-body physics) except for
bodies whose three principal moments are equal (spheres, and every 2D body, which turns
about one principal axis only): for them the term is exactly zero, and Rapier's implicit
gyroscopic step is not -- it spins a free ball up from 3 to 3.0017 rad/s in 2 s (measured).
Moments equal to EQUAL_MOMENTS count as equal: a cube given as a Hull has moments that
differ in the last bit (its mass-property integral), a term |omega|^2 dI of round-off, and
with the implicit step on it tumbled differently from the Box (measured: its spin drifted
3e-5 rad/s in 60 steps of free flight, the Box's not at all).

Shapes. A capsule is Rapier's capsule along z; a cylinder Rapier's cylinder (its axis y)
turned onto body z (CYLINDER_TURN); a hull a convex polyhedron made from its corners and the
faces of their hull (`_convex_mesh`); a 2D polygon the same of its prism along y
(adapters/solids.py); a static mesh a trimesh of its vertices and triangles with ghost-edge
fixing (TRIMESH_FLAGS). No shape is rounded and no collider has a contact skin (0).

Float32. Rapier computes in single precision: positions, velocities, masses and material
values are rounded to 2^-24 relative (6e-8); a body at 10 m is placed to 1e-6 m. Checks
tighter than that measure the float, not the physics. Where it bites on shapes: a hull's or
a mesh's corners are rounded to 6e-8 of their distance from the body origin (a mesh ground
10 km wide places its far corners to 0.24 mm, half the float32 spacing at 5 km); Rapier's own
convex hull flattens plates thinner than 8.5e-4 of their size, which is why hulls are built
from their faces (`_convex_mesh`: a 1 m plate 1e-5 m thick keeps its corners and rests at
its half thickness; tests/test_box2d_rapier_mapping.py).

What one `world.step()` does (rapier 0.35-0.36, src/dynamics/solver): contacts are found
for the whole step, with speculative points up to `prediction_distance` apart; then
`num_solver_iterations` sub-steps of h = dt / n, each: gravity, warm start, one Gauss-Seidel
sweep of the soft contact constraint whose bias pushes overlap out (a spring of natural
frequency f and damping ratio zeta, capped at `max_corrective_velocity`), positions move,
one sweep without the bias; after the sub-steps, restitution once per contact point
(target -e times the normal velocity when the constraint was built). Restitution acts only
where the point took no impulse in the step before (a "new" contact), except at e >= 1
(src/geometry/contact_pair.rs, is_bouncy): a contact that persists is resting. So
`Settings.iterations` is the sub-step count n.

Impacts (`Capabilities.impact_model` "simultaneous"): all contacts of a step are solved
together and restitution targets each contact's own approach speed. Measured at dt = 1e-3,
e = 1: two touching balls dropped on the ground leave it together (0.997 and 0.984 of the
impact speed 5 steps later; the reference's simultaneous model: 0.984 both); a striker at
1 m/s into three touching balls rebounds at -0.125 m/s (sequential impacts would stop it).
At e = 0.5 the dropped pair does not leave together at 0.5 (0 and 0.34 of the impact speed).

Soft contact. Rapier's defaults (30 Hz, zeta = 10; 60 Hz against fixed bodies) let a
resting box sit g / (2 pi f)^2 deep and a five-box stack sink mm. A rigid contact has no
compliance, so the adapter asks for the stiffness Box2D caps its own soft contact at
(1/8 of the sub-step rate, twice that against fixed bodies): the same rigid limit on both
soft-step engines. `Settings.options` may set it (`tunables`).

Continuous collision ("rapier-ccd", `ccd=True`): Rapier's CCD (`ccd_enabled`) on each dynamic
body that starts out moving further in a step than its inscribed radius
(adapters.solids.starts_fast); the plain configuration has none (and no soft CCD). Measured
with 0.36.1 (cases/robustness/tunnelling.py, a 2 cm ball at 100 m/s at a free 1 cm plate):
without CCD the ball is stopped from 1.75 cm in front of the plate but passes it from 5 cm;
with CCD on the ball it is stopped from both, the rebound exact to float32; with CCD on the
ball and the plate it passes from 5 cm again, so only the fast body gets it. In a default
run the configuration takes the families tagged "swept" only (`default_tags`).

Pair materials. Each collider carries a friction and a restitution and a combination rule
for each; a pair takes the rule of higher priority (average < min < multiply < max). The
adapter gives every collider the same rule, chosen per quantity as the first of max, min,
multiply under which per-collider values reproduce every pair of the scene
(adapters.combination); a scene with none is `unsupported`.

Contact forces and points. Rapier reports per contact point its normal impulse over the
step (the sum over the sub-steps and the restitution pass) and two tangent impulses in a
basis the Python bindings do not expose: `contact_forces` sums the normal impulses of each
pair / dt. The bindings (0.36.1) read every point of a trimesh pair's manifolds as 0 while
the pair's total_impulse (the sum of each manifold's normal times its impulses) is the
solver's: a pair with a mesh reports the magnitude of that sum / dt, the summed impulses
wherever its contacts share a normal (a body on a flat patch: its weight; measured).

`contact_points` gives the geometry of every point the solver had in the last step and not
its forces (`Capabilities.contact_geometry`; `contact_points` False, so the per-point force
readings leave Rapier out): f_n and f_t are NaN, since the tangent impulses' basis is not
exposed and, under the SIMPLIFIED friction model, friction is one constraint per manifold,
not per point. The points are each manifold's solver contacts (`ContactManifoldData
.solver_contacts`: those within `prediction_distance`, speculative ones included), made by
the narrow phase at the start of the step from the poses then: `point` the world point on
collider 1's surface (measured: two overlapping balls, collider 1 a fixed one off the
origin), `dist` the signed distance, and the manifold's world normal `normal` points from collider 1 into collider 2,
so the point's a is collider 2's body and b collider 1's (n from b into a). Float32: a point
is placed to 6e-8 of its distance from the origin. (`solver_contact_world_points` would move
the points with the bodies' poses after the step: not used.)
"""
from __future__ import annotations

import math
from importlib import metadata

import numpy as np
import rapier3d as r

FRICTION_MOTOR = 1e9  # the joint-friction motor's damping factor: far stiffer than the bound it is clamped to

from adapters.base import Adapter, Capabilities, Settings, Simulation, Tunable, Unsupported
from adapters.combination import RULES as COMBINE, per_body_values
from adapters.frames import require_turn_about_y, state_row
from adapters.solids import embedded_half_depth, polygon_prism, starts_fast
from cases.overlap import rotation_matrix
from cases.scene import Body, Box, Circle, Hull, Plane, Rect, Scene, Sphere, pair_key
from cases.trajectory import ContactPoint

DEFAULT_SUBSTEPS = 4  # Rapier's own default num_solver_iterations, stated
# Principal moments within this fraction of each other are equal (no gyroscopic term, module
# notes): float64 mass-property integrals agree with a closed form to 1e-15 or so, a body
# meant to be asymmetric differs far more.
EQUAL_MOMENTS = 1e-12
# The contact stiffness asked for, as a fraction of the sub-step rate (dynamic pairs; twice
# this against fixed bodies): Box2D's cap, see the module notes.
HERTZ_PER_SUBSTEP_RATE = 0.125
CONTACT_DAMPING_RATIO = 10.0  # Rapier's default: overdamped, the push-out never rings
MAX_CORRECTIVE_VELOCITY = 1.0  # m/s; Rapier's default is 3 (see box2d_engine.CONTACT_PUSH_SPEED)
# Rapier's default friction model (one friction constraint per contact manifold, plus a twist
# constraint). Its per-point COULOMB model decelerates a box sliding at 1 m/s (mu = 0.5) at
# 4.593 instead of 4.905 m/s^2 and turns it sideways; SIMPLIFIED gives 4.9049 (measured).
FRICTION_MODEL = r.FrictionModel.SIMPLIFIED
# A Cylinder's collider turned by this (w, x, y, z) about the body: +90 deg about x takes
# Rapier's cylinder axis y onto body z. The stated inertia is given in the collider's frame
# (Rapier moves a collider's mass properties by its pose on the body): (I_x, I_z, I_y).
CYLINDER_TURN = [math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0]
# A static Mesh is a trimesh with these flags (parry's TriMeshFlags): FIX_INTERNAL_EDGES marks
# the edges between triangles so a body sliding over a flat edge of two coplanar triangles
# meets no ghost contact on it (measured on a 20 x 20 grid mesh: without it a box sliding at
# 3.2 m/s with mu = 0.2 lost 0.85 m/s more than mu g in 0.5 s and a capsule hopped 37 mm;
# parry adds the ORIENTED and MERGE_DUPLICATE_VERTICES it needs). The triangles are wound as
# the scene gives them: counterclockwise seen from outside, parry's outward normal.
TRIMESH_FLAG_NAMES = ["FIX_INTERNAL_EDGES"]
TRIMESH_FLAGS = r.TriMeshFlags.FIX_INTERNAL_EDGES.bits
RULES = {"max": r.CoefficientCombineRule.MAX, "min": r.CoefficientCombineRule.MIN,
         "product": r.CoefficientCombineRule.MULTIPLY}
RULE_NAMES = {"max": "MAX", "min": "MIN", "product": "MULTIPLY"}


# How Rapier resolves an impact through bodies already touching (Capabilities.impact_model),
# measured (dt = 1e-3, no gravity, a 0.1 kg ball resting on a 1 kg one, both landing at 2 m/s,
# touching without overlap; tests/test_declared_models.py): neither model's closed form.
# Top and bottom ball leave at 3.497, 1.667 m/s (e = 1) and 0.925, 0.925 m/s (e = 0.5) in 3D,
# 3.815, 1.466 and 1.769, 0.671 in 2D. The simultaneous model gives both 2 (e = 1) and 1 m/s (e = 0.5), the sequential one
# 5.273, 1.273 and 2.091, 0.591 (cases/column_impact.py): restitution targets each contact's
# approach when its constraint is built and acts only on a new contact, so the touching pair
# takes (almost) no impulse in the landing step and is resolved later as an impact of its own. So it declares no impact model, and the
# column family's model variants are unsupported on it (its model-free ones still run).
IMPACT_MODEL_MEASURED = None


class RapierAdapter(Adapter):
    name = "rapier"
    package = "rapier3d"
    # the release the conformance battery ran on; the next major (minor for 0.x) may change the API
    supported = ">=0.36.1,<0.37"
    capabilities = Capabilities(
        dimensions=frozenset({2, 3}),
        shapes=frozenset({"sphere", "box", "plane", "circle", "rect", "capsule", "cylinder", "hull", "polygon",
                          "mesh"}),  # a hull: a convex mesh; a polygon: its prism along y; a mesh: a static trimesh
        native_restitution=True,
        static_kinetic=False,  # one friction coefficient per collider
        contact_forces=True,
        iterations=True,       # the sub-step count
        contact_points=False,  # tangent impulses come in a basis the bindings do not expose
        contact_geometry=True,  # each solver contact's point, normal and distance (module notes)
        impact_model=IMPACT_MODEL_MEASURED,  # neither model: see the note above the class
        restitution_law="two_phase",  # restitution in a pass of its own after the sub-steps, without friction
        float_bits=32,         # positions, velocities and masses in single precision (checked: 0.1 m/s reads back as float32(0.1))
        substeps=True,         # Settings.iterations is the sub-step count
        # impulse joints (_joint): constraint rows between the bodies' own coordinates, solved
        # in the sub-steps with the contacts (Rapier's multibody joints are not mapped)
        joints=frozenset({"revolute", "prismatic", "ball", "fixed"}),
        joint_limits=True,
        joint_friction=True,
        coordinates="maximal",
        loads=True,  # RigidBody.add_force / add_torque once: Rapier keeps user forces until reset
        why_not=(("limit_restitution", "a joint's limit takes a range only (Rapier's JointLimits: min, max): its "
                                       "limit rows have no restitution"),),
    )
    tunables = {
        "contact_natural_frequency": Tunable(
            1.0, math.inf, math.inf,
            "push-out stiffness of dynamic pairs, Hz (twice this against fixed bodies; default 1/8 of the sub-step rate)"),
        "contact_damping_ratio": Tunable(0.0, 100.0, CONTACT_DAMPING_RATIO, "push-out damping ratio"),
        "max_corrective_velocity": Tunable(0.0, 100.0, MAX_CORRECTIVE_VELOCITY, "largest push-out speed, m/s"),
    }

    def __init__(self, name: str = "rapier", ccd: bool = False):
        """ccd: Rapier's continuous collision detection on each fast dynamic body (ccd_enabled;
        "rapier-ccd", module notes)."""
        self.name = name
        self.ccd = self.continuous_collision(ccd)

    def version(self) -> str:
        return metadata.version("rapier3d")

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene)
        if reason:
            raise Unsupported(reason)
        return RapierSimulation(scene, settings, self.options_in_force(settings), self.ccd)


def combine_rule(scene: Scene, value_of, what: str) -> tuple[str, dict[str, float]]:
    """The first rule (max, min, product) under which per-collider values give every pair
    its value, and those values (Unsupported if no rule does)."""
    for rule in ("max", "min", "product"):
        try:
            return rule, per_body_values(scene, value_of, rule, what)
        except Unsupported:
            continue
    raise Unsupported(f"the scene's pair {what} values cannot be expressed as per-collider values under "
                      "any of Rapier's combination rules (max, min, multiply)")


def _collider(body: Body) -> tuple[r.ColliderBuilder, dict]:
    """The collider of a body, in the body's frame, and the record of how it was made."""
    s = body.shape
    if isinstance(s, Sphere):
        return r.Collider.ball(s.radius), {"ball": {"radius": s.radius}}
    if isinstance(s, Box):
        return r.Collider.cuboid(*s.half_extents), {"cuboid": list(s.half_extents)}
    if isinstance(s, Circle):  # a cylinder along y (Rapier's cylinder axis)
        return r.Collider.cylinder(s.radius, s.radius), {"cylinder": {"half_height": s.radius, "radius": s.radius}}
    if isinstance(s, Rect):
        a, c = s.half_extents
        half = [a, max(a, c), c]
        return r.Collider.cuboid(*half), {"cuboid": half}
    if s.kind == "capsule":  # its segment along body z
        return (r.Collider.capsule_z(s.half_length, s.radius),
                {"capsule_z": {"half_height": s.half_length, "radius": s.radius}})
    if s.kind == "cylinder":  # Rapier's cylinder is along its y: turned a quarter about x, y onto body z
        return (r.Collider.cylinder(s.half_length, s.radius).rotation((math.pi / 2, 0.0, 0.0)),
                {"cylinder": {"half_height": s.half_length, "radius": s.radius, "rotation_wrt_body": CYLINDER_TURN}})
    if s.kind in ("hull", "polygon"):
        if s.kind == "hull":
            points, record = np.asarray(s.vertices, float), {"convex_mesh": {"points": len(s.vertices)}}
        else:  # a prism along y (adapters/solids.py)
            depth = embedded_half_depth(s.corners)
            points = polygon_prism(s.corners, depth)[0]
            record = {"convex_mesh": {"prism_of_corners": [[float(x), float(z)] for x, z in s.corners],
                                      "half_depth": depth}}
        return _convex_mesh(body, points), record
    if s.kind == "mesh":
        return (r.Collider.trimesh(np.asarray(s.vertices, np.float32), np.asarray(s.triangles, np.uint32),
                                   flags=r.TriMeshFlags(TRIMESH_FLAGS)),
                {"trimesh": {"vertices": len(s.vertices), "triangles": len(s.triangles), "flags": TRIMESH_FLAG_NAMES}})
    # plane n . x = offset: the half-space through offset * n
    return (r.Collider.halfspace(tuple(s.normal)).translation(tuple(s.offset * n for n in s.normal)),
            {"halfspace": {"outward_normal": list(s.normal), "offset": s.offset}})


def _convex_mesh(body: Body, points: np.ndarray) -> r.ColliderBuilder:
    """Rapier's convex polyhedron from `points` (float32) and the faces of their hull as the
    scene computes them (cases.scene.Hull.faces, wound outward), every point a corner
    (Unsupported otherwise). Rapier's own convex_hull is not used: in float32 it flattens a
    plate thinner than 8.5e-4 of its size to its four top corners (measured with 0.36.1 on
    square plates of 0.1, 1 and 10 m: 9e-4 kept, 8e-4 flat), which convex_mesh keeps down to
    1e-7."""
    faces = Hull(tuple(map(tuple, points))).faces  # the face routine only: no frame is asked of these points
    try:
        shape = r.SharedShape.convex_mesh(np.asarray(points, np.float32), np.asarray(faces, np.uint32))
    except Exception as error:  # the bindings raise on a set parry refuses
        raise Unsupported(f"{body.shape.kind} {body.name!r}: Rapier's convex_mesh refuses its {len(points)} "
                          f"corners in float32 ({error})") from None
    polyhedron = shape.as_convex_polyhedron() if shape is not None else None
    kept = polyhedron.num_points() if polyhedron is not None else 0
    if kept != len(points):
        raise Unsupported(f"{body.shape.kind} {body.name!r}: Rapier's convex_mesh keeps {kept} of its {len(points)} "
                          "corners in float32")
    return r.Collider.new(shape)


def _planar_locks(body: Body, frictional: bool) -> r.LockedAxes:
    """A 2D body turns about y only, and moves in the x-z plane unless the scene has
    friction (which Rapier would then drop: module notes)."""
    require_turn_about_y(body, "so it cannot turn about y only")
    locks = r.LockedAxes.ROTATION_LOCKED_X | r.LockedAxes.ROTATION_LOCKED_Z
    return locks if frictional else locks | r.LockedAxes.TRANSLATION_LOCKED_Y


class RapierSimulation(Simulation):
    def __init__(self, scene: Scene, settings: Settings, tuning: dict[str, float], ccd: bool = False):
        self._dt = settings.dt
        self._ccd = ccd
        self.iterations = DEFAULT_SUBSTEPS if settings.iterations is None else settings.iterations
        world = r.PhysicsWorld(gravity=tuple(float(g) for g in scene.gravity))
        hertz = min(tuning["contact_natural_frequency"], HERTZ_PER_SUBSTEP_RATE * self.iterations / self._dt)
        zeta = tuning["contact_damping_ratio"]
        p = world.integration_parameters  # a live view: set in place
        p.dt = self._dt
        p.num_solver_iterations = self.iterations
        p.friction_model = FRICTION_MODEL
        p.contact_softness = r.SpringCoefficients(hertz, zeta)
        p.static_contact_softness = r.SpringCoefficients(2.0 * hertz, zeta)
        p.normalized_max_corrective_velocity = tuning["max_corrective_velocity"]  # length_unit 1
        self._world = world
        self.knobs = {
            "gravity": list(scene.gravity),
            "dt": p.dt,
            "num_solver_iterations": p.num_solver_iterations,
            "num_internal_pgs_iterations": p.num_internal_pgs_iterations,  # default 1
            "num_internal_stabilization_iterations": p.num_internal_stabilization_iterations,  # default 1
            "friction_model": "SIMPLIFIED",  # Rapier's default: one friction constraint per manifold, plus twist
            "contact_softness": {"natural_frequency": hertz, "damping_ratio": zeta},  # default 30 Hz, 10
            "static_contact_softness": {"natural_frequency": 2.0 * hertz, "damping_ratio": zeta},  # default 60 Hz, 10
            "normalized_max_corrective_velocity": p.normalized_max_corrective_velocity,  # default 3 m/s
            "normalized_prediction_distance": p.normalized_prediction_distance,  # speculative contacts, m
            "normalized_allowed_linear_error": p.normalized_allowed_linear_error,  # used by CCD only
            "warmstart_coefficient": p.warmstart_coefficient,
            "length_unit": p.length_unit,
            "contact_force": ("sum of the pair's normal impulses / dt (a pair with a mesh: the magnitude of its total "
                              "normal impulse / dt)"),
            "bodies": {},
        }

        rule_mu, mu = combine_rule(scene, lambda m: m.mu_s, "friction")
        rule_e, e = combine_rule(scene, lambda m: m.e, "restitution")
        self.knobs["friction_combine_rule"] = RULE_NAMES[rule_mu]
        self.knobs["restitution_combine_rule"] = RULE_NAMES[rule_e]
        self._pairs = {pair_key(a.name, b.name): scene.material_of(a.name, b.name)
                       for a, b in scene.contact_pairs()}
        self._handles: dict[str, r.RigidBodyHandle] = {}  # dynamic bodies
        self._every: dict[str, r.RigidBodyHandle] = {}  # every body, for joints
        # a 2D scene's jointed bodies are held in the plane by their joints (a revolute joint
        # about y, a slide in x-z, a weld), not by locked axes: with locks and a joint Rapier
        # blew the 2D pendulum up (energy 5e5 J in 10 s, measured with 0.36.1)
        self._jointed = {j.body for j in scene.joints}
        self._collider_of: dict[int, str] = {}  # collider index -> body name
        self._meshes: set[str] = set()  # bodies that are trimeshes (contact_forces)
        self._frictional = "friction" in scene.effects
        for body in scene.bodies:
            self._add(body, scene.dimension, mu[body.name], e[body.name], RULES[rule_mu], RULES[rule_e])
        self._joints = [self._joint(scene, joint, j) for j, joint in enumerate(scene.joints)]
        bodies = self._world.rigid_bodies
        for load in scene.loads:
            if load.acts:
                bodies[self._handles[load.body]].add_force(tuple(float(c) for c in load.force), True)
                bodies[self._handles[load.body]].add_torque(tuple(float(c) for c in load.torque), True)
                self.knobs.setdefault("loads", {})[load.body] = {"user_force": list(load.force),
                                                                 "user_torque": list(load.torque)}
        self._live = [bodies[h] for h in self._handles.values()]  # write_state reads these
        self.effects = self._built_effects(scene, COMBINE[rule_mu], mu, COMBINE[rule_e], e)

    def _add(self, body: Body, dimension: int, mu: float, e: float, rule_mu, rule_e) -> None:
        w, x, y, z = body.orientation
        if body.static:
            builder = r.RigidBody.fixed()
            record = {"type": "fixed"}
        else:
            inertia = body.principal_inertia
            gyroscopic = dimension == 3 and max(inertia) - min(inertia) > EQUAL_MOMENTS * max(inertia)  # module notes
            ccd = self._ccd and starts_fast(body, self._dt)  # the fast bodies only (module notes, "rapier-ccd")
            builder = (r.RigidBody.dynamic().linvel(tuple(body.velocity)).linear_damping(0.0)
                       .angular_damping(0.0).can_sleep(False).ccd_enabled(ccd).soft_ccd_prediction(0.0)
                       .gyroscopic_forces(gyroscopic).allow_fast_rotation(True))
            record = {"type": "dynamic", "linear_damping": 0.0, "angular_damping": 0.0, "can_sleep": False,
                      "ccd_enabled": ccd, "soft_ccd_prediction": 0.0, "gyroscopic_forces": gyroscopic,
                      "allow_fast_rotation": True}  # default False: angular speed capped at ~45 deg/step
            locks = r.LockedAxes.empty()
            if dimension == 2 and body.name not in self._jointed:
                locks = _planar_locks(body, self._frictional)
            if not body.rotates:
                locks = locks | r.LockedAxes.ROTATION_LOCKED
            else:
                builder = builder.angvel(tuple(body.angular_velocity))
            builder = builder.locked_axes(locks)
            record["locked_axes"] = locks.bits
        if not isinstance(body.shape, Plane):
            builder = builder.position(r.Isometry3(translation=tuple(body.position),
                                                   rotation=r.Rotation3(w, x, y, z)))
        collider, shape_record = _collider(body)
        collider = (collider.friction(mu).restitution(e).friction_combine_rule(rule_mu)
                    .restitution_combine_rule(rule_e).contact_skin(0.0))
        if body.dynamic:
            # in the collider's frame: a cylinder's turns body z onto its y (CYLINDER_TURN)
            ix, iy, iz = inertia
            local = (ix, iz, iy) if body.shape.kind == "cylinder" else (ix, iy, iz)
            collider = collider.mass_properties(r.MassProperties(local_com=(0.0, 0.0, 0.0), mass=body.mass,
                                                                 principal_inertia=local))
            record.update(mass=body.mass, principal_inertia=list(inertia))
        else:
            collider = collider.density(0.0)
        handle = self._world.add_body(builder)
        self._every[body.name] = handle
        ch = self._world.add_collider(collider, handle)
        self._collider_of[ch.index] = body.name
        if body.shape.kind == "mesh":
            self._meshes.add(body.name)
        if body.dynamic:
            self._handles[body.name] = handle
        record.update(collider=shape_record, friction=mu, restitution=e, contact_skin=0.0)
        self.knobs["bodies"][body.name] = record

    def _joint(self, scene: Scene, joint, j: int) -> str:
        """A scene joint as an impulse joint between the parent (body 1; the world: a fixed
        body at the origin, made once) and the body (body 2), anchors and axes in each
        body's frame: revolute a RevoluteJoint about the axis, prismatic a PrismaticJoint
        along it (no relative turn), ball a SphericalJoint, fixed a FixedJoint; a limit on
        the joint's coordinate, body 2 relative to body 1 about (along) the axis. Contacts
        between the two off (cases.scene.Joint); the joints' softness Rapier's default
        (SpringCoefficients.joint_defaults, recorded). A joint's dry friction is a force-based
        velocity motor at speed 0, its damping factor FRICTION_MOTOR (rigid), its force
        clamped to the friction."""
        if joint.parent is None and "world" not in self._every:
            self._every["world"] = self._world.add_body(r.RigidBody.fixed())
        frames = [None if joint.parent is None else scene.body(joint.parent), scene.body(joint.body)]
        anchor, axis = np.asarray(joint.anchor, float), np.asarray(joint.unit_axis, float)
        local = []
        for body in frames:
            R = np.eye(3) if body is None else rotation_matrix(body.orientation)
            x0 = np.zeros(3) if body is None else np.asarray(body.position, float)
            local.append((tuple(float(c) for c in R.T @ (anchor - x0)), tuple(float(c) for c in R.T @ axis)))
        if joint.kind in ("revolute", "prismatic"):
            maker = r.RevoluteJointBuilder if joint.kind == "revolute" else r.PrismaticJointBuilder
            builder = maker(local[0][1]).local_axis1(local[0][1]).local_axis2(local[1][1])
            if joint.limits is not None:
                builder = builder.limits(float(joint.limits[0]), float(joint.limits[1]))
            if joint.friction > 0:  # dry friction: a velocity motor at 0, rigid (factor FRICTION_MOTOR), bounded by it
                builder = (builder.motor_model(r.MotorModel.FORCE_BASED).motor_velocity(0.0, FRICTION_MOTOR)
                           .motor_max_force(float(joint.friction)))
        elif joint.kind == "ball":
            builder = r.SphericalJointBuilder()
        else:
            builder = r.FixedJointBuilder()
            if frames[0] is not None or frames[1].orientation != (1.0, 0.0, 0.0, 0.0):
                raise Unsupported(f"joints[{j}]: a fixed joint between turned frames: FixedJointBuilder's local "
                                  "frames are not mapped (only the anchors)")
        builder = builder.local_anchor1(local[0][0]).local_anchor2(local[1][0]).contacts_enabled(False)
        soft = r.SpringCoefficients.joint_defaults()
        self._world.impulse_joints.insert(self._every["world" if joint.parent is None else joint.parent],
                                          self._every[joint.body], builder, True)
        self.knobs.setdefault("joints", {})[f"joints[{j}]"] = {
            "kind": joint.kind, "local_anchors": [list(a) for a, _ in local], "local_axes": [list(x) for _, x in local],
            "limits": None if joint.limits is None else list(joint.limits), "contacts_enabled": False,
            "softness": {"natural_frequency": soft.natural_frequency, "damping_ratio": soft.damping_ratio},
            **({"friction": {"motor": "force-based, velocity 0", "factor": FRICTION_MOTOR, "max_force": joint.friction}}
               if joint.friction > 0 else {})}
        return joint.kind

    def _built_effects(self, scene: Scene, combine_mu, mu: dict, combine_e, e: dict) -> frozenset[str]:
        """What the built world simulates, from the values given to the engine and its rules."""
        fx = set()
        if any(g != 0.0 for g in scene.gravity):
            fx.add("gravity")
        if self._pairs:
            fx.add("contact")
            if any(combine_e(e[a], e[b]) > 0 for a, b in self._pairs):
                fx.add("restitution")
            if any(combine_mu(mu[a], mu[b]) > 0 for a, b in self._pairs):
                fx.add("friction")
        bodies = self._world.rigid_bodies
        if any(not bodies[h].locked_axes.contains(r.LockedAxes.ROTATION_LOCKED) for h in self._handles.values()):
            fx.add("rotation")
        if self._joints:
            fx.add("joint")
        if any(r_["limits"] is not None for r_ in self.knobs.get("joints", {}).values()):
            fx.add("limit")
        if any("friction" in r_ for r_ in self.knobs.get("joints", {}).values()):
            fx.add("joint_friction")
        if self.knobs.get("loads"):
            fx.add("load")
        return frozenset(fx)

    # --- the contract -------------------------------------------------------------------

    def step(self) -> None:
        self._world.step()

    def states(self):
        bodies = self._world.rigid_bodies
        out = {}
        for name, h in self._handles.items():
            b = bodies[h]
            q = b.rotation
            out[name] = state_row(b.translation.to_tuple(), (q.w, q.i, q.j, q.k), b.linvel.to_tuple(),
                                  b.angvel.to_tuple())
        return out

    # Bulk reads (adapters.base): the rows of states(), one tuple assignment a body (states()
    # builds a dict of arrays: 3.7 us a body against 4.9 us a step), from the RigidBody
    # objects kept at the build (they read the world as it steps; no body is added later).
    def body_order(self) -> list[str]:
        return list(self._handles)

    def write_state(self, out: np.ndarray) -> None:
        i = 0
        for b in self._live:
            q = b.rotation.to_tuple()  # (i, j, k, w)
            out[i:i + 13] = (*b.translation.to_tuple(), q[3], q[0], q[1], q[2], *b.linvel.to_tuple(),
                             *b.angvel.to_tuple())
            i += 13

    def contact_forces(self):
        forces: dict[tuple[str, str], float] = {}
        for pair in self._world.narrow_phase.contact_pairs():
            if not pair.has_any_active_contact:
                continue
            a, b = self._collider_of[pair.collider1.index], self._collider_of[pair.collider2.index]
            if a in self._meshes or b in self._meshes:  # its points read 0 (module notes)
                j = pair.total_impulse_magnitude()
            else:
                j = sum(p.impulse for m in pair.manifolds for p in m.points)
            key = pair_key(a, b)
            forces[key] = forces.get(key, 0.0) + j / self._dt
        return forces

    def contact_points(self) -> list[ContactPoint]:
        """The geometry of each solver contact of the last step, forces NaN (module notes)."""
        out = []
        for pair in self._world.narrow_phase.contact_pairs():
            one, two = self._collider_of[pair.collider1.index], self._collider_of[pair.collider2.index]
            for m in pair.manifolds:
                contacts = m.data.solver_contacts
                if not contacts:
                    continue
                n = np.array(m.data.normal.to_tuple(), float)  # from collider 1 into collider 2: b = one, a = two
                for c in contacts:
                    out.append(ContactPoint(two, one, np.array(c.point.to_tuple(), float), n, math.nan,
                                            np.full(3, math.nan), float(c.dist)))
        return out

    def close(self) -> None:
        world, self._world = getattr(self, "_world", None), None
        if world is not None:
            world.clear()
        self._handles, self._live = {}, []
