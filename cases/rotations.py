"""Quaternions (w, x, y, z) as the scenes, the observables and the adapters use them: the
Hamilton product, the conjugate and the turn of a vector, each on one quaternion or on
arrays of them (the last axis holds the four numbers; numpy broadcasts the rest)."""
from __future__ import annotations

import numpy as np


def multiply(p, q) -> np.ndarray:
    """The Hamilton product p q (the turn q, then p) of (..., 4) arrays."""
    w1, x1, y1, z1 = np.moveaxis(np.asarray(p, float), -1, 0)
    w2, x2, y2, z2 = np.moveaxis(np.asarray(q, float), -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)


def conjugate(q) -> np.ndarray:
    """The conjugate (w, -x, -y, -z) of a quaternion (w, x, y, z), or of each row of an
    (n, 4) array: for a unit quaternion its inverse, the turn from the world into the frame
    that q turns into the world."""
    return np.asarray(q, float) * [1.0, -1.0, -1.0, -1.0]


def rotate(q, v) -> np.ndarray:
    """Vectors v (..., 3) turned by unit quaternions q (..., 4): v + w t + u x t with
    t = 2 u x v (u the vector part)."""
    q = np.asarray(q, float)
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)
