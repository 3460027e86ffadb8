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
   A sweep whose largest velocity change |dP| K is at most `tolerance` ends the loop.
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
"""
from __future__ import annotations

import math

import numpy as np


def solve(contacts, bodies, dt, config) -> tuple[str, ...]:
    stages = []
    if config.warm_start and not any(c.warm for c in contacts) \
            and sum(1 + len(c.tangents) for c in contacts) <= config.cold_start_rows:
        stages.append("cold_start")
        _least_squares_start(contacts)
    if config.warm_start and any(c.Pn != 0.0 for c in contacts):
        stages.append("warm_start")
        for c in contacts:
            c.normal.apply(c.Pn)
            for row, P in zip(c.tangents, c.Pt):
                row.apply(P)

    stages.append("velocity")
    if any(c.tangents for c in contacts):
        stages.append("friction")
    for _ in range(config.iterations):
        largest = 0.0
        for c in contacts:
            if c.tangents:
                largest = max(largest, _friction(c))
            row = c.normal
            Pn = max(c.Pn + row.mass * (c.target - row.velocity()), 0.0)
            dP = Pn - c.Pn
            if dP != 0.0:
                c.Pn = Pn
                row.apply(dP)
                largest = max(largest, abs(dP) * row.K)
        if largest <= config.tolerance:
            break

    if any(c.bias > 0.0 for c in contacts):
        stages.append("position")
        targets = [c.bias - max(c.normal.velocity(), 0.0) for c in contacts]
        for c in contacts:
            c.Pp = 0.0
        for _ in range(config.position_iterations):
            largest = 0.0
            for c, target in zip(contacts, targets):
                row = c.normal
                Pp = max(c.Pp + row.mass * (target - row.pseudo_velocity()), 0.0)
                dP = Pp - c.Pp
                if dP != 0.0:
                    c.Pp = Pp
                    row.apply_pseudo(dP)
                    largest = max(largest, abs(dP) * row.K)
            if largest <= config.tolerance:
                break
    return tuple(stages)


def _friction(c) -> float:
    """The tangent rows of one contact, clamped to the disc |Pt| <= mu Pn; returns the
    largest velocity change made."""
    Pt, limit = c.Pt, c.mu * c.Pn
    if len(Pt) == 1:  # 2D: the disc is the interval [-mu Pn, mu Pn]
        (t,) = c.tangents
        P = max(-limit, min(limit, Pt[0] - t.mass * t.velocity()))
        dP = P - Pt[0]
        if dP == 0.0:
            return 0.0
        Pt[0] = P
        t.apply(dP)
        return abs(dP) * t.K
    t1, t2 = c.tangents
    P1 = Pt[0] - t1.mass * t1.velocity()
    P2 = Pt[1] - t2.mass * t2.velocity()
    norm = math.sqrt(P1 * P1 + P2 * P2)
    if norm > limit:
        scale = limit / norm
        P1, P2 = P1 * scale, P2 * scale
    d1, d2 = P1 - Pt[0], P2 - Pt[1]
    Pt[0], Pt[1] = P1, P2
    if d1 != 0.0:
        t1.apply(d1)
    if d2 != 0.0:
        t2.apply(d2)
    return max(abs(d1) * t1.K, abs(d2) * t2.K)


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
