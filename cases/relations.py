"""Invariance relations: the physics that must not change when a scene is moved, mirrored,
scaled, built in another order, given in another shape representation, or run another way
(in another world of a batch, on more threads, saved and restored midway).

A closed form exists for few scenes; an invariance holds for every scene. A relation runs
a scene twice, once as given and once transformed, and compares the two runs through the
transformation: no oracle is needed (metamorphic testing). A relation is one small object:

    transform(scene) -> scene      the same physics set up another way
    time_scale                     the factor on the time step (a scale relation's sqrt(k));
                                   both runs take the same number of steps
    settings                       Settings fields the second run sets (threads, world)
    restart                        the second run saves its state midway and goes on in a
                                   freshly built engine the state is restored into
    map_back(trajectory) -> ...    the second run's trajectory in the first run's frame
    promise, why                   what the engine promises (BIT_IDENTICAL or ROUND_OFF)
                                   and the reason, written beside each relation
    needs                          the capability the engine must declare (NEEDS), or ""

The scene transforms live here, with the scene vocabulary: they are engine-neutral and
apply to every family, built-in or a user's. The judging (running both, the tolerance at
the engine's float width, the step at which the two runs part) is the harness's
(physval.core.invariance), and so are the selection of scenes a default run applies them
to and the report.

Conventions of the rigid motions: a point x goes to x' = M x + d, M = Q F^s, with Q a
proper rotation and F = diag(-1, 1, 1) the mirror in the plane x = 0 (s = 1 for the
mirror image). Velocities go to M v; angular velocities, pseudo-vectors, to det(M) M w; a
body's orientation R to M R F^s (a proper rotation again: the mirror image of a body is
the mirror of its shape, F^s in its body frame, turned by M R F^s); gravity to M g (it turns
with the scene: that is what makes the motion an invariance). A static plane is rewritten
in the world frame (its normal M n, its offset n'.d further), at the identity pose.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from cases import rotations
from cases.overlap import rotation_matrix
from cases.scene import (Box, Capsule, Circle, Cylinder, Hull, Material, Mesh, Plane, Polygon, Rect,
                         Scene, Sphere)
from cases.trajectory import OMEGA, POS, QUAT, VEL, Trajectory

# What an engine promises of a relation:
# BIT_IDENTICAL  the two runs are equal to the last bit (the same arithmetic on the same
#                numbers: another thread count, another world of a batch, a restored state);
# ROUND_OFF      equal to a round-off share of the engine's float width at the magnitude of
#                the numbers it computes with (the same physics set up with other numbers:
#                a turned, moved, mirrored, scaled or reordered scene).
BIT_IDENTICAL, ROUND_OFF = "bit-identical", "round-off"
PROMISES = (BIT_IDENTICAL, ROUND_OFF)

# The capabilities a relation may need of an engine (adapters.base.Capabilities declares them):
# "threads"       Settings.threads is honoured (the engine steps with a pool of that many threads);
# "worlds"        Settings.world = (k, n) builds the scene as world k of a batch of n;
# "save_restore"  Simulation.save_state() / restore_state(state) carry the engine's whole state.
NEEDS = ("threads", "worlds", "save_restore")

MIRROR = np.diag([-1.0, 1.0, 1.0])  # F: the mirror in the plane x = 0
METRIC_PREFIX = "invariance_"  # a relation's verdict is the metric invariance_<name> (Relation.metric)


class NotApplicable(ValueError):
    """The relation has no meaning for this scene (a 2D scene cannot turn about the
    vertical); the message says why."""


# --- quaternions (w, x, y, z) ----------------------------------------------------------------

def quat_about(axis, angle: float) -> tuple[float, float, float, float]:
    """The rotation by `angle` (rad) about the unit vector `axis`."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    s = math.sin(angle / 2)
    return (math.cos(angle / 2), float(a[0] * s), float(a[1] * s), float(a[2] * s))


def _mirrored_quat(q: np.ndarray) -> np.ndarray:
    """F R F as a quaternion: the axis, a pseudo-vector, goes to -F a (exact: sign flips)."""
    return q * np.array([1.0, 1.0, -1.0, -1.0])


# --- the relation contract -------------------------------------------------------------------

@dataclass(frozen=True)
class Relation:
    """One invariance (the module's docstring). The base relation changes nothing in the
    scene: a relation that runs the same scene another way (threads, worlds, a restart)."""
    name: str
    summary: str
    promise: str
    why: str
    needs: str = ""
    settings: tuple = ()   # (Settings field, value) pairs of the second run
    restart: bool = False  # the second run saves midway and goes on in a fresh engine
    time_scale: float = 1.0
    scenes: tuple = ()     # what a default run applies it to: groups of variants (--cases specs), each
    #                        group giving an engine the first of its variants the engine can represent

    def __post_init__(self):
        if self.promise not in PROMISES:
            raise ValueError(f"relation {self.name}: promise = {self.promise!r}: must be one of {', '.join(PROMISES)}")
        if self.needs and self.needs not in NEEDS:
            raise ValueError(f"relation {self.name}: needs = {self.needs!r}: must be one of {', '.join(NEEDS)}")
        if not self.name.replace("_", "").isalnum():
            raise ValueError(f"relation name {self.name!r}: letters, digits and _ only (it names a metric)")

    @property
    def metric(self) -> str:
        """The metric its verdict goes by in results.csv (and known-deviation files)."""
        return METRIC_PREFIX + self.name

    def applies(self, scene: Scene) -> str | None:
        """Why the relation has no meaning for `scene`, or None."""
        return None

    def transform(self, scene: Scene) -> Scene:
        return scene

    def map_back(self, traj: Trajectory, scene: Scene) -> Trajectory:
        """The second run's trajectory `traj` in the frame of the first, which ran `scene`."""
        return traj

    def offset(self, scene: Scene) -> float:
        """How far (m) the second run's coordinates lie from the first's: its rounding is
        that of numbers this much larger (a scene moved far from the origin)."""
        return 0.0


# --- rigid motions -----------------------------------------------------------------------------

@dataclass(frozen=True)
class Motion(Relation):
    """A rigid motion of the whole scene, x' = Q F^s x + d (the module's conventions):
    `turn` the rotation Q as a quaternion, `mirror` s = 1, `shift` d in m. `planar`: what
    the motion is in a 2D scene (the x-z plane) instead, or None where it has no meaning
    there; `planar_why`: why not."""
    turn: tuple = (1.0, 0.0, 0.0, 0.0)
    mirror: bool = False
    shift: tuple = (0.0, 0.0, 0.0)
    planar: "Motion | None" = field(default=None, compare=False)
    planar_why: str = ""

    def _in(self, scene: Scene) -> "Motion":
        if scene.dimension == 3:
            return self
        if self.planar is None:
            raise NotApplicable(self.planar_why)
        return self.planar

    def applies(self, scene: Scene) -> str | None:
        return _unmoved(scene) or (self.planar_why if scene.dimension == 2 and self.planar is None else None)

    def offset(self, scene: Scene) -> float:
        return float(np.linalg.norm(self._in(scene).shift))

    @property
    def matrix(self) -> np.ndarray:
        Q = rotation_matrix(self.turn)
        return Q @ MIRROR if self.mirror else Q

    def transform(self, scene: Scene) -> Scene:
        m = self._in(scene)
        q, d, M = np.asarray(m.turn, float), np.asarray(m.shift, float), m.matrix
        sign = -1.0 if m.mirror else 1.0

        def point(p):
            x = np.asarray(p, float)
            x = MIRROR @ x if m.mirror else x
            return _vec(rotations.rotate(q, x[None])[0] + d)

        def vector(v, pseudo=False):
            x = np.asarray(v, float)
            if m.mirror:
                x = (sign * MIRROR @ x) if pseudo else MIRROR @ x
            return _vec(rotations.rotate(q, x[None])[0])

        def body(b):
            if isinstance(b.shape, Plane):
                R = rotation_matrix(b.orientation)
                n = R @ np.asarray(b.shape.normal, float)
                offset = b.shape.offset + float(n @ np.asarray(b.position, float))
                n2 = M @ n
                return replace(b, shape=Plane(_vec(n2 / np.linalg.norm(n2)), offset + float(n2 @ d)),
                               position=(0.0, 0.0, 0.0), orientation=(1.0, 0.0, 0.0, 0.0))
            o = np.asarray(b.orientation, float)
            o = _mirrored_quat(o) if m.mirror else o
            o = rotations.multiply(q, o)  # unit to rounding: not normalised, which would round the exact ones
            return replace(b, shape=_mirror_shape(b.shape) if m.mirror else b.shape, position=point(b.position),
                           orientation=_vec(o), velocity=vector(b.velocity),
                           angular_velocity=vector(b.angular_velocity, pseudo=True) if b.rotates
                           else b.angular_velocity)

        return replace(scene, bodies=tuple(body(b) for b in scene.bodies), gravity=vector(scene.gravity))

    def map_back(self, traj: Trajectory, scene: Scene) -> Trajectory:
        """States of the moved run in the original frame: x = F^s Q^T (x' - d), v = F^s Q^T v',
        w = det(M) F^s Q^T w', R = F^s Q^T R' F^s."""
        m = self._in(scene)
        qi = rotations.conjugate(m.turn)  # Q^T
        d = np.asarray(m.shift, float)
        states = {}
        for name, s in traj.states.items():
            out = np.empty_like(s)
            x = rotations.rotate(qi, s[:, POS] - d)
            v = rotations.rotate(qi, s[:, VEL])
            w = rotations.rotate(qi, s[:, OMEGA])
            o = rotations.multiply(qi, s[:, QUAT])
            if m.mirror:
                x, v, w = x @ MIRROR, v @ MIRROR, -(w @ MIRROR)
                o = o * np.array([1.0, 1.0, -1.0, -1.0])
            out[:, POS], out[:, VEL], out[:, OMEGA], out[:, QUAT] = x, v, w, o
            states[name] = out
        return replace(traj, states=states)



def _unmoved(scene: Scene) -> str | None:
    """Why a rigid motion or a scaling does not apply: joints and loads (their anchors, axes,
    limits and forces) are not transformed with the bodies yet."""
    if scene.joints or scene.loads:
        return "the scene has joints or loads, which this relation does not transform yet"
    return None


def _vec(x) -> tuple:
    return tuple(float(c) for c in x)


def _mirror_shape(shape):
    """The shape mirrored in its body frame by F (x -> -x): boxes, balls, discs, rects,
    capsules and cylinders are symmetric in x; a hull's and a polygon's corners flip, a
    mesh's flip and its triangles turn the other way round (so they stay wound outward)."""
    if isinstance(shape, Hull):
        return Hull(tuple((-x, y, z) for x, y, z in shape.vertices))
    if isinstance(shape, Polygon):
        return Polygon(tuple((-x, z) for x, z in shape.vertices))
    if isinstance(shape, Mesh):
        return Mesh(tuple((-x, y, z) for x, y, z in shape.vertices), tuple((a, c, b) for a, b, c in shape.triangles))
    return shape


# --- scale ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Scale(Relation):
    """Lengths x k, times x sqrt(k), masses and gravity kept (Froude's law: g L / v^2 and
    every ratio of lengths stay): positions, sizes and lever arms x k, velocities x sqrt(k),
    angular velocities / sqrt(k), inertias x k^2, the time step x sqrt(k); forces stay m g,
    so a Hooke stiffness goes / k (F = k_c xi, xi x k) and a Hertz modulus / k^2
    (F = 4/3 E* sqrt(R) xi^1.5, R and xi x k). With k a power of 4, every one of these
    factors is a power of 2: the scaled numbers are exact, and an engine whose arithmetic
    is dimensionally consistent computes the same bits scaled; what an engine adds in
    absolute units (a slop, a margin, a speculative distance, a velocity threshold) does not
    scale, and that is what a broken scale invariance finds."""
    k: float = 4.0

    def applies(self, scene: Scene) -> str | None:
        return _unmoved(scene)

    def transform(self, scene: Scene) -> Scene:
        k, r = self.k, math.sqrt(self.k)

        def body(b):
            return replace(b, shape=_scaled_shape(b.shape, k), position=_vec(np.asarray(b.position) * k),
                           velocity=_vec(np.asarray(b.velocity) * r),
                           angular_velocity=_vec(np.asarray(b.angular_velocity) / r),
                           inertia=None if b.inertia is None else _vec(np.asarray(b.inertia) * k * k))

        def material(m: Material) -> Material:
            c = m.compliance
            if c is not None:
                c = replace(c, k=c.k / k) if c.law == "hooke" else replace(c, E=c.E / (k * k))
            return replace(m, rolling_resistance=m.rolling_resistance * k, torsional_friction=m.torsional_friction * k,
                           compliance=c)

        return replace(scene, bodies=tuple(body(b) for b in scene.bodies), material=material(scene.material),
                       pairs=tuple((a, b, material(m)) for a, b, m in scene.pairs),
                       allowed_overlap=scene.allowed_overlap * k)

    def map_back(self, traj: Trajectory, scene: Scene) -> Trajectory:
        k, r = self.k, math.sqrt(self.k)
        states = {}
        for name, s in traj.states.items():
            out = s.copy()
            out[:, POS] /= k
            out[:, VEL] /= r
            out[:, OMEGA] *= r
            states[name] = out
        return replace(traj, states=states, dt=traj.dt / r, t=traj.t / r)


def _scaled_shape(s, k: float):
    if isinstance(s, (Sphere, Circle)):
        return replace(s, radius=s.radius * k)
    if isinstance(s, (Box, Rect)):
        return replace(s, half_extents=_vec(np.asarray(s.half_extents) * k))
    if isinstance(s, (Capsule, Cylinder)):
        return replace(s, radius=s.radius * k, half_length=s.half_length * k)
    if isinstance(s, Plane):
        return replace(s, offset=s.offset * k)
    if isinstance(s, Hull):
        return Hull(tuple(_vec(np.asarray(v) * k) for v in s.vertices))
    if isinstance(s, Polygon):
        return Polygon(tuple(_vec(np.asarray(v) * k) for v in s.vertices))
    if isinstance(s, Mesh):
        return Mesh(tuple(_vec(np.asarray(v) * k) for v in s.vertices), s.triangles)
    raise NotApplicable(f"shape {s.kind}: the scale relation does not know how to scale it")


# --- body order ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class BodyOrder(Relation):
    """The same bodies created in the reverse order, and the pair table listed in the
    reverse order with each pair's two bodies swapped: nothing physical changes, only the
    order an engine meets bodies, pairs and contacts in."""

    def applies(self, scene: Scene) -> str | None:
        if len(scene.bodies) < 2 and not scene.pairs:
            return "one body: there is no other order"
        return None

    def transform(self, scene: Scene) -> Scene:
        return replace(scene, bodies=scene.bodies[::-1], pairs=tuple((b, a, m) for a, b, m in scene.pairs[::-1]))


# --- shape representation ------------------------------------------------------------------------

# The half-width (m) of the square mesh a ground plane becomes, about the point of the plane
# nearest the scene's bodies: far beyond any scene of the library (a slide of a few metres)
GROUND_HALF_WIDTH = 50.0


@dataclass(frozen=True)
class Representation(Relation):
    """The same solids given as another shape: `to` "hull" (every box a Hull of its eight
    corners, every 2D rect a Polygon of its four) or "mesh" (every static plane a square
    triangle mesh, 2 GROUND_HALF_WIDTH wide, two triangles, about the bodies). The
    solid is the same (a hull of a box's corners is that box; a mesh plane under the
    bodies is that plane wherever they go), so the physics is the same: only the collision
    routine an engine picks changes."""
    to: str = "hull"

    def applies(self, scene: Scene) -> str | None:
        kinds = {b.shape.kind for b in scene.bodies}
        if self.to == "hull" and not kinds & {"box", "rect"}:
            return "no box or rect in the scene to give as a hull or polygon"
        if self.to == "mesh" and (scene.dimension == 2 or "plane" not in kinds):
            return ("a 2D scene has no mesh shape" if scene.dimension == 2
                    else "no plane in the scene to give as a mesh")
        return None

    def transform(self, scene: Scene) -> Scene:
        centre = np.mean([b.position for b in scene.dynamic_bodies], axis=0)

        def body(b):
            s = b.shape
            if self.to == "hull" and isinstance(s, Box):
                a, c, e = s.half_extents
                return replace(b, shape=Hull(tuple((x, y, z) for x in (-a, a) for y in (-c, c) for z in (-e, e))))
            if self.to == "hull" and isinstance(s, Rect):
                a, c = s.half_extents
                return replace(b, shape=Polygon(((-a, -c), (a, -c), (a, c), (-a, c))))
            if self.to == "mesh" and isinstance(s, Plane):
                return replace(b, shape=_plane_mesh(b, centre), position=(0.0, 0.0, 0.0),
                               orientation=(1.0, 0.0, 0.0, 0.0))
            return b

        return replace(scene, bodies=tuple(body(b) for b in scene.bodies))


def _plane_mesh(b, centre: np.ndarray) -> Mesh:
    """A static plane body as a square of two triangles in the world frame, centred on the
    plane's point nearest `centre`, wound counterclockwise seen from above (the normal side)."""
    R = rotation_matrix(b.orientation)
    n = R @ np.asarray(b.shape.normal, float)
    offset = b.shape.offset + float(n @ np.asarray(b.position, float))
    foot = centre - (n @ centre - offset) * n
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(n, u)  # u, w, n right-handed
    h = GROUND_HALF_WIDTH
    corners = [foot + h * (su * u + sw * w) for su, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    return Mesh(tuple(_vec(c) for c in corners), ((0, 1, 2), (0, 2, 3)))


# --- the relations ---------------------------------------------------------------------------------

# The scenes a default run applies a relation to (physval run without --cases; every other
# variant of the library, or a user's, with --relations and --cases): groups of variants,
# from each of which an engine takes the first it can represent, so a 3D engine runs the 3D
# scene of a group and a 2D engine its 2D one: two runs per group, relation and engine.
BOX_STACK = "stack_forces[n=4,light-heavy]"  # four boxes at rest on each other: contact sets, warm starts,
#   the order a solver visits contacts in (which engines keep a stack the same turned, reordered, restored)
SLIDE = "slide_to_stop[mu=0.5,v0=2,heading=22.5deg]"  # a box sliding off the world axes to a stop: the
#   friction's direction, its stick at the end, resting contact with the ground (slops, margins), 708 steps
SLIDE_2D = "slide_to_stop[mu=0.5,v0=2,2D]"  # the same in the x-z plane, for the 2D engines
STACK_2D = "stack_forces[n=10,light-heavy,2D]"  # ten boxes: enough contacts for a thread pool to split, and
#   for a solver's order of visits (the 2D engines' body order: a scene every 2D engine can express, which
#   three discs with three pair restitutions are not for Box2D's per-body rule)
SLIDING = (SLIDE, SLIDE_2D)
STACKED = (BOX_STACK, STACK_2D)

# Angles not a multiple of 90 degrees (a quarter turn maps the axes onto each other exactly),
# nor of 45 (the diagonal of a box): 37 degrees turns no edge of an axis-aligned box onto an
# axis, so a tangent basis or a broad phase fixed to the world axes sees other numbers.
VERTICAL_ANGLE = math.radians(37.0)
TILTED_AXIS, TILTED_ANGLE = (1.0, 2.0, 2.0), math.radians(53.0)  # |(1, 2, 2)| = 3: a unit axis in thirds
PLANAR_ANGLE = math.radians(29.0)  # a 2D scene's one rotation, about y
# Translations along a direction with a component on every axis (a 2D scene's in x-z), so
# every coordinate, the ground's offset included, moves far from the origin.
SHIFT_3D, SHIFT_2D = (0.6, 0.48, 0.64), (0.6, 0.0, 0.8)
SHIFTS = (10.0, 1000.0, 100000.0)  # m


def _translation(D: float) -> Motion:
    label = f"{D:g}" if D < 1e4 else f"{D:.0f}"
    return Motion(f"translate_{label}m", f"the whole scene moved {label} m (along (0.6, 0.48, 0.64); 2D: (0.6, 0.8))",
                  ROUND_OFF, f"the same arithmetic on coordinates {label} m from the origin: its rounding grows "
                  "with the coordinates' size, u |x| an operation, so the share scales with the distance",
                  shift=_vec(np.asarray(SHIFT_3D) * D), scenes=(SLIDING,),
                  planar=Motion(f"translate_{label}m", "", ROUND_OFF, "-", shift=_vec(np.asarray(SHIFT_2D) * D)))


ROTATE_VERTICAL = Motion(
    "rotate_vertical", "the whole scene turned 37 degrees about the vertical (z)", ROUND_OFF,
    "the same physics in turned coordinates: the turned start state and every step round differently, "
    "by the float width at the scene's size",
    turn=quat_about((0.0, 0.0, 1.0), VERTICAL_ANGLE),
    planar_why="a 2D scene lies in the x-z plane: turning it about z takes it out (rotate_tilted turns it about y)",
    scenes=((SLIDE,), (BOX_STACK,)))
ROTATE_TILTED = Motion(
    "rotate_tilted", "the whole scene turned 53 degrees about the tilted axis (1, 2, 2)/3, gravity turned with "
    "it (2D: 29 degrees about y)", ROUND_OFF,
    "the same physics in turned coordinates (gravity turns too): only rounding differs",
    turn=quat_about(TILTED_AXIS, TILTED_ANGLE), scenes=(SLIDING,),
    planar=Motion("rotate_tilted", "", ROUND_OFF, "-", turn=quat_about((0.0, 1.0, 0.0), PLANAR_ANGLE)))
MIRROR_IMAGE = Motion(
    "mirror", "the mirror image of the scene in the plane x = 0", ROUND_OFF,
    "negation is exact, but an engine may visit contacts in the order of a coordinate (a sweep along x), and "
    "another order of sums rounds differently",
    mirror=True, planar=Motion("mirror", "", ROUND_OFF, "-", mirror=True), scenes=(SLIDING,))
TRANSLATIONS = tuple(_translation(D) for D in SHIFTS)
SCALE_UP = Scale("scale_4", "lengths x 4, times x 2 (masses and gravity kept)", ROUND_OFF,
                 "every factor a power of 2 (exact): an engine with dimensionally consistent arithmetic computes "
                 "the same bits scaled; absolute slops, margins and thresholds do not scale", time_scale=2.0, k=4.0,
                 scenes=(SLIDING,))
SCALE_DOWN = Scale("scale_quarter", "lengths / 4, times / 2 (masses and gravity kept)", ROUND_OFF,
                   "as scale_4, the other way: absolute slops and margins loom larger", time_scale=0.5, k=0.25,
                   scenes=(SLIDING,))
BODY_ORDER = BodyOrder("body_order", "the bodies created in the reverse order, pairs listed the other way",
                       ROUND_OFF, "the same equations; only the order of sums (and of a Gauss-Seidel sweep's "
                       "visits, converged to round-off where it converges) changes", scenes=(STACKED,))
AS_HULL = Representation("as_hull", "every box given as the hull of its corners (2D: every rect as a polygon)",
                         ROUND_OFF, "the same solid: the contact features are the same corners and faces, found by "
                         "another collision routine", to="hull",
                         scenes=(SLIDING,))
AS_MESH = Representation("as_mesh", "every ground plane given as a two-triangle mesh 100 m wide", ROUND_OFF,
                         "the same surface under the bodies: the contacts are the same, found by another routine",
                         to="mesh", scenes=((SLIDE,),))
THREADS = Relation("threads", "stepped by a pool of 4 threads against 1", BIT_IDENTICAL,
                   "a deterministic engine's threads split the same work: the same sums in the same order",
                   needs="threads", settings=(("threads", 4),), scenes=(STACKED,))
WORLDS = Relation("worlds", "the scene as world 3 of a batch of 4 against alone", BIT_IDENTICAL,
                  "batched worlds do not interact: each is the same arithmetic on its own numbers",
                  needs="worlds", settings=(("world", (3, 4)),), scenes=(STACKED,))
SAVE_RESTORE = Relation("save_restore", "the state saved midway and restored into a freshly built engine",
                        BIT_IDENTICAL, "a saved state that is the engine's whole state continues exactly as the "
                        "engine it was saved from (its warm-start cache and contact state included)",
                        needs="save_restore", restart=True, scenes=((BOX_STACK, SLIDE_2D),))

RELATIONS: tuple[Relation, ...] = (ROTATE_VERTICAL, ROTATE_TILTED, *TRANSLATIONS, MIRROR_IMAGE, SCALE_UP,
                                    SCALE_DOWN, BODY_ORDER, AS_HULL, AS_MESH, THREADS, WORLDS, SAVE_RESTORE)


def by_name(name: str) -> Relation:
    for r in RELATIONS:
        if r.name == name:
            return r
    raise KeyError(f"no relation {name!r}: choose from {', '.join(r.name for r in RELATIONS)}")
