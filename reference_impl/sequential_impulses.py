"""Sequential impulses, the default formulation "si" (note 001, "sequential impulses";
note 000, projected Gauss-Seidel on J M^-1 J^T gamma = b).

Per step, after gravity is in the velocities:

1. warm start: apply last step's accumulated impulses of the same contacts (note 001,
   "inter-timestep persistence"); with them a resting stack is solved before iterating.
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


def solve(contacts, bodies, dt, config) -> tuple[str, ...]:
    stages = []
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
