"""The engine-neutral scene vocabulary: shapes, bodies, pair materials, gravity, effects.

This module is the one thing `cases/` and `adapters/` share. A scene is immutable and is
validated when it is made: a bad field raises `SceneError` naming the field and the range
it must lie in, so no engine ever sees it.

Conventions (SI units throughout):
- positions in metres, world frame, z up;
- orientation as a unit quaternion (w, x, y, z), body to world;
- angular velocity in the world frame, rad/s;
- a 2D scene (`dimension=2`) lies in the x-z plane: y and the rotations about x and z
  stay zero, and its shapes are `Circle`, `Rect`, `Polygon` and `Plane`;
- a body's position and orientation are those of its body frame: the centre of mass and
  principal axes of its shape (each shape's docstring says where they lie), so `inertia`
  holds three principal moments.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from cases.overlap import exact, may_touch, penetration

# The physics a scene can call for (Scene.effects, derived from the scene; an adapter
# simulates these and nothing more, and reports what it simulated in Simulation.effects):
# "gravity" (non-zero gravity), "contact" (a pair that may touch), "restitution" (a pair
# with e > 0), "friction" (a pair with mu_s > 0), "rotation" (a dynamic body that rotates),
# "rolling_resistance" / "torsional_friction" (a pair with Material.rolling_resistance /
# Material.torsional_friction > 0: the contact torques of CONTACT_TORQUES).
# "joint" (a scene with Joints), "limit" (a joint with limits), "load" (a constant external
# force or torque, Scene.loads), "joint_friction" (a joint with Joint.friction > 0),
# "limit_restitution" (a joint with limits and Joint.limit_e > 0).
EFFECTS = ("gravity", "contact", "restitution", "friction", "rotation", "rolling_resistance",
           "torsional_friction", "joint", "limit", "load", "joint_friction", "limit_restitution")
# The effects that are torques a contact exerts (about the rolling axes, about the normal);
# an engine declares the ones it models in Capabilities.contact_torques.
CONTACT_TORQUES = ("rolling_resistance", "torsional_friction")

# How an engine resolves impacts at several contacts within one step (an adapter declares
# its model in Capabilities.impact_model):
# "simultaneous": one impulse problem over all contacts of the step, restitution applied to
#   each contact's own approach velocity (two touching balls dropped on the ground leave it
#   together at e v);
# "sequential": contacts resolved one after another as two-body impacts, so an impulse
#   travels through a chain of touching bodies (Newton's cradle; the top ball of a dropped
#   pair is launched faster than e v);
# "compliant": contacts are springs (dampers) acting over several steps; the outcome
#   depends on the stiffnesses and lies between the two.
IMPACT_MODELS = ("simultaneous", "sequential", "compliant")
# A case that checks one model's closed form names it in its needs, e.g.
# "impact_model:sequential"; an engine that declares another model (or none) reports the
# variant unsupported (adapters.base.Capabilities.cannot_run).
IMPACT_MODEL_NEED = "impact_model:"

# The restitution law an engine applies at a contact with friction (an adapter declares it
# in Capabilities.restitution_law; the closed forms differ where a frictional contact has
# e > 0 and its impulse turns a body, so normal and tangential velocities couple):
# "newton": Newton's velocity restitution with Coulomb friction acting throughout the
#   impact (the Newton-Coulomb impulse of note 004: u_n+ = -e u_n-, friction on the whole
#   normal impulse);
# "two_phase": a plastic impact with Coulomb friction (the Newton-Coulomb impulse at e = 0),
#   then a normal impulse alone up to Newton's u_n+ = -e u_n-, without friction (Box2D and
#   Rapier apply restitution in a pass of its own after the solve);
# "poisson": Poisson's hypothesis, the restitution impulse e times the compression impulse,
#   with Coulomb friction in both phases (no built-in engine declares it; a plug-in may).
# The closed forms of all three: cases/impact_laws.py.
RESTITUTION_LAWS = ("newton", "two_phase", "poisson")
RESTITUTION_LAW_NEED = "restitution_law:"

# Bodies may start this far inside each other: contact geometry built by hand is exact to
# rounding (1e-12 m), and 1 um is far below any depth an engine resolves at dt = 1e-3.
DEFAULT_ALLOWED_OVERLAP = 1e-6


class SceneError(ValueError):
    """A scene field outside its allowed range; the message names the field."""


def _finite(value, where: str, shape: tuple[int, ...] | None = None) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        what = "a number" if shape is None else f"{shape[0]} numbers"
        raise SceneError(f"{where} = {value!r}: must be {what}") from None
    if shape is not None and array.shape != shape:
        raise SceneError(f"{where} = {value!r}: must have {shape[0]} components")
    if not np.all(np.isfinite(array)):
        raise SceneError(f"{where} = {value!r}: must be finite (no NaN or infinity)")
    return array


def _positive(value: float, where: str) -> float:
    _finite(value, where)
    if not value > 0:
        raise SceneError(f"{where} = {value!r}: must be > 0")
    return float(value)


# --- geometry of the point-set shapes (Hull, Polygon, Mesh) --------------------------------

# A hull, polygon or triangle thinner than this fraction of its size is flat to rounding
# (float64 coordinates carry 1e-16 of the size; a real plate is far thicker than 1e-12).
FLAT = 1e-12
# A hull's centre of mass and off-diagonal inertia (a polygon's centroid) must vanish to this
# fraction of its size (of the tensor's trace): points typed by hand or made with sin and cos
# are exact to ~1e-16, and a frame that is off by design is off by far more than 1e-9.
FRAME_TOLERANCE = 1e-9


def _as_tuples(value, kind=float):
    """`value` as a tuple of tuples of `kind` (hashable, for a frozen shape); as given if it
    is not a sequence of sequences of real numbers (validate() then names the field)."""
    try:
        rows = tuple(tuple(row) for row in value)
    except TypeError:
        return value
    numbers_only = all(isinstance(c, numbers.Real) and not isinstance(c, bool) for row in rows for c in row)
    if not numbers_only or (kind is int and not all(float(c).is_integer() for row in rows for c in row)):
        return value
    return tuple(tuple(kind(c) for c in row) for row in rows)


def _brief(value, most: int = 3) -> str:
    """repr of `value`, its first `most` items and a count if it is longer."""
    if isinstance(value, (tuple, list)) and len(value) > most:
        return "(" + ", ".join(repr(v) for v in value[:most]) + f", ... ({len(value)} in all))"
    return repr(value)


def _points(value, where: str, dim: int, least: int) -> np.ndarray:
    """`value` as an (n, dim) array of finite coordinates, n >= least, or SceneError."""
    what = "(x, y, z)" if dim == 3 else "(x, z)"
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SceneError(f"{where} = {_brief(value)}: must be a sequence of {what} points in m") from None
    if array.ndim != 2 or array.shape[1] != dim:
        raise SceneError(f"{where} = {_brief(value)}: must be a sequence of {what} points in m")
    if len(array) < least:
        raise SceneError(f"{where} = {_brief(value)}: must be at least {least} points")
    if not np.all(np.isfinite(array)):
        raise SceneError(f"{where} = {_brief(value)}: must be finite (no NaN or infinity)")
    return array


def _corners(value, where: str, dim: int) -> np.ndarray:
    """The points of a Hull (dim 3) or Polygon (dim 2) as an array, checked to be the
    distinct corners of a convex hull of full dimension."""
    from scipy.spatial import ConvexHull, QhullError
    points = _points(value, where, dim, least=dim + 1)
    _, first, count = np.unique(points, axis=0, return_index=True, return_counts=True)
    if np.any(count > 1):
        k = min(set(range(len(points))) - set(first))
        i = int(np.flatnonzero(np.all(points == points[k], axis=1))[0])
        raise SceneError(f"{where}[{k}] = {tuple(points[k])}: must differ from every other point "
                         f"(it repeats {where.rsplit('.', 1)[-1]}[{i}])")
    try:
        hull = ConvexHull(points)
    except QhullError:
        flat = "coplanar" if dim == 3 else "collinear"
        raise SceneError(f"{where} = {_brief(value)}: must span {'a volume' if dim == 3 else 'an area'} "
                         f"(the points are {flat})") from None
    inside = sorted(set(range(len(points))) - set(hull.vertices.tolist()))
    if inside:
        k = inside[0]
        raise SceneError(f"{where}[{k}] = {tuple(float(c) for c in points[k])}: must be a corner of the convex "
                         "hull of the points (it lies inside it or on its boundary: the shape is given by its "
                         "corners" + (", and a polygon must be convex)" if dim == 2 else ")"))
    return points


def _outward_triangles(points: np.ndarray) -> np.ndarray:
    """The faces of the convex hull of `points` (3D) as triangles wound outward."""
    from scipy.spatial import ConvexHull
    hull = ConvexHull(points)
    tri = hull.simplices.copy()
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), hull.equations[:, :3]) < 0
    tri[inward] = tri[inward][:, [0, 2, 1]]
    return tri


def _polyhedron_moments(points: np.ndarray, tri: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume, first moment (3,) and second moment (3, 3) (the integrals of 1, x, x x^T)
    of the solid polyhedron with corners `points` and outward face triangles `tri`: a sum
    over signed tetrahedra (origin, a, b, c), one per face triangle (Tonon 2004; Mirtich
    1996: see Hull)."""
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    v = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0  # signed volumes
    s = a + b + c
    first = (v[:, None] * s).sum(axis=0) / 4.0  # tetrahedron centroid (0 + a + b + c) / 4
    outer = lambda x: np.einsum("i,ij,ik->jk", v, x, x)  # noqa: E731
    second = (outer(a) + outer(b) + outer(c) + outer(s)) / 20.0
    return float(v.sum()), first, second


def _inertia_tensor(second: np.ndarray) -> np.ndarray:
    """The inertia tensor per unit density from the second moment C = integral of x x^T:
    I = tr(C) 1 - C."""
    return np.trace(second) * np.eye(3) - second


def _ordered(points: np.ndarray) -> np.ndarray:
    """The corners of a convex polygon (n, 2) counterclockwise (scipy's 2D hull order)."""
    from scipy.spatial import ConvexHull
    return points[ConvexHull(points).vertices]


def _polygon_moments(points: np.ndarray) -> tuple[float, np.ndarray, float]:
    """Area, first moment (x, z) and polar second moment about the origin of the convex
    polygon with corners `points` (any order): Green's theorem over its edges, corners
    counterclockwise (scipy's 2D hull order)."""
    p = _ordered(points)
    q = np.roll(p, -1, axis=0)
    cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
    area = cross.sum() / 2.0
    first = ((p + q) * cross[:, None]).sum(axis=0) / 6.0
    polar = (cross * (p[:, 0]**2 + p[:, 0] * q[:, 0] + q[:, 0]**2
                      + p[:, 1]**2 + p[:, 1] * q[:, 1] + q[:, 1]**2)).sum() / 12.0
    return float(area), first, float(polar)


def _principal(where: str, vertices, centre: np.ndarray, tensor: np.ndarray, size: float) -> None:
    """SceneError unless the centre of mass is at the origin and the inertia tensor diagonal."""
    if np.linalg.norm(centre) > FRAME_TOLERANCE * size:
        raise SceneError(f"{where}.vertices = {_brief(vertices)}: must have their centre of mass at the origin "
                         f"(it is at {_brief(tuple(float(c) for c in centre))} m): "
                         "cases.scene.principal_frame moves them there")
    off = np.abs(tensor - np.diag(np.diag(tensor))).max()
    if off > FRAME_TOLERANCE * np.trace(tensor):
        raise SceneError(f"{where}.vertices = {_brief(vertices)}: must be given in the principal axes (the "
                         f"inertia tensor has off-diagonal terms {off / np.trace(tensor):.3g} of its trace): "
                         "cases.scene.principal_frame rotates them there")


def principal_frame(vertices) -> tuple[tuple, tuple[float, float, float], tuple[float, float, float, float]]:
    """Move a Hull's (3D) or Polygon's (2D) point set into its body frame.

    Returns (points, centre, rotation): the points in the body frame (a Hull's centre of
    mass at the origin and principal axes along x, y, z in increasing order of moment; a
    Polygon's centroid at the origin, unrotated), the centre of mass in the points' frame as
    (x, y, z) m (y = 0 for a polygon), and the rotation from the body frame to the points'
    frame as a unit quaternion (w, x, y, z) (identity for a polygon). A solid whose points
    were meant at pose (p, q) therefore has the body pose position = p + R(q) centre,
    orientation = q * rotation. The input is not validated here: the shape is, when made
    into a scene."""
    from scipy.spatial.transform import Rotation
    points = np.asarray(vertices, dtype=float)
    if points.ndim == 2 and points.shape[1] == 2:
        area, first, _ = _polygon_moments(points)
        c = first / area
        return _as_tuples(points - c), (float(c[0]), 0.0, float(c[1])), (1.0, 0.0, 0.0, 0.0)
    volume, first, second = _polyhedron_moments(points, _outward_triangles(points))
    c = first / volume
    about_c = second - volume * np.outer(c, c)  # parallel-axis theorem for the second moment
    _, axes = np.linalg.eigh(_inertia_tensor(about_c))  # columns: principal axes, moments ascending
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    x, y, z, w = Rotation.from_matrix(axes).as_quat()
    return _as_tuples((points - c) @ axes), tuple(float(v) for v in c), (float(w), float(x), float(y), float(z))


# --- shapes -------------------------------------------------------------------------------

@dataclass(frozen=True)
class Sphere:
    """A ball of `radius` m, centred on its body's position (3D scenes). Default inertia
    of a solid ball: 2/5 m r^2 about every axis."""
    radius: float
    kind = "sphere"
    dimension = 3

    def inertia(self, m: float) -> tuple[float, float, float]:
        i = 2.0 / 5.0 * m * self.radius**2
        return (i, i, i)

    def validate(self, where: str) -> None:
        _positive(self.radius, f"{where}.radius")


@dataclass(frozen=True)
class Box:
    """A cuboid with `half_extents` (a, b, c) m along its body's x, y, z axes, centred on
    the body's position (3D scenes). Default inertia of a solid box:
    m (b^2 + c^2) / 3, m (a^2 + c^2) / 3, m (a^2 + b^2) / 3 (principal, body frame)."""
    half_extents: tuple[float, float, float]
    kind = "box"
    dimension = 3

    def inertia(self, m: float) -> tuple[float, float, float]:
        a, b, c = self.half_extents
        return (m * (b * b + c * c) / 3.0, m * (a * a + c * c) / 3.0, m * (a * a + b * b) / 3.0)

    def validate(self, where: str) -> None:
        _finite(self.half_extents, f"{where}.half_extents", (3,))
        for axis, h in zip("xyz", self.half_extents):
            _positive(h, f"{where}.half_extents.{axis}")


@dataclass(frozen=True)
class Plane:
    """The static half-space below the plane n . x = offset (solid on the side opposite n):
    `normal` a unit vector (default +z), `offset` in m. Only a static body may have it; in a
    2D scene it is a line of the x-z plane (engines cannot represent a normal with a
    y component there and report `unsupported`)."""
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    offset: float = 0.0
    kind = "plane"
    dimension = None  # a line in 2D scenes, a plane in 3D ones

    def inertia(self, m: float):
        raise SceneError("a plane is static: it has no inertia")

    def centre_under(self, scene: "Scene", cell: float) -> np.ndarray:
        """Where an engine's finite stand-in for the plane (a box, a segment `cell` m from its
        centre to its edge) is centred: the plane's point nearest the origin, moved along the
        plane by whole multiples of `cell` per world axis towards the dynamic bodies' mean
        position. A scene within cell / 2 of that point keeps it exactly (offset n); one moved
        far from the origin (the invariance battery's translations) still stands on the
        stand-in instead of beyond its edge."""
        n = np.asarray(self.normal, float)
        base = self.offset * n
        bodies = [b.position for b in scene.bodies if not b.static]
        if not bodies:
            return base
        t = np.mean(np.asarray(bodies, float), axis=0) - base
        shift = cell * np.round((t - (n @ t) * n) / cell)
        shift -= (n @ shift) * n
        return base + shift if shift.any() else base

    def validate(self, where: str) -> None:
        n = _finite(self.normal, f"{where}.normal", (3,))
        _finite(self.offset, f"{where}.offset")
        if abs(np.linalg.norm(n) - 1.0) > 1e-9:
            raise SceneError(f"{where}.normal = {self.normal!r}: must be a unit vector")


@dataclass(frozen=True)
class Circle:
    """A disc of `radius` m in a 2D scene (x-z plane); 3D engines embed it as a cylinder
    along y. Default inertia of a solid disc about y: m r^2 / 2."""
    radius: float
    kind = "circle"
    dimension = 2

    def inertia(self, m: float) -> tuple[float, float, float]:
        i = 0.5 * m * self.radius**2  # about y, the only axis a 2D body turns about
        return (i, i, i)

    def validate(self, where: str) -> None:
        _positive(self.radius, f"{where}.radius")


@dataclass(frozen=True)
class Rect:
    """A rectangle in a 2D scene (x-z plane): `half_extents` (a, c) m along the body's x
    and z axes; 3D engines embed it as a box along y. Default inertia about y, the only
    axis a 2D body turns about: m (a^2 + c^2) / 3."""
    half_extents: tuple[float, float]
    kind = "rect"
    dimension = 2

    def inertia(self, m: float) -> tuple[float, float, float]:
        a, c = self.half_extents
        i = m * (a * a + c * c) / 3.0
        return (i, i, i)

    def validate(self, where: str) -> None:
        _finite(self.half_extents, f"{where}.half_extents", (2,))
        for axis, h in zip("xz", self.half_extents):
            _positive(h, f"{where}.half_extents.{axis}")


@dataclass(frozen=True)
class _AlongZ:
    """A solid of revolution about its body's z axis: `radius` and `half_length` in m."""
    radius: float
    half_length: float

    def validate(self, where: str) -> None:
        _positive(self.radius, f"{where}.radius")
        _positive(self.half_length, f"{where}.half_length")


@dataclass(frozen=True)
class Capsule(_AlongZ):
    """A capsule (3D scenes): the points within `radius` m of the segment from
    (0, 0, -half_length) to (0, 0, +half_length) on its body's z axis. The body's position is
    the segment's midpoint, its centre of mass; body z is its axis (the symmetry axis), and
    any two axes across it are principal. Overall length 2 (half_length + radius).

    Default inertia of a solid capsule of uniform density, from its cylinder (mass m_c) and
    its two hemispherical caps (mass m_h in all), the mass shared by volume
    (2 h pi r^2 against 4/3 pi r^3):
      I_z = m_c r^2 / 2 + 2/5 m_h r^2,
      I_x = I_y = m_c (r^2/4 + h^2/3) + m_h (2/5 r^2 + h^2 + 3/4 h r)
    (each cap's centroid lies 3r/8 past its end of the segment; parallel-axis theorem).
    Validated: radius > 0, half_length > 0 (a capsule of no length is a Sphere)."""
    kind = "capsule"
    dimension = 3

    def inertia(self, m: float) -> tuple[float, float, float]:
        r, h = self.radius, self.half_length
        v_cyl, v_caps = 2.0 * h * math.pi * r * r, 4.0 / 3.0 * math.pi * r**3
        m_c, m_h = m * v_cyl / (v_cyl + v_caps), m * v_caps / (v_cyl + v_caps)
        across = m_c * (r * r / 4.0 + h * h / 3.0) + m_h * (0.4 * r * r + h * h + 0.75 * h * r)
        return (across, across, 0.5 * m_c * r * r + 0.4 * m_h * r * r)


@dataclass(frozen=True)
class Cylinder(_AlongZ):
    """A solid circular cylinder (3D scenes) of `radius` m whose axis is its body's z axis,
    with flat ends at z = -half_length and z = +half_length. The body's position is its
    centre (of mass); body z is the symmetry axis, and any two axes across it are principal.
    Default inertia of a solid cylinder of uniform density:
      I_z = m r^2 / 2,   I_x = I_y = m (r^2/4 + h^2/3)  (h = half_length).
    Validated: radius > 0, half_length > 0."""
    kind = "cylinder"
    dimension = 3

    def inertia(self, m: float) -> tuple[float, float, float]:
        r, h = self.radius, self.half_length
        across = m * (r * r / 4.0 + h * h / 3.0)
        return (across, across, 0.5 * m * r * r)


@dataclass(frozen=True)
class Hull:
    """A convex polyhedron (3D scenes): the convex hull of `vertices`, its corners (x, y, z)
    in m in the body frame, in any order. The body frame is the hull's principal frame: its
    centre of mass (uniform density) at the origin and its principal axes along x, y, z, as
    for a Box. A point set given in another frame is refused; `principal_frame(vertices)`
    moves it there and returns the shift and the rotation to put into the body's pose.

    Default inertia of the solid hull at uniform density, by the polyhedral mass-property
    integral: the hull's faces (scipy.spatial.ConvexHull, triangulated, wound outward) and
    the origin span signed tetrahedra, whose volumes a.(b x c)/6 and second moments
    V/20 (a a^T + b b^T + c c^T + s s^T), s = a + b + c, sum to the solid's (Tonon 2004,
    J. Math. Stat. 1(1), "Explicit exact formulas for the 3-D tetrahedron inertia tensor in
    terms of its vertex coordinates"; the same integrals Mirtich 1996, J. Graphics Tools 1(2),
    "Fast and accurate computation of polyhedral mass properties", reduces to the faces by
    the divergence theorem). Exact to
    rounding for the polyhedron; a hull that approximates a curved solid differs from it by
    its facets (a regular n-gon prism inscribed in a cylinder: I_z smaller by the relative
    amount (1 - cos(2 pi / n)) / 3).

    Validated: at least 4 points, finite, none repeated; spanning a volume (not coplanar);
    every point a corner of their hull (none inside it or on a face or an edge: a Hull is
    given by its corners, so engines that take a vertex list get the same solid); the centre
    of mass at the origin and the inertia tensor diagonal, both to 1e-9 of the hull's size."""
    vertices: tuple[tuple[float, float, float], ...]
    kind = "hull"
    dimension = 3

    def __post_init__(self):
        object.__setattr__(self, "vertices", _as_tuples(self.vertices))

    @cached_property
    def mass_properties(self) -> tuple[float, np.ndarray, np.ndarray]:
        """(volume m^3, first moment m^4 (3,), second moment m^5 (3, 3): the integrals of
        1, x and x x^T over the solid in the body frame)."""
        return _polyhedron_moments(np.asarray(self.vertices, dtype=float), self.faces)

    @cached_property
    def faces(self) -> np.ndarray:
        """The hull's faces as triangles (F, 3) of indices into `vertices`, each wound
        counterclockwise seen from outside (its normal by the right-hand rule points out)."""
        return _outward_triangles(np.asarray(self.vertices, dtype=float))

    def inertia(self, m: float) -> tuple[float, float, float]:
        volume, _, second = self.mass_properties
        return tuple(float(i) for i in np.diag(_inertia_tensor(second)) * m / volume)

    def validate(self, where: str) -> None:
        points = _corners(self.vertices, f"{where}.vertices", 3)
        volume, first, second = self.mass_properties
        size = float(np.ptp(points, axis=0).max())
        if not volume > FLAT * size**3:
            raise SceneError(f"{where}.vertices = {_brief(self.vertices)}: must span a volume "
                             "(the points are coplanar)")
        _principal(where, self.vertices, first / volume, _inertia_tensor(second), size)


@dataclass(frozen=True)
class Polygon:
    """A convex polygon in a 2D scene (x-z plane): the convex hull of `vertices`, its corners
    (x, z) in m in the body frame, in any order; 3D engines embed it as a prism along y, as
    a Rect. The body's position is its centroid (the origin of the vertices): a 2D body
    turns about y only, so no axes need aligning; `principal_frame(vertices)` moves a point
    set there. Default inertia about y, the only axis a 2D body turns about: m J / A, with
    the area A and polar area moment J about the centroid of the polygon (Green's theorem
    over its edges: A = 1/2 sum c_i, J = 1/12 sum c_i (x_i^2 + x_i x_i+1 + x_i+1^2 + z_i^2 +
    z_i z_i+1 + z_i+1^2), c_i = x_i z_i+1 - x_i+1 z_i, corners counterclockwise).

    Validated: at least 3 points, finite, none repeated; spanning an area (not collinear);
    every point a corner (the polygon is convex, no point on an edge); the centroid at the
    origin to 1e-9 of the polygon's size."""
    vertices: tuple[tuple[float, float], ...]
    kind = "polygon"
    dimension = 2

    def __post_init__(self):
        object.__setattr__(self, "vertices", _as_tuples(self.vertices))

    @cached_property
    def mass_properties(self) -> tuple[float, np.ndarray, float]:
        """(area m^2, first moment m^3 (x, z), polar second moment m^4 about the origin)."""
        return _polygon_moments(np.asarray(self.vertices, dtype=float))

    @cached_property
    def corners(self) -> np.ndarray:
        """The corners (n, 2) in order around the polygon, counterclockwise in (x, z)
        coordinates (from +x towards +z)."""
        return _ordered(np.asarray(self.vertices, dtype=float))

    def inertia(self, m: float) -> tuple[float, float, float]:
        area, _, polar = self.mass_properties
        i = m * polar / area  # about y, the only axis a 2D body turns about
        return (i, i, i)

    def validate(self, where: str) -> None:
        points = _corners(self.vertices, f"{where}.vertices", 2)
        area, first, _ = _polygon_moments(points)
        size = float(np.ptp(points, axis=0).max())
        if not area > FLAT * size**2:
            raise SceneError(f"{where}.vertices = {_brief(self.vertices)}: must span an area "
                             "(the points are collinear)")
        centroid = first / area
        if np.linalg.norm(centroid) > FRAME_TOLERANCE * size:
            raise SceneError(f"{where}.vertices = {_brief(self.vertices)}: must have their centroid at the "
                             f"origin (it is at x, z = {_brief(tuple(float(c) for c in centroid))} m): "
                             "cases.scene.principal_frame moves them there")


@dataclass(frozen=True)
class Mesh:
    """A static triangle mesh (3D scenes): a ground or an obstacle, never a dynamic body (it
    has no mass properties). `vertices` are points (x, y, z) in m in the body frame (the
    body's position and orientation place it); `triangles` are index triples into
    `vertices`, each wound counterclockwise seen from the side the other bodies are on (its
    normal by the right-hand rule points out of the solid). The mesh need not be closed (a
    ground is an open surface) or convex.

    Validated: at least one triangle; finite vertices; indices whole numbers in
    [0, len(vertices)); every triangle of area > 0 (its cross product larger than 1e-12 of its
    longest edge squared); manifold edges (each edge in at most two triangles), and the two
    triangles at an edge wound alike (they run along it in opposite directions)."""
    vertices: tuple[tuple[float, float, float], ...]
    triangles: tuple[tuple[int, int, int], ...]
    kind = "mesh"
    dimension = 3

    def __post_init__(self):
        object.__setattr__(self, "vertices", _as_tuples(self.vertices))
        object.__setattr__(self, "triangles", _as_tuples(self.triangles, int))

    def inertia(self, m: float):
        raise SceneError("a mesh is static: it has no inertia")

    def validate(self, where: str) -> None:
        points = _points(self.vertices, f"{where}.vertices", 3, least=3)
        try:
            tri = np.asarray(self.triangles)
            ok = tri.ndim == 2 and tri.shape[1] == 3 and len(tri) > 0 and np.all(tri == np.round(tri))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise SceneError(f"{where}.triangles = {_brief(self.triangles)}: must be one or more "
                             "triples of vertex indices")
        tri = tri.astype(int)
        for k, t in enumerate(tri):
            if t.min() < 0 or t.max() >= len(points):
                raise SceneError(f"{where}.triangles[{k}] = {tuple(map(int, t))}: must index vertices "
                                 f"0..{len(points) - 1}")
        a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
        twice_area = np.linalg.norm(np.cross(b - a, c - a), axis=1)
        longest = np.max([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                          np.linalg.norm(a - c, axis=1)], axis=0)
        for k in np.flatnonzero(~(twice_area > FLAT * longest**2)):
            raise SceneError(f"{where}.triangles[{k}] = {tuple(map(int, tri[k]))}: must have an area > 0 "
                             "(its corners repeat or are collinear)")
        seen: dict[tuple[int, int], int] = {}  # directed edge -> triangle
        users: dict[tuple[int, int], int] = {}  # undirected edge -> number of triangles
        for k, t in enumerate(tri):
            for i, j in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
                i, j = int(i), int(j)
                key = (min(i, j), max(i, j))
                users[key] = users.get(key, 0) + 1
                if users[key] > 2:
                    raise SceneError(f"{where}.triangles[{k}] = {tuple(map(int, t))}: must leave each edge in at "
                                     f"most two triangles (the edge {key} is in a third: the mesh is not manifold)")
                if (i, j) in seen:
                    raise SceneError(f"{where}.triangles[{k}] = {tuple(map(int, t))}: must be wound as its "
                                     f"neighbour triangles[{seen[(i, j)]}] (both run along the edge ({i}, {j}) "
                                     "the same way; each should be counterclockwise seen from outside)")
                seen[(i, j)] = k


# Every shape of the vocabulary; Capabilities.shapes names their kinds.
SHAPES = (Sphere, Box, Plane, Circle, Rect, Capsule, Cylinder, Hull, Polygon, Mesh)
SHAPE_KINDS = tuple(s.kind for s in SHAPES)
STATIC_ONLY = ("plane", "mesh")  # kinds only a static body may have
Shape = Sphere | Box | Plane | Circle | Rect | Capsule | Cylinder | Hull | Polygon | Mesh


# --- materials and bodies -----------------------------------------------------------------

@dataclass(frozen=True)
class Compliance:
    """A compliant contact law for a pair (note 001, "Elastic Impact Details", "Hertz
    Constant", "Analyzing Newton's Cradle"): the bodies overlap by xi and push apart with
    - "hertz": F = H xi^1.5, H from Young's modulus E (Pa) and Poisson's ratio nu of the
      material both bodies are made of, and the radii of curvature at the contact;
    - "hooke": F = k xi with the contact stiffness k (N/m).
    Without it (Material.compliance = None) contact is rigid."""
    law: str
    E: float | None = None
    nu: float | None = None
    k: float | None = None

    def validate(self, where: str) -> None:
        if self.law == "hertz":
            if self.E is None or self.nu is None or self.k is not None:
                raise SceneError(f"{where}: a Hertz contact takes E and nu (and no k)")
            _positive(self.E, f"{where}.E")
            _finite(self.nu, f"{where}.nu")
            if not 0.0 <= self.nu < 0.5:
                raise SceneError(f"{where}.nu = {self.nu!r}: Poisson's ratio must lie in [0, 0.5)")
        elif self.law == "hooke":
            if self.k is None or self.E is not None or self.nu is not None:
                raise SceneError(f"{where}: a Hooke contact takes k (and no E, nu)")
            _positive(self.k, f"{where}.k")
        else:
            raise SceneError(f"{where}.law = {self.law!r}: must be 'hertz' or 'hooke'")


@dataclass(frozen=True)
class Material:
    """What a pair of bodies does on contact (a scene's default, or one pair's in Scene.pairs).

    - `e`: Newton's coefficient of restitution in [0, 1], the ratio of the normal
      velocities after and before an impact (0: plastic, 1: elastic);
    - `mu_s`: Coulomb's static friction coefficient (>= 0; 0: frictionless);
    - `mu_k`: the kinetic coefficient, <= mu_s (None: equal to mu_s). Engines with one
      coefficient report a pair with mu_k != mu_s `unsupported`;
    - `compliance`: a compliant contact law (`Compliance`), or None for rigid contact;
    - `rolling_resistance`: d_r in m (>= 0; 0: none), the lever arm of the normal force N
      against rolling: the contact exerts a torque about the rolling axes (tangent to the
      contact plane) opposing the relative rolling, |tau_r| <= d_r N (isotropic: a disc
      in the tangent plane), as static friction holds up to mu_s N. Note 001 ("dry
      friction") writes rolling friction as a force F_r = mu_r F_n, mu_r << mu_k: for a
      body of radius r that is the same law with mu_r = d_r / r (the torque d_r N at the
      contact equals F_r r). A length, not mu_r, because it does not depend on the shape:
      MuJoCo's rolling coefficient (friction[3:5], condim 6) and Bullet's rollingFriction
      (the combined value times the normal impulse) are this length; Box2D v3's
      rollingResistance is mu_r (it multiplies by the larger radius of the pair), so its
      adapter divides;
    - `torsional_friction`: d_t in m (>= 0; 0: none), the same law about the contact
      normal: a torque opposing the relative spin about n, |tau_n| <= d_t N (a contact
      patch of radius a with uniform pressure and Coulomb friction mu gives
      d_t = 2/3 mu a). MuJoCo's torsional coefficient (friction[2], condim 4 or 6) and
      Bullet's spinningFriction are this length.
    Engines that model neither report a pair asking for them `unsupported`
    (Capabilities.contact_torques).
    """
    e: float = 0.0
    mu_s: float = 0.0
    mu_k: float | None = None  # None: equal to mu_s
    compliance: Compliance | None = None
    rolling_resistance: float = 0.0  # m: |tau_r| <= d_r N about the rolling axes
    torsional_friction: float = 0.0  # m: |tau_n| <= d_t N about the contact normal

    @property
    def mu_k_(self) -> float:
        """The kinetic coefficient in force (mu_s when mu_k is None)."""
        return self.mu_s if self.mu_k is None else self.mu_k

    def validate(self, where: str) -> None:
        _finite(self.e, f"{where}.e")
        if not 0.0 <= self.e <= 1.0:
            raise SceneError(f"{where}.e = {self.e!r}: coefficient of restitution must lie in [0, 1]")
        _finite(self.mu_s, f"{where}.mu_s")
        if self.mu_s < 0:
            raise SceneError(f"{where}.mu_s = {self.mu_s!r}: friction coefficient must be >= 0")
        if self.mu_k is not None:
            _finite(self.mu_k, f"{where}.mu_k")
            if self.mu_k < 0:
                raise SceneError(f"{where}.mu_k = {self.mu_k!r}: friction coefficient must be >= 0")
            if self.mu_k > self.mu_s:
                raise SceneError(f"{where}.mu_k = {self.mu_k!r}: must be <= mu_s = {self.mu_s!r}")
        for name in CONTACT_TORQUES:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise SceneError(f"{where}.{name} = {value!r}: must be a number (a lever arm in m, >= 0)")
            _finite(value, f"{where}.{name}")
            if value < 0:
                raise SceneError(f"{where}.{name} = {value!r}: a lever arm in m, must be >= 0")
        if self.compliance is not None:
            self.compliance.validate(f"{where}.compliance")

    def torque(self, effect: str) -> float:
        """The lever arm (m) of a contact torque of CONTACT_TORQUES: d_r or d_t."""
        if effect not in CONTACT_TORQUES:
            raise KeyError(f"{effect!r}: not a contact torque ({', '.join(CONTACT_TORQUES)})")
        return float(getattr(self, effect))

    @property
    def frictional(self) -> bool:
        """True when the pair has friction (mu_s > 0)."""
        return self.mu_s > 0


@dataclass(frozen=True)
class Body:
    """A rigid body of the scene, in its start state.

    - `name`: unique in the scene; trajectories, contact forces and pairs use it;
    - `shape`: Sphere, Box, Capsule, Cylinder, Hull, Plane and Mesh (these two static only)
      in 3D; Circle, Rect, Polygon and Plane in 2D. `position` and `orientation` place the
      shape's body frame: its centre of mass and principal axes (a Box's and a Hull's x, y, z;
      a Capsule's and a Cylinder's axis along z); a Plane's and a Mesh's frame is where
      their normal and offset, or vertices, are given;
    - `mass`: kg, > 0 for a dynamic body, None for a static one;
    - `inertia`: principal moments (kg m^2) in the body frame; None: the shape's solid
      default (see each shape);
    - `position` (m), `orientation` (unit quaternion w, x, y, z, body to world),
      `velocity` (m/s), `angular_velocity` (rad/s, world frame): the start state;
    - `static`: fixed in place, infinite mass (the ground, walls);
    - `rotates`: False holds the orientation fixed (a sphere in a frictionless central
      impact, a block that must only slide), so no engine spins it up from round-off.
    """
    name: str
    shape: Shape
    mass: float | None = None  # None for a static body
    inertia: tuple[float, float, float] | None = None  # principal, body frame; None: from shape
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    static: bool = False
    rotates: bool = True  # False: the orientation is held fixed (e.g. a sphere in a frictionless impact)

    @property
    def dynamic(self) -> bool:
        """True for a body that moves (not static)."""
        return not self.static

    @property
    def principal_inertia(self) -> tuple[float, float, float]:
        """The principal moments in force: `inertia`, else the shape's default for `mass`."""
        if self.inertia is not None:
            return tuple(float(i) for i in self.inertia)
        return self.shape.inertia(self.mass)

    def validate(self, where: str) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise SceneError(f"{where}.name = {self.name!r}: must be a non-empty string")
        if not isinstance(self.shape, SHAPES):
            raise SceneError(f"{where}.shape = {self.shape!r}: must be a shape of cases.scene "
                             f"({', '.join(s.__name__ for s in SHAPES)})")
        self.shape.validate(f"{where}.shape")
        _finite(self.position, f"{where}.position", (3,))
        q = _finite(self.orientation, f"{where}.orientation", (4,))
        if abs(np.linalg.norm(q) - 1.0) > 1e-9:
            raise SceneError(f"{where}.orientation = {self.orientation!r}: must be a unit quaternion (w, x, y, z)")
        _finite(self.velocity, f"{where}.velocity", (3,))
        _finite(self.angular_velocity, f"{where}.angular_velocity", (3,))
        if self.shape.kind in STATIC_ONLY and not self.static:
            raise SceneError(f"{where}.static = False: must be True for a {self.shape.kind} (a static ground "
                             "or obstacle)")
        if not isinstance(self.static, bool) or not isinstance(self.rotates, bool):
            raise SceneError(f"{where}: static and rotates must be True or False")
        if not self.rotates and any(w != 0.0 for w in self.angular_velocity):
            raise SceneError(f"{where}.angular_velocity = {self.angular_velocity!r}: a body held from rotating "
                             "(rotates=False) cannot spin")
        if self.static:
            return
        if self.mass is None:
            raise SceneError(f"{where}.mass = None: a dynamic body needs a mass > 0")
        _positive(self.mass, f"{where}.mass")
        if self.inertia is not None:
            _finite(self.inertia, f"{where}.inertia", (3,))
            for axis, i in zip("xyz", self.inertia):
                _positive(i, f"{where}.inertia.{axis}")


# --- joints and applied loads ----------------------------------------------------------------

# The joints a scene may hold (Joint.kind), by the relative motion they leave between the
# two bodies: "revolute" a rotation about `axis` through `anchor` (a hinge: 1 dof),
# "prismatic" a translation along `axis` (a slider: 1 dof), "ball" every rotation about
# `anchor` (3 dof), "fixed" none (a weld). An engine declares the kinds it builds in
# Capabilities.joints; a scene with another kind is `unsupported` there.
JOINT_KINDS = ("revolute", "prismatic", "ball", "fixed")
# The kinds whose one coordinate a limit bounds (an angle in rad, a displacement in m).
LIMITED_KINDS = ("revolute", "prismatic")
# An axis shorter than this (m, or rad for a direction) has no direction to rounding.
SHORT_AXIS = 1e-12


@dataclass(frozen=True)
class Joint:
    """A joint between `body` and `parent` (another body's name, or None for the world).

    - `kind`: one of JOINT_KINDS;
    - `anchor`: the joint's point, m, in the world frame at the start (both bodies carry it
      along: it stays one point of both while the joint holds);
    - `axis`: the hinge axis (revolute) or the slide direction (prismatic), world frame at
      the start, any length > 0 (normalised here); ignored by ball and fixed joints;
    - `limits`: (lower, upper) of the joint's coordinate, the turn of `body` relative to
      `parent` about `axis` (rad, right-handed) or its slide along `axis` (m), both 0 at the
      start, so lower <= 0 <= upper; None: unlimited. Revolute and prismatic joints only.
    - `friction`: the joint's dry (Coulomb) friction, the largest force (prismatic, N) or
      torque (revolute, N m) with which it resists motion along its coordinate: it stops
      the joint when that suffices and opposes its motion with exactly this much while it
      slides (a constant bound: Coulomb's mu N where the joint's reaction N is constant).
      0: none. Revolute and prismatic joints only.
    - `limit_e`: Newton's coefficient of restitution at a limit, in [0, 1]: the joint's rate
      after it meets a bound is -limit_e times its rate before (0: plastic, the default).
      Joints with limits only.
    Two bodies a joint connects do not collide with each other (the pair is left out of
    Scene.contact_pairs), as in every engine's default for jointed bodies."""
    kind: str
    body: str
    parent: str | None = None  # None: the world
    anchor: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 1.0, 0.0)
    limits: tuple[float, float] | None = None
    friction: float = 0.0
    limit_e: float = 0.0

    @property
    def unit_axis(self) -> tuple[float, float, float]:
        """`axis` normalised to length 1."""
        a = np.asarray(self.axis, float)
        return tuple(float(c) for c in a / np.linalg.norm(a))

    def validate(self, where: str, names: set[str], dimension: int) -> None:
        if self.kind not in JOINT_KINDS:
            raise SceneError(f"{where}.kind = {self.kind!r}: must be one of {', '.join(JOINT_KINDS)}")
        for field_, name in (("body", self.body), ("parent", self.parent)):
            if field_ == "parent" and name is None:
                continue
            if name not in names:
                raise SceneError(f"{where}.{field_} = {name!r}: no body of that name "
                                 f"({', '.join(sorted(names))}{'' if field_ == 'body' else ', or None for the world'})")
        if self.parent == self.body:
            raise SceneError(f"{where}.parent = {self.parent!r}: a joint connects two different bodies "
                             "(None for the world)")
        anchor = _finite(self.anchor, f"{where}.anchor", (3,))
        axis = _finite(self.axis, f"{where}.axis", (3,))
        if np.linalg.norm(axis) <= SHORT_AXIS:
            raise SceneError(f"{where}.axis = {self.axis!r}: must have a length > 0 (a direction)")
        if self.limits is not None:
            if self.kind not in LIMITED_KINDS:
                raise SceneError(f"{where}.limits = {self.limits!r}: only {' and '.join(LIMITED_KINDS)} joints "
                                 "have limits (None for a ball or fixed joint)")
            lim = _finite(self.limits, f"{where}.limits", (2,))
            if lim[0] > lim[1]:
                raise SceneError(f"{where}.limits = {self.limits!r}: lower must be <= upper")
            if not lim[0] <= 0.0 <= lim[1]:
                raise SceneError(f"{where}.limits = {self.limits!r}: must hold the start, 0 "
                                 "(lower <= 0 <= upper: the coordinate is 0 at the start)")
        if isinstance(self.limit_e, bool) or not isinstance(self.limit_e, (int, float)) \
                or not (math.isfinite(self.limit_e) and 0.0 <= self.limit_e <= 1.0):
            raise SceneError(f"{where}.limit_e = {self.limit_e!r}: a coefficient of restitution, must lie in [0, 1]")
        if self.limit_e > 0.0 and self.limits is None:
            raise SceneError(f"{where}.limit_e = {self.limit_e!r}: a restitution at a limit needs limits "
                             "(0 for a joint without)")
        if not (math.isfinite(self.friction) and self.friction >= 0.0):
            raise SceneError(f"{where}.friction = {self.friction!r}: must be a finite force or torque >= 0")
        if self.friction > 0.0 and self.kind not in LIMITED_KINDS:
            raise SceneError(f"{where}.friction = {self.friction!r}: only {' and '.join(LIMITED_KINDS)} joints "
                             "have a dry friction (0 for a ball or fixed joint)")
        if dimension == 2:
            u = axis / np.linalg.norm(axis)
            if self.kind == "ball":
                raise SceneError(f"{where}.kind = 'ball': a 2D scene's joints are revolute (about y), prismatic "
                                 "(along x-z) or fixed")
            if anchor[1] != 0:
                raise SceneError(f"{where}.anchor = {self.anchor!r}: a 2D scene lies in the x-z plane: "
                                 "anchor.y must be 0")
            if self.kind == "revolute" and abs(abs(u[1]) - 1.0) > 1e-12:
                raise SceneError(f"{where}.axis = {self.axis!r}: a 2D revolute joint turns about y: "
                                 "axis must be (0, +-1, 0)")
            if self.kind == "prismatic" and u[1] != 0:
                raise SceneError(f"{where}.axis = {self.axis!r}: a 2D prismatic joint slides in the x-z plane: "
                                 "axis.y must be 0")


@dataclass(frozen=True)
class Load:
    """A constant external `force` (N) and `torque` (N m) on `body`, world frame, the force
    acting at the body's centre of mass, for the whole run (a pad pressed on, a motor's
    torque). A 2D scene's force lies in the x-z plane and its torque is about y."""
    body: str
    force: tuple[float, float, float] = (0.0, 0.0, 0.0)
    torque: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def acts(self) -> bool:
        """True when the force or the torque is not zero."""
        return any(c != 0.0 for c in self.force) or any(c != 0.0 for c in self.torque)

    def validate(self, where: str, dynamic: set[str], dimension: int) -> None:
        if self.body not in dynamic:
            raise SceneError(f"{where}.body = {self.body!r}: must name a dynamic body "
                             f"({', '.join(sorted(dynamic))})")
        force = _finite(self.force, f"{where}.force", (3,))
        torque = _finite(self.torque, f"{where}.torque", (3,))
        if dimension == 2 and (force[1] != 0 or torque[0] != 0 or torque[2] != 0):
            raise SceneError(f"{where}: a 2D scene lies in the x-z plane: force.y must be 0 and the torque "
                             "about y only (torque.x = torque.z = 0)")


def pair_key(a: str, b: str) -> tuple[str, str]:
    """Pairs are unordered: one key for (a, b) and (b, a)."""
    return (a, b) if a <= b else (b, a)


# --- the scene ----------------------------------------------------------------------------

@dataclass(frozen=True)
class Scene:
    """An engine-neutral scene, validated when made (SceneError names the bad field).

    - `bodies`: at least one dynamic body; names unique;
    - `gravity`: m/s^2, world frame (an incline tilts gravity: `tilted_gravity`);
    - `material`: the Material of every pair not named in `pairs`;
    - `pairs`: per-pair overrides (body a, body b, Material), unordered; an engine whose
      per-body combination rule cannot express the pair table reports `unsupported`;
    - `dimension`: 3, or 2 for a scene in the x-z plane (Circle, Rect, Polygon, Plane; y,
      and rotations about x and z, stay zero), which the 2D engines run too;
    - `allowed_overlap`: m the bodies may start inside each other (default 1 um: contact
      built by hand is exact to rounding); a scene that starts deeper on purpose says so;
    - `joints`: Joints between bodies, or a body and the world (a pair a joint connects
      does not collide);
    - `loads`: constant external forces and torques on bodies (Load);
    - `effects`: derived, not given: the physics the scene calls for (EFFECTS).
    """
    bodies: tuple[Body, ...]
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    material: Material = Material()  # every pair not named in `pairs`
    pairs: tuple[tuple[str, str, Material], ...] = ()  # per-pair overrides (a, b, material)
    dimension: int = 3
    allowed_overlap: float = DEFAULT_ALLOWED_OVERLAP
    joints: tuple[Joint, ...] = ()
    loads: tuple[Load, ...] = ()
    effects: frozenset[str] = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "bodies", tuple(self.bodies))
        object.__setattr__(self, "pairs", tuple(self.pairs))
        object.__setattr__(self, "joints", tuple(self.joints))
        object.__setattr__(self, "loads", tuple(self.loads))
        self._validate()
        object.__setattr__(self, "effects", self._derive_effects())

    # lookups
    def body(self, name: str) -> Body:
        """The body called `name` (KeyError if none)."""
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    def material_of(self, a: str, b: str) -> Material:
        """The Material of the pair (a, b): its entry in `pairs`, else `material`."""
        key = pair_key(a, b)
        for x, y, mat in self.pairs:
            if pair_key(x, y) == key:
                return mat
        return self.material

    @property
    def contact_laws(self) -> frozenset[str]:
        """The compliant contact laws the touching pairs ask for (empty: all rigid)."""
        mats = [self.material_of(a.name, b.name) for a, b in self.contact_pairs()]
        return frozenset(m.compliance.law for m in mats if m.compliance is not None)

    @property
    def dynamic_bodies(self) -> tuple[Body, ...]:
        """The bodies that move, in scene order."""
        return tuple(b for b in self.bodies if b.dynamic)

    def contact_pairs(self) -> list[tuple[Body, Body]]:
        """Every pair that may touch: all pairs with at least one dynamic body, but those a
        joint connects."""
        joined = {pair_key(j.body, j.parent) for j in self.joints if j.parent is not None}
        out = []
        for i, a in enumerate(self.bodies):
            for b in self.bodies[i + 1:]:
                if (a.dynamic or b.dynamic) and pair_key(a.name, b.name) not in joined:
                    out.append((a, b))
        return out

    def _derive_effects(self) -> frozenset[str]:
        """The physics the scene calls for; adapters simulate these and nothing more."""
        fx = set()
        if any(g != 0.0 for g in self.gravity):
            fx.add("gravity")
        pairs = self.contact_pairs()
        if pairs:
            fx.add("contact")
            mats = [self.material_of(a.name, b.name) for a, b in pairs]
            if any(m.e > 0 for m in mats):
                fx.add("restitution")
            if any(m.frictional for m in mats):
                fx.add("friction")
            fx.update(effect for effect in CONTACT_TORQUES if any(m.torque(effect) > 0 for m in mats))
        if any(b.rotates for b in self.dynamic_bodies):
            fx.add("rotation")
        if self.joints:
            fx.add("joint")
        if any(j.limits is not None for j in self.joints):
            fx.add("limit")
        if any(j.limits is not None and j.limit_e > 0.0 for j in self.joints):
            fx.add("limit_restitution")
        if any(j.friction > 0 for j in self.joints):
            fx.add("joint_friction")
        if any(load.acts for load in self.loads):
            fx.add("load")
        return frozenset(fx)

    def _validate(self) -> None:
        if self.dimension not in (2, 3):
            raise SceneError(f"dimension = {self.dimension!r}: must be 2 or 3")
        if not self.bodies:
            raise SceneError("bodies = (): a scene needs at least one body")
        if not self.dynamic_bodies:
            raise SceneError("bodies: a scene needs at least one dynamic body")
        _finite(self.gravity, "gravity", (3,))
        _finite(self.allowed_overlap, "allowed_overlap")
        if self.allowed_overlap < 0:
            raise SceneError(f"allowed_overlap = {self.allowed_overlap!r}: must be >= 0")
        names = set()
        for i, body in enumerate(self.bodies):
            where = f"bodies[{i}]"
            if not isinstance(body, Body):
                raise SceneError(f"{where} = {body!r}: must be a Body")
            body.validate(f"{where}({body.name})")
            if body.name in names:
                raise SceneError(f"{where}.name = {body.name!r}: body names must be unique")
            names.add(body.name)
            dim = body.shape.dimension
            if dim is not None and dim != self.dimension:
                kinds = {d: ", ".join(s.kind for s in SHAPES if s.dimension in (d, None)) for d in (2, 3)}
                raise SceneError(f"{where}({body.name}).shape = {body.shape.kind}: a {dim}D shape "
                                 f"in a {self.dimension}D scene (2D: {kinds[2]}; 3D: {kinds[3]})")
        self.material.validate("material")
        for j, (a, b, mat) in enumerate(self.pairs):
            for n in (a, b):
                if n not in names:
                    raise SceneError(f"pairs[{j}] names body {n!r}: not in the scene ({', '.join(sorted(names))})")
            mat.validate(f"pairs[{j}]({a},{b})")
        for j, joint in enumerate(self.joints):
            if not isinstance(joint, Joint):
                raise SceneError(f"joints[{j}] = {joint!r}: must be a cases.scene.Joint")
            joint.validate(f"joints[{j}]", names, self.dimension)
            if self.body(joint.body).static and (joint.parent is None or self.body(joint.parent).static):
                raise SceneError(f"joints[{j}]: joins {joint.body!r} to "
                                 f"{'the world' if joint.parent is None else repr(joint.parent)}, both static: "
                                 "a joint needs a dynamic body")
        dynamic = {b.name for b in self.dynamic_bodies}
        for j, load in enumerate(self.loads):
            if not isinstance(load, Load):
                raise SceneError(f"loads[{j}] = {load!r}: must be a cases.scene.Load")
            load.validate(f"loads[{j}]", dynamic, self.dimension)
        if self.dimension == 2:
            self._validate_planar()
        pairs = self.contact_pairs()
        for (a, b), near in zip(pairs, may_touch(pairs)):
            depth = penetration(a, b) if near else 0.0
            if depth > self.allowed_overlap:
                bound = "" if exact(a.shape.kind, b.shape.kind) else \
                    f" (at most: cases.overlap bounds a {a.shape.kind}-{b.shape.kind} pair's depth from above)"
                raise SceneError(f"bodies {a.name!r} and {b.name!r} start {depth:.3g} m inside each other{bound}: "
                                 f"allowed_overlap is {self.allowed_overlap:.3g} m")

    def _validate_planar(self) -> None:
        for i, body in enumerate(self.bodies):
            where = f"bodies[{i}]({body.name})"
            if body.position[1] != 0 or body.velocity[1] != 0:
                raise SceneError(f"{where}: a 2D scene lies in the x-z plane: position.y and velocity.y must be 0")
            w = body.angular_velocity
            if w[0] != 0 or w[2] != 0:
                raise SceneError(f"{where}.angular_velocity = {w!r}: a 2D body turns about y only")
            if isinstance(body.shape, Plane):
                if body.shape.normal[1] != 0:
                    raise SceneError(f"{where}.shape.normal = {body.shape.normal!r}: a 2D scene's plane is a line "
                                     "in the x-z plane: normal.y must be 0")
            elif body.orientation[1] != 0 or body.orientation[3] != 0:
                raise SceneError(f"{where}.orientation = {body.orientation!r}: a 2D body turns about y only "
                                 "(quaternion x and z must be 0)")
        if self.gravity[1] != 0:
            raise SceneError(f"gravity = {self.gravity!r}: a 2D scene lies in the x-z plane: gravity.y must be 0")


# --- small helpers cases use to build scenes ----------------------------------------------

def ball(radius: float, dimension: int = 3) -> Sphere | Circle:
    """A sphere in a 3D scene, a disc in a 2D one."""
    return Sphere(radius) if dimension == 3 else Circle(radius)


def cube(half: float, dimension: int = 3) -> Box | Rect:
    """A cube of half-extent `half` in a 3D scene, a square in a 2D one."""
    return Box((half, half, half)) if dimension == 3 else Rect((half, half))


def quat_about_y(angle: float) -> tuple[float, float, float, float]:
    """Rotation by `angle` (rad) about +y as a (w, x, y, z) quaternion."""
    return (math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0)


def ground(name: str = "ground") -> Body:
    """The static half-space z <= 0."""
    return Body(name, Plane(), static=True)


def mesh_ground(half: float, name: str = "ground") -> Body:
    """The plane z = 0 as a static triangle mesh: a square 2 half wide about the origin, two
    triangles wound counterclockwise seen from above (their normals +z)."""
    corners = ((-half, -half, 0.0), (half, -half, 0.0), (half, half, 0.0), (-half, half, 0.0))
    return Body(name, Mesh(corners, ((0, 1, 2), (0, 2, 3))), static=True)


def tilted_gravity(theta: float, g: float = 9.81) -> tuple[float, float, float]:
    """Gravity of an incline at angle theta (rad), with the incline as the plane z = 0:
    the downhill direction is +x."""
    return (g * math.sin(theta), 0.0, -g * math.cos(theta))
