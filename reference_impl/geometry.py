"""Shapes and the narrow phase: where two bodies touch.

A contact point is `(point, n, depth, feature)`: `n` is the unit normal from the first
body to the second (note 001, "contact normal pointing from body 1 to body 2"), `depth`
the overlap along n (> 0 overlapping, < 0 a gap), `point` midway between the two
surfaces, and `feature` a hashable id of the features that made the point (a box
corner, a clipped edge...), the same from step to step while the contact persists, so
impulses can be carried over (warm starting).

2D shapes (Circle, Rect) live in the x-z plane of 3D space (y = 0) and turn about y only;
their contacts have y = 0 normals. A 2D scene's line is a `Plane` whose normal has no y.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from reference_impl.compiled import njit
from reference_impl.rigid_body import dot


# --- shapes --------------------------------------------------------------------------------

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


def bounds(body) -> tuple[tuple, tuple] | None:
    """Axis-aligned bounding box (lo, hi) of a body; None for an unbounded plane."""
    s, c = body.shape, body.x
    if s.kind in ("sphere", "circle"):
        r = s.radius
        return (c[0] - r, c[1] - r, c[2] - r), (c[0] + r, c[1] + r, c[2] + r)
    if s.kind == "plane":
        return None
    h = s.half if s.kind == "box" else (s.half[0], 0.0, s.half[1])
    R = body.R
    e = [abs(R[i][0]) * h[0] + abs(R[i][1]) * h[1] + abs(R[i][2]) * h[2] for i in range(3)]
    return (c[0] - e[0], c[1] - e[1], c[2] - e[2]), (c[0] + e[0], c[1] + e[1], c[2] + e[2])


def below_plane(plane, lo, hi, margin: float) -> bool:
    """Whether an AABB reaches within `margin` of a plane's solid side."""
    n = plane.normal
    lowest = sum(n[i] * (lo[i] if n[i] > 0 else hi[i]) for i in range(3))
    return lowest - plane.offset <= margin


# --- small vector helpers ----------------------------------------------------------------

def _add(a, b, s=1.0):
    return (a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2])


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _axes(R):
    """The body axes (columns of R) as three world vectors."""
    return ((R[0][0], R[1][0], R[2][0]), (R[0][1], R[1][1], R[2][1]), (R[0][2], R[1][2], R[2][2]))


# --- round shapes --------------------------------------------------------------------------

def sphere_plane(P, S, margin):
    """Sphere (or circle) S on plane P: n is the plane normal."""
    n, r = P.shape.normal, S.shape.radius
    depth = P.shape.offset - (dot(n, S.x) - r)
    if depth < -margin:
        return []
    surface = _add(S.x, n, -r)  # the sphere's lowest point
    return [(_add(surface, n, 0.5 * depth), n, depth, 0)]


def sphere_sphere(A, B, margin):
    """Two spheres (or circles): n along the line of centres."""
    ra, rb = A.shape.radius, B.shape.radius
    d = _sub(B.x, A.x)
    dist = math.sqrt(dot(d, d))
    depth = ra + rb - dist
    if depth < -margin:
        return []
    n = (d[0] / dist, d[1] / dist, d[2] / dist) if dist > 0 else (1.0, 0.0, 0.0)
    return [(_add(A.x, n, ra - 0.5 * depth), n, depth, 0)]


def _sphere_box(Bx, S, half, axes_used, margin):
    """Sphere S against box Bx (half-extents `half`, faces along `axes_used`): closest point."""
    R, r = Bx.R, S.shape.radius
    d = _sub(S.x, Bx.x)
    local = (dot((R[0][0], R[1][0], R[2][0]), d), dot((R[0][1], R[1][1], R[2][1]), d),
             dot((R[0][2], R[1][2], R[2][2]), d))
    closest = tuple(max(-h, min(h, l)) for h, l in zip(half, local))
    diff = _sub(local, closest)
    dist = math.sqrt(dot(diff, diff))
    if dist > 0:  # centre outside the box
        depth = r - dist
        n_local = (diff[0] / dist, diff[1] / dist, diff[2] / dist)
        surface_local = closest
    else:         # centre inside: leave through the nearest face
        k = min(axes_used, key=lambda i: half[i] - abs(local[i]))
        sign = 1.0 if local[k] >= 0 else -1.0
        depth = r + half[k] - abs(local[k])
        n_local = tuple(sign if i == k else 0.0 for i in range(3))
        surface_local = tuple(sign * half[k] if i == k else local[i] for i in range(3))
    if depth < -margin:
        return []
    n = (dot(R[0], n_local), dot(R[1], n_local), dot(R[2], n_local))
    surface = _add(Bx.x, (dot(R[0], surface_local), dot(R[1], surface_local), dot(R[2], surface_local)))
    return [(_add(surface, n, -0.5 * depth), n, depth, 0)]


def box_sphere(Bx, S, margin):
    return _sphere_box(Bx, S, Bx.shape.half, (0, 1, 2), margin)


def rect_circle(Bx, S, margin):
    hx, hz = Bx.shape.half
    return _sphere_box(Bx, S, (hx, 0.0, hz), (0, 2), margin)


# --- boxes against planes --------------------------------------------------------------------

BOX_CORNERS = tuple((sx, sy, sz) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1))
RECT_CORNERS = tuple((sx, 0, sz) for sx in (-1, 1) for sz in (-1, 1))


def _corners_plane(P, Bx, half, corners, most, margin):
    """Corners of a box (or rect) below the plane: the `most` deepest (4 for a box face,
    2 for a rect edge). Feature: the corner's index."""
    n, R, c = P.shape.normal, Bx.R, Bx.x
    found = []
    for k, (sx, sy, sz) in enumerate(corners):
        local = (sx * half[0], sy * half[1], sz * half[2])
        corner = (c[0] + dot(R[0], local), c[1] + dot(R[1], local), c[2] + dot(R[2], local))
        depth = P.shape.offset - dot(n, corner)
        if depth >= -margin:
            found.append((depth, k, corner))
    found.sort(key=lambda f: -f[0])
    return [(_add(corner, n, 0.5 * depth), n, depth, k) for depth, k, corner in found[:most]]


def plane_box(P, Bx, margin):
    return _corners_plane(P, Bx, Bx.shape.half, BOX_CORNERS, 4, margin)


def plane_rect(P, Bx, margin):
    hx, hz = Bx.shape.half
    return _corners_plane(P, Bx, (hx, 0.0, hz), RECT_CORNERS, 2, margin)


# --- box against box: separating axes and clipping (note 001, "SAT for OBBs") -----------------
#
# Written once, on arrays, and compiled (reference_impl/compiled.py): a body's frame is R
# (its columns are the body axes a_k in the world, so a_k[c] = R[c, k]), its centre x, its
# half-extents h (a rect's: (h_x, 0, h_z)). Every sum is written in the order the plain
# Python version summed it, so the compiled code rounds as it did.

# A face axis wins over an edge axis (and box A's face over B's) unless the other
# overlaps less by more than this: ties between equal faces must not flip from step to
# step (that would change feature ids and lose warm starting).
FEATURE_TIE = 1e-9  # m
# A corner of the incident face this close outside a side of the reference face is kept
# as it is rather than cut into two points a rounding-level tilt apart (a face resting
# exactly on an equal face would otherwise give slivers: 5 or 6 points for 4).
CLIP_TOLERANCE = 1e-6  # m, far below any lever arm that matters
# Feature ids of clipped points: a corner of the incident face is 0..3; a point cut by a
# side plane is node k >= CORNER_IDS of `nodes`, nodes[k] = (tag, side, f1, f2), read back
# into the nested tuple (tag, side, f1, f2) by _feature.
CORNER_IDS = 4
MAX_POINTS = 32  # polygon buffer: 4 corners clipped by 4 sides stay far below this
MAX_NODES = 64


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
                out[m], out_feat[m] = p1, f1
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
                out[m], out_feat[m] = p2, f2
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


def _feature(k, nodes):
    """The feature id of a clipped point: a corner index, or (tag, side, f1, f2)."""
    if k < CORNER_IDS:
        return k
    tag, side, f1, f2 = nodes[k - CORNER_IDS]
    return (tag, float(side), _feature(f1, nodes), _feature(f2, nodes))


def _half3(body):
    s = body.shape
    return s.half if s.kind == "box" else (s.half[0], 0.0, s.half[1])


def _frame(body):
    """R, x, h of a body as arrays (see the compiled functions above)."""
    return np.array(body.R, dtype=float), np.array(body.x, dtype=float), np.array(_half3(body), dtype=float)


def box_box(A, B, margin, planar=False):
    """Separating axis test over the face normals of both boxes (3 + 3) and the 9 edge
    cross products (2 + 2 face normals for rects, no edges); the axis of least overlap
    is the contact normal; faces are clipped (up to 8 points for boxes, 2 for rects).

    Overlaps in A's frame (Gottschalk's OBB test): C[i][j] = a_i . b_j, t = d in A's
    frame; along a_i x b_j (length sqrt(1 - C_ij^2)) the radii are
    ha_i1 |C_i2j| + ha_i2 |C_i1j| and hb_j1 |C_ij2| + hb_j2 |C_ij1|, the centre distance
    |t_i2 C_i1j - t_i1 C_i2j| ((i, i1, i2) and (j, j1, j2) cyclic)."""
    Ra, xa, ha = _frame(A)
    Rb, xb, hb = _frame(B)
    kind, depth, i, j, sign, u = _separating_axes(Ra, xa, ha, Rb, xb, hb, float(margin), planar)
    if kind == 0:
        return []
    if kind == 3:
        point, signs = _edge_contact(Ra, xa, ha, Rb, xb, hb, i, j, u)
        return [(tuple(point.tolist()), tuple(u.tolist()), depth, ("edge", i, j, tuple(signs.tolist())))]
    flip = kind == 2
    if flip:
        points, ids, n, m, nodes = _face_contact(Rb, xb, hb, Ra, xa, ha, j, sign, True, float(margin), planar)
        face = j
    else:
        points, ids, n, m, nodes = _face_contact(Ra, xa, ha, Rb, xb, hb, i, sign, False, float(margin), planar)
        face = i
    n, nodes = tuple(n.tolist()), nodes.tolist()
    return [((x, y, z), n, depth, (flip, face, sign, m, _feature(k, nodes)))
            for (x, y, z, depth), k in zip(points.tolist(), ids.tolist())]


def rect_rect(A, B, margin):
    return box_box(A, B, margin, planar=True)


# --- dispatch --------------------------------------------------------------------------------

NARROW_PHASE = {
    ("plane", "sphere"): sphere_plane,
    ("plane", "circle"): sphere_plane,
    ("sphere", "sphere"): sphere_sphere,
    ("circle", "circle"): sphere_sphere,
    ("box", "sphere"): box_sphere,
    ("rect", "circle"): rect_circle,
    ("plane", "box"): plane_box,
    ("plane", "rect"): plane_rect,
    ("box", "box"): box_box,
    ("rect", "rect"): rect_rect,
}


def collide(A, B, margin: float):
    """(first, second, points) for bodies A and B: the bodies in the order the normals
    point (first to second), and the contact points (empty if apart by more than margin)."""
    kinds = (A.shape.kind, B.shape.kind)
    if kinds in NARROW_PHASE:
        return A, B, NARROW_PHASE[kinds](A, B, margin)
    swapped = (kinds[1], kinds[0])
    if swapped in NARROW_PHASE:
        return B, A, NARROW_PHASE[swapped](B, A, margin)
    return A, B, []  # plane against plane: static, never in contact
