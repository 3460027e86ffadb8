"""Contact forces at the acceleration level for resting contact (Baraff; note 001,
"Contact Force Approach", "Constructing the LCP - Matrix A / Vector b"):

    A f + b >= 0,   f >= 0,   f . (A f + b) = 0

f the normal force of each contact, A f + b the normal relative acceleration. In the
note's graph notation (s_ij = +-1 the side of body i in contact j)
    A_jj' = sum_i s_ij s_ij' n_j . (1/M_i n_j' + I_i^-1 (r_ij' x n_j') x r_ij),
which is J M^-1 J^T with lcp.py's normal rows, and
    b_j = n_j . B_j + 2 n_j' . (v_a - v_b)   (n_j' = dn_j/dt),
    B_j = sum_i s_ij (F_i / M_i + (I_i^-1 (T_i + L_i x w_i)) x r_ij + w_i x (w_i x r_ij)).
Re-derived: the note's first slide drops "L x w" from dw/dt (the summary slide has it:
dw/dt = I^-1 (T + L x w), from d(I^-1)/dt L = I^-1 (L x w)), and prints one n' term where
differentiating the separation n . (p_a - p_b) twice gives two (Baraff 1994, eq. 13;
it vanishes for resting contact, whose relative velocity is zero). We take the normal
as fixed in body b (vertex-face contact with the face on b): n' = w_b x n.

Frictionless (the note's slides compute friction separately); solved exactly by
lemke.py (lemke_or_retry). A set of contacts whose forces are indeterminate (a box resting on four
corners) has many solutions with the same accelerations: compare sums, not single forces.

Compiled (compiled.py), as is the world formulation "acceleration_lcp" below.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reference_impl import lcp, pgs
from reference_impl.compiled import njit
from reference_impl.lcp import STATIC, Bodies, Contact, contact_velocity, delassus, lanes, rows_of
from reference_impl.lemke import TALLY, lemke_or_retry
from reference_impl.vectors import cross


class ContactForces(NamedTuple):
    f: np.ndarray            # (C,) normal force per contact, N
    acceleration: np.ndarray  # (C,) normal relative acceleration A f + b, m/s^2


@njit
def pinv(M):
    """numpy.linalg.pinv of one matrix: V diag(1/s) U^T over the singular values above
    1e-15 of the largest (numpy's default), by the same SVD and product."""
    u, s, vt = np.linalg.svd(M, full_matrices=False)
    cutoff = 1e-15 * np.max(s)
    for k in range(len(s)):
        s[k] = 1.0 / s[k] if s[k] > cutoff else 0.0
    return vt.T @ (s.reshape((-1, 1)) * u.T)


@njit
def _times(M, x):
    """M x, summed as numpy's einsum sums (lcp.lanes)."""
    return np.array([lanes(M[0], x), lanes(M[1], x), lanes(M[2], x)])


@njit
def free_acceleration(bodies: Bodies, u: np.ndarray, F: np.ndarray, T: np.ndarray) -> np.ndarray:
    """(N, 6): F / M and I^-1 (T + L x w) per body (note 001, "Summary LCP-based Contact Forces")."""
    acc = np.empty((len(u), 6))
    for i in range(len(u)):
        w = u[i, 3:]
        L = _times(pinv(bodies.I_inv[i]), w)  # a locked body (I^-1 = 0) has w = 0
        Lw = cross(L, w)
        torque = np.array([T[i, 0] + Lw[0], T[i, 1] + Lw[1], T[i, 2] + Lw[2]])
        turn = _times(bodies.I_inv[i], torque)
        for e in range(3):
            acc[i, e], acc[i, 3 + e] = bodies.m_inv[i] * F[i, e], turn[e]
    return acc


def lcp_terms(contacts: list[Contact], bodies: Bodies, u: np.ndarray, F: np.ndarray,
              T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A and b of the note. u (N, 6) velocities; F, T (N, 3) external force and torque."""
    return terms_of(*_arrays(contacts), bodies, np.asarray(u, dtype=float), np.asarray(F, dtype=float),
                    np.asarray(T, dtype=float))


def _arrays(contacts: list[Contact]):
    C = len(contacts)
    return (np.array([c.a for c in contacts], dtype=np.int64), np.array([c.b for c in contacts], dtype=np.int64),
            np.array([c.r_a for c in contacts], dtype=float).reshape(C, 3),
            np.array([c.r_b for c in contacts], dtype=float).reshape(C, 3),
            np.array([c.n for c in contacts], dtype=float).reshape(C, 3))


@njit(inline=True)
def terms_of(a, b, r_a, r_b, n, bodies, u, F, T):
    """lcp_terms for contacts given as arrays (row j: contact j; frictionless)."""
    C = len(a)
    rows = rows_of(a, b, r_a, r_b, n, np.zeros(C), np.zeros(C), u)
    acc = free_acceleration(bodies, u, F, T)
    rhs = np.zeros(C)
    for j in range(C):
        B = _side(acc[a[j]], u[a[j], 3:], r_a[j])
        n_dot = np.zeros(3)
        if b[j] != STATIC:
            B = B - _side(acc[b[j]], u[b[j], 3:], r_b[j])
            n_dot = np.array(cross(u[b[j], 3:], n[j]))
        velocity = contact_velocity(a[j], b[j], r_a[j], r_b[j], u)
        rhs[j] = _dot(n[j], B) + 2.0 * _dot(n_dot, velocity)
    return delassus(rows, bodies), rhs


@njit
def _dot(x, y) -> float:
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]


@njit
def _side(acc: np.ndarray, w: np.ndarray, r) -> np.ndarray:
    """One body's term of B_j: F/M + (I^-1 (T + L x w)) x r + w x (w x r)."""
    turn, spin = cross(acc[3:], r), cross(w, cross(w, r))
    return np.array([acc[0] + turn[0] + spin[0], acc[1] + turn[1] + spin[1], acc[2] + turn[2] + spin[2]])


def contact_forces(contacts: list[Contact], bodies: Bodies, u: np.ndarray, F: np.ndarray,
                   T: np.ndarray) -> ContactForces:
    return forces_of(*_arrays(contacts), bodies, np.asarray(u, dtype=float), np.asarray(F, dtype=float),
                     np.asarray(T, dtype=float), np.zeros(TALLY, np.int64))


@njit(inline=True)
def forces_of(a, b, r_a, r_b, n, bodies, u, F, T, tally) -> ContactForces:
    """contact_forces for contacts given as arrays, counting Lemke's retries into `tally`."""
    A, rhs = terms_of(a, b, r_a, r_b, n, bodies, u, F, T)
    f = lemke_or_retry(A, rhs, tally)
    return ContactForces(f, A @ f + rhs)


class Settings(NamedTuple):
    position_iterations: int  # sweeps of the overlap repair
    tolerance: float          # m/s
    tally: np.ndarray         # Lemke's counts (lemke.lemke_or_retry)


def settings(config) -> Settings:
    return Settings(config.position_iterations, float(config.tolerance), np.zeros(TALLY, np.int64))


STAGES = ("impact", "forces", "position")
IMPACT, FORCES, POSITION = 1, 2, 4


def unsupported(world) -> str | None:
    if any(m.mu_s > 0.0 for m in (world.material, *world.pair_materials.values())):
        return ("friction asked: the acceleration-level LCP of note 001 gives normal forces "
                "only (the slides compute friction separately)")
    return None


@njit
def solve(contacts, bodies, dt, settings) -> int:
    """World formulation "acceleration_lcp", note 001's "conservative loop":
    1. impacts: the velocity-level LCP (lcp.py, exact by lemke.py) on the velocities W
       before external forces, targets contact.target (-e vn0 when approaching);
    2. contact forces: this module's LCP at W' (after the impacts) for the contacts that
       touch (depth >= 0) and do not separate (J W' <= config.tolerance), under the
       external forces M (u - W) / dt the world added (gravity);
    3. v = W' + dt M^-1 (F + J^T f); then the overlap repair of pgs.repair_overlap.
    Cost: two dense LCPs per step."""
    rows, data, u = lcp.world_rows(contacts, bodies)
    rows = lcp.normal_rows(rows)  # frictionless (see unsupported)
    W = np.empty_like(u)
    for i in range(len(u)):
        for e in range(3):
            W[i, e], W[i, 3 + e] = bodies.v0[i, e], bodies.w0[i, e]
    impulse = lemke_or_retry(delassus(rows, data), -lcp.world_rhs(contacts, rows, W), settings.tally)
    W_after = W + lcp.velocity_change(rows, data, impulse)
    v_after = lcp.row_velocity(rows, W_after)
    resting = np.array([j for j in range(len(contacts.a))
                        if contacts.depth[j] >= 0.0 and v_after[j] <= settings.tolerance], dtype=np.int64)
    u_new = W_after + (u - W)
    if len(resting):
        dv = (u - W) / dt  # external accelerations; as forces F = m dv, T = I dw
        F_ext, T_ext = np.empty((len(u), 3)), np.empty((len(u), 3))
        for i in range(len(u)):
            m_inv = data.m_inv[i] if data.m_inv[i] > 0.0 else np.inf
            torque = _times(pinv(data.I_inv[i]), dv[i, 3:])
            for e in range(3):
                F_ext[i, e], T_ext[i, e] = dv[i, e] / m_inv, torque[e]
        # the resting contacts as lcp.py's (our a is the world's b, our n the world's n,
        # from its a to its b)
        a, b = contacts.b[resting], contacts.a[resting]
        point, n = contacts.point[resting], contacts.n[resting]
        r_a, r_b = point - bodies.x[a], point - bodies.x[b]
        found = forces_of(a, b, r_a, r_b, n, data, W_after, F_ext, T_ext, settings.tally)
        rest_rows = rows_of(a, b, r_a, r_b, n, np.zeros(len(a)), np.zeros(len(a)), W_after)
        u_new += dt * lcp.velocity_change(rest_rows, data, found.f)
        impulse = impulse.copy()
        for k in range(len(resting)):
            impulse[resting[k]] += dt * found.f[k]
    lcp.apply_velocity_change(bodies, u_new - u, False)
    for j in range(len(contacts.a)):
        contacts.Pn[j] = impulse[j]
        for t in range(contacts.n_tangents[j]):
            contacts.Pt[j, t] = 0.0
    if pgs.repair_overlap(contacts, bodies, rows, data, settings.position_iterations, settings.tolerance):
        return IMPACT | FORCES | POSITION
    return IMPACT | FORCES


def knobs(config) -> dict:
    """What this formulation does with the world's contacts, for the adapter's record."""
    return {"impacts": "velocity-level LCP by Lemke on the velocities before external forces",
            "resting": "acceleration-level LCP (Baraff, note 001) by Lemke",
            "friction": "none (refused)", "depenetration": "split impulse: PGS on pseudo-velocities",
            "tolerance": config.tolerance}
