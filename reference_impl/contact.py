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

import numpy as np

from reference_impl.compiled import njit
from reference_impl.rigid_body import ZERO3, cross, dot

Y = (0.0, 1.0, 0.0)
ZERO = (0.0, 0.0, 0.0)


class Row:
    """One constraint direction d of a contact between bodies a and b."""

    __slots__ = ("a", "b", "d", "ra_d", "rb_d", "ia", "ib", "ma", "mb", "K", "mass")

    def __init__(self, a, b, ra, rb, d):
        terms = np.empty(ROW_TERMS)
        _row_terms(terms, np.array(ra, dtype=float), np.array(rb, dtype=float), np.array(d, dtype=float),
                   a.inv_mass, b.inv_mass, _inverse_inertia(a), _inverse_inertia(b), a.inv_I is not ZERO3,
                   b.inv_I is not ZERO3)
        self._fill(a, b, terms.tolist())

    def _fill(self, a, b, x) -> None:
        """The fields from the ROW_TERMS numbers x of _row_terms."""
        self.a, self.b = a, b
        self.d, self.ra_d, self.rb_d = (x[0], x[1], x[2]), (x[3], x[4], x[5]), (x[6], x[7], x[8])
        self.ma, self.mb = (x[9], x[10], x[11]), (x[12], x[13], x[14])
        self.ia, self.ib = (x[15], x[16], x[17]), (x[18], x[19], x[20])
        self.K, self.mass = x[21], x[22]

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


# A row's numbers, as _row_terms writes them: d, r_a x d, r_b x d, d / m_a, d / m_b,
# I_a^-1 (r_a x d), I_b^-1 (r_b x d), K, 1 / K (the first 21 are the J of
# sequential_impulses.iterate).
ROW_TERMS = 23


def _inverse_inertia(body):
    return np.array(body.inv_I, dtype=float)


@njit
def _row_terms(out, ra, rb, d, inv_ma, inv_mb, Ia, Ib, turns_a, turns_b):
    """The numbers of Row(a, b, ra, rb, d) into out (see the module docstring: r x d,
    I^-1 (r x d), K_d = 1/m_a + 1/m_b + (r_a x d) . I_a^-1 (r_a x d) + (r_b x d) . I_b^-1 (r_b x d));
    turns_a False: a cannot rotate (I_a^-1 = 0)."""
    out[0], out[1], out[2] = d[0], d[1], d[2]
    out[3] = ra[1] * d[2] - ra[2] * d[1]   # r_a x d
    out[4] = ra[2] * d[0] - ra[0] * d[2]
    out[5] = ra[0] * d[1] - ra[1] * d[0]
    out[6] = rb[1] * d[2] - rb[2] * d[1]   # r_b x d
    out[7] = rb[2] * d[0] - rb[0] * d[2]
    out[8] = rb[0] * d[1] - rb[1] * d[0]
    for k in range(3):
        out[9 + k] = inv_ma * d[k]         # d / m_a
        out[12 + k] = inv_mb * d[k]
        out[15 + k] = (Ia[k, 0] * out[3] + Ia[k, 1] * out[4] + Ia[k, 2] * out[5]) if turns_a else 0.0
        out[18 + k] = (Ib[k, 0] * out[6] + Ib[k, 1] * out[7] + Ib[k, 2] * out[8]) if turns_b else 0.0
    out[21] = (inv_ma + inv_mb + out[3] * out[15] + out[4] * out[16] + out[5] * out[17]
               + out[6] * out[18] + out[7] * out[19] + out[8] * out[20])
    out[22] = 1.0 / out[21]


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


@njit
def tangent_basis(n):
    """A fixed unit tangent for normal n: y x n, which lies in the x-z plane (the 2D
    tangent) whenever n does; x x n ... if n is along y."""
    t = (1.0 * n[2] - 0.0 * n[1], 0.0 * n[0] - 0.0 * n[2], 0.0 * n[1] - 1.0 * n[0])  # Y x n
    length = math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2])
    if length < 1e-6:
        t = (0.0 * n[2] - 0.0 * n[1], 0.0 * n[0] - 1.0 * n[2], 1.0 * n[1] - 0.0 * n[0])  # X x n
        length = math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2])
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
        at the start of the step (before external forces): `prepare` for this contact."""
        prepare([self], dt, config)

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


def prepare(contacts, dt: float, config) -> None:
    """Contact.prepare for the contacts of a step at once: each contact's rows (the normal,
    then its tangents: fixed while it sticks, the first along the slip while it slides,
    note 001, t = normalize(v_rel,t)), its approach velocity vn0 = J_n v and its slip,
    from the velocities at the start of the step (before external forces), computed by
    _contact_rows over all contacts together; then its normal target (normal_target), the
    bias velocity beta/dt (delta - slop)+ (note 001, "de-penetration bias velocity") and
    its torque rows."""
    if not contacts:
        return
    # per contact, in one array: r_a, r_b, n, 1/m_a, 1/m_b, I_a^-1, I_b^-1 (rows), whether
    # a, b rotate, v_a, w_a, v_b, w_b, whether it has friction, whether it is 2D
    data = np.array([(*_arm(c.point, c.a.x), *_arm(c.point, c.b.x), *c.n, c.a.inv_mass, c.b.inv_mass,
                      *c.a.inv_I[0], *c.a.inv_I[1], *c.a.inv_I[2], *c.b.inv_I[0], *c.b.inv_I[1], *c.b.inv_I[2],
                      c.a.inv_I is not ZERO3, c.b.inv_I is not ZERO3, *c.a.v, *c.a.w, *c.b.v, *c.b.w,
                      c.mu_s != 0.0, c.planar) for c in contacts], dtype=float)
    terms, vn0, sticks = _contact_rows(data, float(config.stick_speed))
    bias = config.beta / dt
    for c, rows, vn0_c, sticks_c in zip(contacts, terms.tolist(), vn0.tolist(), sticks.tolist()):
        c.normal = row = Row.__new__(Row)
        row._fill(c.a, c.b, rows[0])
        c.vn0 = vn0_c
        c.target = c.normal_target(dt, config.slop)
        c.bias = bias * max(c.depth - config.slop, 0.0)
        c.sticks, c.mu = True, c.mu_s
        c._torque_rows()
        if c.mu_s == 0.0:
            c.tangents = ()
            continue
        c.sticks = sticks_c
        c.mu = c.mu_s if sticks_c else c.mu_k  # the coefficient in force this step
        tangents = []
        for k in range(1 if c.planar else 2):
            tangents.append(Row.__new__(Row))
            tangents[k]._fill(c.a, c.b, rows[1 + k])
        c.tangents = tuple(tangents)
        c.Pt = [0.0] * len(tangents)


def _arm(p, x):
    """r = p - x: the arm from a body's centre x to the contact point p."""
    return (p[0] - x[0], p[1] - x[1], p[2] - x[2])


@njit
def _contact_rows(data, stick_speed):
    """Per contact j (row j of data, laid out as in prepare): the terms of its normal row
    and of its tangent rows (_row_terms), vn0 = J_n v, and whether it sticks (slip speed
    below stick_speed)."""
    C = len(data)
    terms = np.zeros((C, 3, ROW_TERMS))
    vn0, sticks = np.empty(C), np.ones(C, dtype=np.bool_)
    for j in range(C):
        ra, rb, n, inv_ma, inv_mb = data[j, 0:3], data[j, 3:6], data[j, 6:9], data[j, 9], data[j, 10]
        Ia, Ib = data[j, 11:20].reshape((3, 3)), data[j, 20:29].reshape((3, 3))
        turns_a, turns_b = data[j, 29] != 0.0, data[j, 30] != 0.0
        va, wa, vb, wb = data[j, 31:34], data[j, 34:37], data[j, 37:40], data[j, 40:43]
        frictional, planar = data[j, 43] != 0.0, data[j, 44] != 0.0
        _row_terms(terms[j, 0], ra, rb, n, inv_ma, inv_mb, Ia, Ib, turns_a, turns_b)
        J = terms[j, 0]
        vn0[j] = (J[0] * (vb[0] - va[0]) + J[1] * (vb[1] - va[1]) + J[2] * (vb[2] - va[2])
                  + J[6] * wb[0] + J[7] * wb[1] + J[8] * wb[2]
                  - J[3] * wa[0] - J[4] * wa[1] - J[5] * wa[2])   # Row.velocity
        if not frictional:
            continue
        # relative velocity of the contact point; its tangential part is the slip
        pa, pb = _point_velocity(va, wa, ra), _point_velocity(vb, wb, rb)
        slip = (pb[0] - pa[0] - vn0[j] * n[0], pb[1] - pa[1] - vn0[j] * n[1], pb[2] - pa[2] - vn0[j] * n[2])
        speed = math.sqrt(slip[0] * slip[0] + slip[1] * slip[1] + slip[2] * slip[2])
        sticks[j] = speed < stick_speed
        if sticks[j] or planar:
            t1 = tangent_basis(n)
        else:  # sliding: the first tangent along the slip
            t1 = (slip[0] / speed, slip[1] / speed, slip[2] / speed)
        t = np.array(t1)
        _row_terms(terms[j, 1], ra, rb, t, inv_ma, inv_mb, Ia, Ib, turns_a, turns_b)
        if not planar:  # the second tangent n x t1
            t2 = np.array((n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0]))
            _row_terms(terms[j, 2], ra, rb, t2, inv_ma, inv_mb, Ia, Ib, turns_a, turns_b)
    return terms, vn0, sticks


@njit
def _point_velocity(v, w, r):
    """v + w x r."""
    return (v[0] + w[1] * r[2] - w[2] * r[1], v[1] + w[2] * r[0] - w[0] * r[2], v[2] + w[0] * r[1] - w[1] * r[0])
