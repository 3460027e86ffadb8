"""Box3D (Box2D v3's soft-step solver in 3D) behind the engine contract, through the C API
that the `robox3d` wheel exposes with cffi (robox3d._ffi: `lib` is libbox3d, `shim` a
batch read-out). robox3d 0.1.0 bundles Box3D 0.1.0, in float32 (b3IsDoublePrecision is
false): positions, velocities and material values are rounded to 2^-24 relative.

What one `b3World_Step(dt, n)` does is Box2D v3's step (adapters/box2d_engine.py module
notes): contacts found for the whole step, speculative ones included; n sub-steps of
h = dt/n, each integrating gravity into the velocities, a soft contact solve with a
push-out bias, positions, and a relax solve without the bias; then restitution on each
point that approached faster than the restitution threshold, against its normal velocity
before the step. `Settings.iterations` is n.

Continuous collision ("box3d-bullet", `bullet=True`): as adapters/box2d_engine.py's
"box2d-bullet", continuous collision on and each fast dynamic body a bullet; measured the
same way (stopped from 1.75 and 5 cm; with every dynamic body a bullet, passes from 5 cm).

Faithful mapping (each setting recorded in `knobs`):
- pair materials exactly: Box3D mixes a pair's friction and restitution through the
  world's friction and restitution callbacks, which receive the two shapes'
  `userMaterialId`s; each body's shape carries its own id and the callbacks return the
  scene's pair value (no per-body combination rule is needed);
- restitution threshold 0 (Box3D's default 1 m/s takes all bounce from slower impacts),
  no sleeping, no continuous collision (time-of-impact clamping of fast bodies moves them),
  no speed cap that can act, no contact recycling (Box3D reuses a pair's manifold while
  the bodies move little; off, every step's manifold is found anew), fast rotation allowed
  (otherwise the rotation per sub-step is clamped), damping 0, gravity scale 1;
- mass and inertia as the scene states them (b3Body_SetMassData), the inertia diagonal in
  the body frame (the shapes' principal axes);
- rotation held by motion locks; 2D scenes in the x-z plane by locking y and the rotation
  about x and z; a circle is a sphere and a rect a box as deep along y as its larger half
  extent (pybullet_engine's choice: every contact lies in y = 0);
- a plane is a static box, PLANE_HALF_WIDTH wide, its top face the plane, centred under the
  dynamic bodies' mean position (float32 places the box's vertices, which contact
  clipping is relative to, to 2^-24 of its size);
- a capsule is Box3D's capsule (b3Capsule, its segment on body z); a hull is b3CreateHull of
  its corners, every corner kept (a hull Box3D would simplify, or cannot index in uint8,
  is unsupported; so is one thinner than HULL_THINNEST of its size, on which b3CreateHull
  can hang); Box3D has no cylinder, so a cylinder is the 42-sided prism inscribed in it
  (CYLINDER_SIDES, the finest a hull holds); a 2D polygon is the hull of its prism along y
  (adapters/solids.py); a static mesh is b3CreateMesh of its vertices and triangles (no
  welding, edges between triangles classified: MESH_IDENTIFY_EDGES), which Box3D's mesh
  contact keeps bodies MESH_REST_OFFSET (5 mm) away from;
- the push-out spring at Box2D's cap, 1/8 of the sub-step rate (as adapters/box2d_engine.py:
  a rigid contact has no compliance; Box3D's default 30 Hz lets a resting ball sit 65 um
  deep, measured), damping ratio 10 and push speed 3 m/s Box3D's defaults.

Contact forces from what the bodies did (adapters.impulse_split, as adapters/box2d_engine.py):
body i took J_i = m_i (v_i' - v_i) - m_i g dt from its contacts in a step, split over the
pairs whose manifolds have points (Box3D's own contacts) along each pair's manifold normal
(plus a tangential part on a frictional pair), and a pair's normal force is the normal part
over dt: unique on a forest of contacts and on cycles of frictionless ones (a sphere in a
V-groove of two frictionless planes at 45 deg: 6.9367 N a face for m g / (2 cos alpha) =
6.9367). Friction around a cycle leaves the normal impulses open: the split with the least
friction is returned and `knobs` ("pair_split") says so; Box3D itself then carries its own
share (with mu 0.5 that groove's points end with 6.31 N a face, last sub-step impulse times
4, and friction the rest; measured). The manifold points' own `normalImpulse` is the
last sub-step's impulse only: on a resting 5-box stack its mean over 1 s is 49.77 N at the
ground for the weight 49.05 N (std 2.2 N), where the momentum read gives 49.0501 N
(measured). No per-point forces (`contact_points` is False): a manifold carries one
friction impulse for all its points.

`contact_points` gives the geometry of every manifold point of the last step and not its
forces (`Capabilities.contact_geometry`: f_n and f_t NaN). Box3D finds its manifolds at the
start of the step from the poses then (contact recycling is off, so every step's are found
anew): each point's `anchorA` is the point relative to body A's centre of mass (its origin:
the adapter sets the mass data about it) in world axes at those poses, so the point is
body A's position before the step plus anchorA; `separation` is its signed distance
(positive: a speculative point, up to 4 linear slops apart); the manifold `normal` points
from shape A to shape B, so the point's a is B's body and b is A's (n from b into a).
"""
from __future__ import annotations

import itertools
import math
from importlib import metadata

import numpy as np

from adapters.base import Adapter, Capabilities, Settings, Simulation, Tunable, Unsupported
from adapters.frames import state_row, wxyz_to_xyzw, xyzw_to_wxyz, z_to
from adapters.impulse_split import OPEN_SPLIT, acting_pairs, split_impulses
from adapters.lazy import require
from adapters.solids import cylinder_prism, embedded_half_depth, polygon_prism, starts_fast
from cases.scene import Body, Plane, Scene, pair_key
from cases.trajectory import ContactPoint

require("robox3d")  # not installed: ImportError now, so the registry reports it
ffi = lib = shim = None  # robox3d._ffi's, bound when a scene is first built (importing takes ~0.5 s)

DEFAULT_SUBSTEPS = 4  # Box2D v3's recommended sub-step count; robox3d's World default too
# How Box3D resolves an impact through bodies already touching (Capabilities.impact_model),
# measured (dt = 1e-3, e = 1, no gravity, a 1 kg ball under a 0.1 kg one landing at 2 m/s):
# where the balls touch without overlapping (gap 0 to 1e-4 m) the pair takes no impulse in
# the landing step, which bounces the bottom ball alone, and the next step resolves the pair
# as an impact of its own: 1.273 and 5.273 m/s, the sequential closed form's 1.2727 and
# 5.2727 (cases/column_impact.py); the simultaneous model's is 2 and 2. Dropped together
# from 0.2 m under gravity the same, to 1e-4 m/s. Pressed 1 um into each other (the column
# family's scenes) the pair does take part in the landing step's soft solve, without
# restitution (its approach before the step is 0), and gets its bounce as an impact of its
# own two steps later: 1.668 and 3.495 m/s, neither model (adapters/xfails/box3d.txt).
IMPACT_MODEL_MEASURED = "sequential"
HERTZ_CAP_PER_SUBSTEP_RATE = 0.125  # Box2D's clamp of contact_hertz (src/world.c), asked for
CONTACT_DAMPING_RATIO = 10.0  # Box3D's default (b3DefaultWorldDef)
CONTACT_PUSH_SPEED = 3.0      # Box3D's default (b3DefaultWorldDef), m/s
MAXIMUM_LINEAR_SPEED = 1e4    # never acts (default 400 m/s; the harness calls > 100 m/s a blow-up)
PLANE_HALF_WIDTH = 100.0      # m
PLANE_HALF_DEPTH = 0.5        # m: deeper than any overlap the scenes make
# Box3D has no cylinder (b3CreateCylinder makes a hull): a Cylinder is the regular prism with
# this many sides inscribed in it, the most a Box3D hull holds (its vertices, half-edges and
# faces are indexed by uint8: 42 sides make 252 half-edges, 43 are refused; measured). Its
# flat sides lie r cos(pi / 42) = 0.99720 r from the axis: lying on its side it rests 2.8e-3 r
# low and rolls over 42 edges a turn.
CYLINDER_SIDES = 42
# b3CreateHull in float32 (robox3d 0.1.0, measured on 1 m square plates): a plate 1e-5 m
# thick keeps its 8 corners, one 3e-6 to 8e-6 m thick makes b3CreateHull loop without end,
# one 1.5e-6 to 2.5e-6 m thick is flattened to 4 corners and thinner ones are refused. So a
# hull thinner than this fraction of its size (its largest coordinate about its centre: five
# times the thinnest plate measured safe, 2e-5, and the hangs at 0.6-1.6e-5) is refused
# before Box3D sees it.
HULL_THINNEST = 1e-4
# b3MeshDef.identifyEdges: Box3D marks each edge between two triangles flat, concave or convex,
# so a body sliding across the flat edge of two coplanar triangles meets no ghost contact on it.
MESH_IDENTIFY_EDGES = True
# Box3D's mesh contact pushes a body out to this distance from a mesh's triangles
# (B3_MESH_REST_OFFSET, one linear slop; a compile-time constant, not settable: "a small
# visual gap", src/mesh_contact.c): a body rests 5 mm above a mesh ground, where it rests on a
# plane's box, and one placed on the mesh is pushed out at up to contactSpeed (measured: a
# 0.1 m box placed touching jumps 23 mm at the default 3 m/s).
MESH_REST_OFFSET = 0.005  # m

# userMaterialId -> (scene key, body name); each simulation takes a block of ids
_MATERIALS: dict[int, tuple[int, str]] = {}
_PAIRS: dict[int, dict[tuple[str, str], tuple[float, float]]] = {}  # scene key -> pair -> (mu, e)
_KEYS = itertools.count(1)
_IDS_PER_SCENE = 1 << 20
_callbacks = None


def _load() -> None:
    """Import robox3d's FFI layer and make the two material callbacks (once a process)."""
    global ffi, lib, shim, _callbacks
    if lib is not None:
        return
    from robox3d._ffi import ffi as _ffi, lib as _lib, shim as _shim
    ffi, lib, shim = _ffi, _lib, _shim

    def mixed(index):
        def value(_a, id_a, _b, id_b):
            key, name_a = _MATERIALS[id_a]
            return _PAIRS[key][pair_key(name_a, _MATERIALS[id_b][1])][index]
        return value

    _callbacks = (ffi.callback("float(float, uint64_t, float, uint64_t)", mixed(0)),
                  ffi.callback("float(float, uint64_t, float, uint64_t)", mixed(1)))


def _vec(v):
    out = ffi.new("b3Vec3*")
    out.x, out.y, out.z = (float(c) for c in v)
    return out[0]


def _quat(q_wxyz, target) -> None:
    x, y, z, w = wxyz_to_xyzw(q_wxyz)
    target.v.x, target.v.y, target.v.z, target.s = x, y, z, w


def _thinness(points: np.ndarray) -> float:
    """The smallest width of the points' hull across one of its faces, over their largest
    coordinate (the hull's size about its centre)."""
    from scipy.spatial import ConvexHull
    normals = ConvexHull(points).equations[:, :3]
    extent = points @ normals.T
    return float((extent.max(axis=0) - extent.min(axis=0)).min() / np.abs(points).max())


class Box3DAdapter(Adapter):
    name = "box3d"
    package = "robox3d"
    # the release the conformance battery ran on (it bundles Box3D 0.1.0); 0.x: the next minor
    # may change the API
    supported = ">=0.1.0,<0.2"
    capabilities = Capabilities(
        dimensions=frozenset({2, 3}),
        # a cylinder is a 42-sided prism (CYLINDER_SIDES), a polygon a prism along y, a mesh static
        shapes=frozenset({"sphere", "box", "plane", "circle", "rect", "capsule", "cylinder", "hull", "polygon",
                          "mesh"}),
        native_restitution=True,
        static_kinetic=False,  # one friction coefficient per pair
        contact_forces=True,
        contact_forces_beside_joints=False,  # the momenta hold the joints' impulses too
        iterations=True,       # the sub-step count
        contact_points=False,
        contact_geometry=True,  # each manifold point's place, normal and separation (module notes)
        impact_model=IMPACT_MODEL_MEASURED,  # touching bodies take an impact one pair a step
        restitution_law="two_phase",  # Box2D v3's relax pass: restitution after the sub-steps, without friction
        float_bits=32,         # positions, velocities and masses in single precision
        substeps=True,         # Settings.iterations is the sub-step count
        # Box3D's joints (_joint): soft constraint rows between the bodies' own coordinates,
        # solved in the sub-steps with the contacts, as Box2D's
        joints=frozenset({"revolute", "prismatic", "ball", "fixed"}),
        joint_limits=True,
        joint_friction=True,  # a motor at speed 0 bounded by the friction (_joint), as Box2D's
        coordinates="maximal",
        loads=True,  # b3Body_ApplyForceToCenter and b3Body_ApplyTorque before each step (Box3D clears them)
        why_not=(("limit_restitution", "a joint's limit takes a range only (lowerAngle and upperAngle, lowerTranslation "
                                       "and upperTranslation): Box3D's limit rows have no restitution"),),
    )
    tunables = {
        "contact_hertz": Tunable(1.0, math.inf, math.inf,
                                 "push-out stiffness, Hz (default: Box2D's cap, 1/8 of the sub-step rate)"),
        "contact_damping_ratio": Tunable(0.0, 100.0, CONTACT_DAMPING_RATIO, "push-out damping ratio"),
        "contact_push_speed": Tunable(0.0, 100.0, CONTACT_PUSH_SPEED, "largest push-out speed, m/s"),
    }

    def __init__(self, name: str = "box3d", bullet: bool = False):
        """bullet: Box3D's continuous collision on, each fast dynamic body a bullet (isBullet;
        "box3d-bullet", as adapters/box2d_engine.py)."""
        self.name = name
        self.bullet = self.continuous_collision(bullet)

    def version(self) -> str:
        return metadata.version("robox3d")

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene)
        if reason:
            raise Unsupported(reason)
        _load()
        return Box3DSimulation(scene, settings, self.options_in_force(settings), self.bullet)


class Box3DSimulation(Simulation):
    def __init__(self, scene: Scene, settings: Settings, tuning: dict[str, float], bullet: bool = False):
        self._bullet = bullet
        self._dt = settings.dt
        self.iterations = DEFAULT_SUBSTEPS if settings.iterations is None else settings.iterations
        self._h = self._dt / self.iterations
        hertz = min(tuning["contact_hertz"], HERTZ_CAP_PER_SUBSTEP_RATE / self._h)
        self._key = next(_KEYS)
        self._world = None
        effects = scene.effects
        _PAIRS[self._key] = {
            pair_key(a.name, b.name): (m.mu_s if "friction" in effects else 0.0, m.e if "restitution" in effects else 0.0)
            for a, b in scene.contact_pairs() for m in [scene.material_of(a.name, b.name)]}
        gravity = scene.gravity if "gravity" in effects else (0.0, 0.0, 0.0)
        wd = lib.b3DefaultWorldDef()
        wd.gravity = _vec(gravity)
        wd.restitutionThreshold = 0.0
        wd.enableSleep = False
        wd.enableContinuous = bullet
        wd.maximumLinearSpeed = MAXIMUM_LINEAR_SPEED
        wd.contactHertz = hertz
        wd.contactDampingRatio = tuning["contact_damping_ratio"]
        wd.contactSpeed = tuning["contact_push_speed"]
        wd.frictionCallback, wd.restitutionCallback = _callbacks
        wd.workerCount = 1
        self._world = lib.b3CreateWorld(ffi.addressof(wd))
        self.knobs = {
            "b3WorldDef": {"gravity": list(gravity), "restitutionThreshold": 0.0, "enableSleep": False,
                           "enableContinuous": bullet, "maximumLinearSpeed": MAXIMUM_LINEAR_SPEED,
                           "contactHertz": hertz, "contactDampingRatio": tuning["contact_damping_ratio"],
                           "contactSpeed": tuning["contact_push_speed"], "workerCount": 1,
                           "frictionCallback": "the scene's pair mu", "restitutionCallback": "the scene's pair e"},
            "subStepCount": self.iterations,
            "speculative": True,  # Box3D's default: contacts found before they touch
            "warm_starting": True,  # Box3D's default
            "pair": {"|".join(k): {"friction": v[0], "restitution": v[1]} for k, v in _PAIRS[self._key].items()},
            "contact_force": ("momentum: J_i = m (v' - v) - m g dt per body, split over the pairs with manifold "
                              "points along their normals (adapters/impulse_split.py)"),
            "bodies": {},
        }
        self._planar = scene.dimension == 2
        dynamic = scene.dynamic_bodies
        self._centre = np.mean([b.position for b in dynamic], axis=0) if dynamic else np.zeros(3)
        self._names: dict[int, str] = {}  # shape index1 -> body name
        self._shape_ids: dict[str, object] = {}  # body name -> b3ShapeId
        self._hulls, self._meshes, self._keep = [], [], []  # Box3D geometry, freed after the world (close)
        self._ids: list = []              # dynamic bodies' b3BodyIds, in scene order
        self._order: list[str] = []
        self._every: dict[str, tuple] = {}  # every body's (b3BodyId, start position, orientation), for joints
        try:
            for i, body in enumerate(scene.bodies):
                self._add(body, self._key * _IDS_PER_SCENE + i)
            self._joints = [self._joint(joint, j) for j, joint in enumerate(scene.joints)]
        except Unsupported:  # a shape Box3D cannot hold (`_hull`, `_mesh`): the world goes too
            self.close()
            raise
        self._id_array = ffi.new("b3BodyId[]", self._ids)
        n = len(self._ids)
        self._poses = np.empty((n, 7), np.float32)
        self._vels = np.empty((n, 6), np.float32)
        self._contacts = ffi.new("b3ContactData[]", 64)
        self._mass = np.array([lib.b3Body_GetMass(bid) for bid in self._ids])  # as Box3D holds them
        # the scene's constant loads: Box3D clears a body's applied force and torque at the
        # end of each b3World_Step, so step() applies them again before each (the force at
        # the centre of mass); the velocity a step's force gives is taken out of the
        # momenta with gravity's (_read_forces)
        self._loads = []
        accel = np.tile(np.asarray(gravity, float), (n, 1))
        for load in scene.loads:
            if load.acts:
                i = self._order.index(load.body)
                force, torque = ffi.new("b3Vec3*"), ffi.new("b3Vec3*")  # kept: the step passes them by value
                force.x, force.y, force.z = (float(c) for c in load.force)
                torque.x, torque.y, torque.z = (float(c) for c in load.torque)
                self._loads.append((self._ids[i], force, torque))
                accel[i] += np.asarray(load.force, float) / self._mass[i]
                self.knobs.setdefault("loads", {})[load.body] = {
                    "b3Body_ApplyForceToCenter": list(load.force), "b3Body_ApplyTorque": list(load.torque),
                    "when": "before each b3World_Step (Box3D clears them after it)"}
        self._g_dt = accel * self._dt  # each body's velocity change from gravity and its load
        self._pending = None  # the velocities before and after the last step
        self._poses_before = None  # the poses before the last step (contact_points)
        self._forces: dict | None = {}
        self.knobs["pair_split"] = "unique"
        self.effects = self._built_effects(scene, gravity)

    def _add(self, body: Body, material_id: int) -> None:
        bd = lib.b3DefaultBodyDef()
        record: dict = {}
        s = body.shape
        if isinstance(s, Plane):
            n = np.asarray(s.normal, float)
            foot = self._centre - (self._centre @ n - s.offset) * n  # the plane's point under the bodies
            position, orientation = foot - PLANE_HALF_DEPTH * n, z_to(n)
        else:
            position, orientation = body.position, body.orientation
        bd.type = lib.b3_staticBody if body.static else lib.b3_dynamicBody
        bd.position = _vec(position)
        _quat(orientation, bd.rotation)
        bd.enableSleep = False
        bd.allowFastRotation = True
        bd.enableContactRecycling = False
        bd.linearDamping = bd.angularDamping = 0.0
        bd.gravityScale = 1.0
        if body.dynamic:
            bd.isBullet = bullet = self._bullet and starts_fast(body, self._dt)  # fast bodies only (box2d_engine)
            bd.linearVelocity = _vec(body.velocity)
            bd.angularVelocity = _vec(body.angular_velocity if body.rotates else (0.0, 0.0, 0.0))
            locks = {"linearY": self._planar, "angularX": self._planar or not body.rotates,
                     "angularY": not body.rotates, "angularZ": self._planar or not body.rotates}
            for k, v in locks.items():
                setattr(bd.motionLocks, k, v)
            record["motionLocks"] = [k for k, v in locks.items() if v]
        bid = lib.b3CreateBody(self._world, ffi.addressof(bd))
        self._every[body.name] = (bid, np.asarray(position, float), tuple(orientation))
        sd = lib.b3DefaultShapeDef()
        sd.baseMaterial.userMaterialId = material_id
        # Box3D's rolling resistance (b3SurfaceMaterial.rollingResistance; a pair takes the larger
        # of its shapes') is not the bound |tau| <= d N that rolling_resistance asks for (measured
        # on that family's ball, r = 0.1 m): rolling on the flat it brakes at 8.76 rr m/s^2, 1.25x
        # Box2D's law with the lever rr r, and a ball released at rest on a 10 deg slope is held by
        # rr = 0.001, where holding needs a lever of r tan(10 deg) = 18 mm; Box3D has no torsional
        # friction value. So the adapter declares no contact torques and sets none.
        sd.baseMaterial.rollingResistance = 0.0
        sd.density = 1.0  # replaced by the stated mass below
        _MATERIALS[material_id] = (self._key, body.name)
        shape = self._shape(bid, sd, body, position, record)
        self._shape_ids[body.name] = shape
        self._names[shape.index1] = body.name
        if body.dynamic:
            md = ffi.new("b3MassData*")
            md.mass = body.mass
            md.center = _vec((0.0, 0.0, 0.0))
            ix, iy, iz = body.principal_inertia
            md.inertia.cx, md.inertia.cy, md.inertia.cz = _vec((ix, 0, 0)), _vec((0, iy, 0)), _vec((0, 0, iz))
            lib.b3Body_SetMassData(bid, md[0])
            # b3Body_SetMassData leaves the world-frame inverse inertia of the shapes' density
            # in force for the first step (measured: a 1 kg ball made of density-1 material,
            # created sliding on the ground, spins up to 8.8 rad/s in that step instead of
            # 0.05); setting the same pose again refreshes it
            lib.b3Body_SetTransform(bid, lib.b3Body_GetPosition(bid), lib.b3Body_GetRotation(bid))
            self._ids.append(bid)
            self._order.append(body.name)
            record.update(mass=lib.b3Body_GetMass(bid), inertia_diagonal=[ix, iy, iz], linearDamping=0.0,
                          angularDamping=0.0, enableSleep=False, allowFastRotation=True,
                          enableContactRecycling=False, isBullet=bullet)
        else:
            record["static"] = True
        self.knobs["bodies"][body.name] = record

    def _shape(self, bid, sd, body: Body, position, record: dict):
        """Create the body's shape in Box3D and note how it was made in `record`."""
        s = body.shape
        if s.kind in ("sphere", "circle"):  # a circle: a sphere of its radius, every contact in y = 0
            sphere = ffi.new("b3Sphere*")
            sphere.center = _vec((0.0, 0.0, 0.0))
            sphere.radius = s.radius
            record["sphere"] = {"radius": s.radius}
            return lib.b3CreateSphereShape(bid, ffi.addressof(sd), sphere)
        if s.kind == "capsule":  # its segment along body z
            capsule = ffi.new("b3Capsule*")
            capsule.center1, capsule.center2 = _vec((0.0, 0.0, -s.half_length)), _vec((0.0, 0.0, s.half_length))
            capsule.radius = s.radius
            record["capsule"] = {"center1": [0.0, 0.0, -s.half_length], "center2": [0.0, 0.0, s.half_length],
                                 "radius": s.radius}
            return lib.b3CreateCapsuleShape(bid, ffi.addressof(sd), capsule)
        if s.kind == "mesh":
            data = self._mesh(body)
            record["mesh"] = {"vertices": len(s.vertices), "triangles": len(s.triangles), "weldVertices": False,
                              "weldTolerance": 0.0, "identifyEdges": MESH_IDENTIFY_EDGES, "useMedianSplit": False,
                              "scale": [1.0, 1.0, 1.0], "rest_offset": MESH_REST_OFFSET}  # B3_MESH_REST_OFFSET, fixed
            return lib.b3CreateMeshShape(bid, ffi.addressof(sd), data, _vec((1.0, 1.0, 1.0)))
        if s.kind in ("box", "rect", "plane"):
            if s.kind == "plane":
                half = (PLANE_HALF_WIDTH, PLANE_HALF_WIDTH, PLANE_HALF_DEPTH)
                record["plane_as_box"] = {"top_face_through": list(position + PLANE_HALF_DEPTH * np.asarray(s.normal)),
                                          "normal": list(s.normal)}
            elif s.kind == "box":
                half = tuple(s.half_extents)
            else:  # rect: a box as deep along y as its larger half-extent
                a, c = s.half_extents
                half = (a, max(a, c), c)
            hull = ffi.new("b3BoxHull*")
            hull[0] = lib.b3MakeBoxHull(*half)
            self._keep.append(hull)
            record["box_hull"] = {"half_extents": list(half)}
            return lib.b3CreateHullShape(bid, ffi.addressof(sd), ffi.addressof(hull.base))
        if s.kind == "cylinder":  # no cylinder in Box3D: the finest prism a hull holds (CYLINDER_SIDES)
            points = cylinder_prism(s.radius, s.half_length, CYLINDER_SIDES)
            record["cylinder_as_hull"] = {"sides": CYLINDER_SIDES, "radius": s.radius, "half_length": s.half_length,
                                          "corners": "on the rim (inscribed)",
                                          "apothem": s.radius * math.cos(math.pi / CYLINDER_SIDES)}
        elif s.kind == "polygon":  # a prism along y (adapters/solids.py)
            depth = embedded_half_depth(s.corners)
            points = polygon_prism(s.corners, depth)[0]
            record["polygon_as_hull"] = {"corners": [[float(x), float(z)] for x, z in s.corners], "half_depth": depth}
        else:  # hull
            points = np.asarray(s.vertices, float)
            record["hull"] = {"vertices": len(points)}
        return lib.b3CreateHullShape(bid, ffi.addressof(sd), self._hull(body, points))

    def _hull(self, body: Body, points: np.ndarray):
        """b3CreateHull of `points` with every point kept as a corner (maxVertexCount = their
        number; Unsupported where Box3D merges or drops one, or cannot hold the hull)."""
        thin = _thinness(points)
        if thin < HULL_THINNEST:
            raise Unsupported(f"{body.shape.kind} {body.name!r}: {thin:.2g} of its size thick, thinner than "
                              f"{HULL_THINNEST:g}: Box3D's b3CreateHull hangs or flattens such hulls (measured)")
        c = ffi.new("b3Vec3[]", len(points))
        np.frombuffer(ffi.buffer(c), dtype=np.float32)[:] = np.asarray(points, np.float32).ravel()
        hull = lib.b3CreateHull(c, len(points), len(points))
        if hull == ffi.NULL or hull.vertexCount != len(points):
            kept = 0 if hull == ffi.NULL else hull.vertexCount
            if hull != ffi.NULL:
                lib.b3DestroyHull(hull)
            raise Unsupported(f"{body.shape.kind} {body.name!r}: Box3D's b3CreateHull keeps {kept} of its "
                              f"{len(points)} corners (a hull holds at most 256 half-edges, and float32 merges "
                              "corners closer than its tolerance)")
        self._hulls.append(hull)
        return hull

    def _mesh(self, body: Body):
        """b3CreateMesh of a scene Mesh: its vertices and triangles as given (no welding), the
        edges between triangles classified (`MESH_IDENTIFY_EDGES`)."""
        s = body.shape
        vertices = ffi.new("b3Vec3[]", len(s.vertices))
        np.frombuffer(ffi.buffer(vertices), dtype=np.float32)[:] = np.asarray(s.vertices, np.float32).ravel()
        indices = ffi.new("int32_t[]", [int(i) for t in s.triangles for i in t])
        md = ffi.new("b3MeshDef*")
        md.vertices, md.indices, md.materialIndices = vertices, indices, ffi.NULL
        md.vertexCount, md.triangleCount = len(s.vertices), len(s.triangles)
        md.weldVertices, md.weldTolerance = False, 0.0
        md.useMedianSplit = False
        md.identifyEdges = MESH_IDENTIFY_EDGES
        degenerate = ffi.new("int[]", len(s.triangles))
        data = lib.b3CreateMesh(md, degenerate, len(s.triangles))
        if data == ffi.NULL or data.degenerateCount:
            count = 0 if data == ffi.NULL else data.degenerateCount
            if data != ffi.NULL:
                lib.b3DestroyMesh(data)
            raise Unsupported(f"mesh {body.name!r}: Box3D's b3CreateMesh finds {count} degenerate triangles in float32 "
                              f"(first: triangles[{degenerate[0]}])")
        self._meshes.append(data)  # Box3D holds a reference: freed after the world (close)
        return data

    def _built_effects(self, scene: Scene, gravity) -> frozenset[str]:
        fx = set()
        if any(g != 0.0 for g in gravity):
            fx.add("gravity")
        pairs = _PAIRS[self._key]
        if pairs:
            fx.add("contact")
            if any(e > 0 for _, e in pairs.values()):
                fx.add("restitution")
            if any(mu > 0 for mu, _ in pairs.values()):
                fx.add("friction")
        if any(b.rotates for b in scene.dynamic_bodies):
            fx.add("rotation")
        if self._joints:
            fx.add("joint")
        if any("limits" in r for r in self.knobs.get("joints", {}).values()):
            fx.add("limit")
        if any("friction" in r for r in self.knobs.get("joints", {}).values()):
            fx.add("joint_friction")
        if self._loads:
            fx.add("load")
        return frozenset(fx)

    def _joint(self, joint, j: int) -> str:
        """A scene joint as a Box3D joint between the parent (body A; the world: a static body
        at the origin, made once) and the body (B). Each body's local frame sits at the anchor
        with its z axis (a revolute joint's) or x axis (a prismatic joint's) along the scene's
        axis (Box3D's hinge and slide axes); a limit bounds
        B's turn (slide) relative to A about (along) it; a dry friction is the joint's motor held
        at speed 0 with its force bounded by it. No springs, collideConnected off (cases.scene.Joint); the constraints' softness Box3D's default."""
        from scipy.spatial.transform import Rotation
        if joint.parent is None and "world" not in self._every:
            bd = lib.b3DefaultBodyDef()
            bd.type = lib.b3_staticBody
            self._every["world"] = (lib.b3CreateBody(self._world, ffi.addressof(bd)), np.zeros(3), (1.0, 0.0, 0.0, 0.0))
        make = {"revolute": (lib.b3DefaultRevoluteJointDef, lib.b3CreateRevoluteJoint),
                "prismatic": (lib.b3DefaultPrismaticJointDef, lib.b3CreatePrismaticJoint),
                "ball": (lib.b3DefaultSphericalJointDef, lib.b3CreateSphericalJoint),
                "fixed": (lib.b3DefaultWeldJointDef, lib.b3CreateWeldJoint)}[joint.kind]
        jd = make[0]()
        anchor = np.asarray(joint.anchor, float)
        # Box3D 0.1.0 turns a revolute joint about its frames' z axis but slides a prismatic
        # one along their x axis (measured: a slider on frames with z on a horizontal axis
        # fell freely under gravity along the frames' x, and one with z on the vertical held)
        along = [1.0, 0.0, 0.0] if joint.kind == "prismatic" else [0.0, 0.0, 1.0]
        z_on_axis = Rotation.align_vectors([joint.unit_axis], [along])[0]
        record = {"kind": joint.kind, "collideConnected": False}
        for (bid, x0, q0), frame, side in ((self._every["world" if joint.parent is None else joint.parent],
                                            jd.base.localFrameA, "A"),
                                           (self._every[joint.body], jd.base.localFrameB, "B")):
            w, x, y, z = q0
            inverse = Rotation.from_quat([x, y, z, w]).inv()
            frame.p = _vec(inverse.apply(anchor - x0))
            qx, qy, qz, qw = (inverse * z_on_axis).as_quat()
            frame.q.v.x, frame.q.v.y, frame.q.v.z, frame.q.s = qx, qy, qz, qw
            record[f"localFrame{side}"] = {"p": inverse.apply(anchor - x0).tolist(), "q_xyzw": [qx, qy, qz, qw]}
        jd.base.bodyIdA = self._every["world" if joint.parent is None else joint.parent][0]
        jd.base.bodyIdB = self._every[joint.body][0]
        jd.base.collideConnected = False
        if joint.limits is not None:
            jd.enableLimit = True
            if joint.kind == "revolute":
                jd.lowerAngle, jd.upperAngle = joint.limits
            else:
                jd.lowerTranslation, jd.upperTranslation = joint.limits
            record["limits"] = list(joint.limits)
        if joint.friction > 0:  # dry friction: a motor held at speed 0 whose force (torque) is bounded by it
            jd.enableMotor, jd.motorSpeed = True, 0.0
            if joint.kind == "revolute":
                jd.maxMotorTorque = joint.friction
                record.update(friction="motor at speed 0", maxMotorTorque=joint.friction)
            else:
                jd.maxMotorForce = joint.friction
                record.update(friction="motor at speed 0", maxMotorForce=joint.friction)
        make[1](self._world, ffi.addressof(jd))
        self.knobs.setdefault("joints", {})[f"joints[{j}]"] = record
        return joint.kind

    # --- stepping and reading -------------------------------------------------------------

    def step(self) -> None:
        poses, vels = self._read()
        before = vels.astype(float)
        self._poses_before = poses.copy()  # where Box3D found this step's manifolds (contact_points)
        for body, force, torque in self._loads:
            lib.b3Body_ApplyForceToCenter(body, force[0], False)
            lib.b3Body_ApplyTorque(body, torque[0], False)
        lib.b3World_Step(self._world, self._dt, self.iterations)
        self._pending = (before, self._read()[1].astype(float))
        self._forces = None  # worked out when asked for (contact_forces), not inside the step

    def _read(self) -> tuple[np.ndarray, np.ndarray]:
        n = len(self._ids)
        shim.rxBodyGetPoses(self._id_array, n, ffi.cast("float*", ffi.from_buffer(self._poses)))
        shim.rxBodyGetVelocities(self._id_array, n, ffi.cast("float*", ffi.from_buffer(self._vels)))
        return self._poses, self._vels

    def states(self) -> dict[str, np.ndarray]:
        poses, vels = self._read()
        return {name: state_row(poses[i, :3], xyzw_to_wxyz(poses[i, 3:7]), vels[i, :3], vels[i, 3:6])
                for i, name in enumerate(self._order)}

    # Bulk reads (adapters.base): poses (x, y, z, qx, qy, qz, qw) then velocities (v, w), as float32.
    def body_order(self) -> list[str]:
        return list(self._order)

    def state_size(self) -> int:
        return 13 * len(self._ids)

    def write_state(self, out: np.ndarray) -> None:
        poses, vels = self._read()
        n = len(self._ids)
        out[:7 * n] = poses.ravel()
        out[7 * n:] = vels.ravel()

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        n = len(self._ids)
        poses = raw[:, :7 * n].reshape(len(raw), n, 7)
        vels = raw[:, 7 * n:].reshape(len(raw), n, 6)
        out = np.empty((len(raw), n, 13))
        out[..., 0:3] = poses[..., 0:3]
        out[..., 3] = poses[..., 6]
        out[..., 4:7] = poses[..., 3:6]
        out[..., 7:13] = vels
        return out

    def _contacts_of(self, bid):
        """The b3ContactData of a body's contacts (a buffer reused between calls)."""
        capacity = lib.b3Body_GetContactCapacity(bid)
        if capacity > len(self._contacts):
            self._contacts = ffi.new("b3ContactData[]", capacity)
        count = lib.b3Body_GetContactData(bid, self._contacts, len(self._contacts))
        return self._contacts[0:count]

    def contact_points(self) -> list[ContactPoint]:
        """The geometry of each manifold point of the last step, forces NaN (module notes)."""
        if self._poses_before is None:
            return []
        where = {name: self._poses_before[i, :3].astype(float) for i, name in enumerate(self._order)}
        out, seen = [], set()
        for bid in self._ids:
            for c in self._contacts_of(bid):
                name_a, name_b = self._names[c.shapeIdA.index1], self._names[c.shapeIdB.index1]
                if (name_a, name_b) in seen:  # a contact between two dynamic bodies is listed for both
                    continue
                seen.add((name_a, name_b))
                origin = where[name_a] if name_a in where else self._every[name_a][1]
                for m in range(c.manifoldCount):
                    manifold = c.manifolds[m]
                    n = np.array([manifold.normal.x, manifold.normal.y, manifold.normal.z])  # A to B: b = A, a = B
                    for j in range(manifold.pointCount):
                        mp = manifold.points[j]
                        x = origin + (mp.anchorA.x, mp.anchorA.y, mp.anchorA.z)
                        out.append(ContactPoint(name_b, name_a, x, n.copy(), math.nan, np.full(3, math.nan),
                                                float(mp.separation)))
        return out

    def _touching(self) -> tuple[dict, dict]:
        """Gap (least separation) and unit normal from b into a of every pair (a, b) whose
        manifolds have points after the step."""
        gaps, normals = {}, {}
        for bid in self._ids:
            for c in self._contacts_of(bid):
                name_a, name_b = self._names[c.shapeIdA.index1], self._names[c.shapeIdB.index1]
                key = pair_key(name_a, name_b)
                if key in gaps:  # a contact between two dynamic bodies is listed for both
                    continue
                gap, normal = math.inf, None
                for m in range(c.manifoldCount):
                    manifold = c.manifolds[m]
                    for j in range(manifold.pointCount):
                        gap = min(gap, manifold.points[j].separation)
                    if manifold.pointCount:
                        normal = manifold.normal  # from shape A to shape B
                if normal is None:
                    continue
                sign = 1.0 if key[0] == name_b else -1.0  # into key[0]
                gaps[key] = gap
                normals[key] = (sign * normal.x, sign * normal.y, sign * normal.z)
        return gaps, normals

    def _read_forces(self) -> dict[tuple[str, str], float]:
        gaps, normals = self._touching()
        pairs = acting_pairs(gaps, set(self._order))
        if not pairs:
            return {}
        before, after = self._pending
        dv = after[:, :3] - before[:, :3] - self._g_dt
        J = {name: self._mass[i] * dv[i] for i, name in enumerate(self._order)}
        mu = _PAIRS[self._key]
        P, open_ = split_impulses(J, pairs, normals, {key: mu[key][0] > 0.0 for key in pairs})
        if open_:
            self.knobs["pair_split"] = OPEN_SPLIT
        return {key: float(np.dot(p, normals[key])) / self._dt for key, p in P.items()}

    def contact_forces(self) -> dict[tuple[str, str], float]:
        if self._forces is None:
            self._forces = self._read_forces() if self._pending else {}
        return dict(self._forces)

    def close(self) -> None:
        world, self._world = self._world, None
        if world is not None:
            lib.b3DestroyWorld(world)
        for hull in self._hulls:
            lib.b3DestroyHull(hull)
        for mesh in self._meshes:
            lib.b3DestroyMesh(mesh)
        self._hulls, self._meshes, self._keep = [], [], []
        for material_id in [k for k, (key, _) in _MATERIALS.items() if key == self._key]:
            del _MATERIALS[material_id]
        _PAIRS.pop(self._key, None)
