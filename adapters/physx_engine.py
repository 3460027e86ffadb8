"""NVIDIA PhysX 5 behind the engine contract, through `ovphysx` (a pre-release wheel, 0.7.0:
PhysX on the CPU, scenes authored as USD and populated through `ovstage`). The adapter
writes each scene as a `.usda` text layer (no USD runtime needed), attaches it to a PhysX
instance in CPU mode and steps it with `step_sync(dt)`; states come back through
`read_sync` (float32 warp arrays), contact forces through a contact binding.

PhysX is the first engine here with separate static and kinetic friction (`mu_s != mu_k`)
per material, and a bounce threshold (restitution acts only above a closing speed).
Measured (a 0.1 m box at rest on a slope, mu_s = 0.5, mu_k = 0.3, dt 1 ms): under TGS, the
schema's default solver, it slides on tan(theta) = 0.4 at the acceleration of mu = 0.300
(static friction holds only up to mu_k); under PGS it holds there (0.007 mm in 1 s) but
slides at tan 0.48 (787 mm in 1 s, mu_k's slide): PGS holds to about 0.42, not mu_s.
frictionType (patch, one- or two-directional) changes nothing there.

Faithful mapping (each setting recorded in `knobs`):
- pair materials through PhysX's combine modes: every body carries its own
  `PhysicsMaterialAPI` material (static friction, dynamic friction, restitution) with
  `frictionCombineMode` and `restitutionCombineMode` "max", the per-body values found by
  adapters.combination (the max rule: static bodies 0, a dynamic body its pairs' value);
- bounce threshold 0 (PhysX's SDK default 2 m/s takes all bounce from slower impacts; the
  USD schema's default is 0 too), sleeping off (`disableSleeping`, sleep threshold 0),
  linear and angular damping 0 (PhysX's default angular damping is 0.05 1/s), no CCD
  (swept or speculative: "physx-ccd" below), no stabilization, gyroscopic forces on (Euler's
  equations);
- `timeStepsPerSecond` = 1/dt, so one `step_sync(dt)` is one PhysX step (PhysX's USD
  default 60 steps a second would sub-step);
- mass, diagonal inertia and centre of mass as the scene states them (`PhysicsMassAPI`);
- solver: TGS (the schema's default) for `physx`, PGS for `physx-pgs`;
  `Settings.iterations` = position iterations a step (schema default 16), velocity
  iterations 1;
- rotation held by locking the three rotational axes (`lockedRotAxis` = 7);
- a plane is PhysX's infinite plane (`UsdGeom.Plane`, axis Z) turned onto the normal;
- a capsule is a `UsdGeom.Capsule` and a cylinder a `UsdGeom.Cylinder`, both along body z
  (axis Z, USD's height the core's 2 h); the cylinder is PhysX's exact convex-core cylinder
  (PxConvexCoreGeometry, margin 0: CYLINDER_CONVEX_CORE), not a faceted convex mesh;
- a hull (and a 2D polygon, as its prism along y: adapters/solids.py) is a `UsdGeom.Mesh`
  of its corners and their hull's faces cooked as a convex hull (physics:approximation
  convexHull), the vertex limit their number (at most 255: else unsupported) and no
  minimum thickness (PhysX's default 1 mm would thicken a thinner plate);
- a static mesh is a single-sided `UsdGeom.Mesh` of its vertices and triangles cooked as a
  triangle mesh (approximation none; rightHanded: counterclockwise from outside), its
  vertices unwelded. PhysX gives no read-back of cooked geometry: tests/test_physx_mapping.py
  checks the layer and where the shapes come to rest;
- initial angular velocity in degrees per second (the UsdPhysics unit), read back in rad/s.

Continuous collision ("physx-ccd", `ccd=True`, TGS): PhysX's swept CCD, the scene's
`physxScene:enableCCD` (a second broad phase after integration) and `physxRigidBody:enableCCD`
on every dynamic body; PhysX needs both (with either alone the ball passes, measured), and its
speculative CCD (`enableSpeculativeCCD`, a contact offset grown with the velocity) stays off.
Measured with 0.7.0 (cases/robustness/tunnelling.py, a 2 cm ball at 50 and 100 m/s at a free
1 cm plate, TGS and PGS alike): without CCD the ball passes from 1.75 cm and from 5 cm, 3D and
2D; with it the ball is stopped from both and leaves at -98.0198 m/s, the plate at 1.9802
(the central impact's (m - M)/(m + M) v and 2 m/(m + M) v, to float32). CCD on the fast ball
alone gives the same bits, so, unlike Box2D's bullets and Rapier's CCD, PhysX sweeps a pair of
two CCD bodies; speculative CCD alone stops the ball from both gaps too (not a configuration
here). In a default run the configuration takes the families tagged "swept" only
(`default_tags`).

Contact normal forces from ovphysx's contact binding (PhysX's contact report): per dynamic
body (sensor) and partner (filter), the normal force of the last step.

`contact_points` gives the geometry of every point of PhysX's contact report for the last
step and not its forces (`Capabilities.contact_geometry`; `contact_points` False, so the
per-point force readings leave PhysX out): the same binding's `read_normal_contact_data`
(deprecated since ovphysx 0.6.0, present in 0.7.0) gives each point's world position,
normal and separation (negative: overlap, physval's gap). Its normal is PhysX's, from the
pair's second shape into its first, whatever the sensor (measured: both sensors of a pair of
balls read the same normal; a static body is second, and of two dynamic bodies PhysX's own
pair order decides: in broad_phase's 64-ball lattice 21 of the 32 dimers have the raw normal
into the ball read second), and the point lies on the second shape's surface. So the adapter orients
each normal itself: a is the sensor, a dynamic and hence convex body, and n points into it,
n . (c_a - x) > 0 for its centre c_a. For a convex body whose contact point lies in the
overlap, n . (c_a - x) is at least its extent from the centre along -n less the depth (and
less its motion in the step, v dt, since c_a is read after it): positive for every pose the
geometry families take (depths of centimetres at most against extents of 5 cm and more). A
pair of two dynamic bodies is read from its first sensor only. PhysX reports a pair within
the sum of its shapes' contact offsets (`physxCollision:contactOffset`, left at ovphysx's
automatic value, 2 % of the shape's smallest width, read back into `knobs` for the dynamic
bodies: 0.002 m for a 0.05 m ball, 0.008 m for a 0.2 m one, 0.02 m for a 1 m cube; measured,
two 0.1 m balls are reported at 5 mm apart and not at 1 cm), so points up to that far apart
come with a positive gap. Setting it would move every family's contacts: it is recorded, not
changed.

Joints (`PhysXSimulation._joint`) are UsdPhysics joints in the same layer, which PhysX
builds as standalone PxD6Joints: maximal coordinates, each body keeping its six and the
joint constraint rows between them, solved with the contacts. A revolute joint is a
`PhysicsRevoluteJoint`, a prismatic one a `PhysicsPrismaticJoint`, a ball a
`PhysicsSphericalJoint` (no cone limit) and a fixed one a `PhysicsFixedJoint`; body0 is the
parent and body1 the body, and a parent that is the world or a static body is no body0 (a
static body is no actor of the joint; its frame is the world's). Both local frames sit at
the anchor with their z axis on the scene's axis (`physics:axis` "Z"), so the joint's
coordinate is body1's turn (slide) relative to body0, 0 at the start; limits are hard,
a hinge's in degrees. Measured on an oblique axis between turned bodies, pushed by a load
each way: the hinge stops at +0.5000 and -0.2000 rad, the slider at +0.3000 and -0.1000 m,
its limits. Jointed bodies do not collide: `physics:collisionEnabled` 0 leaves a dynamic
pair out (measured: a slider pushed into its parent passes through it; with 1 it stops at
the face under 141 N), and a static partner, which the joint does not reach, through the
body's `PhysicsFilteredPairsAPI` (without it the pair collided, 142 N). A joint's dry
friction is its drive at rate 0 bounded by the friction (FRICTION_DAMPING); its restitution
at a limit `physxLimit:<axis>:restitution` at bounce threshold 0, taken by PGS only
(TGS_LIMIT_RESTITUTION). Loads are PhysX's external force (at the centre of mass) and the
torque lanes of its wrench, written through tensor bindings before every step.

2D scenes are embedded in the x-z plane on PhysX's own locks: every dynamic body has its y
translation locked (`lockedPosAxis` = 2) and its rotations about x and z (`lockedRotAxis`
= 5; 7 where it may not turn at all), so it slides in the plane and turns about y; a disc is
a sphere of its radius (the same contacts in the plane, as in the MuJoCo adapter) and a
rectangle a box as deep along y as its x half-extent (the depth only spreads the contact
points, symmetrically about y = 0). Its mass and inertia are the scene's.
"""
from __future__ import annotations

import itertools
import math
import os
import tempfile
from dataclasses import replace
from importlib import metadata

import numpy as np

from adapters.base import Adapter, Capabilities, Settings, Simulation, Unsupported
from adapters.combination import per_body_values
from adapters.frames import require_turn_about_y, state_row, xyzw_to_wxyz, z_to
from adapters.joints import local_frame
from adapters.lazy import require
from adapters.solids import embedded_half_depth, polygon_prism
from cases.scene import Body, Hull, Joint, Plane, Scene, pair_key
from cases.trajectory import ContactPoint

require("ovphysx")  # not installed: ImportError now, so the registry reports it

DEFAULT_POSITION_ITERATIONS = 16  # PhysxRigidBodyAPI's solverPositionIterationCount default
VELOCITY_ITERATIONS = 1
COMBINE = "max"
SOLVERS = ("TGS", "PGS")  # physxScene:solverType: temporal Gauss-Seidel (the default), projected Gauss-Seidel
# PhysX's CPU dispatcher threads: 0 steps each scene on the calling thread. physval runs one
# job a worker process, so its worker threads only wait on each other: measured on 12 scenes
# of stacks, tumbles and drops (1000 steps each, a state read every step), 11.3 s with the
# default pool against 3.9 s on the calling thread, every state bit for bit the same.
CPU_THREADS = 0
# A Cylinder is PhysX's exact convex-core cylinder (PxConvexCoreGeometry, ovphysx's default, set
# here): not the convex mesh of a prism (False) whose facets a rolling cylinder would bump over.
# Its margin (a rounding radius added around the core) is 0.
CYLINDER_CONVEX_CORE = True
# A Hull (and a 2D polygon's prism) is a cooked convex mesh of the scene's corners: the vertex
# limit is their number, at most PhysX's 255 (PxConvexMeshDesc); cooking may not thicken it
# (physxConvexHullCollision:minThickness, 1 mm by default, set to HULL_MIN_THICKNESS).
MAX_HULL_VERTICES = 255
HULL_MIN_THICKNESS = 0.0
# A static Mesh is a cooked triangle mesh (physics:approximation "none"), single-sided, wound as
# the scene gives it (counterclockwise from outside, USD's rightHanded), its vertices unwelded.
MESH_WELD_TOLERANCE = 0.0
# The contact report's capacity a body (adapters' `_capacity`): PhysX's patch of a face contact
# has 4 points and a body of the geometry families touches a few others; a step that reports
# more raises rather than drop points.
POINTS_PER_PAIR = 16
# The scene's joints as UsdPhysics joints, each a standalone PxD6Joint in PhysX (maximal
# coordinates; PhysXSimulation._joint). A revolute joint's limit, limit tuning and drive are
# its "angular" instance, a prismatic joint's its "linear" one.
JOINT_PRIMS = {"revolute": "PhysicsRevoluteJoint", "prismatic": "PhysicsPrismaticJoint",
               "ball": "PhysicsSphericalJoint", "fixed": "PhysicsFixedJoint"}
AXIS_INSTANCES = {"revolute": "angular", "prismatic": "linear"}
# A joint's dry friction is the joint's drive held at rate 0 (damping only) with its force
# (torque) bounded by the friction: PhysX bounds a drive by a force, not an impulse (measured:
# rail_slide's slider decelerates at 4.9050 m/s^2 = mu g and stops at 0.4067 m, its
# closed form less v_0 dt / 2; a load of 0.9 times the friction holds a slider and a hinge,
# 1.5 times accelerates them at 0.5 F / m, TGS and PGS alike). The damping is far stiffer
# than the bound (1e4 and 1e9 gave the same slide), so the joint sticks when it can.
FRICTION_DAMPING = 1e9
# TGS takes no restitution at a joint's limit (measured on limit_impact's rod, dt = 0.2 ms:
# e = 0 and 0.5 give the same rates bit for bit at 4, 16 and 64 position iterations and at
# dt / 10; PGS rebounds at e times the rate it meets the limit with).
TGS_LIMIT_RESTITUTION = ("PhysX's TGS solver takes no restitution at a joint limit: physxLimit:<axis>:restitution "
                         "0 and 0.5 give the same rebound bit for bit (measured; PGS, \"physx-pgs\", takes it)")
_STAGES = itertools.count(1)
_loaded = None


def _load():
    """Import ovphysx and ovstage, switch PhysX to the CPU on CPU_THREADS worker threads and
    register the PhysX USD schemas (once a process)."""
    global _loaded
    if _loaded is None:
        import ovphysx
        import ovstage
        from ovphysx import PhysX
        from ovphysx.samples.python_samples.schema_support import physx_schema_paths
        from ovphysx.types import GlobalConfigKey, ObjectScope, SimObjectType
        PhysX.set_cpu_mode(True)
        ovphysx.set_global_config(GlobalConfigKey.NUM_THREADS, CPU_THREADS)
        ovphysx.set_global_config(GlobalConfigKey.COLLISION_CYLINDER_CUSTOM_GEOMETRY, CYLINDER_CONVEX_CORE)
        ovstage.population.register_usd_schemas(
            [*[str(p) for p in physx_schema_paths()], str(ovphysx.newton_schema_root())])
        _loaded = (ovphysx, ovstage, PhysX, ObjectScope, SimObjectType)
    return _loaded


def _v(x) -> str:
    return "(" + ", ".join(repr(float(c)) for c in x) + ")"


def _mesh_arrays(points: np.ndarray, triangles: np.ndarray) -> list[str]:
    """A UsdGeom.Mesh's points and triangles (counterclockwise seen from outside: rightHanded)."""
    return [f'            point3f[] points = [{", ".join(_v(p) for p in points)}]',
            f'            int[] faceVertexCounts = [{", ".join("3" for _ in triangles)}]',
            f'            int[] faceVertexIndices = [{", ".join(str(int(i)) for t in triangles for i in t)}]',
            '            uniform token orientation = "rightHanded"']


class PhysXAdapter(Adapter):
    name = "physx"
    package = "ovphysx"
    packages = ("ovphysx",)
    # the pre-release the conformance battery ran on; 0.x: the next minor may change the API
    supported = ">=0.7.0,<0.8"
    capabilities = Capabilities(
        dimensions=frozenset({2, 3}),
        shapes=frozenset({"sphere", "box", "plane", "circle", "rect", "capsule", "cylinder", "hull", "polygon",
                          "mesh"}),  # module notes
        native_restitution=True,
        static_kinetic=True,    # PhysicsMaterialAPI staticFriction and dynamicFriction
        contact_forces=True,
        contact_points=False,   # the contact report's per-point forces are normal only, no friction per point
        contact_geometry=True,  # each reported point's place, normal and separation (module notes)
        iterations=True,        # position iterations a step
        float_bits=32,          # PhysX stores poses and velocities in single precision
        # the scene's joints as UsdPhysics joints, standalone PxD6Joints (PhysXSimulation._joint)
        joints=frozenset({"revolute", "prismatic", "ball", "fixed"}),
        joint_limits=True,
        joint_friction=True,      # the joint's drive at rate 0, bounded by the friction (FRICTION_DAMPING)
        limit_restitution=True,   # PhysxLimitAPI's restitution; PGS only (TGS_LIMIT_RESTITUTION, __init__)
        coordinates="maximal",
        loads=True,  # external force and wrench tensor bindings written before each step (PhysX clears them)
    )

    def __init__(self, name: str = "physx", solver: str = "TGS", ccd: bool = False):
        """solver: TGS or PGS (`SOLVERS`); ccd: PhysX's swept continuous collision ("physx-ccd",
        module notes)."""
        if solver not in SOLVERS:
            raise ValueError(f"solver = {solver!r}: must be one of {', '.join(SOLVERS)}")
        self.name, self.solver = name, solver
        self.ccd = self.continuous_collision(ccd)
        if solver == "TGS":
            self.capabilities = replace(self.capabilities, limit_restitution=False,
                                        why_not=self.capabilities.why_not + (("limit_restitution", TGS_LIMIT_RESTITUTION),))

    def version(self) -> str:
        return metadata.version("ovphysx")

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene)
        if reason:
            raise Unsupported(reason)
        steps_per_second = 1.0 / settings.dt
        if abs(steps_per_second - round(steps_per_second)) > 1e-9 * steps_per_second:
            raise Unsupported(f"dt = {settings.dt}: PhysX's timeStepsPerSecond is a whole number, 1/dt is not")
        for body in scene.bodies:
            corners = len(body.shape.vertices) if body.shape.kind == "hull" else \
                2 * len(body.shape.corners) if body.shape.kind == "polygon" else 0
            if corners > MAX_HULL_VERTICES:
                raise Unsupported(f"{body.shape.kind} {body.name!r} has {corners} corners: a PhysX convex mesh holds at "
                                  f"most {MAX_HULL_VERTICES}")
        _load()
        return PhysXSimulation(scene, settings, self.solver, self.ccd)


class PhysXSimulation(Simulation):
    def __init__(self, scene: Scene, settings: Settings, solver: str, ccd: bool = False):
        ovphysx, ovstage, PhysX, self._scope, self._types = _load()
        self._dt = settings.dt
        self._ccd = ccd
        self.iterations = DEFAULT_POSITION_ITERATIONS if settings.iterations is None else settings.iterations
        effects = scene.effects
        friction, restitution = "friction" in effects, "restitution" in effects
        mats = {"staticFriction": per_body_values(scene, lambda m: m.mu_s if friction else 0.0, COMBINE, "mu_s"),
                "dynamicFriction": per_body_values(scene, lambda m: m.mu_k_ if friction else 0.0, COMBINE, "mu_k"),
                "restitution": per_body_values(scene, lambda m: m.e if restitution else 0.0, COMBINE, "e")}
        gravity = np.asarray(scene.gravity if "gravity" in effects else (0.0, 0.0, 0.0), float)
        g = float(np.linalg.norm(gravity))
        self._order = [b.name for b in scene.dynamic_bodies]
        self._paths = {b.name: f"/World/B{i}" for i, b in enumerate(scene.bodies)}
        self.knobs = {
            "PhysicsScene": {"gravity": gravity.tolist(), "timeStepsPerSecond": round(1.0 / self._dt),
                             "bounceThreshold": 0.0, "disableSleeping": True, "enableCCD": ccd,
                             "enableStabilization": False, "solverType": solver,
                             "enableGPUDynamics": False, "broadphaseType": "MBP"},
            "numThreads": CPU_THREADS,
            "collisionCylinderCustomGeometry": CYLINDER_CONVEX_CORE,
            "combineMode": {"friction": COMBINE, "restitution": COMBINE},
            "solverPositionIterationCount": self.iterations,
            "solverVelocityIterationCount": VELOCITY_ITERATIONS,
            "contact_force": "contact binding: normal force matrix per dynamic body and partner",
            "bodies": {},
        }
        lines = ['#usda 1.0', '(', '    defaultPrim = "World"', '    metersPerUnit = 1', '    upAxis = "Z"', ')',
                 'def Xform "World"', '{',
                 '    def PhysicsScene "PhysicsScene" (prepend apiSchemas = ["PhysxSceneAPI"])', '    {',
                 f'        vector3f physics:gravityDirection = {_v(gravity / g if g > 0 else (0, 0, -1))}',
                 f'        float physics:gravityMagnitude = {g!r}',
                 '        bool physxScene:enableGPUDynamics = 0',
                 '        uniform token physxScene:broadphaseType = "MBP"',
                 '        float physxScene:bounceThreshold = 0',
                 '        uniform bool physxScene:disableSleeping = 1',
                 f'        bool physxScene:enableCCD = {int(ccd)}',
                 '        bool physxScene:enableStabilization = 0',
                 f'        uniform token physxScene:solverType = "{solver}"',
                 f'        uint physxScene:timeStepsPerSecond = {round(1.0 / self._dt)}',
                 '    }']
        self._planar = scene.dimension == 2
        self._filtered = self._static_partners(scene)
        for body in scene.bodies:
            lines += self._body(body, {k: v[body.name] for k, v in mats.items()})
        for j in range(len(scene.joints)):
            lines += self._joint(scene, j)
        lines.append('}')
        fd, self._file = tempfile.mkstemp(suffix=".usda", prefix="physval-physx-")
        with os.fdopen(fd, "w") as f:
            f.write("\n".join(lines) + "\n")
        self._physx = PhysX()
        self._stage = ovstage.Stage(f"physval-{next(_STAGES)}")
        ovstage.population.open_usd(self._stage, self._file, ordinal=1, domains=ovstage.PopulationDomain.ALL)
        self._stage.advance_write_floor(ordinal=1).wait()
        self._physx.wait_task(self._physx.attach_ovstage(self._stage, read_ordinal=1))
        self._binding = None
        self._partners = [n for n in self._paths]
        if self._order and len(scene.bodies) > 1:
            # every dynamic body senses every other body (filters_per_sensor of them, flattened)
            filters = []
            static = {b.name for b in scene.bodies if b.static}
            self._filter_names = []
            for name in self._order:
                others = [o for o in self._paths if o != name]
                # a static body is its collider prim (no rigid body above it)
                filters += [self._paths[o] + ("/Geom" if o in static else "") for o in others]
                self._filter_names.append(others)
            self._binding = self._physx.create_contact_binding(
                sensor_patterns=[self._paths[n] for n in self._order], filter_patterns=filters,
                filters_per_sensor=len(scene.bodies) - 1, max_contact_data_count=self._capacity(scene))
            self._matrix = np.zeros((len(self._order), len(scene.bodies) - 1, 3), np.float32)
        self._start = {b.name: b.position for b in scene.dynamic_bodies}
        self._rows = self._row_order()
        if self._order:  # PhysX's own contact offsets (module notes), per dynamic body's shape
            offsets = self._read_raw(["contactOffset", "restOffset"])
            for name, row in zip(self._order, self._rows):
                self.knobs["bodies"][name].update(contactOffset=float(offsets[0][row]), restOffset=float(offsets[1][row]))
        self._stepped = False
        self._loads = self._load_bindings(scene)
        self.effects = self._built_effects(scene, gravity, mats)

    @staticmethod
    def _capacity(scene: Scene) -> int:
        """Room for the contact report's points: POINTS_PER_PAIR for every pair a body may
        touch, twice over (a pair of dynamic bodies is reported by both sensors)."""
        return max(256, 2 * POINTS_PER_PAIR * len(scene.bodies))

    def _body(self, body: Body, mat: dict) -> list[str]:
        path = self._paths[body.name]
        name = path.rsplit("/", 1)[1]
        record: dict = {"material": dict(mat)}
        s = body.shape
        if isinstance(s, Plane):
            n = np.asarray(s.normal, float)
            position, orientation = s.offset * n, z_to(n)
        else:
            position, orientation = body.position, body.orientation
        apis = ["PhysicsRigidBodyAPI", "PhysicsMassAPI", "PhysxRigidBodyAPI", "PhysxContactReportAPI"] if body.dynamic else []
        partners = self._filtered.get(body.name, [])
        if partners:  # the static bodies it is jointed to (_static_partners)
            apis.append("PhysicsFilteredPairsAPI")
        out = [f'    def Material "{name}Mat" (prepend apiSchemas = ["PhysicsMaterialAPI", "PhysxMaterialAPI"])', '    {',
               f'        float physics:staticFriction = {mat["staticFriction"]!r}',
               f'        float physics:dynamicFriction = {mat["dynamicFriction"]!r}',
               f'        float physics:restitution = {mat["restitution"]!r}',
               f'        uniform token physxMaterial:frictionCombineMode = "{COMBINE}"',
               f'        uniform token physxMaterial:restitutionCombineMode = "{COMBINE}"',
               '    }',
               f'    def Xform "{name}"' + (f' (prepend apiSchemas = {apis!r})'.replace("'", '"') if apis else ''), '    {',
               f'        double3 xformOp:translate = {_v(position)}',
               f'        quatd xformOp:orient = {_v(orientation)}',
               '        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:orient"]']
        if partners:
            out.append(f'        rel physics:filteredPairs = [{", ".join(f"<{p}>" for p in partners)}]')
            record["filteredPairs"] = partners
        if body.dynamic:
            ix, iy, iz = body.principal_inertia
            w = np.degrees(np.asarray(body.angular_velocity if body.rotates else (0.0, 0.0, 0.0), float))
            locked = 0 if body.rotates else 7
            moves = 0
            if self._planar:  # in the x-z plane, turning about y only (module notes)
                require_turn_about_y(body, "so it cannot turn about y only")
                locked, moves = (5 if body.rotates else 7), 2
            out += [f'        float physics:mass = {float(body.mass)!r}',
                    f'        float3 physics:diagonalInertia = {_v((ix, iy, iz))}',
                    '        point3f physics:centerOfMass = (0, 0, 0)',
                    '        quatf physics:principalAxes = (1, 0, 0, 0)',
                    f'        vector3f physics:velocity = {_v(body.velocity)}',
                    f'        vector3f physics:angularVelocity = {_v(w)}',
                    '        float physxContactReport:threshold = 0',
                    '        float physxRigidBody:linearDamping = 0',
                    '        float physxRigidBody:angularDamping = 0',
                    '        float physxRigidBody:sleepThreshold = 0',
                    f'        bool physxRigidBody:enableCCD = {int(self._ccd)}',  # every dynamic body ("physx-ccd")
                    '        bool physxRigidBody:enableSpeculativeCCD = 0',
                    '        bool physxRigidBody:enableGyroscopicForces = 1',
                    f'        int physxRigidBody:lockedRotAxis = {locked}',
                    f'        int physxRigidBody:lockedPosAxis = {moves}',
                    f'        int physxRigidBody:solverPositionIterationCount = {self.iterations}',
                    f'        int physxRigidBody:solverVelocityIterationCount = {VELOCITY_ITERATIONS}']
            record.update(mass=float(body.mass), diagonalInertia=[ix, iy, iz], linearDamping=0.0, angularDamping=0.0,
                          sleepThreshold=0.0, lockedRotAxis=locked, lockedPosAxis=moves,
                          enableGyroscopicForces=True, enableCCD=self._ccd, enableSpeculativeCCD=False)
        else:
            record["static"] = True
        collider = '        def {} "Geom" (prepend apiSchemas = ["PhysicsCollisionAPI", "MaterialBindingAPI"{}])'
        if s.kind in ("sphere", "circle"):  # a disc: a sphere of its radius (module notes)
            geom = [collider.format("Sphere", ""), '        {', f'            double radius = {float(s.radius)!r}']
            record["sphere"] = {"radius": s.radius}
        elif s.kind in ("box", "rect"):  # a rectangle: a box as deep along y as its x half-extent
            half = s.half_extents if s.kind == "box" else (s.half_extents[0], s.half_extents[0], s.half_extents[1])
            geom = [collider.format("Cube", ""), '        {', '            double size = 2',
                    f'            float3 xformOp:scale = {_v(half)}',
                    '            uniform token[] xformOpOrder = ["xformOp:scale"]']
            record["cube"] = {"half_extents": list(half)}
        elif s.kind in ("capsule", "cylinder"):  # along body z; USD's height is the core's, 2 h
            geom = [collider.format(s.kind.capitalize(), ""), '        {', '            uniform token axis = "Z"',
                    f'            double radius = {float(s.radius)!r}', f'            double height = {2.0 * s.half_length!r}']
            record[s.kind] = {"axis": "Z", "radius": s.radius, "height": 2.0 * s.half_length}
            if s.kind == "cylinder":
                geom.append('            custom float physxConvexGeometry:margin = 0')
                record["cylinder"].update(geometry="PxConvexCoreGeometry (exact)" if CYLINDER_CONVEX_CORE
                                          else "convex mesh", margin=0.0)
        elif s.kind in ("hull", "polygon"):  # a cooked convex mesh of the corners and their hull's faces
            if s.kind == "hull":
                points = np.asarray(s.vertices, float)
            else:  # a prism along y (adapters/solids.py)
                points = polygon_prism(s.corners, embedded_half_depth(s.corners))[0]
            faces = Hull(tuple(map(tuple, points))).faces  # the face routine only (as the Rapier adapter)
            geom = [collider.format("Mesh", ', "PhysicsMeshCollisionAPI", "PhysxConvexHullCollisionAPI"'), '        {',
                    *_mesh_arrays(points, faces), '            uniform token physics:approximation = "convexHull"',
                    f'            int physxConvexHullCollision:hullVertexLimit = {len(points)}',
                    f'            float physxConvexHullCollision:minThickness = {HULL_MIN_THICKNESS!r}']
            record["convex_mesh"] = {"vertices": len(points), "hullVertexLimit": len(points),
                                     "minThickness": HULL_MIN_THICKNESS}
        elif s.kind == "mesh":  # static: a cooked triangle mesh
            geom = [collider.format("Mesh", ', "PhysicsMeshCollisionAPI", "PhysxTriangleMeshCollisionAPI"'), '        {',
                    *_mesh_arrays(np.asarray(s.vertices, float), np.asarray(s.triangles)),
                    '            uniform bool doubleSided = 0', '            uniform token physics:approximation = "none"',
                    f'            float physxTriangleMeshCollision:weldTolerance = {MESH_WELD_TOLERANCE!r}']
            record["triangle_mesh"] = {"vertices": len(s.vertices), "triangles": len(s.triangles), "doubleSided": False,
                                       "weldTolerance": MESH_WELD_TOLERANCE}
        else:
            geom = [collider.format("Plane", ""), '        {', '            uniform token axis = "Z"']
            record["plane"] = {"normal": list(s.normal), "offset": s.offset}
        out += geom + [f'            rel material:binding:physics = <{path}Mat>', '        }', '    }']
        self.knobs["bodies"][body.name] = record
        return out

    def _static_partners(self, scene: Scene) -> dict[str, list[str]]:
        """Each dynamic body's static joint partners' collider prims. A joint to a static body
        is a joint to the world (no body0: a static body is no PhysX actor of the joint), so
        the joint's own collision filter (physics:collisionEnabled false, PhysX's
        PxConstraintFlag::eCOLLISION_ENABLED off) cannot reach the static collider: the
        body's PhysicsFilteredPairsAPI leaves the pair out (cases.scene.Joint: jointed bodies
        do not collide)."""
        static = {b.name for b in scene.bodies if b.static}
        out: dict[str, list[str]] = {}
        for joint in scene.joints:
            if joint.parent in static:
                out.setdefault(joint.body, []).append(self._paths[joint.parent] + "/Geom")
        return out

    def _joint(self, scene: Scene, j: int) -> list[str]:
        """Scene joint j as a UsdPhysics joint: body0 the parent (none for the world or a
        static body, whose local frame is then the world's), body1 the body. Both local
        frames sit at the anchor with their z axis on the scene's axis (physics:axis "Z"), so
        the joint's coordinate is 0 at the start and counts body1's turn (slide) relative to
        body0 about (along) the axis, as the scene's limits do; a revolute joint's limits in
        degrees (the UsdPhysics unit), every bound written (an unwritten one would lock the
        joint at 0: ovphysx's PhysicsRevoluteJoint notes). The two bodies do not collide
        (collisionEnabled false), and the joint stays a standalone PxJoint
        (excludeFromArticulation)."""
        joint = scene.joints[j]
        parent = None if joint.parent is None or scene.body(joint.parent).static else scene.body(joint.parent)
        on_axis = z_to(joint.unit_axis)
        record: dict = {"prim": JOINT_PRIMS[joint.kind], "body0": "world" if parent is None else parent.name,
                        "body1": joint.body, "collisionEnabled": False, "excludeFromArticulation": True}
        body_lines = []
        for side, body in ((0, parent), (1, scene.body(joint.body))):
            position, orientation = local_frame(body, joint.anchor, on_axis)
            if body is not None:
                body_lines.append(f'        rel physics:body{side} = <{self._paths[body.name]}>')
            body_lines += [f'        point3f physics:localPos{side} = {_v(position)}',
                           f'        quatf physics:localRot{side} = {_v(orientation)}']
            record.update({f"localPos{side}": position.tolist(), f"localRot{side}": orientation.tolist()})
        axis_lines, apis = self._joint_axis(joint, record)
        self.knobs.setdefault("joints", {})[f"joints[{j}]"] = record
        header = f'    def {JOINT_PRIMS[joint.kind]} "J{j}"' + (f' (prepend apiSchemas = {apis!r})'.replace("'", '"')
                                                                if apis else '')
        return [header, '    {', *body_lines, '        bool physics:collisionEnabled = 0',
                '        uniform bool physics:excludeFromArticulation = 1', *axis_lines, '    }']

    @staticmethod
    def _joint_axis(joint: Joint, record: dict) -> tuple[list[str], list[str]]:
        """The joint's axis, limits and limit tuning lines and the API schemas they need."""
        if joint.kind == "ball":  # no cone limit (-1: free; an unwritten one would be a zero cone)
            record.update(coneAngle0Limit=-1.0, coneAngle1Limit=-1.0)
            return ['        float physics:coneAngle0Limit = -1', '        float physics:coneAngle1Limit = -1'], []
        if joint.kind == "fixed":
            return [], []
        lower, upper = joint.limits if joint.limits is not None else (-math.inf, math.inf)
        if joint.kind == "revolute":
            lower, upper = math.degrees(lower), math.degrees(upper)
        record.update(axis="Z", lowerLimit=lower, upperLimit=upper)
        if joint.limits is not None:
            record["limits"] = list(joint.limits)
        lines = ['        uniform token physics:axis = "Z"', f'        float physics:lowerLimit = {lower!r}',
                 f'        float physics:upperLimit = {upper!r}']
        apis = []
        instance = AXIS_INSTANCES[joint.kind]
        if joint.limits is not None:  # the limit's restitution, bouncing at every closing speed (threshold 0)
            apis.append(f"PhysxLimitAPI:{instance}")
            lines += [f'        float physxLimit:{instance}:restitution = {float(joint.limit_e)!r}',
                      f'        float physxLimit:{instance}:bounceThreshold = 0',
                      f'        float physxLimit:{instance}:stiffness = 0', f'        float physxLimit:{instance}:damping = 0']
            record["PhysxLimitAPI"] = {"restitution": joint.limit_e, "bounceThreshold": 0.0, "stiffness": 0.0,
                                       "damping": 0.0}
            if joint.limit_e > 0:
                record["limitRestitution"] = joint.limit_e
        if joint.friction > 0:  # dry friction: a velocity drive at rate 0, its force bounded by the friction
            apis.append(f"PhysicsDriveAPI:{instance}")
            lines += [f'        uniform token drive:{instance}:physics:type = "force"',
                      f'        float drive:{instance}:physics:stiffness = 0',
                      f'        float drive:{instance}:physics:damping = {FRICTION_DAMPING!r}',
                      f'        float drive:{instance}:physics:targetVelocity = 0',
                      f'        float drive:{instance}:physics:maxForce = {float(joint.friction)!r}']
            record["friction"] = {"drive": "force, target velocity 0", "damping": FRICTION_DAMPING,
                                  "maxForce": joint.friction}
        return lines, apis

    def _load_bindings(self, scene: Scene) -> list:
        """The scene's constant loads as PhysX's external force (at the centre of mass) and
        wrench (its torque lanes; its force lanes 0, so its point does not matter) tensor
        bindings, one row a loaded body, written before every step: PhysX clears them after
        each (measured: a force written once moved a body for one step only, 0.0005 m/s of
        1 N on 2 kg at dt = 1 ms after 100 steps)."""
        import warnings

        from ovphysx.types import TensorType
        totals: dict[str, np.ndarray] = {}  # each loaded body's force and torque, summed over its loads
        for load in scene.loads:
            if load.acts:
                totals[load.body] = totals.get(load.body, np.zeros(6)) + np.concatenate([load.force, load.torque])
        out = []
        for kind, lanes in ((TensorType.RIGID_BODY_FORCE, slice(0, 3)), (TensorType.RIGID_BODY_WRENCH, slice(3, 6))):
            rows = [name for name, total in totals.items() if np.any(total[lanes])]
            if not rows:
                continue
            with warnings.catch_warnings():  # the tensor-binding API is deprecated since ovphysx 0.6.0
                warnings.simplefilter("ignore", DeprecationWarning)
                binding = self._physx.create_tensor_binding(prim_paths=[self._paths[name] for name in rows],
                                                            tensor_type=kind, raise_if_empty=True)
            data = np.zeros(binding.shape, np.float32)
            row_of = {path: i for i, path in enumerate(binding.prim_paths)}
            for name in rows:
                data[row_of[self._paths[name]], lanes] = totals[name][lanes]
            out.append((binding, data))
        for name, total in totals.items():
            self.knobs.setdefault("loads", {})[name] = {
                "RIGID_BODY_FORCE": total[:3].tolist(), "RIGID_BODY_WRENCH torque": total[3:].tolist(),
                "when": "before each step_sync (PhysX clears them after it)"}
        return out

    def _built_effects(self, scene: Scene, gravity, mats) -> frozenset[str]:
        fx = set()
        if np.any(gravity != 0.0):
            fx.add("gravity")
        if scene.contact_pairs():
            fx.add("contact")
            if any(v > 0 for v in mats["restitution"].values()):
                fx.add("restitution")
            if any(v > 0 for k in ("staticFriction", "dynamicFriction") for v in mats[k].values()):
                fx.add("friction")
        if any(b.rotates for b in scene.dynamic_bodies):
            fx.add("rotation")
        joints = self.knobs.get("joints", {}).values()
        if joints:
            fx.add("joint")
        if any("limitRestitution" in r for r in joints):
            fx.add("limit_restitution")
        if any("limits" in r for r in joints):
            fx.add("limit")
        if any("friction" in r for r in joints):
            fx.add("joint_friction")
        if self._loads:
            fx.add("load")
        return frozenset(fx)

    # --- stepping and reading -------------------------------------------------------------

    def _read_raw(self, names) -> dict:
        with self._physx.read_sync(self._types.RIGID_BODY, names, scope=self._scope.ALL) as r:
            return {i: g.tensors[0].numpy().copy() for i, g in enumerate(r.groups)}

    def _row_order(self) -> list[int]:
        """The read's rows in scene order, matched by the start positions."""
        if not self._order:
            return []
        pos = self._read_raw(["position"])[0].astype(float)
        rows = []
        for name in self._order:
            want = self._body_position(name)
            rows.append(int(np.argmin(np.linalg.norm(pos - want, axis=1))))
        if len(set(rows)) != len(rows):
            raise Unsupported("two dynamic bodies start at one position: the adapter cannot tell PhysX's rows apart")
        return rows

    def _body_position(self, name):
        return np.asarray(self._start[name], float)

    def step(self) -> None:
        for binding, data in self._loads:  # cleared by each step (_load_bindings)
            binding.write(data)
        self._physx.step_sync(self._dt)
        self._stepped = True

    def _state(self) -> tuple[np.ndarray, ...]:
        if not self._order:
            z = np.zeros((0, 3), np.float32)
            return z, np.zeros((0, 4), np.float32), z, z
        with self._physx.read_sync(self._types.RIGID_BODY, ["position", "orientation", "linearVelocity",
                                                            "angularVelocity"], scope=self._scope.ALL) as r:
            out = [g.tensors[0].numpy()[self._rows].copy() for g in r.groups]
        return tuple(out)

    def body_order(self) -> list[str]:
        return list(self._order)  # known without a read (also after close)

    def states(self) -> dict[str, np.ndarray]:
        p, q, v, w = self._state()
        return {name: state_row(p[i], xyzw_to_wxyz(q[i]), v[i], w[i]) for i, name in enumerate(self._order)}

    def contact_forces(self) -> dict[tuple[str, str], float]:
        if self._binding is None or not self._stepped:
            return {}
        self._binding.read_normal_force_matrix(self._matrix)
        out = {}
        for i, name in enumerate(self._order):
            for j, other in enumerate(self._filter_names[i]):
                f = float(np.linalg.norm(self._matrix[i, j]))
                key = pair_key(name, other)
                if f > 0.0 and key not in out:
                    out[key] = f
        return out

    def contact_points(self) -> list[ContactPoint]:
        """The geometry of each point of the last step's contact report, forces NaN, each
        normal turned into its sensor (module notes)."""
        if self._binding is None or not self._stepped:
            return []
        b = self._binding
        cap, filters = b.max_contact_data_count, b.filter_count
        x, n = np.zeros((cap, 3), np.float32), np.zeros((cap, 3), np.float32)
        forces, separations = np.zeros((cap, 1), np.float32), np.zeros((cap, 1), np.float32)
        counts, starts = np.zeros((len(self._order), filters), np.int32), np.zeros((len(self._order), filters), np.int32)
        total = b.read_normal_contact_data(forces, x, n, separations, counts, starts)
        if total > cap:
            raise RuntimeError(f"PhysX reported {total} contact points, more than the binding's {cap}: raise "
                               "POINTS_PER_PAIR in adapters/physx_engine.py")
        centres = self._state()[0]
        rank = {name: i for i, name in enumerate(self._order)}
        out = []
        for i, j in zip(*np.nonzero(counts)):  # the touching (sensor, filter) entries only
            name, other = self._order[i], self._filter_names[i][j]
            if rank.get(other, len(rank)) < i:  # a dynamic pair: read from its first sensor
                continue
            for k in range(starts[i, j], starts[i, j] + counts[i, j]):
                xk, nk = x[k].astype(float), n[k].astype(float)
                if nk @ (centres[i] - xk) < 0.0:  # PhysX's normal from the second shape: into the sensor
                    nk = -nk
                out.append(ContactPoint(name, other, xk, nk, math.nan, np.full(3, math.nan), float(separations[k, 0])))
        return out

    def close(self) -> None:
        physx, self._physx = getattr(self, "_physx", None), None
        if physx is None:
            return
        if self._binding is not None:
            self._binding.destroy()
            self._binding = None
        for binding, _ in getattr(self, "_loads", []):
            binding.destroy()
        self._loads = []
        physx.wait_task(physx.detach_ovstage())
        self._stage.destroy()
        physx.destroy()
        os.unlink(self._file)
