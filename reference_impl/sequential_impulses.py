"""Sequential impulses, the default formulation "si" (note 001, "sequential impulses";
note 000, projected Gauss-Seidel on J M^-1 J^T gamma = b).

Per step, after gravity is in the velocities:

1. warm start: apply last step's accumulated impulses of the same contacts (note 001,
   "inter-timestep persistence"); with them a resting stack is solved before iterating.
   Cold start (no contact has last step's impulses, e.g. a scene that starts at rest):
   start from the minimum-norm least-squares solution of the unclamped system
   J M^-1 J^T P = v_target - J v over all rows, clamped into the bounds below. Why: the
   impulses of a face resting on four corners are indeterminate, and Gauss-Seidel from
   zero, which pushes one corner at a time, rocks the bodies and locks in friction
   stresses; those relax at the rate of the stack's slowest mode (per sweep 0.9968 for
   five boxes, 0.99978 for ten: computed from J M^-1 J^T), so a ten-box stack took ~700
   steps of 200 sweeps to settle and walked sideways. The minimum-norm solution is the
   symmetric one (no internal stress); it only sets where the sweeps start, not where
   they end.
2. velocity iterations: up to `iterations` sweeps over the contacts in the order the
   world found them (body pairs by index, then the points of each pair); per contact its
   friction rows first, then its normal row (the last word in a sweep is
   non-penetration). Each row accumulates its impulse and clamps the accumulated value
   (note 001, "impulse update with accumulation"):
     normal:   Pn = max(Pn + m_n (target - v_n), 0),   m_n = 1 / K_n
     friction: Pt = Pt + m_t (0 - v_t) for both tangents (from the same velocities),
               then Pt is kept inside the Coulomb disc |Pt| <= mu Pn: the circular
               section of the cone, not the pyramid, so friction is isotropic (sliding
               at any angle to the tangent basis meets mu Pn, not up to mu Pn sqrt 2).
               mu = mu_s while the contact sticks, mu_k while it slides.
     torques:  after its friction rows, a contact's torque rows (contact.Row.angular, on
               the relative angular velocity about an axis), with the same accumulate-
               and-clamp as friction and the lever arm in place of mu:
               rolling resistance about the two tangent axes (one in 2D), target 0,
               the pair kept inside the disc |Pr| <= d_r Pn; torsional friction about n,
               Pq in [-d_t Pn, d_t Pn]. This is how Bullet's sequential impulses
               (btSequentialImpulseConstraintSolver: rolling and spinning friction as
               angular-only friction rows bounded by the coefficient times the normal
               impulse) and Box2D v3 (contact_solver.c, rolling resistance: an angular
               impulse clamped to rollingResistance times the normal impulse) model them;
               note 001 ("dry friction") names rolling friction, mu_r = d_r / r.
   A sweep whose largest velocity change |dP| K is at most `tolerance` ends the loop.
   (config.params["friction_set"] = "pyramid" clamps each tangent row to [-mu Pn, mu Pn]
   on its own instead: lcp.py's friction set, kept to show what the disc buys.)
3. position correction with pseudo-velocities (split impulse): the bias velocity
   beta/dt (delta - slop)+ of note 001 is the target of a second set of normal rows that
   act on pseudo-velocities vp, wp (up to `position_iterations` sweeps). They move the
   positions this step and are then dropped, so pushing bodies apart adds no kinetic
   energy: note 001 puts the bias into the velocity impulse, which would launch a ball
   that came to rest at depth delta with speed beta/dt delta and spoil restitution. The
   bias asks for v + vp >= bias: a contact already leaving faster (a bounce) is not
   pushed as well, which would add potential energy g delta per bounce.

Restitution. The normal target is -e vn0 for an approaching contact (vn0 < 0), else 0
(`Contact.normal_target`), where vn0 is the relative normal velocity at the start of the
step, before gravity was added. Why before: a ball that reaches the ground with speed u
has, at the start of the contact step, vn0 = -u; gravity then makes it -u - g dt. Solving
v_n+ = -e (-u - g dt) would launch it at e (u + g dt), a ratio e (1 + g dt / u) that
depends on dt and on where in the step contact began. Taking the impact at the start of
the step (the ball is touching) and letting the contact also absorb the step's weight
impulse m g dt gives v_n+ = e u: the ratio is exactly e at any dt and phase. With e = 0
the same target is a resting contact's v_n+ = 0.

Cost: O(rows) per sweep, a few dozen float operations per row; a warm-started resting
stack takes one sweep per step. Compiled (compiled.py), on the contacts' rows
(contact.Contacts) and the bodies' arrays.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from reference_impl import joints as joint_rows
from reference_impl.compiled import njit
from reference_impl.contact import K as K_, MASS, apply, velocity
from reference_impl.lcp import BOXED
from reference_impl.vectors import copy

CONTACT_TORQUES = True  # models rolling resistance and torsional friction (torque rows)


class Settings(NamedTuple):
    iterations: int           # velocity sweeps at most (config.iterations)
    position_iterations: int  # pseudo-velocity sweeps at most
    tolerance: float          # a sweep changing no velocity by more ends the loop, m/s
    warm_start: bool
    cold_start_rows: int      # the least-squares cold start up to this many rows
    pyramid: bool             # config.params["friction_set"] == "pyramid"
    beta: float               # a joint's position error corrected per step (config.beta)
    slop: float               # a joint limit's overrun left alone (config.slop), m or rad


def settings(config) -> Settings:
    return Settings(config.iterations, config.position_iterations, float(config.tolerance), config.warm_start,
                    config.cold_start_rows, config.params.get("friction_set", "disc") == "pyramid",
                    float(config.beta), float(config.slop))


# the stages solve can run, in order (bit k of its result: STAGES[k] ran)
STAGES = ("cold_start", "warm_start", "velocity", "friction", "torques", "position", "joints")
COLD_START, WARM_START, VELOCITY, FRICTION, TORQUES, POSITION, JOINTS = (1 << k for k in range(len(STAGES)))
JOINT_KINDS = frozenset({"ball", "revolute", "prismatic", "fixed"})  # the joints solve_joints takes (joints.py)
JOINT_LIMITS = JOINT_FRICTION = LIMIT_RESTITUTION = True  # limit rows (with limit_e), friction rows


@njit
def solve(contacts, bodies, dt, settings) -> int:
    """The module docstring's steps on the world's contacts and bodies; returns the
    STAGES that ran."""
    return _solve(contacts, bodies, settings, None)


@njit
def solve_joints(contacts, joints, bodies, dt, settings) -> int:
    """`solve` with the joints' rows (joints.py) swept after the contacts' in every sweep
    (note 001, "Joints": v_rel+ = 0, one row at a time; a limit row clamped >= 0 with a
    contact's target, a friction row within -+ friction dt), warm started from their last
    impulses, and in the position repair beside the contacts' normal rows with their
    pseudo-velocity targets (note 001, "joint impulses": bias beta/dt (x_1 - x_2), here
    -beta/dt g; joints.position_bias)."""
    found = joint_rows.links(joints, bodies, settings.beta, dt, settings.slop)
    if not settings.warm_start:
        found.P[:] = 0.0
    warm = np.any(found.P != 0.0)
    return _solve(contacts, bodies, settings, found) | JOINTS | (WARM_START if warm else 0)


@njit
def _solve(contacts, bodies, settings, links) -> int:
    """solve, with the joints' Links (or None: a world without joints, whose compiled
    code then has no joint rows at all)."""
    c, C = contacts, len(contacts.a)
    stages, n_rows, any_warm = VELOCITY, 0, False
    for j in range(C):
        n_rows += 1 + c.n_tangents[j]
        any_warm = any_warm or c.warm[j]
    if settings.warm_start and not any_warm and 0 < n_rows <= settings.cold_start_rows:
        stages |= COLD_START
        _least_squares_start(contacts, bodies, links)
    warm = False
    for j in range(C):
        warm = warm or (settings.warm_start and c.Pn[j] != 0.0)
        stages |= ((WARM_START if warm else 0) | (FRICTION if c.n_tangents[j] > 0 else 0)
                   | (TORQUES if c.n_rolling[j] + c.n_torsion[j] > 0 else 0) | (POSITION if c.bias[j] > 0.0 else 0))

    # the contacts' rows as arrays for the sweeps: per contact its normal row, then its
    # tangent rows, then its torque rows; P holds each row's accumulated impulse
    R = 0
    for j in range(C):
        R += 1 + c.n_tangents[j] + c.n_rolling[j] + c.n_torsion[j]
    a, b = np.empty(R, np.int64), np.empty(R, np.int64)
    J, K, mass, P = np.empty((R, 21)), np.empty(R), np.empty(R), np.empty(R)
    k = 0
    for j in range(C):
        nt, nq = c.n_tangents[j], c.n_rolling[j] + c.n_torsion[j]
        for r in range(1 + nt + nq):
            row = c.normal[j] if r == 0 else (c.tangents[j, r - 1] if r <= nt else c.torques[j, r - 1 - nt])
            a[k], b[k], K[k], mass[k] = c.a[j], c.b[j], row[K_], row[MASS]
            copy(J[k], row[:21])
            P[k] = c.Pn[j] if r == 0 else (c.Pt[j, r - 1] if r <= nt else c.Pq[j, r - 1 - nt])
            k += 1
    iterate(a, b, J, K, mass, P, c.n_tangents, c.n_rolling, c.n_torsion, c.target, c.mu, c.rolling, c.torsion,
            c.bias, bodies.v, bodies.w, bodies.vp, bodies.wp, warm, settings.pyramid, settings.iterations,
            settings.position_iterations, settings.tolerance, links)
    k = 0
    for j in range(C):
        nt, nq = c.n_tangents[j], c.n_rolling[j] + c.n_torsion[j]
        c.Pn[j] = P[k]
        for t in range(nt):
            c.Pt[j, t] = P[k + 1 + t]
        for t in range(nq):
            c.Pq[j, t] = P[k + 1 + nt + t]
        k += 1 + nt + nq
    return stages


@njit(inline=True)
def iterate(a, b, J, K, mass, P, n_tangents, n_rolling, n_torsion, target, mu, rolling, torsion, bias,
            v, w, vp, wp, warm, pyramid, iterations, position_iterations, tolerance, links=None):
    """Steps 1 (the warm start's impulses), 2 and 3 of the module docstring, in place on
    the row impulses P, the velocities v, w and the pseudo-velocities vp, wp (per body,
    by world index). Row k joins bodies a[k] and b[k]; J[k] holds its d, r_a x d, r_b x d,
    d / m_a, d / m_b, I_a^-1 (r_a x d), I_b^-1 (r_b x d) (contact.py's row numbers).
    `links` (joints.Links, or None): the joints' rows, swept after the contacts' in each
    sweep of steps 2 and 3, their impulses in links.P and links.Pp (None is pruned when
    compiled: a world without joints runs the code it ran before joints existed)."""
    C = len(n_tangents)
    first = np.zeros(C, dtype=np.int64)  # each contact's normal row
    for j in range(1, C):
        first[j] = first[j - 1] + 1 + n_tangents[j - 1] + n_rolling[j - 1] + n_torsion[j - 1]
    if warm:
        for k in range(len(P)):
            apply(J[k], P[k], v[a[k]], w[a[k]], v[b[k]], w[b[k]])
    if links is not None:  # the joints' warm start (zero without one: solve_joints)
        joint_rows.apply_impulses(links, links.P, v, w)

    for _ in range(iterations):
        largest = 0.0
        for j in range(C):
            k = first[j]
            if n_tangents[j]:
                largest = max(largest, _friction(k, k + 1, n_tangents[j], a, b, J, K, mass, P, mu[j], v, w,
                                                 pyramid))
            q = k + 1 + n_tangents[j]  # the first torque row
            if n_rolling[j]:  # the disc |Pr| <= d_r Pn (2D: the interval)
                largest = max(largest, _friction(k, q, n_rolling[j], a, b, J, K, mass, P, rolling[j], v, w,
                                                 False))
            if n_torsion[j]:  # the interval [-d_t Pn, d_t Pn]
                largest = max(largest, _friction(k, q + n_rolling[j], 1, a, b, J, K, mass, P, torsion[j], v, w,
                                                 False))
            Pn = max(P[k] + mass[k] * (target[j] - velocity(J[k], v[a[k]], w[a[k]], v[b[k]], w[b[k]])), 0.0)
            dP = Pn - P[k]
            if dP != 0.0:
                P[k] = Pn
                apply(J[k], dP, v[a[k]], w[a[k]], v[b[k]], w[b[k]])
                largest = max(largest, abs(dP) * K[k])
        if links is not None:
            largest = max(largest, joint_rows.sweep(links, links.P, links.target, v, w, True))
        if largest <= tolerance:
            break

    repair = np.any(bias > 0.0)
    if links is not None:
        repair = repair or np.any(links.bias != 0.0)
    if repair:
        targets = np.empty(C)
        for j in range(C):
            k = first[j]
            targets[j] = bias[j] - max(velocity(J[k], v[a[k]], w[a[k]], v[b[k]], w[b[k]]), 0.0)
        Pp = np.zeros(C)
        for _ in range(position_iterations):
            largest = 0.0
            for j in range(C):
                k = first[j]
                P_j = max(Pp[j] + mass[k] * (targets[j] - velocity(J[k], vp[a[k]], wp[a[k]], vp[b[k]], wp[b[k]])),
                          0.0)
                dP = P_j - Pp[j]
                if dP != 0.0:
                    Pp[j] = P_j
                    apply(J[k], dP, vp[a[k]], wp[a[k]], vp[b[k]], wp[b[k]])
                    largest = max(largest, abs(dP) * K[k])
            if links is not None:
                largest = max(largest, joint_rows.sweep(links, links.Pp, links.bias, vp, wp, False))
            if largest <= tolerance:
                break


@njit
def _friction(k, first, count, a, b, J, K, mass, P, mu, v, w, pyramid) -> float:
    """The rows first .. first + count - 1 (a contact's tangent rows, or its torque rows
    with the lever arm as mu) of the contact whose normal row is k, clamped to the disc
    |Pt| <= mu Pn; returns the largest velocity change made. (pyramid: each row clamped
    to [-mu Pn, mu Pn] on its own, the friction set of lcp.py, which is the disc in 2D.)"""
    limit = mu * P[k]
    if count == 1 or pyramid:  # 2D: the disc is the interval [-mu Pn, mu Pn]
        largest = 0.0
        for t in range(first, first + count):
            P_t = max(-limit, min(limit, P[t] - mass[t] * velocity(J[t], v[a[t]], w[a[t]], v[b[t]], w[b[t]])))
            dP = P_t - P[t]
            if dP != 0.0:
                P[t] = P_t
                apply(J[t], dP, v[a[t]], w[a[t]], v[b[t]], w[b[t]])
                largest = max(largest, abs(dP) * K[t])
        return largest
    t1, t2 = first, first + 1
    P1 = P[t1] - mass[t1] * velocity(J[t1], v[a[t1]], w[a[t1]], v[b[t1]], w[b[t1]])
    P2 = P[t2] - mass[t2] * velocity(J[t2], v[a[t2]], w[a[t2]], v[b[t2]], w[b[t2]])
    norm = math.sqrt(P1 * P1 + P2 * P2)
    if norm > limit:
        scale = limit / norm
        P1, P2 = P1 * scale, P2 * scale
    d1, d2 = P1 - P[t1], P2 - P[t2]
    P[t1], P[t2] = P1, P2
    if d1 != 0.0:
        apply(J[t1], d1, v[a[t1]], w[a[t1]], v[b[t1]], w[b[t1]])
    if d2 != 0.0:
        apply(J[t2], d2, v[a[t2]], w[a[t2]], v[b[t2]], w[b[t2]])
    return max(abs(d1) * K[t1], abs(d2) * K[t2])

@njit
def _least_squares_start(contacts, bodies, links=None) -> None:
    """Pn, Pt = the minimum-norm P of J M^-1 J^T P = v_target - J v (rows: each contact's
    normal, then its tangents; tangent targets 0), then Pn >= 0 and |Pt| <= mu Pn. With
    the joints' `links`, their rows join the system (targets joints.target, a limit row
    that cannot act this step left out) and their impulses start from it too, clamped to
    their bounds: a contact's share of a load a joint carries (a grasp's pads on their
    sliders) is then that of the joined system, not of free bodies."""
    c, C, N = contacts, len(contacts.a), len(bodies.x)
    column = np.full(N, -1, np.int64)  # body -> its 6 columns (v, w) in J; static bodies have none
    n_rows, used = 0, 0
    for j in range(C):
        n_rows += 1 + c.n_tangents[j]
        for body in (c.a[j], c.b[j]):
            if not bodies.static[body] and column[body] < 0:
                column[body] = 6 * used
                used += 1
    contact_rows = n_rows
    if links is not None:
        n_rows += len(links.P)
        for k in range(len(links.P)):
            for body in (links.rows.a[k], links.rows.b[k]):
                if body != -1 and not bodies.static[body] and column[body] < 0:
                    column[body] = 6 * used
                    used += 1
    J = np.zeros((n_rows, 6 * used))
    W = np.zeros_like(J)  # rows of M^-1 J^T
    rhs = np.empty(n_rows)
    k = 0
    for j in range(C):
        for r in range(1 + c.n_tangents[j]):
            row = c.normal[j] if r == 0 else c.tangents[j, r - 1]
            for body, sign, arm, linear, angular in ((c.a[j], -1.0, 3, 9, 15), (c.b[j], 1.0, 6, 12, 18)):
                col = column[body]
                if col >= 0:
                    for e in range(3):
                        J[k, col + e], J[k, col + 3 + e] = sign * row[e], sign * row[arm + e]
                        W[k, col + e], W[k, col + 3 + e] = sign * row[linear + e], sign * row[angular + e]
            a, b = c.a[j], c.b[j]
            rhs[k] = (c.target[j] if r == 0 else 0.0) - velocity(row, bodies.v[a], bodies.w[a], bodies.v[b],
                                                                  bodies.w[b])
            k += 1
    if links is not None:
        rows = links.rows
        for m in range(len(links.P)):
            rhs[k + m] = 0.0
            if links.target[m] == -np.inf:  # cannot act this step: a zero row
                continue
            speed = 0.0
            for side in range(2):  # body a, then b
                body = rows.a[m] if side == 0 else rows.b[m]
                G, M_G = (rows.J_a[m], links.W_a[m]) if side == 0 else (rows.J_b[m], links.W_b[m])
                if body != -1 and column[body] >= 0:
                    for e in range(3):
                        J[k + m, column[body] + e], W[k + m, column[body] + e] = G[e], M_G[e]
                        J[k + m, column[body] + 3 + e], W[k + m, column[body] + 3 + e] = G[3 + e], M_G[3 + e]
                        speed += G[e] * bodies.v[body, e] + G[3 + e] * bodies.w[body, e]
            rhs[k + m] = links.target[m] - speed
    # rcond: drop the exact null space (the indeterminate split among a face's corners),
    # keep every physical mode (the stiffest-to-softest ratio of a ten-box stack is ~1e-4)
    P = np.linalg.lstsq(J @ W.T, rhs, rcond=1e-10)[0]
    if links is not None:
        for m in range(len(links.P)):
            lam, nk = P[contact_rows + m], links.rows.normal[m]
            if nk == BOXED:
                lam = max(-links.rows.mu[m], min(links.rows.mu[m], lam))
            elif nk >= 0:
                lam = max(lam, 0.0)
            links.P[m] = lam
    k = 0
    for j in range(C):
        nt = c.n_tangents[j]
        c.Pn[j] = max(P[k], 0.0)
        norm = 0.0
        for t in range(nt):
            norm += P[k + 1 + t] * P[k + 1 + t]
        norm, limit = math.sqrt(norm), c.mu[j] * c.Pn[j]
        for t in range(nt):
            c.Pt[j, t] = P[k + 1 + t] * limit / norm if norm > limit else P[k + 1 + t]
        k += 1 + nt


def knobs(config) -> dict:
    """What this formulation does with the world's contacts, for the adapter's record."""
    pyramid = config.params.get("friction_set", "disc") == "pyramid"
    return {"solver": "sequential impulses: accumulated, clamped row impulses swept in contact order (note 001)",
            "friction_set": ("pyramid: |Pt_k| <= mu Pn on each tangent row" if pyramid
                             else "disc: |Pt| <= mu Pn (isotropic)"),
            "contact_torques": "rolling: disc |Pr| <= rolling Pn about the tangent axes; torsion: "
                               "|Pq| <= torsion Pn about n (lever arms in m)",
            "restitution": "v_n+ = -e vn0, vn0 at the start of the step (before gravity)",
            "depenetration": "split impulse: sweeps on pseudo-velocities",
            "cold_start": f"least-squares impulses when no contact is warm (up to {config.cold_start_rows} rows)",
            "iterations": config.iterations, "tolerance": config.tolerance, "warm_start": config.warm_start}
