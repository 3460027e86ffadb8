"""How deep two bodies of a scene start inside each other, for scene validation only.

Exact for every shape pair of the vocabulary: sphere and plane by distance, boxes by the
separating axis test (15 axes in 3D). 2D shapes are measured as their 3D counterparts in
the x-z plane (a circle as a sphere, a rect as a box that is deep along y).
"""
from __future__ import annotations

import numpy as np

from cases.scene import Body, Box, Circle, Plane, Rect, Sphere

_DEEP = 1e6  # y half-extent of a rect seen as a box: never the axis of least overlap


def rotation_matrix(q) -> np.ndarray:
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def _as_3d(shape):
    if isinstance(shape, Circle):
        return Sphere(shape.radius)
    if isinstance(shape, Rect):
        return Box((shape.half_extents[0], _DEEP, shape.half_extents[1]))
    return shape


def penetration(a: Body, b: Body) -> float:
    """Depth (m) by which a and b overlap; 0 when they are apart or touching."""
    sa, sb = _as_3d(a.shape), _as_3d(b.shape)
    if isinstance(sb, Plane) or (isinstance(sb, Sphere) and isinstance(sa, Box)):
        a, b, sa, sb = b, a, sb, sa
    pa, pb = np.asarray(a.position, float), np.asarray(b.position, float)
    if isinstance(sa, Plane):
        if isinstance(sb, Plane):
            return 0.0
        n = np.asarray(sa.normal, float)
        if isinstance(sb, Sphere):
            lowest = n @ pb - sb.radius
        else:
            R = rotation_matrix(b.orientation)
            lowest = n @ pb - np.abs(R.T @ n) @ np.asarray(sb.half_extents, float)
        return max(0.0, sa.offset - lowest)
    if isinstance(sa, Sphere) and isinstance(sb, Sphere):
        return max(0.0, sa.radius + sb.radius - float(np.linalg.norm(pa - pb)))
    if isinstance(sa, Sphere):  # sphere a against box b
        R = rotation_matrix(b.orientation)
        h = np.asarray(sb.half_extents, float)
        local = R.T @ (pa - pb)
        closest = np.clip(local, -h, h)
        if np.any(closest != local):
            return max(0.0, sa.radius - float(np.linalg.norm(local - closest)))
        return sa.radius + float(np.min(h - np.abs(local)))  # centre inside the box
    return _box_box(pa, rotation_matrix(a.orientation), np.asarray(sa.half_extents, float),
                    pb, rotation_matrix(b.orientation), np.asarray(sb.half_extents, float))


def _box_box(pa, Ra, ha, pb, Rb, hb) -> float:
    """Least overlap over the 15 separating axes; 0 if any axis separates."""
    d = pb - pa
    axes = [Ra[:, i] for i in range(3)] + [Rb[:, i] for i in range(3)]
    axes += [np.cross(Ra[:, i], Rb[:, j]) for i in range(3) for j in range(3)]
    least = np.inf
    for axis in axes:
        length = np.linalg.norm(axis)
        if length < 1e-9:  # parallel edges: covered by the face axes
            continue
        u = axis / length
        ra = np.abs(Ra.T @ u) @ ha
        rb = np.abs(Rb.T @ u) @ hb
        least = min(least, ra + rb - abs(d @ u))
        if least <= 0:
            return 0.0
    return float(least)
