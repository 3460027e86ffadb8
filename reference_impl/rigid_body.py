"""A rigid body's state and its step (symplectic Euler for the centre of mass, the
implicit midpoint rule for the free rotation).

State (note 001, "multiple contacts", equations of motion): position x, orientation q
(unit quaternion w, x, y, z, body to world), linear velocity v, angular velocity w (world
frame). Mass and principal inertia I_0 (body frame); world inverse inertia
I^-1 = R I_0^-1 R^T.

The world keeps its bodies as arrays, one row a body (`Bodies`, the struct of arrays that
compiled code steps); a `RigidBody` is its row seen from Python: `body.x`, `body.v`, ...
are views of that row, so what a step writes the body shows, and what is written into
them the next step uses. A body not (yet) in a world has a one-row `Bodies` of its own.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from reference_impl import geometry
from reference_impl.compiled import njit, structure
from reference_impl.vectors import cross, dot, mat_vec, rotation_matrix, similarity  # noqa: F401 (re-exported)


class BodyArrays(NamedTuple):
    """N bodies, row i the body of index i: the arrays Python holds (a RigidBody's state
    is a view of its row); `Bodies(*arrays)` is the same arrays for compiled code."""
    shape: np.ndarray            # (N,) int: geometry's shape kind (geometry.SPHERE, ...)
    radius: np.ndarray           # (N,) a sphere's or circle's radius
    half: np.ndarray             # (N, 3) a box's half extents, a rect's (h_x, 0, h_z)
    normal: np.ndarray           # (N, 3) a plane's unit normal (the half-space n . x <= offset)
    offset: np.ndarray           # (N,)
    bounding_radius: np.ndarray  # (N,) largest distance of a point of the shape from x
    static: np.ndarray           # (N,) bool: 1/m = 0 and I^-1 = 0, never moves
    can_rotate: np.ndarray       # (N,) bool: False keeps q, and I^-1 = 0
    planar: np.ndarray           # (N,) bool: lives in the x-z plane, turns about y only
    inv_mass: np.ndarray         # (N,) 1/m
    inertia: np.ndarray          # (N, 3) principal, body frame
    x: np.ndarray                # (N, 3)
    q: np.ndarray                # (N, 4)
    v: np.ndarray                # (N, 3)
    w: np.ndarray                # (N, 3)
    vp: np.ndarray               # (N, 3) pseudo-velocities: position correction, not kept
    wp: np.ndarray               # (N, 3)
    v0: np.ndarray               # (N, 3) velocities before this step's external forces
    w0: np.ndarray               # (N, 3)
    R: np.ndarray                # (N, 3, 3) rotation matrix of q
    inv_I: np.ndarray            # (N, 3, 3) world inverse inertia
    vertices: np.ndarray         # (N, V, 3) a hull's corners, a mesh's triangles (geometry.shape_arrays), padded
    n_vertices: np.ndarray       # (N,) int: the rows of `vertices` in use
    bvh: np.ndarray              # (N, K, 8) a mesh's tree (gjk.build_bvh), padded


Bodies = structure(BodyArrays, "Bodies")


@njit
def new_bodies(arrays: BodyArrays) -> Bodies:
    """Bodies holding `arrays` (the same arrays: what compiled code writes, they show)."""
    return Bodies(*arrays)


def stack(bodies: list[RigidBody]) -> BodyArrays:
    """The bodies' rows, copied into one `BodyArrays` in list order."""
    if not bodies:
        return _empty(0)
    return BodyArrays(*(_padded([getattr(b._arrays, f)[b._row:b._row + 1] for b in bodies])
                        for f in BodyArrays._fields))


def _padded(rows: list[np.ndarray]) -> np.ndarray:
    """The rows concatenated, each padded with zeros to the longest along axis 1 when
    they differ there (the shapes' vertices and trees)."""
    if rows[0].ndim >= 3 and len({r.shape[1] for r in rows}) > 1:
        longest = max(r.shape[1] for r in rows)
        rows = [np.pad(r, [(0, 0), (0, longest - r.shape[1])] + [(0, 0)] * (r.ndim - 2)) for r in rows]
    return np.concatenate(rows)


def _empty(n: int, V: int = 0, K: int = 0) -> BodyArrays:
    return BodyArrays(np.zeros(n, np.int64), np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n), np.zeros(n),
                  np.zeros(n, np.bool_), np.zeros(n, np.bool_), np.zeros(n, np.bool_), np.zeros(n),
                  np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 4)), np.zeros((n, 3)), np.zeros((n, 3)),
                  np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3, 3)),
                  np.zeros((n, 3, 3)), np.zeros((n, V, 3)), np.zeros(n, np.int64), np.zeros((n, K, 8)))


# --- the body ------------------------------------------------------------------------------

class RigidBody:
    """A body of the world. Static bodies have inv_mass = 0 and inv_I = 0; bodies that
    cannot rotate keep their orientation and have inv_I = 0; planar (2D) bodies live in
    the x-z plane and turn about y only."""

    __slots__ = ("name", "shape", "static", "can_rotate", "planar", "inv_mass", "inertia", "index",
                 "_arrays", "_bodies", "_row", "_x", "_q", "_v", "_w", "_vp", "_wp", "_v0", "_w0")

    def __init__(self, name: str, shape, mass: float | None = None, inertia=(1.0, 1.0, 1.0),
                 x=(0.0, 0.0, 0.0), q=(1.0, 0.0, 0.0, 0.0), v=(0.0, 0.0, 0.0), w=(0.0, 0.0, 0.0),
                 static: bool = False, can_rotate: bool = True, planar: bool = False):
        self.name = name
        self.shape = shape
        self.static = static
        self.can_rotate = can_rotate and not static
        self.planar = planar
        self.inv_mass = 0.0 if static else 1.0 / mass
        self.inertia = tuple(float(i) for i in inertia)  # principal, body frame
        self.index = -1  # position in the world's body list
        vertices, bvh = geometry.shape_arrays(shape)
        row = _empty(1, len(vertices), len(bvh))
        row.vertices[0], row.n_vertices[0], row.bvh[0] = vertices, len(vertices), bvh
        kind, radius, half, normal, offset, bounding = geometry.shape_columns(shape)
        row.shape[0], row.radius[0], row.half[0], row.normal[0], row.offset[0] = kind, radius, half, normal, offset
        row.bounding_radius[0] = bounding
        row.static[0], row.can_rotate[0], row.planar[0] = self.static, self.can_rotate, planar
        row.inv_mass[0], row.inertia[0] = self.inv_mass, self.inertia
        row.x[0], row.q[0] = x, q
        if not static:
            row.v[0], row.w[0] = v, w
        row.v0[0], row.w0[0] = row.v[0], row.w[0]
        self.attach(row, new_bodies(row), 0)
        self.update_frame()

    def attach(self, arrays: BodyArrays, bodies: Bodies, row: int) -> None:
        """Make this body row `row` of `arrays` (its state already copied there), which
        `bodies` holds for compiled code."""
        self._arrays, self._bodies, self._row = arrays, bodies, row
        self._x, self._q, self._v, self._w = arrays.x[row], arrays.q[row], arrays.v[row], arrays.w[row]
        self._vp, self._wp, self._v0, self._w0 = arrays.vp[row], arrays.wp[row], arrays.v0[row], arrays.w0[row]

    # the state: views of the body's row (assigning copies into it)
    x = property(lambda self: self._x, lambda self, value: self._x.__setitem__(slice(None), value))
    q = property(lambda self: self._q, lambda self, value: self._q.__setitem__(slice(None), value))
    v = property(lambda self: self._v, lambda self, value: self._v.__setitem__(slice(None), value))
    w = property(lambda self: self._w, lambda self, value: self._w.__setitem__(slice(None), value))
    vp = property(lambda self: self._vp)
    wp = property(lambda self: self._wp)
    v0 = property(lambda self: self._v0)
    w0 = property(lambda self: self._w0)
    # derived from q, read-only: copies
    R = property(lambda self: self._arrays.R[self._row].copy(), doc="R(q), its columns the body axes")
    inv_I = property(lambda self: self._arrays.inv_I[self._row].copy(), doc="world inverse inertia")

    def speed_bound(self) -> float:
        return speed_bound(self._bodies, self._row)

    def update_frame(self) -> None:
        update_frame(self._bodies, self._row)

    def integrate_position(self, dt: float) -> None:
        integrate_position(self._bodies, self._row, dt)

    def midpoint_spin(self, L, dt: float, iterations: int = 100) -> tuple[float, float, float]:
        return midpoint_spin(self._bodies, self._row, np.asarray(L, dtype=float), dt, iterations)

    def clear_pseudo(self) -> None:
        self._vp[:] = 0.0
        self._wp[:] = 0.0


# --- the step of one body (row i of `bodies`) -----------------------------------------------

@njit
def speed_bound(bodies, i) -> float:
    """An upper bound on the speed of any point of the body: |v| + |w| r_max."""
    v, w = bodies.v[i], bodies.w[i]
    return math.sqrt(dot(v, v)) + math.sqrt(dot(w, w)) * bodies.bounding_radius[i]


@njit
def update_frame(bodies, i) -> None:
    """R and the world inverse inertia I^-1 = R I_0^-1 R^T from q."""
    R, inv_I, inertia = bodies.R[i], bodies.inv_I[i], bodies.inertia[i]
    _assign(R, rotation_matrix(bodies.q[i]))
    if not bodies.can_rotate[i]:
        inv_I[:] = 0.0
    elif bodies.planar[i]:  # turns about y only: I_yy is the same in body and world
        inv_I[:] = 0.0
        inv_I[1, 1] = 1.0 / inertia[1]
    else:
        _assign(inv_I, similarity(R, (1.0 / inertia[0], 1.0 / inertia[1], 1.0 / inertia[2])))


@njit
def _assign(M, rows) -> None:
    """M[i][j] = rows[i][j] for a 3x3 array M."""
    for i in range(3):
        for j in range(3):
            M[i, j] = rows[i][j]


@njit(inline=True)
def integrate_position(bodies, i, dt) -> None:
    """x += dt (v + vp); q turned by the step's rotation (w_mid + wp), normalised; then
    w = I'^-1 L with the world angular momentum L = I w kept (note 001, dL/dt = T: no
    torque acts during the position update).

    w_mid is the implicit midpoint rule for Euler's torque-free equations (body frame
    dL/dt = L x w; Austin, Krishnaprasad and Wang, "Almost Poisson integration of rigid
    body systems", J. Comput. Phys. 107, 1993; Hairer, Lubich and Wanner, "Geometric
    Numerical Integration", sec. IV.2 and VII.5): L_1 = L_0 - dt w_mid x (L_0 + L_1)/2,
    w_mid = I^-1 (L_0 + L_1)/2. It is second order and keeps the quadratic invariants
    |L|^2 and E = L . I^-1 L / 2 exactly; L_1 = cay(-dt w_mid^) L_0 with the Cayley map,
    which is the rotation of the quaternion (1, dt w_mid / 2), so turning q by that
    quaternion keeps L in the world frame too. (The previous update turned by the
    step's initial w: first order, energy drifting by dt^2/2 w_dot . I w_dot per step.)"""
    x, v, vp = bodies.x[i], bodies.v[i], bodies.vp[i]
    x[0] += dt * (v[0] + vp[0])
    x[1] += dt * (v[1] + vp[1])
    x[2] += dt * (v[2] + vp[2])
    if not bodies.can_rotate[i]:
        return
    w, wp, inertia = bodies.w[i], bodies.wp[i], bodies.inertia[i]
    anisotropic = not bodies.planar[i] and not (inertia[0] == inertia[1] and inertia[1] == inertia[2])
    wx, wy, wz = w[0], w[1], w[2]
    L = (0.0, 0.0, 0.0)
    if anisotropic:  # otherwise w is constant between impulses: w_mid = w
        L = mat_vec(similarity(bodies.R[i], inertia), w)
        wx, wy, wz = midpoint_spin(bodies, i, L, dt, 100)
    ox, oy, oz = wx + wp[0], wy + wp[1], wz + wp[2]
    if ox == 0.0 and oy == 0.0 and oz == 0.0:
        return
    q = bodies.q[i]
    qw, qx, qy, qz = q[0], q[1], q[2], q[3]
    h = 0.5 * dt  # q <- (1, dt w / 2) q, normalised: the Cayley rotation of dt w
    qw, qx, qy, qz = (qw - h * (ox * qx + oy * qy + oz * qz),
                      qx + h * (ox * qw + oy * qz - oz * qy),
                      qy + h * (oy * qw + oz * qx - ox * qz),
                      qz + h * (oz * qw + ox * qy - oy * qx))
    norm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    q[0], q[1], q[2], q[3] = qw / norm, qx / norm, qy / norm, qz / norm
    update_frame(bodies, i)
    if anisotropic:
        w[0], w[1], w[2] = mat_vec(bodies.inv_I[i], L)


@njit
def midpoint_spin(bodies, i, L, dt, iterations):
    """w_mid of the implicit midpoint step from world angular momentum L (see
    integrate_position), in the world frame with this step's I^-1: the fixed point of
    L_1 = L - dt w_mid x (L + L_1)/2, w_mid = I^-1 (L + L_1)/2, iterated from L_1 = L.
    Each pass contracts the error by about dt |w| (anisotropy of I): a few passes at
    the steps a contact scene takes; stops when L_1 changes by less than 1e-15 |L|."""
    inv_I = bodies.inv_I[i]
    L_1 = (L[0], L[1], L[2])
    bound = 1e-30 * dot(L, L)
    for _ in range(iterations):
        L_mid = (0.5 * (L[0] + L_1[0]), 0.5 * (L[1] + L_1[1]), 0.5 * (L[2] + L_1[2]))
        w_mid = mat_vec(inv_I, L_mid)
        turn = cross(w_mid, L_mid)
        new = (L[0] - dt * turn[0], L[1] - dt * turn[1], L[2] - dt * turn[2])
        change = (new[0] - L_1[0], new[1] - L_1[1], new[2] - L_1[2])
        L_1 = new
        if dot(change, change) <= bound:
            break
    return mat_vec(inv_I, (0.5 * (L[0] + L_1[0]), 0.5 * (L[1] + L_1[1]), 0.5 * (L[2] + L_1[2])))
