"""How deep two bodies overlap: scene validation (bodies that start inside each other)
and the robustness readings (cases.observables.deepest_overlap).

Exact for every shape pair of the vocabulary: sphere and plane by distance, boxes by the
separating axis test (15 axes in 3D). 2D shapes are measured as their 3D counterparts in
the x-z plane (a circle as a sphere, a rect as a box that is deep along y). Shapes are read
by their `kind` and sizes, so this module imports nothing from cases.scene (which uses it).
"""
from __future__ import annotations

import numpy as np

_DEEP = 1e6  # y half-extent of a rect seen as a box: never the axis of least overlap


def rotation_matrix(q) -> np.ndarray:
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def _as_3d(shape) -> tuple[str, object]:
    """The shape as a 3D solid: ("sphere", radius), ("box", half extents) or ("plane",
    (normal, offset)); a circle is a sphere, a rect a box deep along y."""
    if shape.kind in ("sphere", "circle"):
        return "sphere", shape.radius
    if shape.kind == "rect":
        a, c = shape.half_extents
        return "box", np.array((a, _DEEP, c))
    if shape.kind == "box":
        return "box", np.asarray(shape.half_extents, float)
    return "plane", (np.asarray(shape.normal, float), shape.offset)


def penetration(a, b) -> float:
    """Depth (m) by which bodies a and b (cases.scene.Body) overlap; 0 when they are apart
    or touching."""
    (ka, sa), (kb, sb) = _as_3d(a.shape), _as_3d(b.shape)
    if kb == "plane" or (kb == "sphere" and ka == "box"):
        a, b, ka, kb, sa, sb = b, a, kb, ka, sb, sa
    pa, pb = np.asarray(a.position, float), np.asarray(b.position, float)
    if ka == "plane":
        if kb == "plane":
            return 0.0
        n, offset = sa
        if kb == "sphere":
            lowest = n @ pb - sb
        else:
            R = rotation_matrix(b.orientation)
            lowest = n @ pb - np.abs(R.T @ n) @ sb
        return max(0.0, offset - lowest)
    if ka == "sphere" and kb == "sphere":
        return max(0.0, sa + sb - float(np.linalg.norm(pa - pb)))
    if ka == "sphere":  # sphere a against box b
        R = rotation_matrix(b.orientation)
        local = R.T @ (pa - pb)
        closest = np.clip(local, -sb, sb)
        if np.any(closest != local):
            return max(0.0, sa - float(np.linalg.norm(local - closest)))
        return sa + float(np.min(sb - np.abs(local)))  # centre inside the box
    return _box_box(pa, rotation_matrix(a.orientation), sa, pb, rotation_matrix(b.orientation), sb)


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
