"""How deep two bodies overlap: scene validation (bodies that start inside each other)
and the robustness readings (cases.observables.deepest_overlap).

Each shape is a convex solid in world coordinates with a support function
h(u) = max over the solid of u . x (a Mesh is a set of them: its triangles). Two convex solids
A and B reach past each other along a unit direction u by o(u) = h_A(u) + h_B(-u), and the
least o over all directions is their depth when they overlap, minus their distance when
they are apart (the separating-axis theorem in support-function form). Every direction
gives an upper bound; the depth is taken as the least o over candidate directions made from
the two shapes' features, which contain the minimiser for these pairs:

- a plane against any shape: the depth of the shape's lowest point below it (exact);
- polytopes (box, hull, rect, polygon, a mesh's triangles) and balls swept over a point or
  a segment (sphere, circle, capsule) against each other: the face normals of each, the
  cross products of their edges (the separating-axis test's set for polytopes) and, where
  a swept radius makes the closest features decide, the directions between their corners
  and from their edges to corners: exact;
- a cylinder against a sphere: the direction from the cylinder's closest point (exact);
- a cylinder against a capsule, cylinder, box, hull or triangle: a rim meets an edge or a
  rim along a direction with no closed form, so the candidates (face and cap normals,
  crosses of the axis with the edges, directions from the axis and the rims to corners) are
  refined by a local search over directions. The result is an upper bound on the depth (no
  scene passes the start check deeper than allowed), tight to the search's tolerance;
  `exact(kind_a, kind_b)` says which pairs are measured exactly.

A Mesh is measured triangle by triangle, each a thin convex solid: its depth is the deepest
overlap with any one triangle. A body sunk across a shared edge may free itself from each
triangle alone by a shorter move than from the surface, and a body wholly inside a closed
mesh touches no triangle and reads 0. 2D shapes (circle, rect, polygon) are measured in the
x-z plane. Shapes are read by their `kind` and fields, so this module imports nothing from
cases.scene (which uses it).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

PLANAR = ("circle", "rect", "polygon")  # measured in the x-z plane
_BOX_EDGES = np.array([(i, i ^ b) for i in range(8) for b in (1, 2, 4) if i < i ^ b])  # corners by bits x, y, z
_PARALLEL = 1e-9  # |u x v| of unit edge directions below this: parallel (their faces cover them)
_COINCIDENT = 1e-12  # a difference of points below this fraction of the pair's size: no direction
_CHUNK = 100_000  # directions evaluated at once (two fine hulls have millions of edge pairs)


def rotation_matrix(q) -> np.ndarray:
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def reach(shape) -> float:
    """Radius (m) of a ball about the body's position that holds the shape (inf for a
    plane): bodies farther apart than their reaches cannot touch."""
    kind = shape.kind
    if kind in ("sphere", "circle"):
        return float(shape.radius)
    if kind in ("box", "rect"):
        return float(np.linalg.norm(shape.half_extents))
    if kind == "capsule":
        return float(shape.radius + shape.half_length)
    if kind == "cylinder":
        return math.hypot(shape.radius, shape.half_length)
    if kind in ("hull", "polygon", "mesh"):
        return float(np.linalg.norm(np.asarray(shape.vertices, dtype=float), axis=1).max())
    return math.inf


def may_touch(pairs) -> np.ndarray:
    """For each pair of bodies (cases.scene.Body), False where their reaches prove them
    apart (centres farther apart than the sum of their reaches), True otherwise: the pairs
    worth measuring with `penetration`."""
    reaches: dict[int, float] = {}
    for a, b in pairs:
        for body in (a, b):
            if id(body.shape) not in reaches:
                reaches[id(body.shape)] = reach(body.shape)
    if not pairs:
        return np.zeros(0, dtype=bool)
    bound = np.array([reaches[id(a.shape)] + reaches[id(b.shape)] for a, b in pairs])
    gap = np.array([np.subtract(a.position, b.position) for a, b in pairs], dtype=float)
    return ~(np.linalg.norm(gap, axis=1) > bound)


def exact(kind_a: str, kind_b: str) -> bool:
    """True when `penetration` measures a pair of these shape kinds exactly (to rounding);
    False where it gives an upper bound from a local search (a cylinder against a capsule,
    cylinder, box, hull or mesh)."""
    kinds = {kind_a, kind_b}
    return "cylinder" not in kinds or bool(kinds & {"plane", "sphere"})


def penetration(a, b) -> float:
    """Depth (m) by which bodies a and b (cases.scene.Body) overlap; 0 when they are apart
    or touching. Exact or an upper bound as `exact` says."""
    ka, kb = a.shape.kind, b.shape.kind
    if kb == "plane":
        a, b, ka, kb = b, a, kb, ka
    if ka == "plane":
        return 0.0 if kb == "plane" else max(0.0, _below_plane(a, b))
    if ka == "mesh":
        a, b, ka, kb = b, a, kb, ka
    dim = 2 if ka in PLANAR and kb in PLANAR else 3
    deepest = -math.inf
    for sa in _solids(a, dim):
        for sb in _solids(b, dim, near=sa):
            deepest = max(deepest, _signed(sa, sb, refine=not exact(ka, kb)))
    return max(0.0, deepest)


# --- convex solids in world coordinates ----------------------------------------------------

@dataclass
class _Convex:
    """The solid core + ball(radius) in world coordinates (d = 2 or 3), the core a polytope
    given by its corners (a point, a segment, a triangle, a box...); or a cylinder."""
    points: np.ndarray                 # (k, d) the core's corners (a cylinder: its centre)
    radius: float = 0.0                # the ball swept over the core
    normals: np.ndarray | None = None  # (f, d) the core's face normals (unit; either sign)
    edges: np.ndarray | None = None    # (e, 2) index pairs into points: the core's edges
    directions: np.ndarray | None = None  # (g, 3) unit directions of the edges (3D)
    cylinder: tuple | None = None      # (centre, axis, radius, half_length)
    centre: np.ndarray = field(init=False)
    size: float = field(init=False)

    def __post_init__(self):
        d = self.points.shape[1]
        self.normals = np.zeros((0, d)) if self.normals is None else self.normals
        self.edges = np.zeros((0, 2), dtype=int) if self.edges is None else self.edges
        self.directions = np.zeros((0, d)) if self.directions is None else self.directions
        self.centre = self.points.mean(axis=0)
        spread = float(np.linalg.norm(self.points - self.centre, axis=1).max())
        self.size = spread + self.radius + (math.hypot(*self.cylinder[2:]) if self.cylinder else 0.0)

    def support(self, u: np.ndarray) -> np.ndarray:
        """h(u) = max of u . x over the solid, for unit rows u (n, d)."""
        if self.cylinder is not None:
            c, axis, r, h = self.cylinder
            along = u @ axis
            across = np.linalg.norm(u - np.outer(along, axis), axis=1)  # not sqrt(1 - along^2): exact near the axis
            return u @ c + r * across + h * np.abs(along)
        return (u @ self.points.T).max(axis=1) + self.radius


def _unit(v: np.ndarray, least: float) -> np.ndarray:
    """The rows of v longer than `least`, scaled to unit length."""
    n = np.linalg.norm(v, axis=1)
    keep = n > least
    return v[keep] / n[keep, None]


def _across(d: np.ndarray) -> np.ndarray:
    """Two unit vectors perpendicular to each unit row of d (3D)."""
    helper = np.where(np.abs(d[:, :1]) < 0.6, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    e1 = _unit(np.cross(d, helper), 0.0)
    return np.vstack([e1, np.cross(d, e1)])


def _polytope(points: np.ndarray, triangles: np.ndarray) -> _Convex:
    """A 3D convex polytope from its corners and its outward face triangles."""
    a, b, c = points[triangles[:, 0]], points[triangles[:, 1]], points[triangles[:, 2]]
    edges = np.unique(np.sort(np.vstack([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]),
                              axis=1), axis=0)
    return _Convex(points, normals=_unit(np.cross(b - a, c - a), 0.0), edges=edges,
                   directions=_unit(points[edges[:, 1]] - points[edges[:, 0]], 0.0))


def _solids(body, dim: int, near: _Convex | None = None) -> list[_Convex]:
    """The body's shape as convex solids in world coordinates, in the x-z plane (dim 2) or
    in space (dim 3: a rect or polygon as a flat one in its body's x-z plane). A mesh gives
    its triangles, only those whose bounding balls meet `near`'s if it is given."""
    s, kind = body.shape, body.shape.kind
    p = np.asarray(body.position, dtype=float)
    R = rotation_matrix(body.orientation)
    if kind in PLANAR and dim == 2:
        R2, p2 = R[np.ix_([0, 2], [0, 2])], p[[0, 2]]
        if kind == "circle":
            return [_Convex(p2[None], radius=float(s.radius))]
        if kind == "rect":
            a, c = s.half_extents
            local = np.array([(-a, -c), (a, -c), (a, c), (-a, c)], dtype=float)
        else:
            local = s.corners  # in order around the polygon
        corners = p2 + local @ R2.T
        sides = np.roll(corners, -1, axis=0) - corners
        return [_Convex(corners, normals=_unit(np.column_stack([sides[:, 1], -sides[:, 0]]), 0.0),
                        edges=np.column_stack([np.arange(len(corners)), np.roll(np.arange(len(corners)), -1)]))]
    if kind in ("sphere", "circle"):
        return [_Convex(p[None], radius=float(s.radius))]
    if kind == "capsule":
        half = R[:, 2] * s.half_length
        return [_Convex(np.array([p - half, p + half]), radius=float(s.radius), edges=np.array([[0, 1]]),
                        directions=R[:, 2][None])]
    if kind == "cylinder":
        return [_Convex(p[None], normals=R[:, 2][None], directions=R[:, 2][None],
                        cylinder=(p, R[:, 2], float(s.radius), float(s.half_length)))]
    if kind in ("box", "rect"):
        h = np.array(s.half_extents, dtype=float) if kind == "box" else \
            np.array((s.half_extents[0], 0.0, s.half_extents[1]))
        signs = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
        corners = p + (signs * h) @ R.T
        return [_Convex(corners, normals=R.T.copy(), edges=_BOX_EDGES, directions=R.T.copy())]
    if kind == "polygon":  # a flat polygon in the body's x-z plane (a 2D shape in a 3D pair)
        local = np.asarray(s.vertices, dtype=float)
        corners = p + np.column_stack([local[:, 0], np.zeros(len(local)), local[:, 1]]) @ R.T
        n = len(corners)
        edges = np.column_stack([np.arange(n), np.roll(np.arange(n), -1)])
        return [_Convex(corners, normals=R[:, 1][None], edges=edges,
                        directions=_unit(corners[edges[:, 1]] - corners[edges[:, 0]], 0.0))]
    if kind == "hull":
        return [_polytope(p + np.asarray(s.vertices, dtype=float) @ R.T, s.faces)]
    if kind == "mesh":
        tri = np.asarray(s.triangles, dtype=int)
        corners = (p + np.asarray(s.vertices, dtype=float) @ R.T)[tri]  # (triangles, 3, 3)
        if near is not None:
            centres = corners.mean(axis=1)
            sizes = np.linalg.norm(corners - centres[:, None], axis=2).max(axis=1)
            corners = corners[~(np.linalg.norm(centres - near.centre, axis=1) > sizes + near.size)]
        return [_polytope(c, np.array([[0, 1, 2]])) for c in corners]
    raise ValueError(f"shape kind {kind!r}: cases.overlap does not know it")


# --- the least overlap over candidate directions -------------------------------------------

def _signed(A: _Convex, B: _Convex, refine: bool) -> float:
    """min over directions u of o(u) = h_A(u) + h_B(-u): the depth (> 0) or minus the
    distance (< 0), over the candidates of the pair (and a local search if `refine`)."""
    best, starts = math.inf, []
    for u in _candidates(A, B):
        for chunk in range(0, len(u), _CHUNK):
            v = np.vstack([u[chunk:chunk + _CHUNK], -u[chunk:chunk + _CHUNK]])
            o = A.support(v) + B.support(-v)
            k = int(np.argmin(o))
            best = min(best, float(o[k]))
            starts.append((float(o[k]), v[k]))
    if refine and best > 0:
        best = min(best, _search(A, B, [u for _, u in sorted(starts, key=lambda s: s[0])[:3]]))
    return best


def _candidates(A: _Convex, B: _Convex):
    """Candidate directions for the pair's least overlap, in groups of unit rows (each
    taken with both signs)."""
    d = A.points.shape[1]
    size = A.size + B.size
    yield np.vstack([A.normals, B.normals, np.eye(d), _unit((B.centre - A.centre)[None], _COINCIDENT * size)])
    if d == 3:
        yield _across(np.vstack([A.directions, B.directions]))
        for k in range(0, len(A.directions), max(1, _CHUNK // max(1, len(B.directions)))):
            part = A.directions[k:k + max(1, _CHUNK // max(1, len(B.directions)))]
            yield _unit(np.cross(part[:, None], B.directions[None]).reshape(-1, 3), _PARALLEL)
    if A.radius or B.radius or A.cylinder or B.cylinder:  # the closest features decide
        yield _unit((A.points[:, None] - B.points[None]).reshape(-1, d), _COINCIDENT * size)
        yield _from_edges(A, B.points, size)
        yield _from_edges(B, A.points, size)
    for C, other in ((A, B), (B, A)):
        if C.cylinder is not None:
            yield _from_cylinder(C.cylinder, other, size)


def _from_edges(C: _Convex, points: np.ndarray, size: float) -> np.ndarray:
    """Directions from the lines of C's edges to the points, perpendicular to the edges."""
    if not len(C.edges):
        return np.zeros((0, points.shape[1]))
    x0, x1 = C.points[C.edges[:, 0]], C.points[C.edges[:, 1]]
    e = x1 - x0
    w = points[None] - x0[:, None]  # (edges, points, d)
    t = np.einsum("epd,ed->ep", w, e) / np.einsum("ed,ed->e", e, e)[:, None]
    return _unit((w - t[..., None] * e[:, None]).reshape(-1, points.shape[1]), _COINCIDENT * size)


def _from_cylinder(cylinder, other: _Convex, size: float) -> np.ndarray:
    """Directions from a cylinder to the other solid's corners (and centre): from its axis
    (the side) and from the nearest point of each rim."""
    c, axis, r, h = cylinder
    points = np.vstack([other.points, other.centre[None]])
    w = points - c
    radial = w - np.outer(w @ axis, axis)
    out = [_unit(radial, _COINCIDENT * size)]
    n = np.linalg.norm(radial, axis=1)
    off_axis = n > _COINCIDENT * size
    rim_dir = radial[off_axis] / n[off_axis, None]
    for end in (-h, h):
        out.append(_unit(points[off_axis] - (c + end * axis + r * rim_dir), _COINCIDENT * size))
    return np.vstack(out)


def _search(A: _Convex, B: _Convex, starts: np.ndarray) -> float:
    """The least o(u) found by a local search (Nelder-Mead over the tangent plane) from each
    start direction: an upper bound on the true least."""
    from scipy.optimize import minimize

    def o(u):
        return float((A.support(u[None]) + B.support(-u[None]))[0])

    best = math.inf
    for u0 in starts:
        t1, t2 = _across(u0[None])
        f = lambda s: o((u0 + s[0] * t1 + s[1] * t2) / math.sqrt(1.0 + s @ s))  # noqa: E731
        res = minimize(f, np.zeros(2), method="Nelder-Mead",
                       options={"initial_simplex": [[0, 0], [0.05, 0], [0, 0.05]], "xatol": 1e-12,
                                "fatol": 1e-15 * (A.size + B.size), "maxiter": 2000})
        best = min(best, float(res.fun), o(u0))
    return best


def _below_plane(plane, body) -> float:
    """How far the body reaches below the plane n . x = offset (negative: its gap above)."""
    n = np.asarray(plane.shape.normal, dtype=float)
    offset = plane.shape.offset
    if body.shape.kind in ("sphere", "circle"):
        return float(offset - n @ np.asarray(body.position, dtype=float) + body.shape.radius)
    if body.shape.kind == "box":  # the common case, without its corners: |R^T n| . h below the centre
        R = rotation_matrix(body.orientation)
        reach_down = np.abs(R.T @ n) @ np.asarray(body.shape.half_extents, dtype=float)
        return float(offset - n @ np.asarray(body.position, dtype=float) + reach_down)
    if body.shape.kind == "mesh":
        R = rotation_matrix(body.orientation)
        world = np.asarray(body.position, dtype=float) + np.asarray(body.shape.vertices, dtype=float) @ R.T
        return float(offset - (world @ n).min())
    (solid,) = _solids(body, 3)
    return float(offset + solid.support(-n[None])[0])
