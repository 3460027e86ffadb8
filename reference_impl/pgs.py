"""Projected Gauss-Seidel for the contact LCP of lcp.py (note 000, "Solving the LCP system",
"PGS iteration applied to contact", "PGS for friction"; note 004, "SPOOK - iterations").

Row i is solved assuming the others are right and clamped to its bounds:
    gamma_i <- clamp(gamma_i - ((A + Sigma) gamma - b)_i / (A_ii + Sigma_ii), lo_i, hi_i)
with lo, hi = 0, inf on normal rows and -+ mu gamma_n on tangent rows (the friction
pyramid, see lcp.py). Sigma is SPOOK's regularisation (zero for the impact LCP).

Per-body sums ("a nice trick for maintaining these sums efficiently per object", note 000):
we keep du = M^-1 J^T gamma per body, so (A gamma)_i = J_i du reads only the two bodies
of row i, and a change of gamma_i updates only their two entries. One sweep therefore
costs O(rows), not O(rows^2), and A is never formed.
Compiled (compiled.py), as is the world formulation "pgs" below.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from reference_impl import joints as joint_rows
from reference_impl.compiled import njit
from reference_impl.lcp import (BOXED, Bodies, Rows, _add_at, apply_velocity_change, inverse_mass_times_rows, lanes,
                                normal_rows, row_velocity, stack_rows, store_impulses, world_bias, world_impulses,
                                world_rhs, world_rows)


@dataclass(frozen=True)
class PGSSettings:
    iterations: int = 1000     # sweeps at most
    # stop after a sweep whose largest velocity correction (A_ii + Sigma_ii) |d gamma_i|
    # is below this, in m/s; 1e-13 sits just above the rounding of O(1) velocities
    tolerance: float = 1e-13

    def __post_init__(self):
        if not isinstance(self.iterations, int) or self.iterations < 1:
            raise ValueError(f"iterations = {self.iterations!r}: must be a whole number >= 1")
        if not self.tolerance >= 0:
            raise ValueError(f"tolerance = {self.tolerance!r}: must be >= 0")


class PGSResult(NamedTuple):
    gamma: np.ndarray   # (K,) row impulses
    du: np.ndarray      # (N, 6) velocity change M^-1 J^T gamma per body
    sweeps: int         # sweeps done
    change: float       # largest velocity correction of the last sweep, m/s


def projected_gauss_seidel(rows: Rows, bodies: Bodies, b: np.ndarray, settings: PGSSettings = PGSSettings(),
                           sigma: np.ndarray | None = None, gamma0: np.ndarray | None = None) -> PGSResult:
    """Projected Gauss-Seidel on (A + Sigma) gamma - b with the bounds of lcp.bounds,
    starting from gamma0 (warm start) or zero. Rows are swept in their stored order."""
    K = len(rows.a)
    return gauss_seidel(rows, bodies, np.asarray(b, dtype=float), int(settings.iterations), float(settings.tolerance),
                        np.zeros(K) if sigma is None else np.asarray(sigma, dtype=float),
                        np.zeros(K) if gamma0 is None else np.asarray(gamma0, dtype=float), gamma0 is not None)


@njit
def gauss_seidel(rows, bodies, b, iterations, tolerance, sigma, gamma0, warm) -> PGSResult:
    """projected_gauss_seidel, from gamma0 when warm (else from zero)."""
    K, N = len(rows.a), len(bodies.m_inv)
    W_a, W_b = inverse_mass_times_rows(rows, bodies)
    diag, inv_diag = np.empty(K), np.empty(K)
    for k in range(K):
        diag[k] = lanes(rows.J_a[k], W_a[k]) + lanes(rows.J_b[k], W_b[k]) + sigma[k]
        inv_diag[k] = 1.0 / diag[k] if diag[k] > 0.0 else 0.0
    gamma = gamma0.copy() if warm else np.zeros(K)
    du = np.zeros((N + 1, 6))  # row N: the static world (index -1), never moves (its W is 0)
    if warm:                   # warm start: the sums of the starting impulses
        _add_at(du, rows.a, W_a, gamma)
        _add_at(du, rows.b, W_b, gamma)
        du[N] = 0.0
    sweeps, change = _sweeps(rows.J_a, rows.J_b, W_a, W_b, rows.a, rows.b, rows.normal, rows.mu, b, sigma, diag,
                             inv_diag, gamma, du, iterations, tolerance)
    return PGSResult(gamma, du[:N].copy(), sweeps, change)


@njit(inline=True)
def _sweeps(Ja, Jb, Wa, Wb, ia, ib, normal, mu, rhs, sg, dg, inv_diag, g, v, iterations, tolerance):
    """The sweeps, in place on g (gamma) and v (du per body, row N the static world):
    (sweeps done, largest velocity correction of the last sweep)."""
    K = len(g)
    sweeps, change = 0, np.inf
    while sweeps < iterations and change > tolerance:
        sweeps += 1
        change = 0.0
        for k in range(K):  # O(1) per row: two bodies' 6-vectors
            ja, jb, da, db = Ja[k], Jb[k], v[ia[k]], v[ib[k]]
            r = (ja[0] * da[0] + ja[1] * da[1] + ja[2] * da[2] + ja[3] * da[3] + ja[4] * da[4]
                 + ja[5] * da[5] + jb[0] * db[0] + jb[1] * db[1] + jb[2] * db[2] + jb[3] * db[3]
                 + jb[4] * db[4] + jb[5] * db[5] + sg[k] * g[k] - rhs[k])
            new = g[k] - r * inv_diag[k]
            nk = normal[k]
            if nk == k:
                if new < 0.0:
                    new = 0.0
            elif nk >= 0:
                limit = mu[k] * g[nk]
                new = -limit if new < -limit else (limit if new > limit else new)
            elif nk == BOXED:  # a joint's friction row: a constant bound
                new = -mu[k] if new < -mu[k] else (mu[k] if new > mu[k] else new)
            # else a joint's equality row (BILATERAL): unbounded, no projection
            d = new - g[k]
            if d != 0.0:
                g[k] = new
                wa, wb = Wa[k], Wb[k]
                for j in range(6):
                    da[j] += wa[j] * d
                    db[j] += wb[j] * d
                step = abs(d) * dg[k]
                if step > change:
                    change = step
    return sweeps, change


class Settings(NamedTuple):
    iterations: int           # sweeps at most (config.iterations)
    position_iterations: int  # sweeps of the overlap repair
    tolerance: float          # m/s
    warm_start: bool
    beta: float               # a joint's position error corrected per step (config.beta)
    slop: float               # a joint limit's overrun left alone (config.slop), m or rad


def settings(config) -> Settings:
    return Settings(config.iterations, config.position_iterations, float(config.tolerance), config.warm_start,
                    float(config.beta), float(config.slop))


STAGES = ("warm_start", "velocity", "friction", "position", "joints")
WARM_START, VELOCITY, FRICTION, POSITION, JOINTS = (1 << k for k in range(len(STAGES)))
JOINT_KINDS = frozenset({"ball", "revolute", "prismatic", "fixed"})  # the joints solve_joints takes (joints.py)
JOINT_LIMITS = JOINT_FRICTION = LIMIT_RESTITUTION = True  # limit rows (with limit_e), friction rows


@njit
def solve(contacts, bodies, dt, settings) -> int:
    """World formulation "pgs" (interface: reference_impl/__init__.py). The velocity-level
    LCP of lcp.py on the world's contacts (targets of lcp.world_rhs; friction pyramid on
    the world's tangent rows, mu_s while a contact sticks, mu_k while it slides), by PGS
    from last step's impulses (config.warm_start), at most config.iterations sweeps.
    Then note 000's overlap repair ("bias target velocity in normal direction proportional
    to overlap") as a frictionless PGS on pseudo-velocities (split impulse, as the default
    formulation does, so the repair moves positions but adds no kinetic energy)."""
    rows, data, u = world_rows(contacts, bodies)
    warm = settings.warm_start and np.any(contacts.Pn != 0.0)
    result = gauss_seidel(rows, data, world_rhs(contacts, rows, u), settings.iterations, settings.tolerance,
                          np.zeros(len(rows.a)), world_impulses(contacts), warm)
    apply_velocity_change(bodies, result.du, False)
    store_impulses(contacts, result.gamma)
    stages = (WARM_START if warm else 0) | VELOCITY | (FRICTION if len(rows.a) > len(contacts.a) else 0)
    if repair_overlap(contacts, bodies, rows, data, settings.position_iterations, settings.tolerance):
        stages |= POSITION
    return stages


@njit
def solve_joints(contacts, joints, bodies, dt, settings) -> int:
    """`solve` with the joints' rows (joints.py) after the contact rows: one PGS over both
    (note 000, "PGS for friction": an equality row unbounded, a friction row within its
    constant bound, a limit row >= 0 as a contact's normal row), warm started from last
    step's impulses of both; targets joints.rhs (G v = 0, a limit's contact target).
    Then the overlap repair with the joint rows beside the contacts' normal rows, their
    pseudo-velocity targets joints.position_bias (note 001, "joint impulses": -beta/dt g
    for an equality, the de-penetration bias for a limit), so that the drift of the
    velocity-level rows is taken back by moving positions, adding no energy."""
    rows, data, u = world_rows(contacts, bodies)
    C, K = len(rows.a), len(joints.g)
    every = stack_rows(rows, joints.rows)
    rhs, start = np.empty(C + K), np.empty(C + K)
    contact_rhs, contact_start, joint_rhs = world_rhs(contacts, rows, u), world_impulses(contacts), \
        joint_rows.rhs(joints, u)
    for k in range(C):
        rhs[k], start[k] = contact_rhs[k], contact_start[k]
    for k in range(K):
        rhs[C + k], start[C + k] = joint_rhs[k], joints.P[k]
    warm = settings.warm_start and (np.any(contacts.Pn != 0.0) or np.any(joints.P != 0.0))
    result = gauss_seidel(every, data, rhs, settings.iterations, settings.tolerance, np.zeros(C + K), start, warm)
    apply_velocity_change(bodies, result.du, False)
    store_impulses(contacts, result.gamma[:C])
    for k in range(K):
        joints.P[k] = result.gamma[C + k]
    stages = (WARM_START if warm else 0) | VELOCITY | (FRICTION if C > len(contacts.a) else 0) | JOINTS
    normal = stack_rows(normal_rows(rows), joint_rows.position_rows(joints))
    overlap = world_bias(contacts, bodies)
    joint_bias = joint_rows.position_bias(joints, settings.beta, dt, settings.slop)
    bias = np.empty(len(overlap) + K)
    for k in range(len(overlap)):
        bias[k] = overlap[k]
    for k in range(K):
        bias[len(overlap) + k] = joint_bias[k]
    if np.any(bias != 0.0):
        pseudo = gauss_seidel(normal, data, bias, settings.position_iterations, settings.tolerance,
                              np.zeros(len(bias)), bias, False)
        apply_velocity_change(bodies, pseudo.du, True)
        stages |= POSITION
    return stages


@njit
def repair_overlap(contacts, bodies, rows, data, iterations, tolerance) -> bool:
    """Note 000's overlap repair on pseudo-velocities (targets: lcp.world_bias), by PGS on
    the normal rows; sets the bodies' vp, wp. Returns whether there was overlap to repair."""
    bias = world_bias(contacts, bodies)
    if not np.any(bias > 0.0):
        return False
    normal = normal_rows(rows)
    pseudo = gauss_seidel(normal, data, bias, iterations, tolerance, np.zeros(len(normal.a)), bias, False)
    apply_velocity_change(bodies, pseudo.du, True)
    return True


def knobs(config) -> dict:
    """What this formulation does with the world's contacts, for the adapter's record."""
    return {"solver": "projected Gauss-Seidel with per-body velocity sums (note 000)",
            "friction_set": "pyramid: |Pt_k| <= mu Pn on each tangent row (t1 along the slip when sliding)",
            "restitution": "v_n+ >= contact.normal_target (-e vn0, vn0 before external forces)",
            "depenetration": "split impulse: PGS on pseudo-velocities",
            "joints": "ball, revolute, prismatic and fixed joints as equality rows in the same PGS (unbounded "
                      "impulse), limits as unilateral rows with a contact's target (limit_e its restitution), "
                      "friction as a row within -+ friction dt; position error taken back on pseudo-velocities "
                      "(-beta/dt g)",
            "iterations": config.iterations, "tolerance": config.tolerance, "warm_start": config.warm_start}
