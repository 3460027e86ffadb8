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
stack takes one sweep per step.
The sweeps (`iterate`) run compiled (reference_impl/compiled.py) on the rows' numbers
packed into arrays; they are contact.Row's `velocity` and `apply`, written out on arrays.
"""
from __future__ import annotations

import math

import numpy as np

from reference_impl.compiled import njit

CONTACT_TORQUES = True  # models rolling resistance and torsional friction (torque rows)


def solve(contacts, bodies, dt, config) -> tuple[str, ...]:
    stages = []
    if config.warm_start and not any(c.warm for c in contacts) \
            and sum(1 + len(c.tangents) for c in contacts) <= config.cold_start_rows:
        stages.append("cold_start")
        _least_squares_start(contacts)
    warm = config.warm_start and any(c.Pn != 0.0 for c in contacts)
    if warm:
        stages.append("warm_start")
    stages.append("velocity")
    if any(c.tangents for c in contacts):
        stages.append("friction")
    if any(c.torques for c in contacts):
        stages.append("torques")
    if any(c.bias > 0.0 for c in contacts):
        stages.append("position")

    # the contacts' rows (contact.Row) as arrays for the compiled sweeps: per contact its
    # normal row, then its tangent rows, then its torque rows; P holds each row's
    # accumulated impulse
    rows = [row for c in contacts for row in (c.normal, *c.tangents, *c.torques)]
    a = np.array([row.a.index for row in rows], dtype=np.int64)
    b = np.array([row.b.index for row in rows], dtype=np.int64)
    J = np.array([(row.d, row.ra_d, row.rb_d, row.ma, row.mb, row.ia, row.ib) for row in rows],
                 dtype=float).reshape(-1, 21)
    K, mass = np.array([row.K for row in rows], dtype=float), np.array([row.mass for row in rows], dtype=float)
    P = np.array([P for c in contacts for P in (c.Pn, *c.Pt, *c.Pq)], dtype=float)
    n_tangents = np.array([len(c.tangents) for c in contacts], dtype=np.int64)
    n_rolling = np.array([c.n_rolling for c in contacts], dtype=np.int64)
    n_torsion = np.array([len(c.torques) - c.n_rolling for c in contacts], dtype=np.int64)
    target, mu, bias, rolling, torsion = (np.array([getattr(c, name) for c in contacts], dtype=float)
                                          for name in ("target", "mu", "bias", "rolling", "torsion"))
    v, w = np.array([body.v for body in bodies], dtype=float), np.array([body.w for body in bodies], dtype=float)
    vp, wp = np.array([body.vp for body in bodies], dtype=float), np.array([body.wp for body in bodies], dtype=float)
    pyramid = config.params.get("friction_set", "disc") == "pyramid"
    iterate(a, b, J, K, mass, P, n_tangents, n_rolling, n_torsion, target, mu, rolling, torsion, bias,
            v, w, vp, wp, warm, pyramid, config.iterations, config.position_iterations, float(config.tolerance))
    for body, v_i, w_i, vp_i, wp_i in zip(bodies, v.tolist(), w.tolist(), vp.tolist(), wp.tolist()):
        if not body.static:
            body.v[:], body.w[:], body.vp[:], body.wp[:] = v_i, w_i, vp_i, wp_i
    k, P = 0, P.tolist()
    for c in contacts:
        nt, nq = len(c.tangents), len(c.torques)
        c.Pn, c.Pt, c.Pq = P[k], P[k + 1:k + 1 + nt], P[k + 1 + nt:k + 1 + nt + nq]
        k += 1 + nt + nq
    return tuple(stages)


@njit
def iterate(a, b, J, K, mass, P, n_tangents, n_rolling, n_torsion, target, mu, rolling, torsion, bias,
            v, w, vp, wp, warm, pyramid, iterations, position_iterations, tolerance):
    """Steps 1 (the warm start's impulses), 2 and 3 of the module docstring, in place on
    the row impulses P, the velocities v, w and the pseudo-velocities vp, wp (per body,
    by world index). Row k joins bodies a[k] and b[k]; J[k] holds its d, r_a x d, r_b x d,
    d / m_a, d / m_b, I_a^-1 (r_a x d), I_b^-1 (r_b x d) (contact.Row)."""
    C = len(n_tangents)
    first = np.zeros(C, dtype=np.int64)  # each contact's normal row
    for j in range(1, C):
        first[j] = first[j - 1] + 1 + n_tangents[j - 1] + n_rolling[j - 1] + n_torsion[j - 1]
    if warm:
        for k in range(len(P)):
            _apply(J[k], P[k], v[a[k]], w[a[k]], v[b[k]], w[b[k]])

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
            Pn = max(P[k] + mass[k] * (target[j] - _velocity(J[k], v[a[k]], w[a[k]], v[b[k]], w[b[k]])), 0.0)
            dP = Pn - P[k]
            if dP != 0.0:
                P[k] = Pn
                _apply(J[k], dP, v[a[k]], w[a[k]], v[b[k]], w[b[k]])
                largest = max(largest, abs(dP) * K[k])
        if largest <= tolerance:
            break

    if np.any(bias > 0.0):
        targets = np.empty(C)
        for j in range(C):
            k = first[j]
            targets[j] = bias[j] - max(_velocity(J[k], v[a[k]], w[a[k]], v[b[k]], w[b[k]]), 0.0)
        Pp = np.zeros(C)
        for _ in range(position_iterations):
            largest = 0.0
            for j in range(C):
                k = first[j]
                P_j = max(Pp[j] + mass[k] * (targets[j] - _velocity(J[k], vp[a[k]], wp[a[k]], vp[b[k]], wp[b[k]])),
                          0.0)
                dP = P_j - Pp[j]
                if dP != 0.0:
                    Pp[j] = P_j
                    _apply(J[k], dP, vp[a[k]], wp[a[k]], vp[b[k]], wp[b[k]])
                    largest = max(largest, abs(dP) * K[k])
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
            P_t = max(-limit, min(limit, P[t] - mass[t] * _velocity(J[t], v[a[t]], w[a[t]], v[b[t]], w[b[t]])))
            dP = P_t - P[t]
            if dP != 0.0:
                P[t] = P_t
                _apply(J[t], dP, v[a[t]], w[a[t]], v[b[t]], w[b[t]])
                largest = max(largest, abs(dP) * K[t])
        return largest
    t1, t2 = first, first + 1
    P1 = P[t1] - mass[t1] * _velocity(J[t1], v[a[t1]], w[a[t1]], v[b[t1]], w[b[t1]])
    P2 = P[t2] - mass[t2] * _velocity(J[t2], v[a[t2]], w[a[t2]], v[b[t2]], w[b[t2]])
    norm = math.sqrt(P1 * P1 + P2 * P2)
    if norm > limit:
        scale = limit / norm
        P1, P2 = P1 * scale, P2 * scale
    d1, d2 = P1 - P[t1], P2 - P[t2]
    P[t1], P[t2] = P1, P2
    if d1 != 0.0:
        _apply(J[t1], d1, v[a[t1]], w[a[t1]], v[b[t1]], w[b[t1]])
    if d2 != 0.0:
        _apply(J[t2], d2, v[a[t2]], w[a[t2]], v[b[t2]], w[b[t2]])
    return max(abs(d1) * K[t1], abs(d2) * K[t2])


# the two inner-loop operations of contact.Row on one row's J (see iterate)
@njit
def _velocity(J, va, wa, vb, wb) -> float:
    """Row.velocity: d . (v_b - v_a) + (r_b x d) . w_b - (r_a x d) . w_a."""
    return (J[0] * (vb[0] - va[0]) + J[1] * (vb[1] - va[1]) + J[2] * (vb[2] - va[2])
            + J[6] * wb[0] + J[7] * wb[1] + J[8] * wb[2]
            - J[3] * wa[0] - J[4] * wa[1] - J[5] * wa[2])


@njit
def _apply(J, P, va, wa, vb, wb) -> None:
    """Row.apply: impulse P d on b at its contact point, -P d on a."""
    va[0] -= P * J[9]; va[1] -= P * J[10]; va[2] -= P * J[11]
    wa[0] -= P * J[15]; wa[1] -= P * J[16]; wa[2] -= P * J[17]
    vb[0] += P * J[12]; vb[1] += P * J[13]; vb[2] += P * J[14]
    wb[0] += P * J[18]; wb[1] += P * J[19]; wb[2] += P * J[20]


def _least_squares_start(contacts) -> None:
    """Pn, Pt = the minimum-norm P of J M^-1 J^T P = v_target - J v (rows: each contact's
    normal, then its tangents; tangent targets 0), then Pn >= 0 and |Pt| <= mu Pn."""
    rows = [row for c in contacts for row in (c.normal, *c.tangents)]
    column = {}  # body -> its 6 columns (v, w) in J; static bodies have none
    for row in rows:
        for body in (row.a, row.b):
            if not body.static and body not in column:
                column[body] = 6 * len(column)
    J = np.zeros((len(rows), 6 * len(column)))
    W = np.zeros_like(J)  # rows of M^-1 J^T
    for k, row in enumerate(rows):
        for body, sign, arm, linear, angular in ((row.a, -1.0, row.ra_d, row.ma, row.ia),
                                                 (row.b, 1.0, row.rb_d, row.mb, row.ib)):
            if body in column:
                j = column[body]
                J[k, j:j + 3], J[k, j + 3:j + 6] = sign * np.array(row.d), sign * np.array(arm)
                W[k, j:j + 3], W[k, j + 3:j + 6] = sign * np.array(linear), sign * np.array(angular)
    rhs = np.array([(c.target if k == 0 else 0.0) - row.velocity()
                    for c in contacts for k, row in enumerate((c.normal, *c.tangents))])
    # rcond: drop the exact null space (the indeterminate split among a face's corners),
    # keep every physical mode (the stiffest-to-softest ratio of a ten-box stack is ~1e-4)
    P = np.linalg.lstsq(J @ W.T, rhs, rcond=1e-10)[0].tolist()
    k = 0
    for c in contacts:
        c.Pn = max(P[k], 0.0)
        Pt = P[k + 1:k + 1 + len(c.tangents)]
        norm, limit = math.sqrt(sum(x * x for x in Pt)), c.mu * c.Pn
        c.Pt = [x * limit / norm for x in Pt] if norm > limit else Pt
        k += 1 + len(c.tangents)


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
