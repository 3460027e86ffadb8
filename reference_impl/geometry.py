"""Shapes and the narrow phase: where two bodies touch.

A contact point is `(point, n, depth, feature)`: `n` is the unit normal from the first
body to the second (note 001, "contact normal pointing from body 1 to body 2"), `depth`
the overlap along n (> 0 overlapping, < 0 a gap), `point` midway between the two
surfaces, and `feature` an integer naming the features that made the point (a box
corner, a clipped edge...), the same from step to step while the contact persists, so
impulses can be carried over (warm starting).

2D shapes (Circle, Rect) live in the x-z plane of 3D space (y = 0) and turn about y only;
their contacts have y = 0 normals. A 2D scene's line is a `Plane` whose normal has no y.

Compiled (compiled.py): the routines read the bodies' rows (rigid_body.Bodies: row i is
body i; its shape is `shape[i]`, a kind below, with `radius`, `half`, `normal`, `offset`)
and write the points they find into `out` (`Points`) from row k on, returning how many.
`narrow_phase` picks the routine of a pair of shape kinds: a new shape is a kind, its
columns in `shape_columns`, and a routine for each pair it meets (or, for convex shapes,
a support function for GJK), each one line in `_routine`. Every sum is written in the
order the plain Python version of this module summed it, so the compiled code rounds as
it did.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from reference_impl.compiled import njit
from reference_impl.vectors import copy, dot

# --- shapes --------------------------------------------------------------------------------

# shape kinds, as the bodies' arrays hold them (NONE: a body without a shape, which touches nothing)
NONE, SPHERE, BOX, PLANE, CIRCLE, RECT, CAPSULE, CYLINDER, HULL, MESH = range(10)


@dataclass(frozen=True)
class Sphere:
    radius: float
    kind = "sphere"

    @property
    def bounding_radius(self) -> float:
        return self.radius


@dataclass(frozen=True)
class Box:
    half: tuple[float, float, float]
    kind = "box"

    @property
    def bounding_radius(self) -> float:
        return math.sqrt(sum(h * h for h in self.half))


@dataclass(frozen=True)
class Plane:
    """The static half-space n . x <= offset."""
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    offset: float = 0.0
    kind = "plane"
    bounding_radius = 0.0  # static: never moves


@dataclass(frozen=True)
class Circle:
    radius: float
    kind = "circle"

    @property
    def bounding_radius(self) -> float:
        return self.radius


@dataclass(frozen=True)
class Rect:
    half: tuple[float, float]  # along body x and z
    kind = "rect"

    @property
    def bounding_radius(self) -> float:
        return math.hypot(*self.half)


@dataclass(frozen=True)
class Capsule:
    """Points within `radius` of the segment from -half_length to +half_length on body z."""
    radius: float
    half_length: float
    kind = "capsule"

    @property
    def bounding_radius(self) -> float:
        return self.radius + self.half_length


@dataclass(frozen=True)
class Cylinder:
    """A solid cylinder about body z, its flat ends at z = -half_length and +half_length."""
    radius: float
    half_length: float
    kind = "cylinder"

    @property
    def bounding_radius(self) -> float:
        return math.hypot(self.radius, self.half_length)


@dataclass(frozen=True)
class Hull:
    """The convex hull of `vertices` (body frame): GJK needs its corners only (gjk.py)."""
    vertices: tuple[tuple[float, float, float], ...]
    kind = "hull"

    @property
    def bounding_radius(self) -> float:
        return max(math.sqrt(x * x + y * y + z * z) for x, y, z in self.vertices)


@dataclass(frozen=True)
class Mesh:
    """A static triangle mesh (body frame), wound counterclockwise seen from outside."""
    vertices: tuple[tuple[float, float, float], ...]
    triangles: tuple[tuple[int, int, int], ...]
    kind = "mesh"
    bounding_radius = 0.0  # static: never moves


KINDS = {"sphere": SPHERE, "box": BOX, "plane": PLANE, "circle": CIRCLE, "rect": RECT,
         "capsule": CAPSULE, "cylinder": CYLINDER, "hull": HULL, "mesh": MESH}


def shape_columns(shape) -> tuple:
    """A shape's entries in the bodies' arrays: (kind, radius, half, normal, offset,
    bounding radius); a rect's half extents are (h_x, 0, h_z)."""
    if shape is None:
        return NONE, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, 0.0
    kind = KINDS[shape.kind]
    radius = shape.radius if kind in (SPHERE, CIRCLE, CAPSULE, CYLINDER) else 0.0
    half = shape.half if kind == BOX else ((shape.half[0], 0.0, shape.half[1]) if kind == RECT else (0.0, 0.0, 0.0))
    if kind in (CAPSULE, CYLINDER):
        half = (0.0, 0.0, shape.half_length)
    normal, offset = (shape.normal, shape.offset) if kind == PLANE else ((0.0, 0.0, 0.0), 0.0)
    return kind, radius, half, normal, offset, shape.bounding_radius


def shape_arrays(shape) -> tuple[np.ndarray, np.ndarray]:
    """A shape's rows of the bodies' `vertices` and `bvh` arrays: a hull's corners (V, 3)
    (body frame), or a mesh's triangles' corners in its tree's order (3 rows a triangle)
    and the tree's nodes (K, 8) (gjk.build_bvh); empty for the other shapes."""
    if shape is not None and shape.kind == "hull":
        return np.asarray(shape.vertices, dtype=float).reshape(-1, 3), np.zeros((0, 8))
    if shape is not None and shape.kind == "mesh":
        return gjk.build_bvh(shape.vertices, shape.triangles)
    return np.zeros((0, 3)), np.zeros((0, 8))


class Points(NamedTuple):
    """Contact points found by the narrow phase, one row each."""
    point: np.ndarray    # (M, 3)
    n: np.ndarray        # (M, 3)
    depth: np.ndarray    # (M,)
    feature: np.ndarray  # (M,) int64


@njit
def new_points(size):
    return Points(np.empty((size, 3)), np.empty((size, 3)), np.empty(size), np.empty(size, np.int64))


@njit
def _put(out, k, point, n, depth, feature) -> None:
    for c in range(3):
        out.point[k, c] = point[c]
        out.n[k, c] = n[c]
    out.depth[k], out.feature[k] = depth, feature


# --- bounding boxes (the broad phase's, broadphase.py) ----------------------------------------

@njit
def box_bounds(bodies, i):
    """Axis-aligned bounding box (lo, hi) of body i; a plane has none (unbounded): check
    `bodies.shape[i] == PLANE` first."""
    c, kind = bodies.x[i], bodies.shape[i]
    if kind == SPHERE or kind == CIRCLE:
        r = bodies.radius[i]
        return (c[0] - r, c[1] - r, c[2] - r), (c[0] + r, c[1] + r, c[2] + r)
    if kind >= CAPSULE:  # from the support function (gjk.py)
        lo, hi = gjk.body_bounds(bodies, i)
        return (lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])
    h, R = bodies.half[i], bodies.R[i]
    e0 = abs(R[0, 0]) * h[0] + abs(R[0, 1]) * h[1] + abs(R[0, 2]) * h[2]
    e1 = abs(R[1, 0]) * h[0] + abs(R[1, 1]) * h[1] + abs(R[1, 2]) * h[2]
    e2 = abs(R[2, 0]) * h[0] + abs(R[2, 1]) * h[1] + abs(R[2, 2]) * h[2]
    return (c[0] - e0, c[1] - e1, c[2] - e2), (c[0] + e0, c[1] + e1, c[2] + e2)


@njit
def reaches_plane(n, offset, lo, hi, margin) -> bool:
    """Whether an AABB reaches within `margin` of the plane n . x <= offset."""
    lowest = 0.0
    for i in range(3):
        lowest += n[i] * (lo[i] if n[i] > 0 else hi[i])
    return lowest - offset <= margin


def bounds(body) -> tuple[tuple, tuple] | None:
    """Axis-aligned bounding box (lo, hi) of a RigidBody; None for an unbounded plane."""
    return None if body.shape.kind == "plane" else box_bounds(body._bodies, body._row)


def below_plane(plane: Plane, lo, hi, margin: float) -> bool:
    """Whether an AABB reaches within `margin` of a plane's solid side."""
    return reaches_plane(plane.normal, plane.offset, lo, hi, margin)


# --- small helpers ---------------------------------------------------------------------------

@njit
def _add(a, b, s):
    """a + s b."""
    return (a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2])


@njit
def _column(R, k):
    """Body axis k (column k of R) as a world vector."""
    return (R[0][k], R[1][k], R[2][k])


# --- round shapes --------------------------------------------------------------------------

@njit
def sphere_plane(bodies, p, s, margin, features, out, k) -> int:
    """Sphere (or circle) s on plane p: n is the plane normal."""
    n, r, x = bodies.normal[p], bodies.radius[s], bodies.x[s]
    depth = bodies.offset[p] - (dot(n, x) - r)
    if depth < -margin:
        return 0
    surface = _add(x, n, -r)  # the sphere's lowest point
    _put(out, k, _add(surface, n, 0.5 * depth), n, depth, 0)
    return 1


@njit
def sphere_sphere(bodies, a, b, margin, features, out, k) -> int:
    """Two spheres (or circles): n along the line of centres."""
    ra, rb, xa, xb = bodies.radius[a], bodies.radius[b], bodies.x[a], bodies.x[b]
    d = (xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2])
    dist = math.sqrt(dot(d, d))
    depth = ra + rb - dist
    if depth < -margin:
        return 0
    n = (d[0] / dist, d[1] / dist, d[2] / dist) if dist > 0 else (1.0, 0.0, 0.0)
    _put(out, k, _add(xa, n, ra - 0.5 * depth), n, depth, 0)
    return 1


@njit
def box_sphere(bodies, bx, s, margin, features, out, k) -> int:
    """Sphere (or circle) s against box (or rect) bx: the closest point of the box; a
    centre inside leaves through the nearest face (of a rect: x or z)."""
    R, r, half, xb, xs = bodies.R[bx], bodies.radius[s], bodies.half[bx], bodies.x[bx], bodies.x[s]
    d = (xs[0] - xb[0], xs[1] - xb[1], xs[2] - xb[2])
    local = (dot(_column(R, 0), d), dot(_column(R, 1), d), dot(_column(R, 2), d))
    closest = (max(-half[0], min(half[0], local[0])), max(-half[1], min(half[1], local[1])),
               max(-half[2], min(half[2], local[2])))
    diff = (local[0] - closest[0], local[1] - closest[1], local[2] - closest[2])
    dist = math.sqrt(dot(diff, diff))
    if dist > 0:  # centre outside the box
        depth = r - dist
        n_local = (diff[0] / dist, diff[1] / dist, diff[2] / dist)
        surface_local = closest
    else:         # centre inside: leave through the nearest face
        planar = bodies.shape[bx] == RECT
        f = 0  # the face axis with the least way out (the first of equals)
        for i in (1, 2):
            if not (planar and i == 1) and half[i] - abs(local[i]) < half[f] - abs(local[f]):
                f = i
        sign = 1.0 if local[f] >= 0 else -1.0
        depth = r + half[f] - abs(local[f])
        n_local = (sign if f == 0 else 0.0, sign if f == 1 else 0.0, sign if f == 2 else 0.0)
        surface_local = (sign * half[f] if f == 0 else local[0], sign * half[f] if f == 1 else local[1],
                         sign * half[f] if f == 2 else local[2])
    if depth < -margin:
        return 0
    n = (dot(R[0], n_local), dot(R[1], n_local), dot(R[2], n_local))
    surface = _add(xb, (dot(R[0], surface_local), dot(R[1], surface_local), dot(R[2], surface_local)), 1.0)
    _put(out, k, _add(surface, n, -0.5 * depth), n, depth, 0)
    return 1


# --- boxes against planes --------------------------------------------------------------------

# corner signs of a box (feature = row) and of a rect (the box's corners with y = 0)
BOX_CORNERS = np.array([(sx, sy, sz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.int64)
RECT_CORNERS = np.array([(sx, 0, sz) for sx in (-1, 1) for sz in (-1, 1)], dtype=np.int64)


@njit
def plane_box(bodies, p, bx, margin, features, out, k) -> int:
    """Corners of a box (or rect) below the plane: the 4 deepest (a box's face; 2 for a
    rect's edge). Feature: the corner's index."""
    planar = bodies.shape[bx] == RECT
    corners, most = (RECT_CORNERS, 2) if planar else (BOX_CORNERS, 4)
    n, R, c, half, offset = bodies.normal[p], bodies.R[bx], bodies.x[bx], bodies.half[bx], bodies.offset[p]
    depths, found = np.empty(len(corners)), np.empty((len(corners), 3))
    order, m = np.empty(len(corners), np.int64), 0
    for f in range(len(corners)):
        local = (corners[f, 0] * half[0], corners[f, 1] * half[1], corners[f, 2] * half[2])
        corner = (c[0] + dot(R[0], local), c[1] + dot(R[1], local), c[2] + dot(R[2], local))
        depth = offset - dot(n, corner)
        if depth >= -margin:
            depths[f] = depth
            found[f, 0], found[f, 1], found[f, 2] = corner
            t = m  # insert, deepest first (the first of equals stays first)
            while t > 0 and -depths[order[t - 1]] > -depth:
                order[t] = order[t - 1]
                t -= 1
            order[t] = f
            m += 1
    for t in range(min(m, most)):
        f = order[t]
        _put(out, k + t, _add(found[f], n, 0.5 * depths[f]), n, depths[f], f)
    return min(m, most)


# --- box against box: separating axes and clipping (note 001, "SAT for OBBs") -----------------
#
# A body's frame is R (its columns are the body axes a_k in the world, so a_k[c] = R[c, k]),
# its centre x, its half-extents h (a rect's: (h_x, 0, h_z)).

# A face axis wins over an edge axis (and box A's face over B's) unless the other
# overlaps less by more than this: ties between equal faces must not flip from step to
# step (that would change feature ids and lose warm starting).
FEATURE_TIE = 1e-9  # m
# A corner of the incident face this close outside a side of the reference face is kept
# as it is rather than cut into two points a rounding-level tilt apart (a face resting
# exactly on an equal face would otherwise give slivers: 5 or 6 points for 4).
CLIP_TOLERANCE = 1e-6  # m, far below any lever arm that matters
# Feature ids of clipped points: a corner of the incident face is 0..3; a point cut by a
# side plane is node k >= CORNER_IDS of `nodes`, nodes[k] = (tag, side, f1, f2): cut by the
# side plane `side` (+-1) of axis `tag` on the edge from feature f1 (inside) to f2.
CORNER_IDS = 4
MAX_POINTS = 32  # polygon buffer: 4 corners clipped by 4 sides stay far below this
MAX_NODES = 64
MAX_PAIR_POINTS = 8  # a routine's points: a quadrilateral cut by 4 half-planes keeps at most 8


@njit
def _clip(poly, feat, count, centre, axis, half, tag, nodes, n_nodes):
    """Sutherland-Hodgman: keep the part of the polygon poly[:count] (features feat) with
    |(x - centre) . axis| <= half. A corner at most CLIP_TOLERANCE outside is kept as it
    is (it is the boundary point); an edge from inside to beyond that is cut at the side
    plane itself, the new point carrying node (tag, side, f1, f2). Returns the new
    polygon, its features, its size and the node count."""
    for side in (1.0, -1.0):
        dist = np.empty(count)
        for k in range(count):
            p = poly[k]
            dist[k] = side * ((p[0] - centre[0]) * axis[0] + (p[1] - centre[1]) * axis[1]
                              + (p[2] - centre[2]) * axis[2]) - half
        out, out_feat, m = np.empty((MAX_POINTS, 3)), np.empty(MAX_POINTS, np.int64), 0
        n = count
        for k in range(n if n > 2 else 1):  # a segment (2D) has one edge, a polygon n
            k1 = k - 1 if k > 0 else n - 1
            p1, p2, f1, f2 = poly[k1], poly[k], feat[k1], feat[k]
            d1, d2 = dist[k1], dist[k]
            if n == 2 and d1 <= CLIP_TOLERANCE:
                copy(out[m], p1)
                out_feat[m] = f1
                m += 1
            if d1 <= 0.0 < CLIP_TOLERANCE < d2 or d2 <= 0.0 < CLIP_TOLERANCE < d1:
                s = d1 / (d1 - d2)
                for c in range(3):
                    out[m, c] = p1[c] + s * (p2[c] - p1[c])
                nodes[n_nodes, 0], nodes[n_nodes, 1] = tag, 1 if side > 0.0 else -1
                nodes[n_nodes, 2], nodes[n_nodes, 3] = (f1, f2) if d1 <= 0.0 else (f2, f1)
                out_feat[m] = CORNER_IDS + n_nodes
                n_nodes += 1
                m += 1
            if d2 <= CLIP_TOLERANCE:
                copy(out[m], p2)
                out_feat[m] = f2
                m += 1
        poly, feat, count = out, out_feat, m
        if count == 0:
            break
    return poly, feat, count, n_nodes


@njit
def _face_contact(R_ref, x_ref, h_ref, R_inc, x_inc, h_inc, i, sign, flip, margin, planar):
    """Reference face i (outward normal nf = sign * axis i of Ref, facing Inc) against the
    incident face of Inc most opposed to it: clip, keep the points below the face.
    Returns the points (row k: point, depth, feature id), the normal n, the incident
    axis m and the clip nodes."""
    nf = np.array([sign * R_ref[0, i], sign * R_ref[1, i], sign * R_ref[2, i]])
    used = (0, 2, -1) if planar else (0, 1, 2)
    m, best = -1, -1.0
    for k in used:  # the incident axis most along nf (the first of equals)
        if k >= 0:
            along = abs(R_inc[0, k] * nf[0] + R_inc[1, k] * nf[1] + R_inc[2, k] * nf[2])
            if m < 0 or along > best:
                m, best = k, along
    s_inc = -1.0 if R_inc[0, m] * nf[0] + R_inc[1, m] * nf[1] + R_inc[2, m] * nf[2] > 0 else 1.0
    centre = np.empty(3)
    for c in range(3):
        centre[c] = x_inc[c] + s_inc * h_inc[m] * R_inc[c, m]
    poly, feat = np.empty((MAX_POINTS, 3)), np.empty(MAX_POINTS, np.int64)
    if planar:  # an edge: two end points
        o = 2 if m == 0 else 0
        for c in range(3):
            poly[0, c] = centre[c] + h_inc[o] * R_inc[c, o]
            poly[1, c] = centre[c] + -h_inc[o] * R_inc[c, o]
        feat[0], feat[1], count = 0, 1, 2
    else:       # a face: four corners in cyclic order
        o1, o2 = (1, 2) if m == 0 else ((0, 2) if m == 1 else (0, 1))
        hu, hw = h_inc[o1], h_inc[o2]
        for k, (su, sw) in enumerate(((1, 1), (-1, 1), (-1, -1), (1, -1))):
            for c in range(3):
                poly[k, c] = (centre[c] + su * hu * R_inc[c, o1]) + sw * hw * R_inc[c, o2]
            feat[k] = k
        count = 4
    nodes, n_nodes = np.zeros((MAX_NODES, 4), np.int64), 0
    for k in used:
        if k >= 0 and k != i and count > 0:
            axis = np.array([R_ref[0, k], R_ref[1, k], R_ref[2, k]])
            poly, feat, count, n_nodes = _clip(poly, feat, count, x_ref, axis, h_ref[k], k, nodes, n_nodes)
    points, ids, found = np.empty((count, 4)), np.empty(count, np.int64), 0
    for k in range(count):
        p = poly[k]
        depth = h_ref[i] - ((p[0] - x_ref[0]) * nf[0] + (p[1] - x_ref[1]) * nf[1] + (p[2] - x_ref[2]) * nf[2])
        if depth >= -margin:
            for c in range(3):
                points[found, c] = p[c] + 0.5 * depth * nf[c]
            points[found, 3], ids[found] = depth, feat[k]
            found += 1
    n = -nf if flip else nf
    return points[:found], ids[:found], n, m, nodes[:n_nodes]


@njit
def _edge_contact(Ra, xa, ha, Rb, xb, hb, i, j, u):
    """Edge i of A against edge j of B across axis u (from A to B): the closest points of
    the two edges, their midpoint and the signs that pick the edges (the feature)."""
    ea, eb, signs, found = xa.copy(), xb.copy(), np.empty(4), 0
    for k in range(3):
        if k != i:
            s = 1.0 if Ra[0, k] * u[0] + Ra[1, k] * u[1] + Ra[2, k] * u[2] > 0 else -1.0
            for c in range(3):
                ea[c] = ea[c] + s * ha[k] * Ra[c, k]
            signs[found] = s
            found += 1
        if k != j:
            s = 1.0 if Rb[0, k] * u[0] + Rb[1, k] * u[1] + Rb[2, k] * u[2] > 0 else -1.0
            for c in range(3):
                eb[c] = eb[c] + -s * hb[k] * Rb[c, k]
            signs[found] = s
            found += 1
    da, db = Ra[:, i].copy(), Rb[:, j].copy()
    w0 = ea - eb
    b = da[0] * db[0] + da[1] * db[1] + da[2] * db[2]
    d = da[0] * w0[0] + da[1] * w0[1] + da[2] * w0[2]
    e = db[0] * w0[0] + db[1] * w0[1] + db[2] * w0[2]
    denom = 1.0 - b * b
    s = max(-ha[i], min(ha[i], (b * e - d) / denom))
    t = max(-hb[j], min(hb[j], (e - b * d) / denom))
    point = np.empty(3)
    for c in range(3):
        point[c] = 0.5 * ((ea[c] + s * da[c]) + (eb[c] + t * db[c]))
    return point, signs


@njit
def _separating_axes(Ra, xa, ha, Rb, xb, hb, margin, planar):
    """The separating axis test of box_box: (kind, depth, i, j, sign, u) of the axis of
    least overlap, kind 0 apart, 1 a face of A, 2 a face of B (index j), 3 the edge pair
    (i, j) with unit axis u from A to B."""
    used = (0, 2, -1) if planar else (0, 1, 2)
    d = xb - xa
    C, t = np.empty((3, 3)), np.empty(3)
    for i in range(3):
        for j in range(3):
            C[i, j] = Ra[0, i] * Rb[0, j] + Ra[1, i] * Rb[1, j] + Ra[2, i] * Rb[2, j]  # a_i . b_j
        t[i] = d[0] * Ra[0, i] + d[1] * Ra[1, i] + d[2] * Ra[2, i]  # d . a_i
    Ab = np.abs(C)
    u = np.zeros(3)
    best_a, best_b = (np.inf, -1, 1.0), (np.inf, -1, 1.0)
    for i in used:
        if i >= 0:
            depth = ha[i] + hb[0] * Ab[i, 0] + hb[1] * Ab[i, 1] + hb[2] * Ab[i, 2] - abs(t[i])
            if depth < -margin:
                return 0, depth, -1, -1, 0.0, u
            if best_a[1] < 0 or depth < best_a[0]:
                best_a = (depth, i, 1.0 if t[i] >= 0 else -1.0)
    for j in used:
        if j >= 0:
            s = t[0] * C[0, j] + t[1] * C[1, j] + t[2] * C[2, j]  # d . b_j
            depth = hb[j] + ha[0] * Ab[0, j] + ha[1] * Ab[1, j] + ha[2] * Ab[2, j] - abs(s)
            if depth < -margin:
                return 0, depth, -1, -1, 0.0, u
            if best_b[1] < 0 or depth < best_b[0]:
                best_b = (depth, j, -1.0 if s >= 0 else 1.0)  # B's face towards A
    edge, edge_i, edge_j, edge_length = np.inf, -1, -1, 0.0
    if not planar:
        for i in range(3):
            i1, i2 = (i + 1) % 3, (i + 2) % 3
            for j in range(3):
                length = math.sqrt(max(1.0 - C[i, j] * C[i, j], 0.0))
                if length < 1e-6:  # parallel edges: the face axes cover them
                    continue
                j1, j2 = (j + 1) % 3, (j + 2) % 3
                ra = ha[i1] * Ab[i2, j] + ha[i2] * Ab[i1, j]
                rb = hb[j1] * Ab[i, j2] + hb[j2] * Ab[i, j1]
                depth = (ra + rb - abs(t[i2] * C[i1, j] - t[i1] * C[i2, j])) / length
                if depth < -margin:
                    return 0, depth, -1, -1, 0.0, u
                if edge_i < 0 or depth < edge:
                    edge, edge_i, edge_j, edge_length = depth, i, j, length
    face_a = best_a[0] <= best_b[0] + FEATURE_TIE
    face = best_a[0] if face_a else best_b[0]
    if edge_i >= 0 and edge + FEATURE_TIE < face:
        i, j = edge_i, edge_j
        u[0] = Ra[1, i] * Rb[2, j] - Ra[2, i] * Rb[1, j]  # a_i x b_j
        u[1] = Ra[2, i] * Rb[0, j] - Ra[0, i] * Rb[2, j]
        u[2] = Ra[0, i] * Rb[1, j] - Ra[1, i] * Rb[0, j]
        if d[0] * u[0] + d[1] * u[1] + d[2] * u[2] >= 0:
            u = u / edge_length
        else:
            u = -u / edge_length
        return 3, edge, i, j, 1.0, u
    if face_a:
        return 1, best_a[0], best_a[1], -1, best_a[2], u
    return 2, best_b[0], -1, best_b[1], best_b[2], u


# Feature ids of box-box points: the kind of contact in the top bits, below them what
# picks the features (the face and the incident axis, or the two edges and their sides).
FACE_FEATURE, EDGE_FEATURE = 1 << 60, 2 << 60


@njit
def _clip_feature(k, nodes, features) -> int:
    """The id of feature k of a clipped polygon: a corner (k < CORNER_IDS), or the number
    `features` (the world's table of clip nodes, kept from step to step) gives the node
    (tag, side, f1, f2) with its ends' ids, numbering a node the first time it is seen:
    two points have the same id exactly when they were cut by the same sides from the
    same corners."""
    if k < CORNER_IDS:
        return k
    node = nodes[k - CORNER_IDS]
    tag, side, f1, f2 = node[0], node[1], node[2], node[3]
    key = (tag, side, _clip_feature(f1, nodes, features), _clip_feature(f2, nodes, features))
    found = features.get(key, -1)
    if found < 0:
        found = CORNER_IDS + len(features)
        features[key] = found
    return found


@njit(inline=True)
def box_box(bodies, a, b, margin, features, out, k) -> int:
    """Separating axis test over the face normals of both boxes (3 + 3) and the 9 edge
    cross products (2 + 2 face normals for rects, no edges); the axis of least overlap
    is the contact normal; faces are clipped (up to 8 points for boxes, 2 for rects).

    Overlaps in A's frame (Gottschalk's OBB test): C[i][j] = a_i . b_j, t = d in A's
    frame; along a_i x b_j (length sqrt(1 - C_ij^2)) the radii are
    ha_i1 |C_i2j| + ha_i2 |C_i1j| and hb_j1 |C_ij2| + hb_j2 |C_ij1|, the centre distance
    |t_i2 C_i1j - t_i1 C_i2j| ((i, i1, i2) and (j, j1, j2) cyclic)."""
    planar = bodies.shape[a] == RECT
    Ra, xa, ha, Rb, xb, hb = bodies.R[a], bodies.x[a], bodies.half[a], bodies.R[b], bodies.x[b], bodies.half[b]
    kind, depth, i, j, sign, u = _separating_axes(Ra, xa, ha, Rb, xb, hb, margin, planar)
    if kind == 0:
        return 0
    if kind == 3:
        point, signs = _edge_contact(Ra, xa, ha, Rb, xb, hb, i, j, u)
        sides = 0
        for s in signs:
            sides = 2 * sides + (1 if s > 0 else 0)
        _put(out, k, point, u, depth, EDGE_FEATURE + (i * 4 + j) * 16 + sides)
        return 1
    flip = kind == 2
    if flip:
        points, ids, n, m, nodes = _face_contact(Rb, xb, hb, Ra, xa, ha, j, sign, True, margin, planar)
        face = j
    else:
        points, ids, n, m, nodes = _face_contact(Ra, xa, ha, Rb, xb, hb, i, sign, False, margin, planar)
        face = i
    which = FACE_FEATURE + ((((1 if flip else 0) * 4 + face) * 2 + (1 if sign > 0 else 0)) * 4 + m) * (1 << 48)
    for t in range(len(ids)):
        _put(out, k + t, points[t, :3], n, points[t, 3], which + _clip_feature(ids[t], nodes, features))
    return len(ids)


def is_edge_feature(feature: int) -> bool:
    """Whether a box-box point's feature is an edge pair (else a clipped face point)."""
    return feature >= EDGE_FEATURE


# --- dispatch --------------------------------------------------------------------------------

@njit
def _routine(bodies, first, second, margin, features, out, k) -> int:
    """The points of the pair in this order (normals from first to second), or -1 when
    no routine takes the shapes in this order."""
    A, B = bodies.shape[first], bodies.shape[second]
    if A == PLANE and (B == SPHERE or B == CIRCLE):
        return sphere_plane(bodies, first, second, margin, features, out, k)
    if (A == SPHERE and B == SPHERE) or (A == CIRCLE and B == CIRCLE):
        return sphere_sphere(bodies, first, second, margin, features, out, k)
    if (A == BOX and B == SPHERE) or (A == RECT and B == CIRCLE):
        return box_sphere(bodies, first, second, margin, features, out, k)
    if A == PLANE and (B == BOX or B == RECT):
        return plane_box(bodies, first, second, margin, features, out, k)
    if (A == BOX and B == BOX) or (A == RECT and B == RECT):
        return box_box(bodies, first, second, margin, features, out, k)
    # the shapes the notes' GJK takes (gjk.py): by their support functions
    if A == PLANE and B >= CAPSULE and B != MESH:
        return gjk.plane_convex(bodies, first, second, margin, features, out, k)
    if A == MESH and (B == SPHERE or B == BOX or (B >= CAPSULE and B != MESH)):
        return gjk.mesh_convex(bodies, first, second, margin, features, out, k)
    if A >= CAPSULE and A != MESH and (B == SPHERE or B == BOX or (B >= CAPSULE and B != MESH)):
        return gjk.convex_convex(bodies, first, second, margin, features, out, k)
    return -1


@njit(inline=True)
def narrow_phase(bodies, i, j, margin, features, out, k):
    """(first, second, count): bodies i and j in the order the normals point (first to
    second) and the number of contact points (0 if apart by more than margin) written
    into out from row k."""
    count = _routine(bodies, i, j, margin, features, out, k)
    if count >= 0:
        return i, j, count
    count = _routine(bodies, j, i, margin, features, out, k)
    if count >= 0:
        return j, i, count
    return i, j, 0  # plane against plane: static, never in contact


def collide(A, B, margin: float):
    """(first, second, points) for bodies A and B (rigid_body.RigidBody): the bodies in
    the order the normals point (first to second), and the contact points
    [(point, n, depth, feature)] (empty if apart by more than margin)."""
    from reference_impl.compiled import int_dict
    from reference_impl.rigid_body import new_bodies, stack
    bodies = new_bodies(stack([A, B]))
    out = new_points(MAX_PAIR_POINTS)
    first, second, count = narrow_phase(bodies, 0, 1, float(margin), int_dict(4), out, 0)
    points = [(tuple(out.point[t].tolist()), tuple(out.n[t].tolist()), float(out.depth[t]), int(out.feature[t]))
              for t in range(count)]
    return (A, B, points) if first == 0 else (B, A, points)


from reference_impl import gjk  # noqa: E402 (gjk.py reads the shape kinds above)
