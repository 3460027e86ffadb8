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
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from reference_impl import lcp, pgs
from reference_impl.lcp import STATIC, Bodies, Contact, build_rows, contact_velocity, delassus
from reference_impl.lemke import lemke_or_retry


@dataclass(frozen=True)
class ContactForces:
    f: np.ndarray            # (C,) normal force per contact, N
    acceleration: np.ndarray  # (C,) normal relative acceleration A f + b, m/s^2


def free_acceleration(bodies: Bodies, u: np.ndarray, F: np.ndarray, T: np.ndarray) -> np.ndarray:
    """(N, 6): F / M and I^-1 (T + L x w) per body (note 001, "Summary LCP-based Contact Forces")."""
    w = u[:, 3:]
    L = np.einsum("nij,nj->ni", np.linalg.pinv(bodies.I_inv), w)  # a locked body (I^-1 = 0) has w = 0
    return np.column_stack([bodies.m_inv[:, None] * F,
                            np.einsum("nij,nj->ni", bodies.I_inv, T + np.cross(L, w))])


def lcp_terms(contacts: list[Contact], bodies: Bodies, u: np.ndarray, F: np.ndarray,
              T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A and b of the note. u (N, 6) velocities; F, T (N, 3) external force and torque."""
    rows = build_rows([dataclasses.replace(c, mu=0.0) for c in contacts], u)
    acc = free_acceleration(bodies, u, F, T)
    b = np.zeros(len(contacts))
    for j, c in enumerate(contacts):
        n = np.asarray(c.n, dtype=float)
        B = _side(acc[c.a], u[c.a, 3:], c.r_a)
        n_dot = np.zeros(3)
        if c.b != STATIC:
            B = B - _side(acc[c.b], u[c.b, 3:], c.r_b)
            n_dot = np.cross(u[c.b, 3:], n)
        b[j] = n @ B + 2.0 * n_dot @ contact_velocity(c, u)
    return delassus(rows, bodies), b


def _side(acc: np.ndarray, w: np.ndarray, r) -> np.ndarray:
    """One body's term of B_j: F/M + (I^-1 (T + L x w)) x r + w x (w x r)."""
    return acc[:3] + np.cross(acc[3:], r) + np.cross(w, np.cross(w, r))


def contact_forces(contacts: list[Contact], bodies: Bodies, u: np.ndarray, F: np.ndarray,
                   T: np.ndarray) -> ContactForces:
    A, b = lcp_terms(contacts, bodies, u, F, T)
    f = lemke_or_retry(A, b)
    return ContactForces(f, A @ f + b)


def unsupported(world) -> str | None:
    if any(m.mu_s > 0.0 for m in (world.material, *world.pair_materials.values())):
        return ("friction asked: the acceleration-level LCP of note 001 gives normal forces "
                "only (the slides compute friction separately)")
    return None


def solve(contacts, bodies, dt: float, config) -> tuple[str, ...]:
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
    W = np.array([[*body.v0, *body.w0] for body in bodies], dtype=float).reshape(-1, 6)
    impulse = lemke_or_retry(delassus(rows, data), -lcp.world_rhs(contacts, rows, W))
    W_after = W + lcp.velocity_change(rows, data, impulse)
    resting = [j for j, (c, v) in enumerate(zip(contacts, lcp.row_velocity(rows, W_after)))
               if c.depth >= 0.0 and v <= config.tolerance]
    u_new = W_after + (u - W)
    stages = ["impact", "forces"]
    if resting:
        dv = (u - W) / dt  # external accelerations; as forces F = m dv, T = I dw
        F_ext = dv[:, :3] / np.where(data.m_inv > 0.0, data.m_inv, np.inf)[:, None]
        T_ext = np.einsum("nij,nj->ni", np.linalg.pinv(data.I_inv), dv[:, 3:])
        geometry = lcp.world_contacts([contacts[j] for j in resting])
        found = contact_forces(geometry, data, W_after, F_ext, T_ext)
        rest_rows = build_rows([dataclasses.replace(c, mu=0.0) for c in geometry], W_after)
        u_new += dt * lcp.velocity_change(rest_rows, data, found.f)
        impulse = impulse.copy()
        impulse[resting] += dt * found.f
    lcp.apply_velocity_change(bodies, u_new - u)
    for c, P in zip(contacts, impulse):
        c.Pn, c.Pt = float(P), [0.0] * len(c.tangents)
    if pgs.repair_overlap(contacts, bodies, rows, data, config):
        stages.append("position")
    return tuple(stages)


def knobs(config) -> dict:
    """What this formulation does with the world's contacts, for the adapter's record."""
    return {"impacts": "velocity-level LCP by Lemke on the velocities before external forces",
            "resting": "acceleration-level LCP (Baraff, note 001) by Lemke",
            "friction": "none (refused)", "depenetration": "split impulse: PGS on pseudo-velocities",
            "tolerance": config.tolerance}
