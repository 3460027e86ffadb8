"""A rigid body's state and its step (symplectic Euler for the centre of mass, the
implicit midpoint rule for the free rotation), plus the 3-vector helpers the engine uses. Vectors are plain lists/tuples of floats: the inner loops run on a handful
of numbers, where numpy's per-call cost would dominate.

State (note 001, "multiple contacts", equations of motion): position x, orientation q
(unit quaternion w, x, y, z, body to world), linear velocity v, angular velocity w (world
frame). Mass and principal inertia I_0 (body frame); world inverse inertia
I^-1 = R I_0^-1 R^T.
"""
from __future__ import annotations

import math


# --- 3-vectors and 3x3 matrices (tuples of rows) -------------------------------------------

def dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def mat_vec(M, a) -> tuple[float, float, float]:
    return (dot(M[0], a), dot(M[1], a), dot(M[2], a))


def rotation_matrix(q) -> tuple:
    """R(q) for a unit quaternion (w, x, y, z); its columns are the body axes in the world."""
    w, x, y, z = q
    return ((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
            (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
            (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)))


def similarity(R, d) -> tuple:
    """R diag(d) R^T."""
    return tuple(tuple(R[i][0] * d[0] * R[j][0] + R[i][1] * d[1] * R[j][1] + R[i][2] * d[2] * R[j][2]
                       for j in range(3)) for i in range(3))


ZERO3 = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


# --- the body ------------------------------------------------------------------------------

class RigidBody:
    """A body of the world. Static bodies have inv_mass = 0 and inv_I = 0; bodies that
    cannot rotate keep their orientation and have inv_I = 0; planar (2D) bodies live in
    the x-z plane and turn about y only."""

    __slots__ = ("name", "shape", "static", "can_rotate", "planar", "inv_mass", "inertia",
                 "x", "q", "v", "w", "vp", "wp", "v0", "w0", "R", "inv_I", "index")

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
        self.x = [float(c) for c in x]
        self.q = [float(c) for c in q]
        self.v = [0.0, 0.0, 0.0] if static else [float(c) for c in v]
        self.w = [0.0, 0.0, 0.0] if static else [float(c) for c in w]
        self.vp = [0.0, 0.0, 0.0]  # pseudo-velocities: position correction, not kept
        self.wp = [0.0, 0.0, 0.0]
        self.v0 = list(self.v)     # velocities before this step's external forces
        self.w0 = list(self.w)
        self.index = -1            # position in the world's body list
        self.update_frame()

    def speed_bound(self) -> float:
        """An upper bound on the speed of any point of the body: |v| + |w| r_max."""
        v, w = self.v, self.w
        return math.sqrt(dot(v, v)) + math.sqrt(dot(w, w)) * self.shape.bounding_radius

    def update_frame(self) -> None:
        """R and the world inverse inertia I^-1 = R I_0^-1 R^T from q."""
        self.R = rotation_matrix(self.q)
        if not self.can_rotate:
            self.inv_I = ZERO3
        elif self.planar:  # turns about y only: I_yy is the same in body and world
            self.inv_I = ((0.0, 0.0, 0.0), (0.0, 1.0 / self.inertia[1], 0.0), (0.0, 0.0, 0.0))
        else:
            self.inv_I = similarity(self.R, tuple(1.0 / i for i in self.inertia))

    def integrate_position(self, dt: float) -> None:
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
        x, v, vp = self.x, self.v, self.vp
        x[0] += dt * (v[0] + vp[0])
        x[1] += dt * (v[1] + vp[1])
        x[2] += dt * (v[2] + vp[2])
        if not self.can_rotate:
            return
        w, wp = self.w, self.wp
        anisotropic = not self.planar and not (self.inertia[0] == self.inertia[1] == self.inertia[2])
        if anisotropic:  # otherwise w is constant between impulses: w_mid = w
            L = mat_vec(similarity(self.R, self.inertia), w)
            w = self.midpoint_spin(L, dt)
        ox, oy, oz = w[0] + wp[0], w[1] + wp[1], w[2] + wp[2]
        if ox == 0.0 and oy == 0.0 and oz == 0.0:
            return
        qw, qx, qy, qz = self.q
        h = 0.5 * dt  # q <- (1, dt w / 2) q, normalised: the Cayley rotation of dt w
        qw, qx, qy, qz = (qw - h * (ox * qx + oy * qy + oz * qz),
                          qx + h * (ox * qw + oy * qz - oz * qy),
                          qy + h * (oy * qw + oz * qx - ox * qz),
                          qz + h * (oz * qw + ox * qy - oy * qx))
        norm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        self.q = [qw / norm, qx / norm, qy / norm, qz / norm]
        self.update_frame()
        if anisotropic:
            self.w = list(mat_vec(self.inv_I, L))

    def midpoint_spin(self, L, dt: float, iterations: int = 100) -> tuple[float, float, float]:
        """w_mid of the implicit midpoint step from world angular momentum L (see
        integrate_position), in the world frame with this step's I^-1: the fixed point of
        L_1 = L - dt w_mid x (L + L_1)/2, w_mid = I^-1 (L + L_1)/2, iterated from L_1 = L.
        Each pass contracts the error by about dt |w| (anisotropy of I): a few passes at
        the steps a contact scene takes; stops when L_1 changes by less than 1e-15 |L|."""
        L_1 = L
        bound = 1e-30 * dot(L, L)
        for _ in range(iterations):
            L_mid = (0.5 * (L[0] + L_1[0]), 0.5 * (L[1] + L_1[1]), 0.5 * (L[2] + L_1[2]))
            w_mid = mat_vec(self.inv_I, L_mid)
            turn = cross(w_mid, L_mid)
            new = (L[0] - dt * turn[0], L[1] - dt * turn[1], L[2] - dt * turn[2])
            change = (new[0] - L_1[0], new[1] - L_1[1], new[2] - L_1[2])
            L_1 = new
            if dot(change, change) <= bound:
                break
        return mat_vec(self.inv_I, (0.5 * (L[0] + L_1[0]), 0.5 * (L[1] + L_1[1]), 0.5 * (L[2] + L_1[2])))

    def clear_pseudo(self) -> None:
        self.vp[0] = self.vp[1] = self.vp[2] = 0.0
        self.wp[0] = self.wp[1] = self.wp[2] = 0.0
