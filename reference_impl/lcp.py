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
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STATIC = -1  # body index of the static world


@dataclass(frozen=True)
class Bodies:
    """What the rows need of N bodies: 1/m (N,) and the world inverse inertia (N, 3, 3)."""
    m_inv: np.ndarray
    I_inv: np.ndarray

    def __len__(self) -> int:
        return len(self.m_inv)


@dataclass(frozen=True)
class Contact:
    a: int               # body pushed by +gamma n
    b: int               # body pushed by -gamma n, or STATIC
    r_a: np.ndarray      # contact point minus centre of a (world)
    r_b: np.ndarray      # contact point minus centre of b (ignored when b is STATIC)
    n: np.ndarray        # unit normal from b towards a
    c_r: float = 0.0     # coefficient of restitution
    mu: float = 0.0      # friction coefficient; 0: the contact has no friction rows


@dataclass(frozen=True)
class Rows:
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

    def __len__(self) -> int:
        return len(self.a)

    @property
    def is_normal(self) -> np.ndarray:
        return self.normal == np.arange(len(self))


def tangent_basis(n: np.ndarray, v_t: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Unit t1, t2 with (n, t1, t2) right-handed; t1 along v_t when v_t is not negligible
    (see the module docstring), else a fixed choice from n alone."""
    if v_t is not None:
        speed = float(np.linalg.norm(v_t))
        if speed > 1e-12:
            t1 = v_t / speed
            return t1, np.cross(n, t1)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = helper - (helper @ n) * n
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(n, t1)


def _block(direction: np.ndarray, r: np.ndarray) -> np.ndarray:
    """One body's 6-block of a row, [d^T, (r x d)^T] (note 000, "Matrix form for rigid bodies")."""
    return np.concatenate([direction, np.cross(r, direction)])


def contact_velocity(contact: Contact, u: np.ndarray) -> np.ndarray:
    """Relative velocity u_a - u_b of the contact points (world)."""
    v = u[contact.a, :3] + np.cross(u[contact.a, 3:], contact.r_a)
    if contact.b != STATIC:
        v = v - u[contact.b, :3] - np.cross(u[contact.b, 3:], contact.r_b)
    return v


def build_rows(contacts: list[Contact], u: np.ndarray) -> Rows:
    """The rows of J for `contacts`; u (N, 6) is the velocity the tangent basis follows
    (the velocity the solve starts from)."""
    a, b, J_a, J_b, normal, mu, c_r = [], [], [], [], [], [], []
    for c in contacts:
        n = np.asarray(c.n, dtype=float)
        directions = [n]
        if c.mu > 0.0:
            v = contact_velocity(c, u)
            directions += list(tangent_basis(n, v - (v @ n) * n))
        first = len(a)
        for k, d in enumerate(directions):
            a.append(c.a)
            b.append(c.b)
            J_a.append(_block(d, np.asarray(c.r_a, dtype=float)))
            J_b.append(np.zeros(6) if c.b == STATIC else -_block(d, np.asarray(c.r_b, dtype=float)))
            normal.append(first)
            mu.append(c.mu if k else 0.0)
            c_r.append(0.0 if k else c.c_r)
    return Rows(np.array(a, dtype=int), np.array(b, dtype=int), np.array(J_a).reshape(-1, 6),
                np.array(J_b).reshape(-1, 6), np.array(normal, dtype=int), np.array(mu), np.array(c_r))


def jacobian(rows: Rows, n_bodies: int) -> np.ndarray:
    """Dense J (K, 6N)."""
    J = np.zeros((len(rows), 6 * n_bodies))
    for k in range(len(rows)):
        J[k, 6 * rows.a[k]:6 * rows.a[k] + 6] += rows.J_a[k]
        if rows.b[k] != STATIC:
            J[k, 6 * rows.b[k]:6 * rows.b[k] + 6] += rows.J_b[k]
    return J


def inverse_mass_matrix(bodies: Bodies) -> np.ndarray:
    """Block-diagonal M^-1 (6N, 6N): per body 1/m 1 and I^-1 (note 000: "longer diagonal for M")."""
    N = len(bodies)
    M_inv = np.zeros((6 * N, 6 * N))
    for i in range(N):
        M_inv[6 * i:6 * i + 3, 6 * i:6 * i + 3] = bodies.m_inv[i] * np.eye(3)
        M_inv[6 * i + 3:6 * i + 6, 6 * i + 3:6 * i + 6] = bodies.I_inv[i]
    return M_inv


def inverse_mass_times_rows(rows: Rows, bodies: Bodies) -> tuple[np.ndarray, np.ndarray]:
    """M^-1 J^T per row, as the velocity change of body a and of body b (K, 6) per unit
    gamma: [1/m d, I^-1 (r x d)] (note 000, "Delta v_a = m_a^-1 gamma n, Delta w_a = I_a^-1 r x gamma n")."""
    def block(J, index):
        index = np.where(index < 0, 0, index)  # the static world's rows of J are zero anyway
        return np.concatenate([bodies.m_inv[index, None] * J[:, :3],
                               np.einsum("kij,kj->ki", bodies.I_inv[index], J[:, 3:])], axis=1)
    return block(rows.J_a, rows.a), block(rows.J_b, rows.b)


def velocity_change(rows: Rows, bodies: Bodies, gamma: np.ndarray) -> np.ndarray:
    """M^-1 J^T gamma per body (N, 6)."""
    W_a, W_b = inverse_mass_times_rows(rows, bodies)
    du = np.zeros((len(bodies) + 1, 6))  # row N collects the static world's (zero) share
    np.add.at(du, rows.a, W_a * gamma[:, None])
    np.add.at(du, rows.b, W_b * gamma[:, None])
    return du[:-1]


def delassus(rows: Rows, bodies: Bodies) -> np.ndarray:
    """A = J M^-1 J^T (K, K)."""
    J = jacobian(rows, len(bodies))
    return J @ inverse_mass_matrix(bodies) @ J.T


def row_velocity(rows: Rows, u: np.ndarray) -> np.ndarray:
    """J u, per row (u is (N, 6))."""
    v = np.einsum("kj,kj->k", rows.J_a, u[rows.a])
    world = rows.b == STATIC
    return v + np.where(world, 0.0, np.einsum("kj,kj->k", rows.J_b, u[np.where(world, 0, rows.b)]))


def impact_rhs(rows: Rows, u_minus: np.ndarray) -> np.ndarray:
    """b of A gamma - b >= 0 from the restitution hypothesis v_n+ >= -c_r v_n- (note 000,
    "Global system from restitution hypothesis"): b = -(1 + c_r) J v- on approaching rows.
    The PGS slide of note 000 prints (1 - c_r): garbled, the derivation two slides earlier
    gives J v- + A gamma = -c_r J v-, i.e. A gamma = -(1 + c_r) J v-.
    A row that is not approaching (J v- >= 0) gets b = -J v- (target v+ >= 0): with
    -(1 + c_r) J v- it could leave approaching at c_r J v-. Tangent rows target v_t+ = 0."""
    v = row_velocity(rows, u_minus)
    approaching = rows.is_normal & (v < 0.0)
    return -v - np.where(approaching, rows.c_r * v, 0.0)


def bounds(rows: Rows, gamma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bound of every row given gamma: [0, inf) on normal rows,
    [-mu gamma_n, mu gamma_n] on tangent rows (note 000, "PGS for friction")."""
    limit = rows.mu * gamma[rows.normal]
    is_normal = rows.is_normal
    return np.where(is_normal, 0.0, -limit), np.where(is_normal, np.inf, limit)


def residual(A: np.ndarray, b: np.ndarray, rows: Rows, gamma: np.ndarray) -> float:
    """Complementarity residual of the boxed LCP, max |gamma - clamp(gamma - (A gamma - b))|
    (zero exactly at a solution; velocity and impulse in the same units, so scale the
    problem to order one before reading it as a tolerance)."""
    lo, hi = bounds(rows, gamma)
    return float(np.max(np.abs(gamma - np.clip(gamma - (A @ gamma - b), lo, hi)), initial=0.0))


# --- the world's contacts as rows (the formulation interface of reference_impl/__init__.py)

def world_rows(contacts, bodies) -> tuple[Rows, Bodies, np.ndarray]:
    """Rows, body data and velocities u (N, 6) of the world's contacts and bodies (all of
    them; a static body has 1/m = 0 and I^-1 = 0). Per contact: its normal row, then its
    tangent rows (the world's basis: t1 along the slip when sliding). The world's row
    measures b's point against a's and pushes b with +P d, so our body a is its b."""
    a, b, J_a, J_b, normal, mu, c_r = [], [], [], [], [], [], []
    for c in contacts:
        first = len(a)
        for k, row in enumerate((c.normal, *c.tangents)):
            a.append(row.b.index)
            b.append(row.a.index)
            J_a.append([*row.d, *row.rb_d])
            J_b.append([-x for x in (*row.d, *row.ra_d)])
            normal.append(first)
            mu.append(c.mu if k else 0.0)
            c_r.append(0.0 if k else c.e)
    rows = Rows(np.array(a, dtype=int), np.array(b, dtype=int), np.array(J_a, dtype=float).reshape(-1, 6),
                np.array(J_b, dtype=float).reshape(-1, 6), np.array(normal, dtype=int), np.array(mu),
                np.array(c_r))
    data = Bodies(np.array([body.inv_mass for body in bodies], dtype=float),
                  np.array([body.inv_I for body in bodies], dtype=float).reshape(-1, 3, 3))
    u = np.array([[*body.v, *body.w] for body in bodies], dtype=float).reshape(-1, 6)
    return rows, data, u


def world_rhs(contacts, rows: Rows, u: np.ndarray) -> np.ndarray:
    """b = v_target - J u: on normal rows the contact's own target (contact.normal_target:
    -e vn0 for an approaching contact, vn0 measured before external forces; a speculative
    contact may close its gap but not overlap), on tangent rows 0. With vn0 = J u this is
    impact_rhs's -(1 + c_r) J u."""
    target = np.zeros(len(rows))
    target[rows.is_normal] = [c.target for c in contacts]
    return target - row_velocity(rows, u)


def world_impulses(contacts) -> np.ndarray:
    """The contacts' Pn, Pt in row order (their warm-start values on entry)."""
    return np.array([P for c in contacts for P in (c.Pn, *c.Pt)], dtype=float)


def store_impulses(contacts, gamma: np.ndarray) -> None:
    k = 0
    for c in contacts:
        c.Pn = float(gamma[k])
        c.Pt = [float(P) for P in gamma[k + 1:k + 1 + len(c.tangents)]]
        k += 1 + len(c.tangents)


def apply_velocity_change(bodies, du: np.ndarray, pseudo: bool = False) -> None:
    """v, w += du (or vp, wp = du for pseudo-velocities) on the dynamic bodies."""
    for body, d in zip(bodies, du.tolist()):
        if body.static:
            continue
        v, w = (body.vp, body.wp) if pseudo else (body.v, body.w)
        for k in range(3):
            v[k] = d[k] if pseudo else v[k] + d[k]
            w[k] = d[k + 3] if pseudo else w[k] + d[k + 3]


def normal_rows(rows: Rows) -> Rows:
    """The frictionless sub-problem: normal rows only."""
    keep = np.flatnonzero(rows.is_normal)
    return Rows(rows.a[keep], rows.b[keep], rows.J_a[keep], rows.J_b[keep], np.arange(len(keep)),
                np.zeros(len(keep)), rows.c_r[keep])


def world_bias(contacts) -> np.ndarray:
    """Targets of the overlap repair on pseudo-velocities (as sequential_impulses.py):
    the bias beta/dt (delta - slop)+ less what the contact already separates at."""
    return np.array([c.bias - max(c.normal.velocity(), 0.0) for c in contacts], dtype=float)


def world_contacts(contacts) -> list[Contact]:
    """The world's contacts as this module's Contact (body indices into the world's list;
    our a is the world's b, our n the world's n, from its a to its b)."""
    out = []
    for c in contacts:
        p = np.asarray(c.point, dtype=float)
        out.append(Contact(c.b.index, c.a.index, p - np.asarray(c.b.x, dtype=float),
                           p - np.asarray(c.a.x, dtype=float), np.asarray(c.n, dtype=float),
                           c.e, c.mu))
    return out
