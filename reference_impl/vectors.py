"""3-vectors and 3x3 matrices, on tuples or numpy rows alike (compiled: compiled.py).

A matrix is indexed M[i][j] (row i), a quaternion is (w, x, y, z). Each sum is written out
left to right, so compiled and plain Python round alike.
"""
from __future__ import annotations

from reference_impl.compiled import njit


@njit
def dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit
def cross(a, b) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit
def mat_vec(M, a) -> tuple[float, float, float]:
    return (dot(M[0], a), dot(M[1], a), dot(M[2], a))


@njit
def rotation_matrix(q) -> tuple:
    """R(q) for a unit quaternion (w, x, y, z); its columns are the body axes in the world."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return ((1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)),
            (2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)),
            (2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)))


@njit
def similarity(R, d) -> tuple:
    """R diag(d) R^T."""
    return ((_similar(R, d, 0, 0), _similar(R, d, 0, 1), _similar(R, d, 0, 2)),
            (_similar(R, d, 1, 0), _similar(R, d, 1, 1), _similar(R, d, 1, 2)),
            (_similar(R, d, 2, 0), _similar(R, d, 2, 1), _similar(R, d, 2, 2)))


@njit
def _similar(R, d, i, j) -> float:
    """Entry (i, j) of R diag(d) R^T."""
    return R[i][0] * d[0] * R[j][0] + R[i][1] * d[1] * R[j][1] + R[i][2] * d[2] * R[j][2]


@njit
def copy(dst, src) -> None:
    """dst[:] = src for 1-D arrays, element by element (a slice assignment compiles numba's
    shape checks and their messages, seconds each)."""
    for k in range(len(src)):
        dst[k] = src[k]
