"""DART (dartpy) adapter.

One skeleton per scene body, or per connected group of jointed bodies (a tree: its root on
the scene joint to the world or free, each other body on its joint to its parent's BodyNode,
the start velocities as joint rates; self-collision on, jointed pairs black-listed; a joint
that closes a planar loop a BallJointConstraint: `_tree_joint`, `_joined_pairs`). A free
dynamic body hangs on a FreeJoint when it rotates and on a
TranslationalJoint when it does not; a 2D scene (x-z plane) uses a PlanarJoint (x, z and
the angle about y) or a TranslationalJoint2D. Static bodies are welded to the world; a
`Plane` becomes a large welded box whose top face is the plane (a `PlaneShape` under a box
gives DART's detectors a single contact point, measured: a box on it slides where it must stick).

Shapes (`_shape`): capsules and cylinders are DART's own, along the body's z; a hull, a 2D
polygon's prism and a static mesh are MeshShapes of their triangles, read through DART's
URDF loader from a temporary OBJ file (dartpy makes a MeshShape from no other source).
Which detector a world gets depends on its shapes (`_detector`, measured at DETECTOR):
DART's own for spheres, boxes and capsules, ODE's where a cylinder, hull, polygon or mesh is
in the scene. Every body has the scene's mass and principal inertia.

Pair materials map onto DART's combination rule (ContactConstraint: friction min,
restitution product) with adapters.combination.per_body_values; DART has no per-pair
override. Every engine parameter set here is recorded in `Simulation.knobs`, together with
the contact constants DART hard-codes (`ENGINE_CONSTANTS`).

Those constants make known deviations (sizes measured in the adapter's report):
- restitution, v_n+ = -e v_n (seeds/002, "particle vs fixed obstacle"), is applied to the
  normal velocity after this step's gravity was added: a bounce off the ground leaves at
  e (v + g dt) instead of e v;
- no bounce when e v_n < 0.1 m/s (DART_BOUNCING_VELOCITY_THRESHOLD);
- overlap is pushed out at ERP 0.01/dt but at most 1 mm/s, as a velocity: an e = 0
  impact leaves millimetres of overlap for seconds and the bodies part at up to 1 mm/s;
- a pair friction or restitution coefficient <= 1e-3 counts as zero: such scenes raise
  Unsupported rather than run silently frictionless (or without bounce).

Contact read-out (`contact_forces`, `contact_points`) comes from the contacts of
`World.getLastCollisionResult()`, which DART's solver fills in after the step; only the
contacts it built an active constraint for count (`DartSimulation._solved_contacts`). A 2D
scene's points are projected onto the x-z plane; the two points DART reports at the ends
of an extruded corner (y = -+HALF_DEPTH_2D) project onto one and are reported as one point
(forces summed, the smaller gap).

DART's C++ code writes warnings to file descriptor 2 and messages to 1. Every engine call
runs with those redirected into a temporary file; knobs["captured_output"] holds the
number of lines and the first one.
"""
from __future__ import annotations

import math
import os
import re
import tempfile
import weakref
from importlib import metadata

import numpy as np

from adapters.base import Adapter, Capabilities, Settings, Simulation, Unsupported
from adapters.combination import per_body_values
from adapters.frames import state_row
from adapters.joints import TreeJoint, closing_ball_points, joint_tree, start_rate
from adapters.lazy import require
from adapters.solids import polygon_prism
from cases.scene import Body, Box, Capsule, Circle, Cylinder, Hull, Mesh, Plane, Polygon, Rect, Scene, Sphere, pair_key
from cases.trajectory import ContactPoint

# dartpy (0.06-0.15 s to import) is imported by the functions that build a scene: planning a
# run reads only the adapter's capabilities, and workers import their engines themselves.
require("dartpy")  # not installed: ImportError now, so the registry reports it

# The collision detector, one a world (World.setCollisionDetector), chosen by the scene's
# shapes (`_detector`). DART's own: exact depths for spheres and boxes and the steadiest
# five-box stack of the four (FCL, Bullet, ODE: 40-60 % transient force errors there, at 30x
# the step cost), and a capsule lying on a box by both ends of its segment. It has no mesh
# (a hull on it sinks 0.7 mm and turns, a body on a mesh falls through) and a cylinder on a
# box meets it at one point (lying, it sinks 1.4 mm and rolls off). ODE's detector takes
# them: a cylinder resting on a box on its side (2 contacts) or end (8), a hull on a box (4),
# boxes, spheres, hulls and capsules on a triangle mesh (6, 2, 4, 1), each at its height to
# 2 um and at rest. The others fail them (measured, dartpy 6.20, 0.3 s at rest): FCL builds a
# capsule as a sphere, lets a sphere fall through a mesh and meets a cylinder at one point;
# Bullet rounds every box and cylinder edge by its default 4 cm margin, which DART does not
# set, and rests a box on a mesh on one point.
DETECTOR = "dart"
ODE_SHAPES = frozenset({"cylinder", "hull", "polygon", "mesh"})  # the kinds that take ODE's detector
# Exact Coulomb cone (NsgsFrictionSolver, law Coulomb) instead of the default Dantzig
# solver, whose box friction limit holds mu*sqrt(2) at 45 deg to the tangent basis
# (measured: effective mu 0.707 for mu = 0.5). The solver's own 1e-5 m/s and 100 sweeps
# leave a five-box stack rocking at 0.03 rad/s; 1e-6 m/s and 300 sweeps, at 5e-4 rad/s.
# `Settings.iterations` sets maxSweeps.
DEFAULT_SWEEPS = 300
SOLVER_TOLERANCE = 1e-6       # m/s, per-contact violation of the Coulomb law
# A Plane is a welded box this large: wider than any scene travels, thicker than any
# body moves in one step.
GROUND_HALF_WIDTH = 100.0     # m
GROUND_HALF_THICKNESS = 1.0   # m
# 2D shapes are extruded along y by this half-depth; the dynamics do not depend on it
# (the inertia is the scene's and the joints keep bodies in the x-z plane).
HALF_DEPTH_2D = 0.1           # m
ORIGIN = np.zeros(3)          # a load's point: the body frame's origin, its centre of mass
# Hard-coded in dart/constraint/ContactConstraint.cpp, not settable from dartpy.
ENGINE_CONSTANTS = {
    "DART_ERP": 0.01,
    "DART_MAX_ERV": 1e-3,                       # m/s
    "DART_CFM": 1e-5,
    "DART_BOUNCING_VELOCITY_THRESHOLD": 0.1,    # m/s
    "DART_MAX_BOUNCING_VELOCITY": 100.0,        # m/s
    "DART_FRICTION_COEFF_THRESHOLD": 1e-3,
    "DART_RESTITUTION_COEFF_THRESHOLD": 1e-3,
}
# collision::Contact::getNormalEpsilonSquared(): ConstraintSolver skips shorter normals.
NORMAL_EPSILON_SQUARED = 1e-12
# 2D: points of one pair closer than this in the x-z plane, with the same normal, are the
# two ends of one extruded corner.
MERGE_DISTANCE_2D = 1e-9      # m
_ANSI = re.compile(r"\x1b\[[0-9;]*m")


class _CapturedOutput:
    """Points file descriptors 1 and/or 2 at one temporary file around engine calls, so
    DART's C++ output never reaches the terminal; keeps it for inspection."""

    def __init__(self):
        self._file = tempfile.TemporaryFile()
        self._fd = self._file.fileno()
        self._saved = {1: os.dup(1), 2: os.dup(2)}  # where they pointed at build time
        self._size = -1
        self._summary = {"lines": 0, "first": ""}
        # frees the descriptors if the simulation is dropped without close()
        self._release = weakref.finalize(self, _release, self._file, list(self._saved.values()))

    def begin(self, fds=(1, 2)) -> None:
        for fd in fds:
            os.dup2(self._fd, fd)

    def end(self, fds=(1, 2)) -> None:
        for fd in fds:
            os.dup2(self._saved[fd], fd)

    def summary(self) -> dict:
        if self._file.closed:
            return self._summary
        size = os.fstat(self._fd).st_size
        if size != self._size:
            self._size = size
            text = os.pread(self._fd, size, 0).decode("utf-8", "replace")
            lines = [_ANSI.sub("", line).strip() for line in text.splitlines() if line.strip()]
            self._summary = {"lines": len(lines), "first": lines[0] if lines else ""}
        return self._summary

    def close(self) -> None:
        if not self._file.closed:
            self.summary()
            self._release()


def _release(file, fds) -> None:
    for fd in fds:
        os.close(fd)
    file.close()


# --- geometry -----------------------------------------------------------------------------

def _isometry(position=(0.0, 0.0, 0.0), rotation=np.eye(3)):
    import dartpy as dart
    T = dart.math.Isometry3()
    T.set_rotation(np.asarray(rotation, float))
    T.set_translation(np.asarray(position, float))
    return T


def _rotation_z_to(n) -> np.ndarray:
    """A rotation taking +z onto the unit vector n (Rodrigues' formula)."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, n)
    s, c = float(np.linalg.norm(axis)), float(z @ n)
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    kx, ky, kz = axis / s
    K = np.array([[0.0, -kz, ky], [kz, 0.0, -kx], [-ky, kx, 0.0]])
    return np.eye(3) + s * K + (1.0 - c) * K @ K


def _frame(body: Body, scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """World position and rotation of the body frame; a plane's frame has z along its
    normal and its origin on the plane, at its point nearest the origin (moved under the
    bodies where they are far from it: Plane.centre_under)."""
    import dartpy as dart
    if isinstance(body.shape, Plane):
        n = np.asarray(body.shape.normal, float)
        return body.shape.centre_under(scene, GROUND_HALF_WIDTH), _rotation_z_to(n)
    return (np.asarray(body.position, float),
            dart.math.Quaternion(np.asarray(body.orientation, float)).to_rotation_matrix())


def _shape(body: Body):
    """The DART shape of a body and its pose in the body frame. A capsule and a cylinder
    are DART's own, whose axis is the body's z, as the scene's (`height`: the cylindrical
    part's length, 2 half_length; the whole length for a cylinder). A hull, a polygon's
    prism and a mesh are MeshShapes of their triangles (`_mesh_shape`)."""
    from dartpy import dynamics as D
    s = body.shape
    if isinstance(s, Sphere):
        return D.SphereShape(s.radius), _isometry()
    if isinstance(s, Box):
        return D.BoxShape(2.0 * np.asarray(s.half_extents, float)), _isometry()
    if isinstance(s, Circle):
        # a sphere: every contact of a planar scene lies in y = 0, where the sphere's section
        # is the disc (the inertia stays the disc's, set from the scene). DART's cylinder
        # contact lets a rolling disc sink (13 mm after 1 s at 1 m/s, measured).
        return D.SphereShape(s.radius), _isometry()
    if isinstance(s, Rect):
        a, c = s.half_extents
        return D.BoxShape([2.0 * a, 2.0 * HALF_DEPTH_2D, 2.0 * c]), _isometry()
    if isinstance(s, Plane):  # the box lies below the frame's x-y plane
        size = [2 * GROUND_HALF_WIDTH, 2 * GROUND_HALF_WIDTH, 2 * GROUND_HALF_THICKNESS]
        return D.BoxShape(size), _isometry((0.0, 0.0, -GROUND_HALF_THICKNESS))
    if isinstance(s, Capsule):
        return D.CapsuleShape(s.radius, 2.0 * s.half_length), _isometry()
    if isinstance(s, Cylinder):
        return D.CylinderShape(s.radius, 2.0 * s.half_length), _isometry()
    if isinstance(s, Hull):
        return _mesh_shape(s.vertices, s.faces), _isometry()
    if isinstance(s, Polygon):  # a prism HALF_DEPTH_2D deep along y, as a rect
        return _mesh_shape(*polygon_prism(s.corners, HALF_DEPTH_2D)), _isometry()
    if isinstance(s, Mesh):
        return _mesh_shape(s.vertices, s.triangles), _isometry()
    raise Unsupported(f"shape {s.kind} not available in the DART adapter")


def _mesh_shape(vertices, triangles):
    """A MeshShape of `triangles` (index triples, wound outward) over `vertices` (body
    frame). dartpy makes a MeshShape only from a file that assimp reads, so the triangles are
    written as an OBJ file into a temporary folder and read by DART's URDF loader, which keeps
    them in memory (assimp stores vertices in float32: 6e-8 of their size)."""
    import dartpy as dart
    with tempfile.TemporaryDirectory(prefix="physval-dart-") as folder:
        path = os.path.join(folder, "shape.obj")
        with open(path, "w") as f:
            f.writelines(f"v {x!r} {y!r} {z!r}\n" for x, y, z in np.asarray(vertices, float).tolist())
            f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in np.asarray(triangles, int).tolist())
        uri = dart.common.Uri.createFromPath(path).toString()
        urdf = (f'<robot name="shape"><link name="shape"><collision><geometry><mesh filename="{uri}"/>'
                "</geometry></collision></link></robot>")
        skeleton = dart.utils.DartLoader().parseSkeletonString(urdf, dart.common.Uri.createFromPath(folder + "/"))
        if skeleton is None:
            raise Unsupported("DART's loader could not read the mesh written for it")
        return skeleton.getBodyNode(0).getShapeNodes()[0].getShape()


NEW_KINDS = ("capsule", "cylinder", "hull", "polygon", "mesh")  # recorded in knobs["shapes"]


def _shape_record(s) -> dict:
    """How a capsule, cylinder, hull, polygon or mesh went to DART, for the knobs."""
    if isinstance(s, (Capsule, Cylinder)):
        return {f"{type(s).__name__}Shape": {"radius": s.radius, "height": 2.0 * s.half_length}}
    count = {"hull": lambda: len(s.faces), "polygon": lambda: 4 * len(s.corners) - 4,
             "mesh": lambda: len(s.triangles)}[s.kind]()
    depth = f", {HALF_DEPTH_2D:g} m either side of y = 0" if s.kind == "polygon" else ""
    return {"MeshShape": f"{count} triangles of the scene's {s.kind}{depth}, body frame, scale 1 "
                         "(an OBJ file read by DartLoader; float32 in assimp)"}


def _detector(scene: Scene) -> str:
    """ODE's detector for a scene with a cylinder, hull, polygon or mesh; DART's own for the
    rest (DETECTOR, ODE_SHAPES)."""
    return "ode" if any(b.shape.kind in ODE_SHAPES for b in scene.bodies) else DETECTOR


def _angle_about_y(body: Body) -> float:
    w, x, y, z = body.orientation
    if x != 0.0 or z != 0.0:
        raise Unsupported(f"{body.name}.orientation = {body.orientation}: a 2D body may only be "
                          "turned about y")
    return 2.0 * math.atan2(y, w)


def _mobile_joint(skeleton, body: Body, dimension: int, position, R) -> str:
    """Hang a dynamic body on the joint that frees exactly its degrees of freedom; set its
    pose and velocity. Where rotation is locked, the orientation sits on the child side of
    the joint, so the joint coordinates are world translations."""
    v = np.asarray(body.velocity, float)
    w = np.asarray(body.angular_velocity, float)
    if dimension == 3 and body.rotates:
        joint, _ = skeleton.createFreeJointAndBodyNodePair()
        joint.setTransform(_isometry(position, R))
        joint.setLinearVelocity(v)   # FreeJoint's default frames: world
        joint.setAngularVelocity(w)
        return "FreeJoint"
    if dimension == 3:
        joint, _ = skeleton.createTranslationalJointAndBodyNodePair()
        joint.setTransformFromChildBodyNode(_isometry(rotation=R.T))
        joint.setPositions(position)
        joint.setVelocities(v)
        return "TranslationalJoint"
    theta = _angle_about_y(body)
    if body.rotates:  # z-x plane: coordinates (z, x, angle about z cross x = y)
        joint, _ = skeleton.createPlanarJointAndBodyNodePair()
        joint.setZXPlane()
        joint.setPositions(np.array([position[2], position[0], theta]))
        joint.setVelocities(np.array([v[2], v[0], w[1]]))
        return "PlanarJoint"
    joint, _ = skeleton.createTranslationalJoint2DAndBodyNodePair()
    joint.setZXPlane()
    joint.setTransformFromChildBodyNode(_isometry(rotation=R.T))
    joint.setPositions(np.array([position[2], position[0]]))
    joint.setVelocities(np.array([v[2], v[0]]))
    return "TranslationalJoint2D"


# --- the simulation -----------------------------------------------------------------------

class DartSimulation(Simulation):
    def __init__(self, world, nodes, frames, knobs, effects, iterations, output, dimension, rough):
        self._world = world
        self._nodes = nodes          # dynamic body name -> BodyNode
        # ShapeNode wrapper -> body name. Holding the wrappers makes pybind11 hand back these
        # same objects from CollisionObject.getShapeFrame(), so a contact's bodies are found
        # by identity: ShapeFrame.getName() costs 80 us a call (measured, dartpy 6.20).
        self._frames = frames
        self._knobs = knobs
        self.effects = effects
        self.iterations = iterations
        self._output = output
        self._dimension = dimension
        self._rough = rough          # bodies whose friction coefficient DART does not treat as zero
        self._loads = []             # (BodyNode, force, torque), world frame: the scene's loads

    def load(self, scene: Scene) -> None:
        """The scene's constant loads, applied before each step (World::step clears every
        external force after it): BodyNode.addExtForce at the body frame's origin, its centre
        of mass (the Inertia's com is 0), and addExtTorque, both in the world frame."""
        for load in scene.loads:
            if load.acts:
                self._loads.append((self._nodes[load.body], np.array(load.force, float),
                                    np.array(load.torque, float)))
        if self._loads:
            self.effects = self.effects | {"load"}
            self._knobs["loads"] = {"BodyNode.addExtForce": "world frame, at the centre of mass, before each step",
                                    "BodyNode.addExtTorque": "world frame, before each step"}

    @property
    def knobs(self) -> dict:
        self._knobs["captured_output"] = dict(self._output.summary())
        return self._knobs

    def step(self) -> None:
        # Only fd 2 here: stepping warns through dtwarn/dterr (stderr). The two redirects
        # cost 1-2 us per step, measured against a bare 2-4 us one-body world.step().
        self._output.begin((2,))
        try:
            for node, force, torque in self._loads:
                node.addExtForce(force, ORIGIN, False, True)
                node.addExtTorque(torque, False)
            self._world.step()
        finally:
            self._output.end((2,))

    # Bulk reads (adapters.base): per body its skeleton's joint positions then velocities
    # (two calls), decoded by joint type. Read off dartpy 6.20 and checked against states()
    # (tests/test_bulk_reads.py): a FreeJoint's positions are the rotation vector then the
    # world translation, its velocities the world angular then linear velocity; a PlanarJoint
    # in the z-x plane has (z, x, angle about +y); translational joints keep the start
    # orientation (carried on the child side) and have world coordinates.
    _DOFS = {"FreeJoint": 6, "TranslationalJoint": 3, "PlanarJoint": 3, "TranslationalJoint2D": 2}

    def _reader(self):
        if not hasattr(self, "_read"):
            self._read = []
            for name, node in self._nodes.items():
                kind = self._knobs["joints"][name]
                q0 = np.asarray(node.getWorldTransform().quaternion().wxyz(), float)
                self._read.append((name, node.getSkeleton(), kind, self._DOFS[kind], q0))
        return self._read

    def body_order(self) -> list[str]:
        return [r[0] for r in self._reader()]

    def state_size(self) -> int:
        return sum(2 * r[3] for r in self._reader())

    def write_state(self, out: np.ndarray) -> None:
        i = 0
        for _, skeleton, _, n, _ in self._reader():
            out[i:i + n] = skeleton.getPositions()
            out[i + n:i + 2 * n] = skeleton.getVelocities()
            i += 2 * n

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        out = np.zeros((len(raw), len(self._reader()), 13))
        i = 0
        for b, (_, _, kind, n, q0) in enumerate(self._reader()):
            q, dq, row = raw[:, i:i + n], raw[:, i + n:i + 2 * n], out[:, b]
            i += 2 * n
            if kind == "FreeJoint":
                rv = q[:, 0:3]
                angle = np.linalg.norm(rv, axis=1)
                scale = np.where(angle > 1e-12, np.sin(angle / 2) / np.where(angle > 1e-12, angle, 1.0), 0.5)
                row[:, 3], row[:, 4:7] = np.cos(angle / 2), rv * scale[:, None]
                row[:, 0:3], row[:, 10:13], row[:, 7:10] = q[:, 3:6], dq[:, 0:3], dq[:, 3:6]
            elif kind == "TranslationalJoint":
                row[:, 0:3], row[:, 3:7], row[:, 7:10] = q, q0, dq
            elif kind == "PlanarJoint":  # (z, x, angle about +y)
                row[:, 0], row[:, 2], row[:, 7], row[:, 9] = q[:, 1], q[:, 0], dq[:, 1], dq[:, 0]
                row[:, 3], row[:, 5], row[:, 11] = np.cos(q[:, 2] / 2), np.sin(q[:, 2] / 2), dq[:, 2]
            else:  # TranslationalJoint2D, (z, x)
                row[:, 0], row[:, 2], row[:, 7], row[:, 9] = q[:, 1], q[:, 0], dq[:, 1], dq[:, 0]
                row[:, 3:7] = q0
        return out

    def states(self) -> dict[str, np.ndarray]:
        rows = {}
        for name, node in self._nodes.items():
            T = node.getWorldTransform()
            rows[name] = state_row(T.translation(), T.quaternion().wxyz(),
                                   node.getLinearVelocity(), node.getAngularVelocity())
        return rows

    # Conventions (dart/collision/Contact.hpp: "normal vector from bodyNode2 to bodyNode1",
    # "force acting on bodyNode1"; dart/constraint/ContactConstraint.cpp, applyImpulse):
    # after a step, contact.force = (normal lambda_0 + D_0 lambda_1 + D_1 lambda_2) / dt is
    # the whole contact force on collisionObject1, normal AND friction part (D: the
    # constraint's tangent basis, perpendicular to the normal; the frictionless branch
    # stores normal lambda_0 / dt only), and the normal points from collisionObject2 into
    # collisionObject1 whatever the detector. So collisionObject1 is the contract's a, the
    # normal its n, force . n = lambda_0 / dt >= 0 its f_n and the rest its friction.
    # Checked on dartpy 6.20 (box on the ground sliding at 30 deg, mu = 0.5): the ground is
    # object 1, normal -z, and minus the summed forces on it is (m g along +z) plus
    # mu m g against the slip. Shape nodes carry the scene's body names.

    def _solved_contacts(self):
        """(name 1, name 2, contact, normal) of each contact DART's solver acted on in the
        last step. ConstraintSolver::updateConstraints skips contacts with a non-finite
        point or normal, a zero normal (Contact::isZeroNormal) or a negative depth, and a
        contact constraint is active only when one of its bodies is reactive
        (ContactConstraint::update): the detector's contacts between two static bodies are
        never solved (force stays 0) and are not reported."""
        dynamic, frames = self._nodes, self._frames
        for c in self._world.getLastCollisionResult().getContacts():
            s1, s2 = c.collisionObject1.getShapeFrame(), c.collisionObject2.getShapeFrame()
            a = frames.get(s1) or s1.getName()
            b = frames.get(s2) or s2.getName()
            if a not in dynamic and b not in dynamic:
                continue
            n = c.normal
            if not (n @ n >= NORMAL_EPSILON_SQUARED and c.penetrationDepth >= 0.0):
                continue   # also false for NaN
            yield a, b, c, n

    def contact_forces(self) -> dict[tuple[str, str], float]:
        forces: dict[tuple[str, str], float] = {}
        for a, b, c, n in self._solved_contacts():
            key = pair_key(a, b)
            forces[key] = forces.get(key, 0.0) + float(c.force @ n)
        return forces

    def contact_points(self) -> list[ContactPoint]:
        """Every contact point DART's solver acted on in the last step (see
        `_solved_contacts`), a = collisionObject1, b = collisionObject2. Friction is the
        tangential part of the engine's contact.force (its friction impulses along its
        tangent basis, / dt); a pair DART solves frictionless (ContactConstraint: min of
        the two coefficients <= DART_FRICTION_COEFF_THRESHOLD) has no tangential impulse
        and reports f_t = 0 exactly. 2D scenes: vectors projected onto the x-z plane (a
        y component of force acts along a direction the planar joints lock) and the two
        ends of an extruded corner merged into one point."""
        rough = self._rough
        solved = list(self._solved_contacts())
        if not solved:
            return []
        x = np.array([c.point for _, _, c, _ in solved], dtype=float)
        f = np.array([c.force for _, _, c, _ in solved], dtype=float)
        n = np.array([normal for _, _, _, normal in solved], dtype=float)
        planar = self._dimension == 2
        if planar:
            x[:, 1] = f[:, 1] = n[:, 1] = 0.0
        length = np.sqrt(np.einsum("ij,ij->i", n, n))
        length[length * length < NORMAL_EPSILON_SQUARED] = np.nan  # 2D: a normal along y
        n /= length[:, None]
        f_n = np.einsum("ij,ij->i", f, n)
        f_t = f - f_n[:, None] * n
        for i, (a, b, _, _) in enumerate(solved):
            if a not in rough or b not in rough:
                f_t[i] = 0.0
        points: list[ContactPoint] = []
        for i, (a, b, c, _) in enumerate(solved):
            if length[i] != length[i]:
                continue   # NaN: 2D, the normal was along y, which no planar motion feels
            gap = -float(c.penetrationDepth)
            if planar:
                same = next((k for k, p in enumerate(points)
                             if p.a == a and p.b == b
                             and abs(p.x[0] - x[i, 0]) <= MERGE_DISTANCE_2D
                             and abs(p.x[2] - x[i, 2]) <= MERGE_DISTANCE_2D
                             and float(p.n @ n[i]) >= 1.0 - 1e-12), None)
                if same is not None:
                    p = points[same]
                    points[same] = ContactPoint(a, b, p.x, p.n, p.f_n + float(f_n[i]),
                                                p.f_t + f_t[i], min(p.gap, gap))
                    continue
            points.append(ContactPoint(a, b, x[i], n[i], float(f_n[i]), f_t[i], gap))
        return points

    def close(self) -> None:
        if self._world is None:
            return
        self._output.begin()
        try:
            self._world.removeAllSkeletons()
        finally:
            self._output.end()
        self._world = None
        self._nodes = {}
        self._frames = {}
        self._output.close()


class DartJointSimulation(DartSimulation):
    """A scene with joints: each body's state read from its BodyNode (world transform and
    velocities, DartSimulation.states) rather than decoded from a free or planar joint's
    coordinates."""

    def body_order(self) -> list[str]:
        return list(self._nodes)

    def state_size(self) -> int:
        return 13 * len(self._nodes)

    def write_state(self, out: np.ndarray) -> None:
        Simulation.write_state(self, out)

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        return Simulation.decode_states(self, raw)


class DartAdapter(Adapter):
    name = "dart"
    package = "dartpy"
    # the release the conformance battery ran on; the next major (minor for 0.x) may change the API
    supported = ">=6.20.0,<7"
    capabilities = Capabilities(
        dimensions=frozenset({2, 3}),
        # every kind (_shape); a scene with a cylinder, hull, polygon or mesh on ODE's detector
        shapes=frozenset({"sphere", "box", "plane", "circle", "rect", "capsule", "cylinder", "hull", "polygon",
                          "mesh"}),
        native_restitution=True,
        static_kinetic=False,
        contact_forces=True,
        iterations=True,
        contact_points=True,
        # one boxed LCP over all the step's contacts, each bouncing from its own approach
        # velocity (cases/column_impact.py: two pressed balls leave the ground together,
        # a struck row of two leaves as one body)
        impact_model="simultaneous",
        # one skeleton per connected jointed group (adapters.joints.joint_tree): a root on a
        # scene joint to the world or free, each other body on DART's joint of its kind on its
        # parent's BodyNode (_tree_joint); a loop closed by a BallJointConstraint: reduced coordinates
        joints=frozenset({"revolute", "prismatic", "ball", "fixed"}),
        joint_limits=True,
        joint_friction=True,  # Joint::setCoulombFriction (_tree_joint)
        coordinates="reduced",
        loads=True,  # BodyNode.addExtForce and addExtTorque before each step (DartSimulation.load)
        why_not=(("limit_restitution", "a joint's limit takes a range only (setPositionLowerLimit, "
                                       "setPositionUpperLimit): DART's limit constraint has no restitution"),),
    )

    def version(self) -> str:
        return metadata.version("dartpy")

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        why = self.capabilities.cannot_run(scene)
        if why:
            raise Unsupported(why)
        for a, b in scene.contact_pairs():
            mat = scene.material_of(a.name, b.name)
            for what, value, limit in (("friction", mat.mu_s, "DART_FRICTION_COEFF_THRESHOLD"),
                                       ("restitution", mat.e, "DART_RESTITUTION_COEFF_THRESHOLD")):
                if 0.0 < value <= ENGINE_CONSTANTS[limit]:
                    raise Unsupported(f"{what} {value} for {a.name}/{b.name}: DART treats a pair "
                                      f"coefficient <= {ENGINE_CONSTANTS[limit]} as zero ({limit})")
        closing_ball_points(scene, joint_tree(scene)[1], "DART's BallJointConstraint")  # Unsupported: loops not mapped
        mu = per_body_values(scene, lambda m: m.mu_s, "min", "friction")
        e = per_body_values(scene, lambda m: m.e, "product", "restitution")
        sweeps = DEFAULT_SWEEPS if settings.iterations is None else settings.iterations

        output = _CapturedOutput()
        output.begin()
        try:
            world, nodes, frames, knobs = _build_world(scene, settings, mu, e, sweeps)
        except BaseException:
            output.end()
            output.close()
            raise
        output.end()
        rough = frozenset(name for name, m in mu.items()
                          if m > ENGINE_CONSTANTS["DART_FRICTION_COEFF_THRESHOLD"])
        kind = DartJointSimulation if scene.joints else DartSimulation
        sim = kind(world, nodes, frames, knobs, _effects(scene, knobs, mu, e), sweeps, output, scene.dimension, rough)
        sim.load(scene)
        return sim


def _effects(scene: Scene, knobs: dict, mu: dict, e: dict) -> frozenset[str]:
    """What the built world simulates, read from what was given to DART: the world's
    gravity, the per-body coefficients under DART's rules (friction min, restitution
    product) and the joints."""
    fx = set()
    if any(g != 0.0 for g in scene.gravity):  # world.setGravity(scene.gravity)
        fx.add("gravity")
    pairs = scene.contact_pairs()
    if pairs:
        fx.add("contact")
        if any(e[a.name] * e[b.name] > 0.0 for a, b in pairs):
            fx.add("restitution")
        if any(min(mu[a.name], mu[b.name]) > 0.0 for a, b in pairs):
            fx.add("friction")
    if any(j in ("FreeJoint", "PlanarJoint", "RevoluteJoint", "BallJoint") for j in knobs["joints"].values()):
        fx.add("rotation")
    if scene.joints:
        fx.add("joint")
    if knobs.get("joint limits"):
        fx.add("limit")
    if knobs.get("joint friction"):
        fx.add("joint_friction")
    return frozenset(fx)


def _tree_joint(skeleton, scene: Scene, body: Body, tj: TreeJoint, position, R, parent, knobs: dict) -> str:
    """Hang a dynamic body on its tree joint: its skeleton's root joint (`parent` None: on the
    world) or a joint on the parent's BodyNode (`parent`: (node, its start position, its
    start rotation)). The joint frame sits at the anchor, world-aligned at the start (its
    axis the scene's axis), and the body's frame at its start pose relative to it, so the
    joint's coordinate is 0 at the start and is the turn (slide) of the body about (along)
    the axis relative to the parent; its rate is the bodies' start velocities' (start_rate)."""
    joint = tj.joint
    make = {"revolute": skeleton.createRevoluteJointAndBodyNodePair,
            "prismatic": skeleton.createPrismaticJointAndBodyNodePair,
            "ball": skeleton.createBallJointAndBodyNodePair,
            "fixed": skeleton.createWeldJointAndBodyNodePair}[joint.kind]
    anchor = np.asarray(joint.anchor, float)
    if parent is None:
        made, _ = make()
        made.setTransformFromParentBodyNode(_isometry(anchor))
    else:  # the joint frame in the parent's body frame at its start pose
        node, p_P, R_P = parent
        made, _ = make(node)
        made.setTransformFromParentBodyNode(_isometry(R_P.T @ (anchor - p_P), R_P.T))
    made.setTransformFromChildBodyNode(_isometry(R.T @ (anchor - np.asarray(position, float)), R.T))
    record = {"kind": type(made).__name__, "on": tj.parent or "world", "anchor": anchor.tolist()}
    if joint.kind in ("revolute", "prismatic"):
        made.setAxis(np.asarray(joint.unit_axis, float))
        record["axis"] = list(joint.unit_axis)
        if joint.limits is not None:
            made.setPositionLowerLimit(0, float(joint.limits[0]))
            made.setPositionUpperLimit(0, float(joint.limits[1]))
            made.setLimitEnforcement(True)
            record["limits"] = list(joint.limits)
            knobs["joint limits"] = True
    if joint.kind != "fixed":
        for i in range(made.getNumDofs()):  # no joint damping or stiffness (DART's defaults, stated)
            made.setDampingCoefficient(i, 0.0)
            made.setSpringStiffness(i, 0.0)
            # the joint's dry friction (0: none): DART's JointCoulombFrictionConstraint, a row in the
            # step's boxed LCP whose impulse lies within -+ friction dt, Coulomb's law with the scene's
            # constant bound (cases.scene.Joint)
            made.setCoulombFriction(i, float(joint.friction))
        if joint.friction > 0:
            record["setCoulombFriction"] = float(joint.friction)
            knobs["joint friction"] = True
        # a ball joint's rates are the turn's angular velocity in the joint's child frame,
        # world-aligned at the start: start_rate's world-frame w_rel
        rate = start_rate(scene, tj)
        made.setVelocities(rate)
        record["start rate"] = [float(r) for r in rate]
    knobs.setdefault("scene joints", {})[body.name] = record
    return type(made).__name__


def _joined_pairs(world, scene: Scene, every: dict, skeletons: dict, closing: list, knobs: dict) -> None:
    """Bodies a joint connects do not collide (Scene.contact_pairs): each such pair is on the
    world's BodyNodeCollisionFilter's black list. Within a skeleton of several bodies DART
    checks no collision by default: self-collision is switched on (adjacent bodies, a parent
    and its child, stay unchecked; they are on the list anyway), so two links that no joint
    connects collide as two skeletons would. A joint that closes a loop is a
    BallJointConstraint at its anchor (closing_ball_points: planar loops' hinges and ball
    joints), solved with the contacts."""
    import dartpy as dart
    jointed = [(j.body, j.parent) for j in scene.joints if j.parent is not None]
    if jointed:
        black = world.getConstraintSolver().getCollisionOption().collisionFilter
        for a, b in jointed:
            black.addBodyNodePairToBlackList(every[a], every[b])
        knobs["collision filter: jointed pairs black-listed"] = [list(p) for p in jointed]
    for skeleton in {id(s): s for s in skeletons.values()}.values():
        if skeleton.getNumBodyNodes() > 1:
            skeleton.enableSelfCollisionCheck()
            skeleton.disableAdjacentBodyCheck()
            knobs.setdefault("Skeleton.enableSelfCollisionCheck", []).append(skeleton.getName())
    for j, body, _, parent, _ in closing_ball_points(scene, closing, "DART's BallJointConstraint"):
        anchor = np.asarray(scene.joints[j].anchor, float)
        c = dart.constraint.BallJointConstraint(every[body], anchor) if parent is None else \
            dart.constraint.BallJointConstraint(every[body], every[parent], anchor)
        world.getConstraintSolver().addConstraint(c)
        knobs.setdefault("loop", {})[f"joints[{j}]"] = {"BallJointConstraint": [body, parent or "world"],
                                                      "anchor": anchor.tolist()}


def _build_world(scene: Scene, settings: Settings, mu: dict, e: dict, sweeps: int):
    import dartpy as dart
    D = dart.dynamics
    world = dart.simulation.World()
    world.setTimeStep(settings.dt)
    world.setGravity(np.asarray(scene.gravity, float))  # zero when the scene has none
    detector = _detector(scene)
    world.setCollisionDetector(getattr(dart.simulation.CollisionDetectorType, detector.upper()))
    world.setNumSimulationThreads(1)
    sleeping = world.getDeactivationOptions()
    sleeping.mEnabled = False
    world.setDeactivationOptions(sleeping)

    solver = world.getConstraintSolver()
    options = dart.constraint.NsgsFrictionSolver.Options()
    options.law = dart.constraint.NsgsFrictionSolver.Law.Coulomb
    options.maxSweeps = sweeps
    options.tolerance = SOLVER_TOLERANCE
    solver.setBoxedLcpSolver(dart.constraint.NsgsFrictionSolver(options))
    # No fallback: the default secondary (PGS) is box friction again; without one NSGS
    # returns its best iterate.
    solver.setSecondaryBoxedLcpSolver(None)
    # Split impulse moves the push-out into a position pass (still 1 mm/s) but makes
    # stack contact forces jump by several per cent at times; keep DART's default.
    solver.setSplitImpulseEnabled(False)

    knobs = {
        "World.setTimeStep": settings.dt,
        "World.setGravity": [float(g) for g in scene.gravity],
        "World.setCollisionDetector": detector,
        "World.setNumSimulationThreads": 1,
        "DeactivationOptions.mEnabled": False,
        "BoxedLcpConstraintSolver.setBoxedLcpSolver": "NsgsFrictionSolver",
        "NsgsFrictionSolver.Options": {"law": "Coulomb", "maxSweeps": sweeps,
                                       "tolerance": SOLVER_TOLERANCE,
                                       "boxForAnisotropic": bool(options.boxForAnisotropic)},
        "BoxedLcpConstraintSolver.setSecondaryBoxedLcpSolver": None,
        "ConstraintSolver.setSplitImpulseEnabled": False,
        "DynamicsAspect.setFrictionCoeff": {k: float(v) for k, v in mu.items()},
        "DynamicsAspect.setRestitutionCoeff": {k: float(v) for k, v in e.items()},
        # a scene Plane: a welded box (a PlaneShape under a box gives the dart detector one
        # contact point: a box resting on it stands on one corner, measured with dartpy 6.20)
        "ground": "box",
        "joints": {},
        "Inertia": {},
        "engine_constants (not settable)": dict(ENGINE_CONSTANTS),
    }
    nodes, frames = {}, {}
    # One skeleton per connected jointed group (joint_tree): a root (on a scene joint to the
    # world, or free) and the bodies hanging on it, parents before children.
    tree, closing = joint_tree(scene)
    every, skeletons, starts, made = {}, {}, {}, []
    order = [b for b in scene.bodies if b.name not in tree or tree[b.name].parent is None] + \
        [scene.body(n) for n, tj in tree.items() if tj.parent is not None]
    for body in order:
        position, R = _frame(body, scene)
        starts[body.name] = (position, R)
        tj = tree.get(body.name)
        if tj is not None and tj.parent is not None:
            skeleton = skeletons[tj.parent]
        else:
            skeleton = D.Skeleton(body.name)
            made.append(skeleton)
        skeletons[body.name] = skeleton
        if body.static:
            joint, node = skeleton.createWeldJointAndBodyNodePair()
            joint.setTransformFromParentBodyNode(_isometry(position, R))
            knobs["joints"][body.name] = "WeldJoint"
        else:
            if tj is not None:
                parent = None if tj.parent is None else (every[tj.parent], *starts[tj.parent])
                knobs["joints"][body.name] = _tree_joint(skeleton, scene, body, tj, position, R, parent, knobs)
                node = skeleton.getBodyNode(skeleton.getNumBodyNodes() - 1)
            else:
                knobs["joints"][body.name] = _mobile_joint(skeleton, body, scene.dimension, position, R)
                node = skeleton.getBodyNode(0)
            # the scene's inertia; DART's default is mass 1 and identity whatever the shape
            node.setInertia(D.Inertia(body.mass, np.zeros(3), np.diag(body.principal_inertia)))
            knobs["Inertia"][body.name] = {"mass": float(body.mass),
                                           "moment": [float(i) for i in body.principal_inertia]}
            nodes[body.name] = node
        every[body.name] = node
        node.setName(body.name)
        shape, pose = _shape(body)
        if body.shape.kind in NEW_KINDS:
            knobs.setdefault("shapes", {})[body.name] = _shape_record(body.shape)
        shape_node = node.createShapeNode(shape)
        shape_node.setName(body.name)
        frames[shape_node] = body.name
        shape_node.setRelativeTransform(pose)
        shape_node.createCollisionAspect()  # without these two aspects bodies pass through
        aspect = shape_node.createDynamicsAspect()
        aspect.setFrictionCoeff(mu[body.name])
        aspect.setRestitutionCoeff(e[body.name])
        if isinstance(body.shape, Plane):
            knobs.setdefault("ground BoxShape half-extents", {})[body.name] = [
                GROUND_HALF_WIDTH, GROUND_HALF_WIDTH, GROUND_HALF_THICKNESS]
    for skeleton in made:  # each whole: the world registers its shapes for collision as it is added
        world.addSkeleton(skeleton)
    _joined_pairs(world, scene, every, skeletons, closing, knobs)
    if scene.dimension == 2:
        knobs["2D half-depth along y"] = HALF_DEPTH_2D
    return world, nodes, frames, knobs
