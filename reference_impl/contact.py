"""Contact constraint rows: the pieces every formulation shares.

A row constrains the relative velocity of the contact point along one direction d (the
normal n or a tangent t). Note 000 ("rigid bodies") writes it as J v with

    J v = d . (v_b + w_b x r_b - v_a - w_a x r_a)
        = d . v_b + (r_b x d) . w_b - d . v_a - (r_a x d) . w_a,

r the arm from each body's centre to the contact point. An impulse P along d changes
the velocities by M^-1 J^T P:  v_b += P d / m_b,  w_b += P I_b^-1 (r_b x d), and the
opposite on a. The row's effective mass is 1 / (J M^-1 J^T) = 1 / K_d with (note 001,
"inverse mass matrix of contact"; note 004, collision matrix)

    K_d = d^T K d = 1/m_a + 1/m_b + (r_a x d) . I_a^-1 (r_a x d) + (r_b x d) . I_b^-1 (r_b x d).

Signs re-derived here, since the extracted slides garble them: with r* the cross-product
matrix of r (r* p = r x p, r*^T = -r*), note 001's K_i = 1/M_i + r*^T I^-1 r* gives
d^T r*^T I^-1 r* d = (r x d) . I^-1 (r x d) >= 0. The convention is note 001's: n points
from body a (1) to body b (2) and v_rel = v_b - v_a, so v_n < 0 approaches (note 000
writes v_a - v_b with the normal the other way round).
"""
from __future__ import annotations

import math

from reference_impl.rigid_body import ZERO3, cross, dot

Y = (0.0, 1.0, 0.0)
ZERO = (0.0, 0.0, 0.0)


class Row:
    """One constraint direction d of a contact between bodies a and b."""

    __slots__ = ("a", "b", "d", "ra_d", "rb_d", "ia", "ib", "ma", "mb", "K", "mass")

    def __init__(self, a, b, ra, rb, d):
        self.a, self.b, self.d = a, b, d
        self.ra_d = ra_d = (ra[1] * d[2] - ra[2] * d[1], ra[2] * d[0] - ra[0] * d[2],
                            ra[0] * d[1] - ra[1] * d[0])        # r_a x d
        self.rb_d = rb_d = (rb[1] * d[2] - rb[2] * d[1], rb[2] * d[0] - rb[0] * d[2],
                            rb[0] * d[1] - rb[1] * d[0])        # r_b x d
        self.ia = ia = _inertia_times(a.inv_I, ra_d)           # I_a^-1 (r_a x d)
        self.ib = ib = _inertia_times(b.inv_I, rb_d)
        ma, mb = a.inv_mass, b.inv_mass
        self.ma = (ma * d[0], ma * d[1], ma * d[2])            # d / m_a
        self.mb = (mb * d[0], mb * d[1], mb * d[2])
        self.K = (ma + mb + ra_d[0] * ia[0] + ra_d[1] * ia[1] + ra_d[2] * ia[2]
                  + rb_d[0] * ib[0] + rb_d[1] * ib[1] + rb_d[2] * ib[2])
        self.mass = 1.0 / self.K

    @classmethod
    def angular(cls, a, b, axis):
        """A row on the relative angular velocity about a unit `axis`: J v = axis . (w_b - w_a),
        a torque impulse P axis on b and -P axis on a (rolling resistance, torsional
        friction). In the fields of a linear row: d = 0, r_a x d = r_b x d = axis, so
        `velocity`, `apply` and `coupling` need nothing new; K = axis . (I_a^-1 + I_b^-1) axis."""
        row = cls.__new__(cls)
        row.a, row.b, row.d = a, b, ZERO
        row.ra_d = row.rb_d = tuple(axis)
        row.ia, row.ib = _inertia_times(a.inv_I, axis), _inertia_times(b.inv_I, axis)
        row.ma = row.mb = ZERO
        row.K = dot(axis, row.ia) + dot(axis, row.ib)
        row.mass = 1.0 / row.K if row.K > 0.0 else 0.0
        return row

    def velocity(self) -> float:
        """J v: the relative velocity of b's point against a's along d."""
        return _jv(self, self.a.v, self.a.w, self.b.v, self.b.w)

    def apply(self, P: float) -> None:
        """v += M^-1 J^T P: impulse P d on b at its contact point, -P d on a."""
        _push(self, P, self.a.v, self.a.w, self.b.v, self.b.w)

    def pseudo_velocity(self) -> float:
        """J vp: the same row on the pseudo-velocities (position correction)."""
        return _jv(self, self.a.vp, self.a.wp, self.b.vp, self.b.wp)

    def apply_pseudo(self, P: float) -> None:
        _push(self, P, self.a.vp, self.a.wp, self.b.vp, self.b.wp)


def _inertia_times(M, r):
    if M is ZERO3:  # static, or cannot rotate
        return ZERO
    m0, m1, m2 = M
    return (m0[0] * r[0] + m0[1] * r[1] + m0[2] * r[2], m1[0] * r[0] + m1[1] * r[1] + m1[2] * r[2],
            m2[0] * r[0] + m2[1] * r[1] + m2[2] * r[2])


# the two inner-loop operations, written out on floats: they are most of a step's cost
def _jv(row, va, wa, vb, wb):
    d, ra_d, rb_d = row.d, row.ra_d, row.rb_d
    return (d[0] * (vb[0] - va[0]) + d[1] * (vb[1] - va[1]) + d[2] * (vb[2] - va[2])
            + rb_d[0] * wb[0] + rb_d[1] * wb[1] + rb_d[2] * wb[2]
            - ra_d[0] * wa[0] - ra_d[1] * wa[1] - ra_d[2] * wa[2])


def _push(row, P, va, wa, vb, wb):
    ma, mb, ia, ib = row.ma, row.mb, row.ia, row.ib
    va[0] -= P * ma[0]; va[1] -= P * ma[1]; va[2] -= P * ma[2]
    wa[0] -= P * ia[0]; wa[1] -= P * ia[1]; wa[2] -= P * ia[2]
    vb[0] += P * mb[0]; vb[1] += P * mb[1]; vb[2] += P * mb[2]
    wb[0] += P * ib[0]; wb[1] += P * ib[1]; wb[2] += P * ib[2]


def coupling(ri: Row, rj: Row) -> float:
    """J_i M^-1 J_j^T: how an impulse on row j changes the velocity of row i (the
    off-diagonal entries of note 000's A = J M^-1 J^T). coupling(r, r) == r.K."""
    total = 0.0
    for body_i, sign_i, arm_i in ((ri.a, -1.0, ri.ra_d), (ri.b, 1.0, ri.rb_d)):
        for body_j, sign_j, angular_j in ((rj.a, -1.0, rj.ia), (rj.b, 1.0, rj.ib)):
            if body_i is body_j and not body_i.static:
                total += sign_i * sign_j * (body_i.inv_mass * dot(ri.d, rj.d) + dot(arm_i, angular_j))
    return total


def tangent_basis(n):
    """A fixed unit tangent for normal n: y x n, which lies in the x-z plane (the 2D
    tangent) whenever n does; x x n ... if n is along y."""
    t = cross(Y, n)
    length = math.sqrt(dot(t, t))
    if length < 1e-6:
        t = cross((1.0, 0.0, 0.0), n)
        length = math.sqrt(dot(t, t))
    return (t[0] / length, t[1] / length, t[2] / length)


class Contact:
    """A contact point between bodies a and b with its rows and impulses."""

    __slots__ = ("a", "b", "point", "n", "depth", "feature", "planar", "e", "mu_s", "mu_k",
                 "rolling", "torsion", "normal", "tangents", "torques", "n_rolling", "vn0", "target",
                 "sticks", "mu", "bias", "Pn", "Pt", "Pq", "Pp", "warm")

    def __init__(self, a, b, point, n, depth, feature, e, mu_s, mu_k, planar, rolling=0.0, torsion=0.0):
        self.a, self.b = a, b
        self.point, self.n, self.depth, self.feature = point, n, depth, feature
        self.e, self.mu_s, self.mu_k = e, mu_s, mu_k
        self.rolling, self.torsion = rolling, torsion  # lever arms of the contact torques, m
        self.planar = planar
        self.torques = ()  # angular rows: n_rolling about tangent axes, then one about n (torsion)
        self.n_rolling = 0
        self.Pn = 0.0   # accumulated normal impulse (N s)
        self.Pt = []    # accumulated tangential impulses, one per tangent row
        self.Pq = []    # accumulated torque impulses (N m s), one per torque row
        self.Pp = 0.0   # accumulated pseudo-impulse of the position correction
        self.warm = False  # Pn, Pt hold the impulses of this contact's previous step

    def normal_target(self, dt: float, slop: float = 0.0) -> float | None:
        """The normal velocity the contact asks for at the end of the step (row >= target),
        or None: the contact belongs to the next step.

        - touching (gap <= slop, i.e. depth >= -slop: the slop is a dead band on both
          sides, as overlaps within it are not pushed out): v_n+ = -e vn0 if approaching
          (vn0 < 0, measured before external forces: see sequential_impulses.py), else 0
          (stays touching or leaves). Were a gap of rounding size speculative, a row of
          touching balls would let every impact through it close the gaps at gap/dt,
          doubling them each time, until the row no longer moved as one (a Newton's
          cradle lost 23 % of its energy in 2 s that way);
        - a bouncing contact (e > 0) whose gap g this step's approach closes: the bounce is
          taken at the step boundary nearest the moment of contact, so it starts at most
          |vn0| dt / 2 off the surface, above or below (always taking it at the boundary
          after the overlap would start every bounce up to |vn0| dt below the surface, a
          one-sided bias of the rebound height). Closed within the first half of the step
          (2 g <= -vn0 dt): bounce now, as if touching; in the second half: None;
        - otherwise (a plastic contact, or a gap the approach does not close):
          v_n >= -g/dt, the gap may close this step but not overlap (a speculative
          contact: a plastic impact lands exactly on the surface, then stops)."""
        gap, vn0 = -self.depth, self.vn0
        if gap <= slop:
            return -self.e * vn0 if vn0 < 0.0 else 0.0
        closing = -vn0 * dt  # how far the approach carries the bodies this step
        if self.e > 0.0 and gap < closing:
            return -self.e * vn0 if 2.0 * gap <= closing else None
        return -gap / dt

    def prepare(self, dt: float, config) -> None:
        """Rows, approach velocity vn0, stick/slide decision and bias, from the velocities
        at the start of the step (before external forces)."""
        a, b, p, n = self.a, self.b, self.point, self.n
        ra = (p[0] - a.x[0], p[1] - a.x[1], p[2] - a.x[2])
        rb = (p[0] - b.x[0], p[1] - b.x[1], p[2] - b.x[2])
        self.normal = Row(a, b, ra, rb, n)
        self.vn0 = self.normal.velocity()
        self.target = self.normal_target(dt, config.slop)
        # bias velocity beta/dt (delta - slop)+ (note 001, "de-penetration bias velocity")
        self.bias = config.beta / dt * max(self.depth - config.slop, 0.0)
        self.sticks, self.mu = True, self.mu_s
        self._torque_rows()
        if self.mu_s == 0.0:
            self.tangents = ()
            return
        # relative velocity of the contact point; its tangential part is the slip
        va, vb = _point_velocity(a, ra), _point_velocity(b, rb)
        vn0 = self.vn0
        slip = (vb[0] - va[0] - vn0 * n[0], vb[1] - va[1] - vn0 * n[1], vb[2] - va[2] - vn0 * n[2])
        speed = math.sqrt(dot(slip, slip))
        self.sticks = speed < config.stick_speed
        self.mu = self.mu_s if self.sticks else self.mu_k  # the coefficient in force this step
        if self.sticks or self.planar:
            t1 = tangent_basis(n)
        else:  # sliding: the first tangent along the slip (note 001, t = normalize(v_rel,t))
            t1 = (slip[0] / speed, slip[1] / speed, slip[2] / speed)
        if self.planar:
            self.tangents = (Row(a, b, ra, rb, t1),)
        else:
            self.tangents = (Row(a, b, ra, rb, t1), Row(a, b, ra, rb, cross(n, t1)))
        self.Pt = [0.0] * len(self.tangents)


    def _torque_rows(self) -> None:
        """Rolling resistance and torsional friction as angular rows (Row.angular), each
        torque impulse bounded by its lever arm times the normal impulse, as friction is by
        mu Pn (sequential_impulses.py): rolling about the two tangent axes (one in 2D, the
        axis y normal to the plane), kept in the disc |Pr| <= rolling Pn; torsion about n,
        in [-torsion Pn, torsion Pn]. An axis no body can turn about (K = 0: a 2D body about
        n, bodies that cannot rotate) gets no row."""
        rows, n = [], self.n
        if self.rolling > 0.0:
            t1 = tangent_basis(n)
            axes = ((cross(n, t1),) if self.planar else (t1, cross(n, t1)))
            rows = [Row.angular(self.a, self.b, axis) for axis in axes]
            rows = rows if all(row.K > 0.0 for row in rows) else []
        self.n_rolling = len(rows)
        if self.torsion > 0.0:
            row = Row.angular(self.a, self.b, n)
            if row.K > 0.0:
                rows.append(row)
        self.torques = tuple(rows)
        self.Pq = [0.0] * len(rows)


def _point_velocity(body, r):
    v, w = body.v, body.w
    return (v[0] + w[1] * r[2] - w[2] * r[1], v[1] + w[2] * r[0] - w[0] * r[2], v[2] + w[0] * r[1] - w[1] * r[0])
