"""Simultaneous contacts as one linear complementarity problem (note 000, "Matrix form for
rigid bodies" and "Friction"): the Jacobian J, the inverse mass matrix M^-1,
A = J M^-1 J^T and the right-hand side b of

    A gamma - b >= 0,   gamma >= 0,   gamma . (A gamma - b) = 0     (normal rows)

and of the boxed rows of friction, -mu gamma_n <= gamma_t <= mu gamma_n.

Friction set: the friction PYRAMID (a box in each contact's tangent plane, the note's
"bounds +- mu gamma_n" on two tangent rows). Its corners reach sqrt(2) mu gamma_n, so a
box fixed to the world would make friction depend on the direction of sliding. We align
the first tangent t1 with the contact's tangential velocity before the solve (when there
is one): a contact that slides along t1 then meets exactly mu gamma_n, and the rows turn
with the scene, so a rigid transform of the whole scene does not change the result.
pgs.py and lemke.py solve the same pyramid problem.

Conventions: generalised velocity u = [v_1, w_1, ..., v_N, w_N] (per body: linear
velocity, world angular velocity); a contact pushes body a with +gamma n and body b with
-gamma n, n pointing from b to a; b = -1 is the static world (no columns in J). A static
or rotation-locked body enters only through M^-1, as a zero block (infinite mass or
inertia), which is why this module builds M^-1 rather than M.

Compiled (compiled.py): the functions take the named tuples below and arrays, so the
world formulations call them inside their compiled solve and Python calls the same ones.
Where numpy summed with its own order (einsum in two interleaved lanes, BLAS products),
the loops here sum in that order, so the rows are those of the numpy code to the last bit.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reference_impl.compiled import njit
from reference_impl.contact import RA_D, RB_D, velocity
from reference_impl.vectors import cross

STATIC = -1  # body index of the static world
# Rows.normal of a joint's rows that are no contact's (joints.py): an equality row, its
# impulse unbounded, and a boxed row, its impulse within -+ Rows.mu (a constant bound)
BILATERAL, BOXED = -1, -2


class Bodies(NamedTuple):
    """What the rows need of N bodies: 1/m (N,) and the world inverse inertia (N, 3, 3)."""
    m_inv: np.ndarray
    I_inv: np.ndarray


class Contact(NamedTuple):
    a: int               # body pushed by +gamma n
    b: int               # body pushed by -gamma n, or STATIC
    r_a: np.ndarray      # contact point minus centre of a (world)
    r_b: np.ndarray      # contact point minus centre of b (ignored when b is STATIC)
    n: np.ndarray        # unit normal from b towards a
    c_r: float = 0.0     # coefficient of restitution
    mu: float = 0.0      # friction coefficient; 0: the contact has no friction rows


class Rows(NamedTuple):
    """The rows of J, stored per row as two 6-blocks (body a, body b). Contact c gives a
    normal row and, if mu > 0, two tangent rows right after it; `normal` maps every row to
    its contact's normal row (itself for a normal row)."""
    a: np.ndarray        # (K,) int
    b: np.ndarray        # (K,) int, STATIC for the world
    J_a: np.ndarray      # (K, 6)
    J_b: np.ndarray      # (K, 6)
    normal: np.ndarray   # (K,) int
    mu: np.ndarray       # (K,) the contact's mu on its tangent rows, 0 on normal rows
    c_r: np.ndarray      # (K,) the contact's restitution on its normal row, 0 on tangent rows

    @property
    def is_normal(self) -> np.ndarray:
        return self.normal == np.arange(len(self.a))


@njit
def lanes(x, y) -> float:
    """sum_k x[k] y[k] as numpy's einsum sums it: in two interleaved lanes (even and odd
    k), added at the end."""
    even, odd = 0.0, 0.0
    for k in range(0, len(x) - 1, 2):
        even = x[k] * y[k] + even
        odd = x[k + 1] * y[k + 1] + odd
    if len(x) % 2:
        even = x[len(x) - 1] * y[len(x) - 1] + even
        odd = 0.0 * 0.0 + odd
    return even + odd


@njit
def _dot(x, y) -> float:
    """x . y for 3-vectors as BLAS sums them: from 0, in order."""
    total = 0.0
    for k in range(3):
        total += x[k] * y[k]
    return total


@njit
def tangent_basis(n, v_t):
    """Unit t1, t2 with (n, t1, t2) right-handed; t1 along v_t when v_t is not negligible
    (see the module docstring), else a fixed choice from n alone."""
    speed = np.sqrt(_dot(v_t, v_t))
    if speed > 1e-12:
        t1 = v_t / speed
        return t1, np.array(cross(n, t1))
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = helper - _dot(helper, n) * n
    t1 = t1 / np.sqrt(_dot(t1, t1))
    return t1, np.array(cross(n, t1))


@njit
def _block(out, direction, r, sign) -> None:
    """One body's 6-block of a row, sign [d^T, (r x d)^T] (note 000, "Matrix form for rigid bodies")."""
    arm = cross(r, direction)
    for k in range(3):
        out[k], out[3 + k] = sign * direction[k], sign * arm[k]


@njit
def contact_velocity(a, b, r_a, r_b, u):
    """Relative velocity u_a - u_b of the contact points (world) of a contact between
    bodies a and b (b may be STATIC)."""
    v = u[a, :3] + np.array(cross(u[a, 3:], r_a))
    if b != STATIC:
        v = v - u[b, :3] - np.array(cross(u[b, 3:], r_b))
    return v


def build_rows(contacts: list[Contact], u: np.ndarray) -> Rows:
    """The rows of J for `contacts`; u (N, 6) is the velocity the tangent basis follows
    (the velocity the solve starts from)."""
    C = len(contacts)
    return rows_of(np.array([c.a for c in contacts], dtype=np.int64), np.array([c.b for c in contacts], dtype=np.int64),
                   np.array([c.r_a for c in contacts], dtype=float).reshape(C, 3),
                   np.array([c.r_b for c in contacts], dtype=float).reshape(C, 3),
                   np.array([c.n for c in contacts], dtype=float).reshape(C, 3),
                   np.array([c.c_r for c in contacts], dtype=float), np.array([c.mu for c in contacts], dtype=float),
                   np.asarray(u, dtype=float))


@njit
def rows_of(a, b, r_a, r_b, n, c_r, mu, u) -> Rows:
    """build_rows for contacts given as arrays (row j: contact j)."""
    K = 0
    for j in range(len(a)):
        K += 3 if mu[j] > 0.0 else 1
    rows = Rows(np.empty(K, np.int64), np.empty(K, np.int64), np.empty((K, 6)), np.zeros((K, 6)),
                np.empty(K, np.int64), np.empty(K), np.empty(K))
    k = 0
    for j in range(len(a)):
        directions = np.empty((3 if mu[j] > 0.0 else 1, 3))
        directions[0] = n[j]
        if mu[j] > 0.0:
            v = contact_velocity(a[j], b[j], r_a[j], r_b[j], u)
            t1, t2 = tangent_basis(n[j], v - _dot(v, n[j]) * n[j])
            directions[1], directions[2] = t1, t2
        for d in range(len(directions)):
            rows.a[k + d], rows.b[k + d], rows.normal[k + d] = a[j], b[j], k
            _block(rows.J_a[k + d], directions[d], r_a[j], 1.0)
            if b[j] != STATIC:
                _block(rows.J_b[k + d], directions[d], r_b[j], -1.0)
            rows.mu[k + d] = mu[j] if d else 0.0
            rows.c_r[k + d] = 0.0 if d else c_r[j]
        k += len(directions)
    return rows


@njit
def jacobian(rows: Rows, n_bodies: int) -> np.ndarray:
    """Dense J (K, 6N)."""
    J = np.zeros((len(rows.a), 6 * n_bodies))
    for k in range(len(rows.a)):
        for e in range(6):
            J[k, 6 * rows.a[k] + e] += rows.J_a[k, e]
        if rows.b[k] != STATIC:
            for e in range(6):
                J[k, 6 * rows.b[k] + e] += rows.J_b[k, e]
    return J


@njit
def inverse_mass_matrix(bodies: Bodies) -> np.ndarray:
    """Block-diagonal M^-1 (6N, 6N): per body 1/m 1 and I^-1 (note 000: "longer diagonal for M")."""
    N = len(bodies.m_inv)
    M_inv = np.zeros((6 * N, 6 * N))
    for i in range(N):
        for r in range(3):
            for c in range(3):
                M_inv[6 * i + r, 6 * i + c] = bodies.m_inv[i] * (1.0 if r == c else 0.0)
                M_inv[6 * i + 3 + r, 6 * i + 3 + c] = bodies.I_inv[i, r, c]
    return M_inv


@njit
def inverse_mass_times_rows(rows: Rows, bodies: Bodies):
    """M^-1 J^T per row, as the velocity change of body a and of body b (K, 6) per unit
    gamma: [1/m d, I^-1 (r x d)] (note 000, "Delta v_a = m_a^-1 gamma n, Delta w_a = I_a^-1 r x gamma n")."""
    return _inverse_mass_times(rows.J_a, rows.a, bodies), _inverse_mass_times(rows.J_b, rows.b, bodies)


@njit
def _inverse_mass_times(J, index, bodies):
    W = np.empty((len(index), 6))
    for k in range(len(index)):
        i = index[k] if index[k] >= 0 else 0  # the static world's rows of J are zero anyway
        for e in range(3):
            W[k, e] = bodies.m_inv[i] * J[k, e]
            W[k, 3 + e] = lanes(bodies.I_inv[i, e], J[k, 3:])
    return W


@njit
def velocity_change(rows: Rows, bodies: Bodies, gamma: np.ndarray) -> np.ndarray:
    """M^-1 J^T gamma per body (N, 6)."""
    W_a, W_b = inverse_mass_times_rows(rows, bodies)
    N = len(bodies.m_inv)
    du = np.zeros((N + 1, 6))  # row N collects the static world's (zero) share
    _add_at(du, rows.a, W_a, gamma)
    _add_at(du, rows.b, W_b, gamma)
    return du[:N].copy()


@njit
def _add_at(du, index, W, gamma) -> None:
    """du[index[k]] += W[k] gamma[k] for each row k in order (index -1: du's last row)."""
    for k in range(len(index)):
        i = index[k] if index[k] >= 0 else len(du) - 1
        for e in range(6):
            du[i, e] += W[k, e] * gamma[k]


@njit
def delassus(rows: Rows, bodies: Bodies) -> np.ndarray:
    """A = J M^-1 J^T (K, K)."""
    J = jacobian(rows, len(bodies.m_inv))
    return J @ inverse_mass_matrix(bodies) @ J.T


@njit
def row_velocity(rows: Rows, u: np.ndarray) -> np.ndarray:
    """J u, per row (u is (N, 6))."""
    v = np.empty(len(rows.a))
    for k in range(len(rows.a)):
        v[k] = lanes(rows.J_a[k], u[rows.a[k]]) + (0.0 if rows.b[k] == STATIC else lanes(rows.J_b[k], u[rows.b[k]]))
    return v


@njit
def impact_rhs(rows: Rows, u_minus: np.ndarray) -> np.ndarray:
    """b of A gamma - b >= 0 from the restitution hypothesis v_n+ >= -c_r v_n- (note 000,
    "Global system from restitution hypothesis"): b = -(1 + c_r) J v- on approaching rows.
    The PGS slide of note 000 prints (1 - c_r): garbled, the derivation two slides earlier
    gives J v- + A gamma = -c_r J v-, i.e. A gamma = -(1 + c_r) J v-.
    A row that is not approaching (J v- >= 0) gets b = -J v- (target v+ >= 0): with
    -(1 + c_r) J v- it could leave approaching at c_r J v-. Tangent rows target v_t+ = 0."""
    v = row_velocity(rows, u_minus)
    b = np.empty(len(v))
    for k in range(len(v)):
        approaching = rows.normal[k] == k and v[k] < 0.0
        b[k] = -v[k] - (rows.c_r[k] * v[k] if approaching else 0.0)
    return b


@njit
def bounds(rows: Rows, gamma: np.ndarray):
    """Lower and upper bound of every row given gamma: [0, inf) on normal rows,
    [-mu gamma_n, mu gamma_n] on tangent rows (note 000, "PGS for friction"), (-inf, inf)
    on a joint's equality rows (BILATERAL) and [-mu, mu] on its friction rows (BOXED)."""
    lo, hi = np.empty(len(gamma)), np.empty(len(gamma))
    for k in range(len(gamma)):
        if rows.normal[k] == BILATERAL:
            lo[k], hi[k] = -np.inf, np.inf
            continue
        if rows.normal[k] == BOXED:
            lo[k], hi[k] = -rows.mu[k], rows.mu[k]
            continue
        limit = rows.mu[k] * gamma[rows.normal[k]]
        lo[k], hi[k] = (0.0, np.inf) if rows.normal[k] == k else (-limit, limit)
    return lo, hi


def residual(A: np.ndarray, b: np.ndarray, rows: Rows, gamma: np.ndarray) -> float:
    """Complementarity residual of the boxed LCP, max |gamma - clamp(gamma - (A gamma - b))|
    (zero exactly at a solution; velocity and impulse in the same units, so scale the
    problem to order one before reading it as a tolerance)."""
    lo, hi = bounds(rows, gamma)
    return float(np.max(np.abs(gamma - np.clip(gamma - (A @ gamma - b), lo, hi)), initial=0.0))


# --- the world's contacts as rows (the formulation interface of reference_impl/__init__.py)

@njit
def world_rows(contacts, bodies):
    """Rows, body data and velocities u (N, 6) of the world's contacts (contact.Contacts)
    and bodies (rigid_body.Bodies; all of them: a static body has 1/m = 0 and I^-1 = 0).
    Per contact: its normal row, then its tangent rows (the world's basis: t1 along the
    slip when sliding). The world's row measures b's point against a's and pushes b with
    +P d, so our body a is its b."""
    c, K = contacts, 0
    for j in range(len(c.a)):
        K += 1 + c.n_tangents[j]
    rows = Rows(np.empty(K, np.int64), np.empty(K, np.int64), np.empty((K, 6)), np.empty((K, 6)),
                np.empty(K, np.int64), np.empty(K), np.empty(K))
    k = 0
    for j in range(len(c.a)):
        for r in range(1 + c.n_tangents[j]):
            row = c.normal[j] if r == 0 else c.tangents[j, r - 1]
            rows.a[k + r], rows.b[k + r], rows.normal[k + r] = c.b[j], c.a[j], k
            for e in range(3):
                rows.J_a[k + r, e], rows.J_a[k + r, 3 + e] = row[e], row[RB_D + e]
                rows.J_b[k + r, e], rows.J_b[k + r, 3 + e] = -row[e], -row[RA_D + e]
            rows.mu[k + r] = c.mu[j] if r else 0.0
            rows.c_r[k + r] = 0.0 if r else c.e[j]
        k += 1 + c.n_tangents[j]
    N = len(bodies.x)
    u = np.empty((N, 6))
    for i in range(N):
        for e in range(3):
            u[i, e], u[i, 3 + e] = bodies.v[i, e], bodies.w[i, e]
    return rows, Bodies(bodies.inv_mass.copy(), bodies.inv_I.copy()), u


@njit
def world_rhs(contacts, rows: Rows, u: np.ndarray) -> np.ndarray:
    """b = v_target - J u: on normal rows the contact's own target (contact.normal_target:
    -e vn0 for an approaching contact, vn0 measured before external forces; a speculative
    contact may close its gap but not overlap), on tangent rows 0. With vn0 = J u this is
    impact_rhs's -(1 + c_r) J u."""
    target, j = np.zeros(len(rows.a)), 0
    for k in range(len(rows.a)):
        if rows.normal[k] == k:
            target[k] = contacts.target[j]
            j += 1
    return target - row_velocity(rows, u)


@njit
def world_impulses(contacts) -> np.ndarray:
    """The contacts' Pn, Pt in row order (their warm-start values on entry)."""
    c, k = contacts, 0
    gamma = np.empty(len(c.a) + np.sum(c.n_tangents))
    for j in range(len(c.a)):
        gamma[k] = c.Pn[j]
        for t in range(c.n_tangents[j]):
            gamma[k + 1 + t] = c.Pt[j, t]
        k += 1 + c.n_tangents[j]
    return gamma


@njit
def store_impulses(contacts, gamma: np.ndarray) -> None:
    c, k = contacts, 0
    for j in range(len(c.a)):
        c.Pn[j] = gamma[k]
        for t in range(c.n_tangents[j]):
            c.Pt[j, t] = gamma[k + 1 + t]
        k += 1 + c.n_tangents[j]


@njit
def apply_velocity_change(bodies, du: np.ndarray, pseudo: bool) -> None:
    """v, w += du (or vp, wp = du for pseudo-velocities) on the dynamic bodies."""
    for i in range(len(bodies.x)):
        if bodies.static[i]:
            continue
        for e in range(3):
            if pseudo:
                bodies.vp[i, e], bodies.wp[i, e] = du[i, e], du[i, 3 + e]
            else:
                bodies.v[i, e] += du[i, e]
                bodies.w[i, e] += du[i, 3 + e]


@njit
def normal_rows(rows: Rows) -> Rows:
    """The frictionless sub-problem: normal rows only."""
    K = 0
    for k in range(len(rows.a)):
        K += rows.normal[k] == k
    out = Rows(np.empty(K, np.int64), np.empty(K, np.int64), np.empty((K, 6)), np.empty((K, 6)), np.arange(K),
               np.zeros(K), np.empty(K))
    m = 0
    for k in range(len(rows.a)):
        if rows.normal[k] == k:
            out.a[m], out.b[m], out.c_r[m] = rows.a[k], rows.b[k], rows.c_r[k]
            for e in range(6):
                out.J_a[m, e], out.J_b[m, e] = rows.J_a[k, e], rows.J_b[k, e]
            m += 1
    return out


@njit
def world_bias(contacts, bodies) -> np.ndarray:
    """Targets of the overlap repair on pseudo-velocities (as sequential_impulses.py):
    the bias beta/dt (delta - slop)+ less what the contact already separates at."""
    c = contacts
    bias = np.empty(len(c.a))
    for j in range(len(c.a)):
        a, b = c.a[j], c.b[j]
        bias[j] = c.bias[j] - max(velocity(c.normal[j], bodies.v[a], bodies.w[a], bodies.v[b], bodies.w[b]), 0.0)
    return bias


@njit
def stack_rows(first: Rows, second: Rows) -> Rows:
    """The rows of `first`, then those of `second` (their `normal` indices moved along;
    a joint's equality and friction rows keep theirs, BILATERAL and BOXED)."""
    K, L = len(first.a), len(second.a)
    out = Rows(np.empty(K + L, np.int64), np.empty(K + L, np.int64), np.empty((K + L, 6)), np.empty((K + L, 6)),
               np.empty(K + L, np.int64), np.empty(K + L), np.empty(K + L))
    for k in range(K + L):
        rows, m = (first, k) if k < K else (second, k - K)
        out.a[k], out.b[k], out.mu[k], out.c_r[k] = rows.a[m], rows.b[m], rows.mu[m], rows.c_r[m]
        out.normal[k] = rows.normal[m] + (K if k >= K and rows.normal[m] >= 0 else 0)
        for e in range(6):
            out.J_a[k, e], out.J_b[k, e] = rows.J_a[m, e], rows.J_b[m, e]
    return out
