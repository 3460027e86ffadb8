"""Solids an engine can take, made from scene shapes it has no native kind for.

- A 2D `Polygon` in a 3D engine: the prism of its corners extruded along y (as a `Rect`
  becomes a box), with its faces for engines that take triangles, `polygon_prism`; as deep
  as the adapter makes a rect (`embedded_half_depth` where that is its larger half-extent).
- A `Cylinder` in an engine with no cylinder of its own: the regular prism inscribed in it,
  `cylinder_prism`.
- A static `Mesh` in an engine that collides with convex solids only (MuJoCo takes a mesh
  geom's convex hull, Drake's point contact a Mesh's): one convex prism per triangle, the
  triangle and its copy moved against its outward normal into the solid,
  `triangle_prisms`. Their union has the mesh's surface on the side the bodies are on (the
  triangles' normals), whatever the mesh's shape, where its convex hull would fill every
  hollow. Each prism is as deep as the solid behind its triangle (`depth` at most): the
  distance along -n from each corner to the mesh's far side, the least of the three, which
  for a convex closed mesh keeps every prism inside the solid (a convex solid's thickness
  along a direction is a concave function over a face, least at a corner). An open mesh
  (a ground) has no far side: its prisms are `depth` deep. Bodies meet the prisms' side
  faces only where they cross a seam between triangles deeper than they overlap the top
  (the internal-edge contacts every triangle-mesh collider has).
"""
from __future__ import annotations

import math

import numpy as np

# How deep a triangle's prism reaches behind an open mesh (a ground): more than twice what a
# compliant contact sinks into it (MuJoCo's and Drake's, ~ v n dt / pi: 23 mm at 4.4 m/s and
# 16 steps), so a body sunk into a prism leaves it by its top, the triangle, not its bottom.
PRISM_DEPTH = 0.1  # m

# A ray from a corner that meets a triangle nearer than this fraction of the mesh's size, or
# runs along it (|n . d| below it), is at the corner's own edge or face, not the far side.
_GRAZE = 1e-9


def embedded_half_depth(corners) -> float:
    """Half the depth along y of a 2D polygon's prism: its largest |x| or |z| (a square of
    half side a: a, as a 3D engine makes a Rect a box as deep as its larger half-extent).
    The depth only spreads the contact points, symmetrically about y = 0."""
    return float(np.abs(np.asarray(corners, dtype=float)).max())


def width_half_depth(corners) -> float:
    """Half the depth along y of a 2D polygon's prism as deep as it is wide (its extent along
    x), as a Rect's box is as deep as it is wide: the MuJoCo, Drake and Newton adapters' rule."""
    return float(np.ptp(np.asarray(corners, dtype=float)[:, 0])) / 2.0


def cylinder_prism(radius: float, half_length: float, sides: int) -> np.ndarray:
    """The corners (2 sides, 3) of the regular prism inscribed in a cylinder along z: each
    end's corners on its rim at angles 2 pi k / sides from +x, the end at z = -half_length
    first. Its flat sides lie radius cos(pi / sides) from the axis (the apothem)."""
    angle = 2.0 * math.pi * np.arange(sides) / sides
    rim = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    out = np.empty((2 * sides, 3))
    out[:, :2] = np.tile(rim, (2, 1))
    out[:, 2] = np.repeat([-half_length, half_length], sides)
    return out


def polygon_prism(corners_xz, half_depth: float) -> tuple[np.ndarray, np.ndarray]:
    """The prism of a convex polygon given by its corners (x, z) in order, counterclockwise
    from +x towards +z (cases.scene.Polygon.corners), extruded from y = -half_depth to
    +half_depth: its corners (2n, 3), those at -half_depth first, and its faces as triangles
    (4n - 4, 3) wound outward (two fans for the ends, two triangles a side)."""
    c = np.asarray(corners_xz, dtype=float)
    n = len(c)
    points = np.empty((2 * n, 3))
    points[:n, 0] = points[n:, 0] = c[:, 0]
    points[:n, 2] = points[n:, 2] = c[:, 1]
    points[:n, 1], points[n:, 1] = -half_depth, half_depth
    ends = [(0, i, i + 1) for i in range(1, n - 1)] + [(n, n + i + 1, n + i) for i in range(1, n - 1)]
    sides = []
    for i in range(n):
        j = (i + 1) % n
        sides += [(i, n + i, n + j), (i, n + j, j)]
    return points, np.array(ends + sides, dtype=int)


def triangle_normals(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Outward unit normals (T, 3) of counterclockwise-wound triangles (right-hand rule)."""
    a, b, c = points[triangles[:, 0]], points[triangles[:, 1]], points[triangles[:, 2]]
    n = np.cross(b - a, c - a)
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _far_side(points: np.ndarray, triangles: np.ndarray, normals: np.ndarray, i: int) -> float:
    """The least distance along -n_i from a corner of triangle i to a triangle of the mesh
    that does not hold that corner (Moller-Trumbore), inf if none is met."""
    a, b, c = points[triangles[:, 0]], points[triangles[:, 1]], points[triangles[:, 2]]
    e1, e2 = b - a, c - a
    d = -normals[i]
    size = float(np.ptp(points, axis=0).max())
    scale = np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)  # det's size for a ray across the face
    best = np.inf
    for corner in triangles[i]:
        o = points[corner]
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = (np.abs(det) > _GRAZE * scale) & np.all(triangles != corner, axis=1)
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - a
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        hit = ok & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t > _GRAZE * size)
        if hit.any():
            best = min(best, float(t[hit].min()))
    return best


def triangle_prisms(vertices, triangles, depth: float = PRISM_DEPTH) -> tuple[list[np.ndarray], list[float]]:
    """Each triangle of a static mesh (body frame) as a convex prism: its corners a, b, c
    and a - t n, b - t n, c - t n (n its outward normal), t the solid's thickness behind it
    (`_far_side`) or `depth`, whichever is less. Returns the prisms' corners (6, 3) and
    their depths t."""
    points = np.asarray(vertices, dtype=float)
    tri = np.asarray(triangles, dtype=int)
    normals = triangle_normals(points, tri)
    prisms, depths = [], []
    for i, (t, n) in enumerate(zip(tri, normals)):
        t_i = min(depth, _far_side(points, tri, normals, i))
        front = points[t]
        prisms.append(np.vstack([front, front - t_i * n]))
        depths.append(t_i)
    return prisms, depths


def inscribed_radius(shape) -> float:
    """The radius of the largest ball about the body's origin inside `shape` (a scene shape):
    a sphere's, disc's or capsule's radius, a box's or rect's smallest half-extent, a
    cylinder's radius or half-length, whichever is smaller, a hull's or polygon's distance
    to its nearest face or edge (hulls and polygons are centred); 0 for a plane or mesh."""
    kind = shape.kind
    if kind in ("sphere", "circle", "capsule"):
        return float(shape.radius)
    if kind in ("box", "rect"):
        return float(min(shape.half_extents))
    if kind == "cylinder":
        return float(min(shape.radius, shape.half_length))
    if kind == "hull":
        v = np.asarray(shape.vertices, dtype=float)
        a, b, c = (v[shape.faces[:, k]] for k in range(3))
        n = np.cross(b - a, c - a)
        return float(np.min(np.abs(np.einsum("ij,ij->i", n, a)) / np.linalg.norm(n, axis=1)))
    if kind == "polygon":
        v = np.asarray(shape.corners, dtype=float)
        a, d = v, np.roll(v, -1, axis=0) - v
        return float(np.min(np.abs(a[:, 0] * d[:, 1] - a[:, 1] * d[:, 0]) / np.linalg.norm(d, axis=1)))
    return 0.0


def starts_fast(body, dt: float) -> bool:
    """Whether a dynamic body starts out moving further in a step of `dt` than its inscribed
    radius: a body that can pass through a thing as thick as itself between two steps, the
    one a user marks for continuous collision (Box2D's bullets, Rapier's CCD)."""
    return body.dynamic and float(np.linalg.norm(body.velocity)) * dt > inscribed_radius(body.shape)
