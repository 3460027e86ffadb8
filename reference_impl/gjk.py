"""The narrow phase of convex shapes by GJK, and triangle meshes through a bounding-volume
hierarchy (note 003, "Collision Detection": "GJK Algorithm: origin in Minkowski
Difference (MD) -> iteratively approximate MD by simplices", "Choose direction -> origin
use barycentric coords"; "Detection: top-down (Bounding Volume Hierarchy)").

A convex shape is known by its support function s(d), its point furthest along d. The
Minkowski difference MD = A - B = {a - b} has the support s_MD(d) = s_A(d) - s_B(-d), and
A and B overlap exactly when the origin lies in MD. GJK walks a simplex (1 to 4 points of
MD) towards the origin: each pass finds the point v of the simplex closest to the origin
(barycentric coordinates over the simplex's faces: Johnson's sub-algorithm), drops the
simplex points that do not carry v, and adds s_MD(-v), the next direction being the one
to the origin. It stops when s_MD(-v) brings the origin no nearer: |v| is the distance,
the barycentric weights give the closest points a on A and b on B. A simplex that comes to
hold the origin means overlap; then EPA (the expanding polytope algorithm) grows that
simplex into a polytope inside MD until its face nearest the origin is on MD's boundary:
that face's normal and distance are the direction and depth of least penetration.

Shapes (`Convex`): a polytope core (a box's 8 corners, a hull's vertices, a triangle's 3
corners, a capsule's segment, a sphere's centre) rounded by a radius r, or a cylinder.
GJK and EPA run on the cores; the rounding adds r_A + r_B to the depth (the Minkowski sum
with a ball moves MD's boundary out by the radius along the same normal).

The contact manifold is made by clipping on the found features (not by EPA alone, which
gives one point): with the normal n (from A to B), each shape's feature is its set of
surface points within `margin` of its support plane (a face, an edge, a vertex; for a
cylinder its rim samples and the two ends of its side line); the feature with more points
is the reference, the other the incident, clipped by the reference's side planes
(Sutherland-Hodgman, as box_box clips in geometry.py); each kept point gets the depth to
the reference plane. A vertex on either side, or two crossed segments, gives the one point
midway between GJK's (or EPA's) closest points. More than four points are reduced to four
(the deepest, then those spanning the largest area).

Meshes: a static triangle mesh holds its triangles (reordered by the tree, 3 rows of
`vertices` each, body frame) and a top-down tree of axis-aligned boxes (`bvh`: each node
lo(3), hi(3), then two children, or for a leaf -1 - first triangle and the count). A query
walks the tree with the other shape's box in the mesh's frame; each triangle reached is a
convex shape for GJK.
"""
from __future__ import annotations

import math

import numpy as np

from reference_impl.compiled import njit
from reference_impl.geometry import BOX as BOX_KIND, CAPSULE as CAPSULE_KIND, CYLINDER as CYLINDER_KIND
from reference_impl.geometry import MESH as MESH_KIND, SPHERE as SPHERE_KIND

# --- tolerances ---------------------------------------------------------------------------

# GJK stops when the new support point brings v no nearer than this fraction of |v|^2
# (relative: shapes of millimetres and of metres alike); float64 gives ~1e-16 per
# operation, so 1e-12 is reached within a few passes and stays far above rounding.
GJK_RELATIVE = 1e-12
# Cores closer than this (m) are taken as overlapping and handed to EPA: below it the
# direction v / |v| is rounding noise (|v| ~ 1e-16 times the coordinates, here < 1e3 m).
GJK_TOUCH = 1e-10
# EPA stops when the support along the nearest face's normal is within this (m) of it:
# the depth is then exact to this, far below the slop (1e-5 m) the solver works to.
EPA_TOLERANCE = 1e-10
# B is moved this far (m) apart for GJK when EPA cannot start (cores touching where MD
# is flat): more than any overlap the solver leaves (its slop, 1e-5 m), small beside the shapes.
SHIFT = 1e-3
MAX_ITERATIONS = 64   # GJK passes (it converges in a handful on polytopes; cylinders take more)
EPA_FACES = 256       # polytope faces kept by EPA (64 passes add at most 2 faces net each)
# Two segment features at least this far from parallel (sine of the angle) touch at one
# point, not along a line (crossed capsules, a cylinder's side across a box's edge).
PARALLEL = 1e-3
MANIFOLD = 4          # points kept per pair (per reduction)
FEATURE_POINTS = 16   # the most points a feature has (a cylinder: 6 + 6 rim samples + 2)
# A side line's end this close (relative to the radius) to a rim sample is that sample.
SAME_POINT = 1e-9
RIM = 6               # rim samples per cylinder cap (body-fixed angles 2 pi k / RIM)

# Convex kinds
POLYTOPE, CYLINDER = 0, 1


# --- 3-vectors as new arrays (written out: numpy's array expressions cost seconds to compile)

@njit
def _minus(a, b):
    """a - b."""
    out = np.empty(3)
    for c in range(3):
        out[c] = a[c] - b[c]
    return out


@njit
def _along(a, s, b):
    """a + s b."""
    out = np.empty(3)
    for c in range(3):
        out[c] = a[c] + s * b[c]
    return out


@njit
def _scaled(a, s):
    """s a."""
    out = np.empty(3)
    for c in range(3):
        out[c] = s * a[c]
    return out


@njit
def _cross(a, b):
    """a x b."""
    out = np.empty(3)
    out[0], out[1], out[2] = a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]
    return out


# --- support functions (note 003, GJK: the support point of a shape along Dir) ------------

@njit
def polytope(P, ids, r):
    """A polytope core with world vertices P (M, 3), their feature ids, rounded by r."""
    return (POLYTOPE, P, ids, r, np.zeros(3), np.zeros((3, 3)), 0.0, 0.0)


@njit
def cylinder(x, R, radius, h):
    """A cylinder: centre x, frame R (its axis body z), radius, half-length h."""
    return (CYLINDER, np.zeros((0, 3)), np.zeros(0, np.int64), 0.0, x, R, radius, h)


@njit
def core_support(C, d):
    """s(d) of C's core: its point furthest along d (need not be unit)."""
    if C[0] == POLYTOPE:
        P = C[1]
        best, k = -np.inf, 0
        for m in range(len(P)):
            s = P[m, 0] * d[0] + P[m, 1] * d[1] + P[m, 2] * d[2]
            if s > best:
                best, k = s, m
        return P[k].copy()
    x, R, radius, h = C[4], C[5], C[6], C[7]
    along = d[0] * R[0, 2] + d[1] * R[1, 2] + d[2] * R[2, 2]
    side = 1.0 if along >= 0.0 else -1.0
    out = np.empty(3)
    across = np.empty(3)
    for c in range(3):
        across[c] = d[c] - along * R[c, 2]
    norm = math.sqrt(across[0] ** 2 + across[1] ** 2 + across[2] ** 2)
    for c in range(3):
        out[c] = x[c] + side * h * R[c, 2] + (radius * across[c] / norm if norm > 0.0 else 0.0)
    return out


@njit
def _md_support(A, B, d, W, SA, SB, k, shift):
    """s_MD(d) = s_A(d) - s_B(-d) into row k of W, with its parts in SA, SB (B moved by shift)."""
    a = core_support(A, d)
    b = core_support(B, _scaled(d, -1.0))
    for c in range(3):
        SA[k, c], SB[k, c] = a[c], b[c] + shift[c]
        W[k, c] = a[c] - SB[k, c]


# --- GJK (note 003, "GJK Algorithm: origin in Minkowski Difference") -----------------------

@njit
def _solve_affine(W, rows, n):
    """Barycentric weights lam (sum 1) of the point of the affine hull of W[rows[:n]]
    nearest the origin (Gram system of the edges y_i - y_0), and whether it is regular."""
    lam = np.zeros(4)
    if n == 1:
        lam[0] = 1.0
        return lam, True
    y0 = W[rows[0]]
    G = np.zeros((3, 3))
    g = np.zeros(3)
    m = n - 1
    for i in range(m):
        ei = _minus(W[rows[i + 1]], y0)
        g[i] = -(ei[0] * y0[0] + ei[1] * y0[1] + ei[2] * y0[2])
        for j in range(m):
            ej = _minus(W[rows[j + 1]], y0)
            G[i, j] = ei[0] * ej[0] + ei[1] * ej[1] + ei[2] * ej[2]
    scale = G[0, 0] + (G[1, 1] if m > 1 else 0.0) + (G[2, 2] if m > 2 else 0.0)
    if m == 1:
        det = G[0, 0]
        if det <= 1e-14 * scale * scale + 1e-300:
            return lam, False
        t = (g[0] / det,)
        lam[1] = t[0]
    elif m == 2:
        det = G[0, 0] * G[1, 1] - G[0, 1] * G[1, 0]
        if det <= 1e-14 * scale * scale + 1e-300:
            return lam, False
        lam[1] = (g[0] * G[1, 1] - G[0, 1] * g[1]) / det
        lam[2] = (G[0, 0] * g[1] - g[0] * G[1, 0]) / det
    else:
        det = (G[0, 0] * (G[1, 1] * G[2, 2] - G[1, 2] * G[2, 1]) - G[0, 1] * (G[1, 0] * G[2, 2] - G[1, 2] * G[2, 0])
               + G[0, 2] * (G[1, 0] * G[2, 1] - G[1, 1] * G[2, 0]))
        if abs(det) <= 1e-14 * scale * scale * scale + 1e-300:
            return lam, False
        for col in range(3):  # Cramer's rule
            H = G.copy()
            for i in range(3):
                H[i, col] = g[i]
            lam[col + 1] = (H[0, 0] * (H[1, 1] * H[2, 2] - H[1, 2] * H[2, 1])
                            - H[0, 1] * (H[1, 0] * H[2, 2] - H[1, 2] * H[2, 0])
                            + H[0, 2] * (H[1, 0] * H[2, 1] - H[1, 1] * H[2, 0])) / det
    total = 0.0
    for i in range(1, n):
        total += lam[i]
    lam[0] = 1.0 - total
    return lam, True


@njit
def _closest_on_simplex(W, simplex, n):
    """Johnson's sub-algorithm: of the faces of the simplex W[simplex[:n]] (every subset),
    the one whose affine hull's nearest point to the origin has all barycentric weights
    > 0 and is nearest: (v, the kept rows, their count, their weights)."""
    best, best_rows, best_n, best_lam = np.inf, np.zeros(4, np.int64), 0, np.zeros(4)
    v_best = np.zeros(3)
    rows = np.zeros(4, np.int64)
    for mask in range(1, 1 << n):
        m = 0
        for i in range(n):
            if mask & (1 << i):
                rows[m] = simplex[i]
                m += 1
        lam, ok = _solve_affine(W, rows, m)
        if not ok:
            continue
        inside = True
        for i in range(m):
            if lam[i] <= 0.0 and m > 1:
                inside = False
        if not inside:
            continue
        v = np.zeros(3)
        for i in range(m):
            for c in range(3):
                v[c] += lam[i] * W[rows[i], c]
        dist = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
        if dist < best:
            best, best_n = dist, m
            for i in range(4):
                best_rows[i], best_lam[i] = rows[i], lam[i]
            v_best = v
    return v_best, best_rows, best_n, best_lam


@njit
def gjk(A, B, shift):
    """GJK on the cores of A and of B moved by `shift`: (distance, a, b, W, SA, SB,
    simplex, n, used): the closest points a of A and b of B (distance |a - b|, 0 when the
    cores overlap or GJK cannot show them apart within MAX_ITERATIONS passes: then the
    simplex W[simplex[:n]] holds the origin, for EPA)."""
    W, SA, SB = np.zeros((MAX_ITERATIONS + 4, 3)), np.zeros((MAX_ITERATIONS + 4, 3)), np.zeros((MAX_ITERATIONS + 4, 3))
    d = np.array([1.0, 0.0, 0.0])
    _md_support(A, B, d, W, SA, SB, 0, shift)
    simplex, n, used = np.zeros(4, np.int64), 1, 1
    lam = np.zeros(4)
    lam[0] = 1.0
    v = W[0].copy()
    lower = -np.inf  # the distance is at least v . w / |v| (w: MD's support along -v), at most |v|
    for _ in range(MAX_ITERATIONS):
        vv = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
        if vv <= GJK_TOUCH * GJK_TOUCH:
            break
        _md_support(A, B, _scaled(v, -1.0), W, SA, SB, used, shift)  # Dir: from v to the origin
        w = W[used]
        vw = v[0] * w[0] + v[1] * w[1] + v[2] * w[2]
        lower = vw / math.sqrt(vv)
        if vv - vw <= GJK_RELATIVE * vv:
            lower = math.sqrt(vv)
            break  # no nearer: v is the nearest point of MD
        simplex[n] = used
        n += 1
        used += 1
        v, rows, n, lam = _closest_on_simplex(W, simplex, n)
        for i in range(4):
            simplex[i] = rows[i]
        if n == 4:  # the origin is inside the tetrahedron
            v = np.zeros(3)
            break
    a, b = np.zeros(3), np.zeros(3)
    for i in range(n):
        for c in range(3):
            a[c] += lam[i] * SA[simplex[i], c]
            b[c] += lam[i] * SB[simplex[i], c]
    dist = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if lower <= GJK_TOUCH:
        # the passes ran out with the distance not bracketed away from 0 (on a sliver simplex
        # across a triangle 100 m wide: v was 1e-9 m of rounding pointing across the ground,
        # measured on the invariance battery's as_mesh ground): the cores may touch, and
        # v's direction is no normal; 0 hands them to EPA
        dist = 0.0
    return dist, a, b, W, SA, SB, simplex, n, used


# --- EPA: the depth of overlapping cores ---------------------------------------------------

@njit
def _face(W, F, N, D, f, i, j, k, inner):
    """Face f = (i, j, k) of the polytope, its normal turned away from the point `inner`
    inside it (not from the origin: a face through the origin, the shapes just touching,
    would take either side by rounding, and EPA would push them through each other)."""
    e1, e2 = _minus(W[j], W[i]), _minus(W[k], W[i])
    nx, ny, nz = e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    if norm <= 1e-300:  # no area: never the nearest face, never seen
        F[f, 0], F[f, 1], F[f, 2] = i, j, k
        N[f, 0], N[f, 1], N[f, 2], D[f] = 0.0, 0.0, 0.0, np.inf
        return
    nx, ny, nz = nx / norm, ny / norm, nz / norm
    if nx * (W[i, 0] - inner[0]) + ny * (W[i, 1] - inner[1]) + nz * (W[i, 2] - inner[2]) < 0.0:
        j, k = k, j  # wound the other way: flip
        nx, ny, nz = -nx, -ny, -nz
    dist = nx * W[i, 0] + ny * W[i, 1] + nz * W[i, 2]
    F[f, 0], F[f, 1], F[f, 2] = i, j, k
    N[f, 0], N[f, 1], N[f, 2], D[f] = nx, ny, nz, dist


@njit
def _blow_up(A, B, W, SA, SB, simplex, n, used):
    """Grow a simplex holding the origin with fewer than 4 points into a tetrahedron
    (support points along the axes, then across the segment, then off the triangle)."""
    while n < 4:
        best, best_row = -1.0, -1
        for t in range(6):
            d = np.zeros(3)
            d[t // 2] = 1.0 if t % 2 == 0 else -1.0
            if n == 2:
                d = _cross(_minus(W[simplex[1]], W[simplex[0]]), d)
            elif n == 3:
                d = _scaled(_cross(_minus(W[simplex[1]], W[simplex[0]]), _minus(W[simplex[2]], W[simplex[0]])),
                            1.0 if t % 2 == 0 else -1.0)
            if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= 1e-300:
                continue
            _md_support(A, B, d, W, SA, SB, used, np.zeros(3))
            # how far the new point is from the simplex's affine hull
            gap = _affine_gap(W, simplex, n, used)
            if gap > best:
                best, best_row = gap, t
                for c in range(3):
                    W[used + 1, c], SA[used + 1, c], SB[used + 1, c] = W[used, c], SA[used, c], SB[used, c]
        if best <= 1e-14:
            return n, used  # MD is flat here: no volume
        for c in range(3):
            W[used, c], SA[used, c], SB[used, c] = W[used + 1, c], SA[used + 1, c], SB[used + 1, c]
        simplex[n] = used
        n += 1
        used += 1
    return n, used


@njit
def _affine_gap(W, simplex, n, row):
    """Distance of W[row] from the affine hull of W[simplex[:n]] (n = 1..3)."""
    p = _minus(W[row], W[simplex[0]])
    if n == 1:
        return math.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2])
    e = _minus(W[simplex[1]], W[simplex[0]])
    if n == 2:
        ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2]
        t = (p[0] * e[0] + p[1] * e[1] + p[2] * e[2]) / ee
        q = _along(p, -t, e)
        return math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2])
    f = _minus(W[simplex[2]], W[simplex[0]])
    nx, ny, nz = e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0]
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    return abs(p[0] * nx + p[1] * ny + p[2] * nz) / norm if norm > 0 else 0.0


@njit(inline=True)
def epa(A, B, W, SA, SB, simplex, n, used):
    """(depth, n, a, b): the least penetration of the overlapping cores, its direction n
    (from A to B: moving B by depth n separates them) and the deepest points a of A and
    b of B (a - b = depth n). Returns depth -1 when MD has no volume at the origin."""
    size = len(W)
    if size < used + 2 * MAX_ITERATIONS + 8:  # room for the polytope's vertices
        W2, SA2, SB2 = np.zeros((used + 2 * MAX_ITERATIONS + 8, 3)), np.zeros((used + 2 * MAX_ITERATIONS + 8, 3)), \
            np.zeros((used + 2 * MAX_ITERATIONS + 8, 3))
        for t in range(used):
            for c in range(3):
                W2[t, c], SA2[t, c], SB2[t, c] = W[t, c], SA[t, c], SB[t, c]
        W, SA, SB = W2, SA2, SB2
    n, used = _blow_up(A, B, W, SA, SB, simplex, n, used)
    if n < 4:
        return -1.0, np.zeros(3), np.zeros(3), np.zeros(3)
    F, N, D = np.zeros((EPA_FACES, 3), np.int64), np.zeros((EPA_FACES, 3)), np.zeros(EPA_FACES)
    alive = np.zeros(EPA_FACES, np.bool_)
    s = simplex
    inner = np.zeros(3)  # the first tetrahedron's centroid: inside every polytope grown from it
    for t in range(4):
        for c in range(3):
            inner[c] += 0.25 * W[s[t], c]
    _face(W, F, N, D, 0, s[0], s[1], s[2], inner)
    _face(W, F, N, D, 1, s[0], s[1], s[3], inner)
    _face(W, F, N, D, 2, s[0], s[2], s[3], inner)
    _face(W, F, N, D, 3, s[1], s[2], s[3], inner)
    for f in range(4):
        alive[f] = True
    faces = 4
    edges = np.zeros((3 * EPA_FACES, 2), np.int64)
    best = 0
    for _ in range(MAX_ITERATIONS):
        best, nearest = -1, np.inf
        for f in range(faces):
            if alive[f] and D[f] < nearest:
                best, nearest = f, D[f]
        _md_support(A, B, N[best], W, SA, SB, used, np.zeros(3))
        w = W[used]
        if w[0] * N[best, 0] + w[1] * N[best, 1] + w[2] * N[best, 2] - nearest <= EPA_TOLERANCE:
            break
        # remove every face that sees w; its edges that no other removed face shares are the horizon
        n_edges = 0
        for f in range(faces):
            if not alive[f]:
                continue
            p = W[F[f, 0]]
            if N[f, 0] * (w[0] - p[0]) + N[f, 1] * (w[1] - p[1]) + N[f, 2] * (w[2] - p[2]) > 0.0:
                alive[f] = False
                for e in range(3):
                    i, j = F[f, e], F[f, (e + 1) % 3]
                    shared = -1
                    for t in range(n_edges):
                        if edges[t, 0] == j and edges[t, 1] == i:
                            shared = t
                    if shared >= 0:
                        edges[shared, 0], edges[shared, 1] = edges[n_edges - 1, 0], edges[n_edges - 1, 1]
                        n_edges -= 1
                    else:
                        edges[n_edges, 0], edges[n_edges, 1] = i, j
                        n_edges += 1
        if faces + n_edges > EPA_FACES:
            break
        for t in range(n_edges):
            _face(W, F, N, D, faces, edges[t, 0], edges[t, 1], used, inner)
            alive[faces] = True
            faces += 1
        used += 1
        if used >= len(W):
            break
    # the point of the nearest face nearest the origin, in barycentric weights
    i, j, k = F[best, 0], F[best, 1], F[best, 2]
    nb = N[best]
    depth = max(D[best], 0.0)  # the origin on the face: touching
    rows = np.array([i, j, k, 0])
    lam, ok = _solve_affine(W, rows, 3)
    if not ok:
        lam[0], lam[1], lam[2] = 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0
    a, b = np.zeros(3), np.zeros(3)
    for m in range(3):
        for c in range(3):
            a[c] += lam[m] * SA[rows[m], c]
            b[c] += lam[m] * SB[rows[m], c]
    return depth, nb.copy(), a, b


@njit(inline=True)
def separation(A, B):
    """(depth, n, a, b) of two convex shapes, rounded: depth > 0 overlapping, < 0 the gap;
    n the unit normal from A to B; a, b the closest (or deepest) points of the rounded
    shapes' surfaces."""
    rA, rB = A[3], B[3]
    dist, a, b, W, SA, SB, simplex, n, used = gjk(A, B, np.zeros(3))
    if dist > GJK_TOUCH:
        normal = _scaled(_minus(b, a), 1.0 / dist)
        return rA + rB - dist, normal, _along(a, rA, normal), _along(b, -rB, normal)
    depth, normal, a, b = epa(A, B, W, SA, SB, simplex, n, used)
    if not (depth >= 0.0 and abs(normal[0] ** 2 + normal[1] ** 2 + normal[2] ** 2 - 1.0) < 1e-6):
        # the cores touch where MD has no volume at the origin (EPA cannot start): GJK
        # again with B moved SHIFT apart along a guess of the normal (GJK's last face of
        # MD, a triangle's own normal, the line of the centres: the first that parts
        # them); what the shift adds along the normal found comes off the depth again
        inside = _minus(_centre(A), _centre(B))  # a point inside MD
        for guess in range(3):
            u = np.zeros(3)
            if guess == 0 and n == 3:
                u = _cross(_minus(W[simplex[1]], W[simplex[0]]), _minus(W[simplex[2]], W[simplex[0]]))
            elif guess == 1 and A[0] == POLYTOPE and len(A[1]) == 3:
                P = A[1]
                u = _cross(_minus(P[1], P[0]), _minus(P[2], P[0]))
            elif guess == 2:
                u = _scaled(inside, -1.0)
            norm = math.sqrt(u[0] ** 2 + u[1] ** 2 + u[2] ** 2)
            if norm <= 0.0:
                continue
            if u[0] * inside[0] + u[1] * inside[1] + u[2] * inside[2] > 0.0:
                norm = -norm  # away from MD's inside
            u = _scaled(u, 1.0 / norm)
            shift = _scaled(u, SHIFT)
            dist, a, b, W2, SA2, SB2, simplex2, n2, used2 = gjk(A, B, shift)
            normal, depth = u, SHIFT
            if dist > GJK_TOUCH:
                normal = _scaled(_minus(b, a), 1.0 / dist)
                depth = SHIFT * (u[0] * normal[0] + u[1] * normal[1] + u[2] * normal[2]) - dist
                b = _along(b, -1.0, shift)
                break
            b = _along(b, -1.0, shift)
    return depth + rA + rB, normal, _along(a, -rA, normal), _along(b, rB, normal)


@njit
def _centre(C):
    """A point inside C's core: its vertices' mean, or the cylinder's centre."""
    if C[0] == CYLINDER:
        return C[4].copy()
    P = C[1]
    out = np.zeros(3)
    for k in range(len(P)):
        for c in range(3):
            out[c] += P[k, c] / len(P)
    return out


# --- features and clipping (the manifold) -----------------------------------------------------

@njit
def feature(C, d, tol, P, ids):
    """C's surface points within tol of its support plane along unit d into P, ids; the count."""
    m = 0
    if C[0] == POLYTOPE:
        V, vid, r = C[1], C[2], C[3]
        top = -np.inf
        for k in range(len(V)):
            top = max(top, V[k, 0] * d[0] + V[k, 1] * d[1] + V[k, 2] * d[2])
        for k in range(len(V)):
            if V[k, 0] * d[0] + V[k, 1] * d[1] + V[k, 2] * d[2] >= top - tol and m < FEATURE_POINTS:
                for c in range(3):
                    P[m, c] = V[k, c] + r * d[c]
                ids[m] = vid[k]
                m += 1
        return m
    x, R, radius, h = C[4], C[5], C[6], C[7]
    top = core_support(C, d)
    level = top[0] * d[0] + top[1] * d[1] + top[2] * d[2]
    cand = np.empty((2 * RIM + 2, 3))
    for cap in range(2):
        side = 1.0 if cap == 0 else -1.0
        for k in range(RIM):
            phi = 2.0 * math.pi * k / RIM
            cs, sn = math.cos(phi), math.sin(phi)
            for c in range(3):
                cand[cap * RIM + k, c] = x[c] + side * h * R[c, 2] + radius * (cs * R[c, 0] + sn * R[c, 1])
    along = d[0] * R[0, 2] + d[1] * R[1, 2] + d[2] * R[2, 2]
    side = 1.0 if along >= 0.0 else -1.0
    for c in range(3):  # the side line along d: its end on the supporting cap (top) and on the other
        cand[2 * RIM, c] = top[c]
        cand[2 * RIM + 1, c] = top[c] - 2.0 * side * h * R[c, 2]
    # the rim samples only when the whole cap lies within tol of the support plane (a flat
    # face down): on a cylinder rolling on its side they would be points of a curved
    # surface, whose gap the solver's speculative contact (gap / dt, linear) mistakes for
    # an approach, braking the roll
    flat_cap = 2.0 * radius * math.sqrt(max(0.0, 1.0 - along * along)) <= tol
    for k in range(2 * RIM + 2):
        if k < 2 * RIM and not flat_cap:
            continue
        if cand[k, 0] * d[0] + cand[k, 1] * d[1] + cand[k, 2] * d[2] >= level - tol and m < FEATURE_POINTS:
            seen = False  # a side line's end on a rim sample (the cylinder turned just so): once
            for t in range(m):
                if (P[t, 0] - cand[k, 0]) ** 2 + (P[t, 1] - cand[k, 1]) ** 2 + (P[t, 2] - cand[k, 2]) ** 2 \
                        <= (SAME_POINT * radius) ** 2:
                    seen = True
            if not seen:
                for c in range(3):
                    P[m, c] = cand[k, c]
                ids[m] = k
                m += 1
    return m


@njit
def _plane_basis(n):
    """Two unit vectors u, w with (u, w, n) right-handed."""
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = _cross(n, a)
    u = _scaled(u, 1.0 / math.sqrt(u[0] ** 2 + u[1] ** 2 + u[2] ** 2))
    w = _cross(n, u)
    return u, w


@njit
def _convex_order(P, ids, m, n):
    """The corners of P[:m] as a convex polygon in the plane across n (counterclockwise
    about n; points inside dropped; monotone chain): returns P, ids, count."""
    if m < 3:
        return P[:m].copy(), ids[:m].copy(), m
    u, w = _plane_basis(n)
    xs, ys = np.empty(m), np.empty(m)
    for k in range(m):
        xs[k] = P[k, 0] * u[0] + P[k, 1] * u[1] + P[k, 2] * u[2]
        ys[k] = P[k, 0] * w[0] + P[k, 1] * w[1] + P[k, 2] * w[2]
    order = np.empty(m, np.int64)  # by x, then y: insertion sort (a feature has at most FEATURE_POINTS)
    for k in range(m):
        t = k
        while t > 0 and (xs[order[t - 1]] > xs[k] or (xs[order[t - 1]] == xs[k] and ys[order[t - 1]] > ys[k])):
            order[t] = order[t - 1]
            t -= 1
        order[t] = k
    hull = np.empty(2 * m + 1, np.int64)
    t = 0
    for rep in range(2):
        start = t
        for step in range(m):
            k = order[step] if rep == 0 else order[m - 1 - step]
            while t >= start + 2:
                i, j = hull[t - 2], hull[t - 1]
                if (xs[j] - xs[i]) * (ys[k] - ys[i]) - (ys[j] - ys[i]) * (xs[k] - xs[i]) <= 1e-14:
                    t -= 1
                else:
                    break
            hull[t] = k
            t += 1
        t -= 1
    if t < 2:  # all points on one line
        lo, hi = order[0], order[-1]
        out, oid = np.empty((2, 3)), np.empty(2, np.int64)
        for c in range(3):
            out[0, c], out[1, c] = P[lo, c], P[hi, c]
        oid[0], oid[1] = ids[lo], ids[hi]
        return out, oid, 2
    out, oid = np.empty((t, 3)), np.empty(t, np.int64)
    for k in range(t):
        for c in range(3):
            out[k, c] = P[hull[k], c]
        oid[k] = ids[hull[k]]
    return out, oid, t


@njit
def _clip(poly, pid, count, ref, n):
    """Sutherland-Hodgman: the part of the incident polygon poly[:count] inside the side
    planes of the convex reference polygon ref (counterclockwise about n): each side's
    plane holds the side and n. A point cut from incident edge (k-1, k) by side s gets
    id 1 << 20 + s << 10 + its edge's first id."""
    R = len(ref)
    for s in range(R if R > 2 else 2):
        if R == 2:  # a segment: its slab between the planes across it at its ends
            e = _minus(ref[1], ref[0]) if s == 0 else _minus(ref[0], ref[1])
            e = _along(e, -(e[0] * n[0] + e[1] * n[1] + e[2] * n[2]), n)
            o = ref[1] if s == 0 else ref[0]
            side = e
        else:
            p0, p1 = ref[s], ref[(s + 1) % R]
            side = _cross(_minus(p1, p0), n)
            o = p0
        norm = math.sqrt(side[0] ** 2 + side[1] ** 2 + side[2] ** 2)
        side = _scaled(side, 1.0 / norm)
        dist = np.empty(count)
        for k in range(count):
            dist[k] = (poly[k, 0] - o[0]) * side[0] + (poly[k, 1] - o[1]) * side[1] + (poly[k, 2] - o[2]) * side[2]
        out, oid, m = np.empty((2 * count + 2, 3)), np.empty(2 * count + 2, np.int64), 0
        for k in range(count if count > 2 else 1):
            k1 = k - 1 if k > 0 else count - 1
            if count == 2:
                k1, k = 0, 1
            d1, d2 = dist[k1], dist[k]
            if count == 2 and d1 <= 0.0:
                for c in range(3):
                    out[m, c] = poly[k1, c]
                oid[m] = pid[k1]
                m += 1
            if (d1 < 0.0 < d2) or (d2 < 0.0 < d1):
                t = d1 / (d1 - d2)
                for c in range(3):
                    out[m, c] = poly[k1, c] + t * (poly[k, c] - poly[k1, c])
                oid[m] = (1 << 20) + (s << 10) + pid[k1 if d1 < 0.0 else k] % 1024
                m += 1
            if d2 <= 0.0:
                for c in range(3):
                    out[m, c] = poly[k, c]
                oid[m] = pid[k]
                m += 1
        poly, pid, count = out, oid, m
        if count == 0:
            break
    return poly, pid, count


@njit
def reduce(P, depth, ids, m, n, most):
    """At most `most` of the points P[:m] (the deepest, the farthest from it, then the
    ones spanning the largest area across n): the kept rows' indices and their count."""
    keep = np.empty(most, np.int64)
    if m <= most:
        for k in range(m):
            keep[k] = k
        return keep, m
    first = 0
    for k in range(m):
        if depth[k] > depth[first]:
            first = k
    keep[0] = first
    second, far = first, -1.0
    for k in range(m):
        dd = (P[k, 0] - P[first, 0]) ** 2 + (P[k, 1] - P[first, 1]) ** 2 + (P[k, 2] - P[first, 2]) ** 2
        if dd > far:
            second, far = k, dd
    keep[1] = second
    count = 2
    if most > 2:
        hi, lo, k_hi, k_lo = 0.0, 0.0, -1, -1
        e = _minus(P[second], P[first])
        for k in range(m):
            f = _minus(P[k], P[first])
            s = n[0] * (e[1] * f[2] - e[2] * f[1]) + n[1] * (e[2] * f[0] - e[0] * f[2]) + n[2] * (e[0] * f[1] - e[1] * f[0])
            if s > hi:
                hi, k_hi = s, k
            if s < lo:
                lo, k_lo = s, k
        if k_hi >= 0:
            keep[count] = k_hi
            count += 1
        if k_lo >= 0 and count < most:
            keep[count] = k_lo
            count += 1
    return keep, count


@njit
def manifold(A, B, margin, points, depths, ids):
    """The contact points of convex A and B (normal from A to B) into points, depths, ids:
    (count, n). Count 0 when they are more than margin apart."""
    depth, n, a, b = separation(A, B)
    if depth < -margin:
        return 0, n
    PA, IA, PB, IB = np.empty((FEATURE_POINTS, 3)), np.empty(FEATURE_POINTS, np.int64), \
        np.empty((FEATURE_POINTS, 3)), np.empty(FEATURE_POINTS, np.int64)
    tol = max(margin, 0.0)
    mA = feature(A, n, tol, PA, IA)
    mB = feature(B, _scaled(n, -1.0), tol, PB, IB)
    QA, JA, kA = _convex_order(PA, IA, mA, n)
    QB, JB, kB = _convex_order(PB, IB, mB, n)
    single = kA <= 1 or kB <= 1
    if not single and kA == 2 and kB == 2:  # two segments: along a line only when parallel
        ea, eb = _minus(QA[1], QA[0]), _minus(QB[1], QB[0])
        cx = _cross(ea, eb)
        la, lb = math.sqrt(ea[0] ** 2 + ea[1] ** 2 + ea[2] ** 2), math.sqrt(eb[0] ** 2 + eb[1] ** 2 + eb[2] ** 2)
        single = math.sqrt(cx[0] ** 2 + cx[1] ** 2 + cx[2] ** 2) > PARALLEL * la * lb
    count = 0
    if not single:
        flip = kB > kA  # the reference: the feature with more corners (A's of equals)
        if flip:
            ref, inc, iid, mi = QB, QA, JA, kA
            level = np.inf
            for k in range(mB):
                level = min(level, PB[k, 0] * n[0] + PB[k, 1] * n[1] + PB[k, 2] * n[2])
        else:
            ref, inc, iid, mi = QA, QB, JB, kB
            level = -np.inf
            for k in range(mA):
                level = max(level, PA[k, 0] * n[0] + PA[k, 1] * n[1] + PA[k, 2] * n[2])
        if len(ref) >= 3:  # a face: its own normal (exact for a face along the axes), not EPA's
            nf = _cross(_minus(ref[1], ref[0]), _minus(ref[2], ref[0]))
            norm = math.sqrt(nf[0] ** 2 + nf[1] ** 2 + nf[2] ** 2)
            if nf[0] * n[0] + nf[1] * n[1] + nf[2] * n[2] < 0.0:
                norm = -norm
            n = _scaled(nf, 1.0 / norm)
            level = np.inf if flip else -np.inf
            for k in range(len(ref)):
                h = ref[k, 0] * n[0] + ref[k, 1] * n[1] + ref[k, 2] * n[2]
                level = min(level, h) if flip else max(level, h)
        poly, pid, m = _clip(inc, iid, mi, ref, n)
        P, dep, fid = np.empty((m, 3)), np.empty(m), np.empty(m, np.int64)
        for k in range(m):
            h = poly[k, 0] * n[0] + poly[k, 1] * n[1] + poly[k, 2] * n[2]
            d = h - level if flip else level - h
            if d >= -margin:
                half = -0.5 * d if flip else 0.5 * d
                for c in range(3):
                    P[count, c] = poly[k, c] + half * n[c]
                dep[count], fid[count] = d, pid[k] + (1 << 30 if flip else 0)
                count += 1
        keep, kept = reduce(P, dep, fid, count, n, MANIFOLD)
        for t in range(kept):
            for c in range(3):
                points[t, c] = P[keep[t], c]
            depths[t], ids[t] = dep[keep[t]], fid[keep[t]]
        count = kept
    if count == 0:  # a vertex, crossed segments, or nothing left by clipping: the one point
        for c in range(3):
            points[0, c] = 0.5 * (a[c] + b[c])
        depths[0], ids[0] = depth, 0
        count = 1
    return count, n


# --- meshes: a top-down bounding-volume hierarchy (note 003, "Detection: top-down") --------

LEAF_SIZE = 2  # triangles per leaf


def build_bvh(vertices: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(corners (3T, 3): the triangles' corners in tree order, nodes (K, 8)): a top-down
    tree of axis-aligned boxes, each node split at the median of its triangles' centroids
    along its box's longest side (in Python, once, when the mesh is made)."""
    tri = np.asarray(triangles, dtype=np.int64)
    V = np.asarray(vertices, dtype=float)
    corners = V[tri]  # (T, 3, 3)
    centroid = corners.mean(axis=1)
    nodes: list[list[float]] = []
    order: list[int] = []

    def build(items: np.ndarray) -> int:
        box = corners[items].reshape(-1, 3)
        lo, hi = box.min(axis=0), box.max(axis=0)
        index = len(nodes)
        nodes.append([*lo, *hi, 0.0, 0.0])
        if len(items) <= LEAF_SIZE:
            nodes[index][6:] = [-1.0 - len(order), float(len(items))]
            order.extend(int(i) for i in items)
            return index
        axis = int(np.argmax(hi - lo))
        items = items[np.argsort(centroid[items, axis], kind="mergesort")]
        half = len(items) // 2
        left = build(items[:half])
        right = build(items[half:])
        nodes[index][6:] = [float(left), float(right)]
        return index

    build(np.arange(len(tri)))
    return corners[np.array(order)].reshape(-1, 3), np.array(nodes, dtype=float)


@njit
def mesh_candidates(bvh, lo, hi):
    """The triangles whose leaf boxes meet the box [lo, hi] (mesh frame)."""
    found = np.empty(64, np.int64)
    n_found = 0
    stack = np.empty(64, np.int64)
    stack[0], top = 0, 1
    while top > 0:
        top -= 1
        node = bvh[stack[top]]
        if (node[0] > hi[0] or node[3] < lo[0] or node[1] > hi[1] or node[4] < lo[1]
                or node[2] > hi[2] or node[5] < lo[2]):
            continue
        if node[6] < 0.0:  # a leaf: its triangles
            first = int(-1.0 - node[6])
            for t in range(first, first + int(node[7])):
                if n_found == len(found):
                    grown = np.empty(2 * len(found), np.int64)
                    for t2 in range(n_found):
                        grown[t2] = found[t2]
                    found = grown
                found[n_found] = t
                n_found += 1
        else:
            if top + 2 > len(stack):
                grown = np.empty(2 * len(stack), np.int64)
                for t2 in range(top):
                    grown[t2] = stack[t2]
                stack = grown
            stack[top], stack[top + 1] = int(node[6]), int(node[7])
            top += 2
    return found[:n_found]


# --- the bodies' shapes as convex shapes, and the routines of geometry's dispatch ------------

@njit
def convex_of(bodies, i):
    """Body i's shape as a Convex in the world (a sphere, box, capsule, cylinder or hull)."""
    kind, x, R = bodies.shape[i], bodies.x[i], bodies.R[i]
    if kind == CYLINDER_KIND:
        return cylinder(x, R, bodies.radius[i], bodies.half[i, 2])
    if kind == SPHERE_KIND:
        P = np.empty((1, 3))
        P[0] = x
        return polytope(P, np.zeros(1, np.int64), bodies.radius[i])
    if kind == CAPSULE_KIND:
        P = np.empty((2, 3))
        h = bodies.half[i, 2]
        for c in range(3):
            P[0, c] = x[c] + h * R[c, 2]
            P[1, c] = x[c] - h * R[c, 2]
        return polytope(P, _indices(2), bodies.radius[i])
    if kind == BOX_KIND:
        local = np.empty((8, 3))
        h = bodies.half[i]
        for k in range(8):
            local[k, 0] = h[0] if k & 4 else -h[0]
            local[k, 1] = h[1] if k & 2 else -h[1]
            local[k, 2] = h[2] if k & 1 else -h[2]
        return polytope(_to_world(local, 8, x, R), _indices(8), 0.0)
    return polytope(_to_world(bodies.vertices[i], bodies.n_vertices[i], x, R), _indices(bodies.n_vertices[i]), 0.0)


@njit
def _indices(m):
    """0, 1, ..., m - 1 (written out: np.arange compiles longer)."""
    out = np.empty(m, np.int64)
    for k in range(m):
        out[k] = k
    return out


@njit
def _to_world(local, m, x, R):
    P = np.empty((m, 3))
    for k in range(m):
        for c in range(3):
            P[k, c] = x[c] + R[c, 0] * local[k, 0] + R[c, 1] * local[k, 1] + R[c, 2] * local[k, 2]
    return P


@njit
def _put_all(out, k, P, depths, ids, count, n, base):
    for t in range(count):
        for c in range(3):
            out.point[k + t, c] = P[t, c]
            out.n[k + t, c] = n[c]
        out.depth[k + t], out.feature[k + t] = depths[t], base + ids[t]


@njit(inline=True)
def convex_convex(bodies, a, b, margin, features, out, k) -> int:
    """Two convex bodies by GJK (EPA when they overlap) and clipping on their features."""
    P, depths, ids = np.empty((MANIFOLD, 3)), np.empty(MANIFOLD), np.empty(MANIFOLD, np.int64)
    count, n = manifold(convex_of(bodies, a), convex_of(bodies, b), margin, P, depths, ids)
    _put_all(out, k, P, depths, ids, count, n, 0)
    return count


@njit(inline=True)
def plane_convex(bodies, p, s, margin, features, out, k) -> int:
    """A convex body s on plane p: its feature along -n (its points within margin of its
    lowest), each at its own depth below the plane; the deepest four spanning the most area."""
    n = bodies.normal[p]
    C = convex_of(bodies, s)
    P, ids = np.empty((FEATURE_POINTS, 3)), np.empty(FEATURE_POINTS, np.int64)
    low = core_support(C, -n)
    lowest = low[0] * n[0] + low[1] * n[1] + low[2] * n[2] - C[3]
    if bodies.offset[p] - lowest < -margin:
        return 0
    m = feature(C, -n, margin, P, ids)
    depths = np.empty(m)
    for t in range(m):
        depths[t] = bodies.offset[p] - (P[t, 0] * n[0] + P[t, 1] * n[1] + P[t, 2] * n[2])
    keep, kept = reduce(P, depths, ids, m, n, MANIFOLD)
    count = 0
    for t in range(kept):
        j = keep[t]
        if depths[j] >= -margin:
            for c in range(3):
                out.point[k + count, c] = P[j, c] + 0.5 * depths[j] * n[c]
                out.n[k + count, c] = n[c]
            out.depth[k + count], out.feature[k + count] = depths[j], ids[j]
            count += 1
    return count


@njit(inline=True)
def mesh_convex(bodies, mesh, s, margin, features, out, k) -> int:
    """A convex body s against a static mesh: the triangles under its box (the tree),
    each a convex shape for GJK (normals from the triangle to s); all their points
    reduced to the four that span the most area."""
    C = convex_of(bodies, s)
    x, R = bodies.x[mesh], bodies.R[mesh]
    lo_w, hi_w = body_bounds(bodies, s)
    centre, extent = np.empty(3), np.empty(3)
    for c in range(3):  # the body's box, grown by margin, in the mesh's frame (a box around it)
        centre[c] = 0.5 * (lo_w[c] + hi_w[c]) - x[c]
        extent[c] = 0.5 * (hi_w[c] - lo_w[c]) + margin
    lo, hi = np.empty(3), np.empty(3)
    for c in range(3):
        mid = R[0, c] * centre[0] + R[1, c] * centre[1] + R[2, c] * centre[2]
        e = abs(R[0, c]) * extent[0] + abs(R[1, c]) * extent[1] + abs(R[2, c]) * extent[2]
        lo[c], hi[c] = mid - e, mid + e
    found = mesh_candidates(bodies.bvh[mesh], lo, hi)
    T = len(found)
    P, depths, ids = np.empty((MANIFOLD * T, 3)), np.empty(MANIFOLD * T), np.empty(MANIFOLD * T, np.int64)
    N = np.empty((MANIFOLD * T, 3))
    Pt, dt, it = np.empty((MANIFOLD, 3)), np.empty(MANIFOLD), np.empty(MANIFOLD, np.int64)
    total = 0
    corners = bodies.vertices[mesh]
    for t in range(T):
        tri = found[t]
        local = corners[3 * tri:3 * tri + 3]
        triangle = polytope(_to_world(local, 3, x, R), _indices(3), 0.0)
        count, n = manifold(triangle, C, margin, Pt, dt, it)
        for j in range(total, total + count):
            for c in range(3):
                P[j, c] = Pt[j - total, c]
            depths[j], ids[j] = dt[j - total], it[j - total] + tri * (1 << 32)
            for c in range(3):
                N[j, c] = n[c]
        total += count
    if total == 0:
        return 0
    keep, kept = reduce(P, depths, ids, total, N[0], MANIFOLD)
    for t in range(kept):
        j = keep[t]
        for c in range(3):
            out.point[k + t, c] = P[j, c]
            out.n[k + t, c] = N[j, c]
        out.depth[k + t], out.feature[k + t] = depths[j], ids[j]
    return kept


@njit
def body_bounds(bodies, i):
    """Axis-aligned box (lo, hi) of a convex body from its support along the world axes;
    of a mesh, the box around its tree's root box."""
    x = bodies.x[i]
    lo, hi = np.empty(3), np.empty(3)
    if bodies.shape[i] == MESH_KIND:
        root, R = bodies.bvh[i, 0], bodies.R[i]
        for c in range(3):
            mid, e = x[c], 0.0
            for j in range(3):
                mid += R[c, j] * 0.5 * (root[j] + root[3 + j])
                e += abs(R[c, j]) * 0.5 * (root[3 + j] - root[j])
            lo[c], hi[c] = mid - e, mid + e
        return lo, hi
    C = convex_of(bodies, i)
    for c in range(3):
        d = np.zeros(3)
        d[c] = 1.0
        hi[c] = core_support(C, d)[c] + C[3]
        d[c] = -1.0
        lo[c] = core_support(C, d)[c] - C[3]
    return lo, hi
