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

from reference_impl.rigid_body import cross, dot


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

# A face axis wins over an edge axis (and box A's face over B's) unless the other
# overlaps less by more than this: ties between equal faces must not flip from step to
# step (that would change feature ids and lose warm starting).
FEATURE_TIE = 1e-9  # m
# A corner of the incident face this close outside a side of the reference face is kept
# as it is rather than cut into two points a rounding-level tilt apart (a face resting
# exactly on an equal face would otherwise give slivers: 5 or 6 points for 4).
CLIP_TOLERANCE = 1e-6  # m, far below any lever arm that matters


def _clip(polygon, centre, axis, half, tag):
    """Sutherland-Hodgman: keep the part of `polygon` [(point, feature)] with
    |(x - centre) . axis| <= half. A corner at most CLIP_TOLERANCE outside is kept as it
    is (it is the boundary point); an edge from inside to beyond that is cut at the side
    plane itself, the new point carrying (tag, side, f1, f2)."""
    for side in (1.0, -1.0):
        dist = [side * dot(_sub(p, centre), axis) - half for p, _ in polygon]
        out = []
        n = len(polygon)
        for k in range(n if n > 2 else 1):  # a segment (2D) has one edge, a polygon n
            (p1, f1), (p2, f2) = polygon[k - 1], polygon[k]
            d1, d2 = dist[k - 1], dist[k]
            if n == 2 and d1 <= CLIP_TOLERANCE:
                out.append((p1, f1))
            if d1 <= 0.0 < CLIP_TOLERANCE < d2 or d2 <= 0.0 < CLIP_TOLERANCE < d1:
                cut = _add(p1, _sub(p2, p1), d1 / (d1 - d2))
                out.append((cut, (tag, side, f1, f2) if d1 <= 0.0 else (tag, side, f2, f1)))
            if d2 <= CLIP_TOLERANCE:
                out.append((p2, f2))
        polygon = out
        if not polygon:
            break
    return polygon


def _face_contact(Ref, Inc, i, sign, flip, margin, planar):
    """Reference face i (outward normal sign * axis i of Ref, facing Inc) against the
    incident face of Inc most opposed to it: clip, keep the points below the face."""
    ref_axes, inc_axes = _axes(Ref.R), _axes(Inc.R)
    h_ref, h_inc = _half3(Ref), _half3(Inc)
    nf = tuple(sign * c for c in ref_axes[i])
    used = (0, 2) if planar else (0, 1, 2)
    m = max(used, key=lambda k: abs(dot(inc_axes[k], nf)))
    s_inc = -1.0 if dot(inc_axes[m], nf) > 0 else 1.0
    centre = _add(Inc.x, inc_axes[m], s_inc * h_inc[m])
    others = [k for k in used if k != m]
    if planar:  # an edge: two end points
        u = inc_axes[others[0]]
        polygon = [(_add(centre, u, h_inc[others[0]]), 0), (_add(centre, u, -h_inc[others[0]]), 1)]
    else:       # a face: four corners in cyclic order
        u, w = inc_axes[others[0]], inc_axes[others[1]]
        hu, hw = h_inc[others[0]], h_inc[others[1]]
        polygon = [(_add(_add(centre, u, su * hu), w, sw * hw), k)
                   for k, (su, sw) in enumerate(((1, 1), (-1, 1), (-1, -1), (1, -1)))]
    for k in used:
        if k != i and polygon:
            polygon = _clip(polygon, Ref.x, ref_axes[k], h_ref[k], k)
    n = tuple(-c for c in nf) if flip else nf
    points = []
    for p, f in polygon:
        depth = h_ref[i] - dot(_sub(p, Ref.x), nf)
        if depth >= -margin:
            points.append((_add(p, nf, 0.5 * depth), n, depth, (flip, i, sign, m, f)))
    return points


def _half3(body):
    s = body.shape
    return s.half if s.kind == "box" else (s.half[0], 0.0, s.half[1])


def _edge_contact(A, B, i, j, u, depth):
    """Edge i of A against edge j of B across axis u (from A to B): closest points."""
    a_axes, b_axes = _axes(A.R), _axes(B.R)
    ha, hb = A.shape.half, B.shape.half
    ea, eb, signs = A.x, B.x, []
    for k in range(3):
        if k != i:
            s = 1.0 if dot(a_axes[k], u) > 0 else -1.0
            ea = _add(ea, a_axes[k], s * ha[k])
            signs.append(s)
        if k != j:
            s = 1.0 if dot(b_axes[k], u) > 0 else -1.0
            eb = _add(eb, b_axes[k], -s * hb[k])
            signs.append(s)
    da, db = a_axes[i], b_axes[j]
    w0 = _sub(ea, eb)
    b, d, e = dot(da, db), dot(da, w0), dot(db, w0)
    denom = 1.0 - b * b
    s = max(-ha[i], min(ha[i], (b * e - d) / denom))
    t = max(-hb[j], min(hb[j], (e - b * d) / denom))
    pa, pb = _add(ea, da, s), _add(eb, db, t)
    point = tuple(0.5 * (x + y) for x, y in zip(pa, pb))
    return [(point, u, depth, ("edge", i, j, tuple(signs)))]


def box_box(A, B, margin, planar=False):
    """Separating axis test over the face normals of both boxes (3 + 3) and the 9 edge
    cross products (2 + 2 face normals for rects, no edges); the axis of least overlap
    is the contact normal; faces are clipped (up to 8 points for boxes, 2 for rects).

    Overlaps in A's frame (Gottschalk's OBB test): C[i][j] = a_i . b_j, t = d in A's
    frame; along a_i x b_j (length sqrt(1 - C_ij^2)) the radii are
    ha_i1 |C_i2j| + ha_i2 |C_i1j| and hb_j1 |C_ij2| + hb_j2 |C_ij1|, the centre distance
    |t_i2 C_i1j - t_i1 C_i2j| ((i, i1, i2) and (j, j1, j2) cyclic)."""
    a_axes, b_axes = _axes(A.R), _axes(B.R)
    ha, hb = _half3(A), _half3(B)
    used = (0, 2) if planar else (0, 1, 2)
    d = _sub(B.x, A.x)
    C = [[dot(a, b) for b in b_axes] for a in a_axes]
    Ab = [[abs(c) for c in row] for row in C]
    t = [dot(d, a) for a in a_axes]
    best_a = best_b = None
    for i in used:
        row = Ab[i]
        depth = ha[i] + hb[0] * row[0] + hb[1] * row[1] + hb[2] * row[2] - abs(t[i])
        if depth < -margin:
            return []
        if best_a is None or depth < best_a[0]:
            best_a = (depth, i, 1.0 if t[i] >= 0 else -1.0)
    for j in used:
        s = t[0] * C[0][j] + t[1] * C[1][j] + t[2] * C[2][j]  # d . b_j
        depth = hb[j] + ha[0] * Ab[0][j] + ha[1] * Ab[1][j] + ha[2] * Ab[2][j] - abs(s)
        if depth < -margin:
            return []
        if best_b is None or depth < best_b[0]:
            best_b = (depth, j, -1.0 if s >= 0 else 1.0)  # B's face towards A
    best_edge = None
    if not planar:
        for i in range(3):
            i1, i2 = (i + 1) % 3, (i + 2) % 3
            for j in range(3):
                length = math.sqrt(max(1.0 - C[i][j] * C[i][j], 0.0))
                if length < 1e-6:  # parallel edges: the face axes cover them
                    continue
                j1, j2 = (j + 1) % 3, (j + 2) % 3
                ra = ha[i1] * Ab[i2][j] + ha[i2] * Ab[i1][j]
                rb = hb[j1] * Ab[i][j2] + hb[j2] * Ab[i][j1]
                depth = (ra + rb - abs(t[i2] * C[i1][j] - t[i1] * C[i2][j])) / length
                if depth < -margin:
                    return []
                if best_edge is None or depth < best_edge[0]:
                    best_edge = (depth, i, j, length)
    face = best_a if best_a[0] <= best_b[0] + FEATURE_TIE else best_b
    if best_edge is not None and best_edge[0] + FEATURE_TIE < face[0]:
        depth, i, j, length = best_edge
        u = cross(a_axes[i], b_axes[j])
        u = tuple(c / length for c in u) if dot(d, u) >= 0 else tuple(-c / length for c in u)
        return _edge_contact(A, B, i, j, u, depth)
    if face is best_a:
        return _face_contact(A, B, best_a[1], best_a[2], False, margin, planar)
    return _face_contact(B, A, best_b[1], best_b[2], True, margin, planar)


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
