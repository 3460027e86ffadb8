"""Sequential impulses, the default formulation "si" (note 001, "sequential impulses";
note 000, projected Gauss-Seidel on J M^-1 J^T gamma = b).

Per step, after gravity is in the velocities:

1. warm start: apply last step's accumulated impulses of the same contacts (note 001,
   "inter-timestep persistence"); with them a resting stack is solved before iterating.
2. velocity iterations: for k = 1..iterations, contacts in the order the world found
   them (body pairs by index, then the points of each pair), each contact's friction
   rows first, then its normal row (so the last word in a sweep is non-penetration). Each
   row accumulates its impulse and clamps the accumulated value (note 001, "impulse
   update with accumulation"):
     normal:   Pn = max(Pn + m_n (v_target - v_n), 0),   m_n = 1 / K_n
     friction: Pt = Pt + m_t (0 - v_t), then Pt is kept inside the Coulomb disc
               |Pt| <= mu Pn (the circular cone section, not the pyramid: friction is
               isotropic, so sliding at any angle to the tangent basis meets mu Pn),
               mu = mu_s while the contact sticks, mu_k while it slides.
   A sweep whose largest velocity change |dP| K is below `tolerance` ends the loop.
3. position correction with pseudo-velocities (split impulse): the bias velocity
   beta/dt (delta - slop)+ of note 001 is the target of a second set of normal rows that
   act on pseudo-velocities vp, wp. They move the positions this step and are then
   dropped, so pushing bodies apart adds no kinetic energy: note 001 puts the bias into
   the velocity impulse, which would launch a ball that came to rest at depth delta with
   speed beta/dt delta and spoil restitution.

Restitution. The target normal velocity is v_target = -e vn0 for an approaching contact
(vn0 < 0), else 0, where vn0 is the relative normal velocity at the start of the step,
before gravity was added. Why before: a ball that reaches the ground with speed u has, at
the start of the contact step, vn0 = -u; gravity then makes it -u - g dt. Solving
v_n+ = -e (-u - g dt) would launch it at e (u + g dt), a ratio e (1 + g dt / u) that
depends on dt and on where in the step contact began. Taking the impact at the start of
the step (the ball is already touching) and letting the contact also absorb the step's
weight impulse m g dt gives v_n+ = e u: the ratio is exactly e at any dt and phase.
The same target with e = 0 is a resting contact's v_n+ = 0.

Cost per sweep: O(rows), each row a few dozen float operations.
"""
from __future__ import annotations

import math


def solve(contacts, bodies, dt, config) -> tuple[str, ...]:
    stages = []
    friction = any(c.tangents for c in contacts)

    if config.warm_start and any(c.Pn != 0.0 for c in contacts):
        stages.append("warm_start")
        for c in contacts:
            c.normal.apply(c.Pn)
            for row, P in zip(c.tangents, c.Pt):
                row.apply(P)

    stages.append("velocity")
    if friction:
        stages.append("friction")
    tolerance = config.tolerance
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
        if largest <= tolerance:
            break

    if any(c.bias > 0.0 for c in contacts):
        stages.append("position")
        # total normal velocity v + vp >= bias: a contact already leaving faster than
        # the bias (a bounce) is not pushed as well
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
            if largest <= tolerance:
                break
    return tuple(stages)


def _friction(c) -> float:
    """One Gauss-Seidel pass over a contact's tangent rows, clamped to the disc
    |Pt| <= mu Pn; returns the largest velocity change it made."""
    rows, Pt = c.tangents, c.Pt
    new = [P - row.mass * row.velocity() for row, P in zip(rows, Pt)]
    limit = c.mu * c.Pn
    norm = math.sqrt(sum(P * P for P in new))
    if norm > limit:
        scale = limit / norm
        new = [P * scale for P in new]
    largest = 0.0
    for k, row in enumerate(rows):
        dP = new[k] - Pt[k]
        if dP != 0.0:
            Pt[k] = new[k]
            row.apply(dP)
            largest = max(largest, abs(dP) * row.K)
    return largest
