"""Contacts and their constraint rows: the pieces every formulation shares.

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

The contacts of a step are one `Contacts` (a struct of arrays, row j the contact j), each
row of a contact its ROW_TERMS numbers (`_row_terms`); `prepare` computes them, compiled
(compiled.py). `Contact` and `Row` are the same numbers seen from Python (world.contacts).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from reference_impl.compiled import njit, structure
from reference_impl.vectors import copy, cross, dot

# A row's numbers, as _row_terms writes them: d, r_a x d, r_b x d, d / m_a, d / m_b,
# I_a^-1 (r_a x d), I_b^-1 (r_b x d) (three each: the J and M^-1 J^T of the row), then
# K = J M^-1 J^T and the effective mass 1 / K.
D, RA_D, RB_D, MA, MB, IA, IB, K, MASS = 0, 3, 6, 9, 12, 15, 18, 21, 22
ROW_TERMS = 23


class ContactArrays(NamedTuple):
    """The contacts of a step, row j the contact j (in the order the world found them:
    body pairs by index, then the points of each pair). Compiled code holds them as
    `Contacts` (the same fields); Python reads them with `contact_arrays`."""
    a: np.ndarray           # (C,) int: the body the normal leaves (rigid_body.Bodies index)
    b: np.ndarray           # (C,) int: the body it enters
    point: np.ndarray       # (C, 3) midway between the surfaces
    n: np.ndarray           # (C, 3) unit normal from a to b
    depth: np.ndarray       # (C,) > 0 overlapping, < 0 a gap
    feature: np.ndarray     # (C,) int: what made the point (geometry.py), kept while it persists
    e: np.ndarray           # (C,) the pair's restitution
    mu_s: np.ndarray        # (C,) static friction
    mu_k: np.ndarray        # (C,) kinetic friction
    rolling: np.ndarray     # (C,) lever arm of rolling resistance, m
    torsion: np.ndarray     # (C,) lever arm of torsional friction, m
    planar: np.ndarray      # (C,) bool: a 2D contact (one tangent row)
    vn0: np.ndarray         # (C,) J_n v at the start of the step, before external forces
    target: np.ndarray      # (C,) the normal velocity to reach (normal_target); NaN: the next step's
    bias: np.ndarray        # (C,) beta/dt (depth - slop)+
    sticks: np.ndarray      # (C,) bool: slip below config.stick_speed at the start of the step
    mu: np.ndarray          # (C,) the friction coefficient in force: mu_s while it sticks, else mu_k
    warm: np.ndarray        # (C,) bool: Pn, Pt, Pq hold this contact's impulses of the last step
    normal: np.ndarray      # (C, ROW_TERMS) the normal row
    tangents: np.ndarray    # (C, 2, ROW_TERMS) the tangent rows (the first n_tangents)
    n_tangents: np.ndarray  # (C,) int: 0 (frictionless), 1 (2D) or 2
    torques: np.ndarray     # (C, 3, ROW_TERMS) angular rows: n_rolling about tangent axes, then torsion
    n_rolling: np.ndarray   # (C,) int
    n_torsion: np.ndarray   # (C,) int
    Pn: np.ndarray          # (C,) normal impulse, N s (>= 0)
    Pt: np.ndarray          # (C, 2) tangential impulses, one per tangent row
    Pq: np.ndarray          # (C, 3) torque impulses, N m s, one per torque row


Contacts = structure(ContactArrays, "Contacts")


@njit
def contact_arrays(contacts) -> ContactArrays:
    """The arrays of compiled code's Contacts, for Python."""
    c = contacts
    return ContactArrays(c.a, c.b, c.point, c.n, c.depth, c.feature, c.e, c.mu_s, c.mu_k, c.rolling, c.torsion,
                         c.planar, c.vn0, c.target, c.bias, c.sticks, c.mu, c.warm, c.normal, c.tangents,
                         c.n_tangents, c.torques, c.n_rolling, c.n_torsion, c.Pn, c.Pt, c.Pq)


@njit
def new_contacts(C):
    """C contacts, their numbers zero (targets NaN)."""
    return Contacts(np.zeros(C, np.int64), np.zeros(C, np.int64), np.zeros((C, 3)), np.zeros((C, 3)), np.zeros(C),
                    np.zeros(C, np.int64), np.zeros(C), np.zeros(C), np.zeros(C), np.zeros(C), np.zeros(C),
                    np.zeros(C, np.bool_), np.zeros(C), np.full(C, np.nan), np.zeros(C), np.ones(C, np.bool_),
                    np.zeros(C), np.zeros(C, np.bool_), np.zeros((C, ROW_TERMS)), np.zeros((C, 2, ROW_TERMS)),
                    np.zeros(C, np.int64), np.zeros((C, 3, ROW_TERMS)), np.zeros(C, np.int64),
                    np.zeros(C, np.int64), np.zeros(C), np.zeros((C, 2)), np.zeros((C, 3)))


@njit
def compact(contacts, keep):
    """The contacts whose `keep` is True, in order: moved to the front, and the arrays cut
    to them."""
    c, m = contacts, 0
    for k in range(len(keep)):
        if keep[k]:
            if m != k:
                c.a[m], c.b[m], c.depth[m], c.feature[m] = c.a[k], c.b[k], c.depth[k], c.feature[k]
                c.e[m], c.mu_s[m], c.mu_k[m], c.rolling[m], c.torsion[m], c.planar[m] = \
                    c.e[k], c.mu_s[k], c.mu_k[k], c.rolling[k], c.torsion[k], c.planar[k]
                c.vn0[m], c.target[m], c.bias[m], c.sticks[m], c.mu[m], c.warm[m] = \
                    c.vn0[k], c.target[k], c.bias[k], c.sticks[k], c.mu[k], c.warm[k]
                c.n_tangents[m], c.n_rolling[m], c.n_torsion[m], c.Pn[m] = \
                    c.n_tangents[k], c.n_rolling[k], c.n_torsion[k], c.Pn[k]
                for row in (c.point, c.n, c.normal, c.Pt, c.Pq):
                    copy(row[m], row[k])
                for rows in (c.tangents, c.torques):
                    for r in range(rows.shape[1]):
                        copy(rows[m, r], rows[k, r])
            m += 1
    return Contacts(c.a[:m], c.b[:m], c.point[:m], c.n[:m], c.depth[:m], c.feature[:m], c.e[:m], c.mu_s[:m],
                    c.mu_k[:m], c.rolling[:m], c.torsion[:m], c.planar[:m], c.vn0[:m], c.target[:m], c.bias[:m],
                    c.sticks[:m], c.mu[:m], c.warm[:m], c.normal[:m], c.tangents[:m], c.n_tangents[:m],
                    c.torques[:m], c.n_rolling[:m], c.n_torsion[:m], c.Pn[:m], c.Pt[:m], c.Pq[:m])


# --- one row -----------------------------------------------------------------------------

@njit
def _row_terms(out, ra, rb, d, inv_ma, inv_mb, Ia, Ib, turns_a, turns_b):
    """The numbers of the row along d into out (see the module docstring: r x d,
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


@njit
def _angular_row(out, Ia, Ib, turns_a, turns_b, axis):
    """A row on the relative angular velocity about a unit `axis`: J v = axis . (w_b - w_a),
    a torque impulse P axis on b and -P axis on a (rolling resistance, torsional
    friction). In the numbers of a linear row: d = 0, r_a x d = r_b x d = axis, so
    `velocity` and `apply` need nothing new; K = axis . (I_a^-1 + I_b^-1) axis."""
    out[:] = 0.0
    for k in range(3):
        out[RA_D + k] = out[RB_D + k] = axis[k]
    ia = (dot(Ia[0], axis), dot(Ia[1], axis), dot(Ia[2], axis)) if turns_a else (0.0, 0.0, 0.0)
    ib = (dot(Ib[0], axis), dot(Ib[1], axis), dot(Ib[2], axis)) if turns_b else (0.0, 0.0, 0.0)
    for k in range(3):
        out[IA + k], out[IB + k] = ia[k], ib[k]
    out[K] = dot(axis, ia) + dot(axis, ib)
    out[MASS] = 1.0 / out[K] if out[K] > 0.0 else 0.0


# the two inner-loop operations on a row, written out on floats
@njit
def velocity(row, va, wa, vb, wb) -> float:
    """J v: the relative velocity of b's point against a's along d:
    d . (v_b - v_a) + (r_b x d) . w_b - (r_a x d) . w_a."""
    return (row[0] * (vb[0] - va[0]) + row[1] * (vb[1] - va[1]) + row[2] * (vb[2] - va[2])
            + row[6] * wb[0] + row[7] * wb[1] + row[8] * wb[2]
            - row[3] * wa[0] - row[4] * wa[1] - row[5] * wa[2])


@njit
def apply(row, P, va, wa, vb, wb) -> None:
    """v += M^-1 J^T P: impulse P d on b at its contact point, -P d on a."""
    va[0] -= P * row[9]; va[1] -= P * row[10]; va[2] -= P * row[11]
    wa[0] -= P * row[15]; wa[1] -= P * row[16]; wa[2] -= P * row[17]
    vb[0] += P * row[12]; vb[1] += P * row[13]; vb[2] += P * row[14]
    wb[0] += P * row[18]; wb[1] += P * row[19]; wb[2] += P * row[20]


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


# --- a step's contacts -----------------------------------------------------------------------

@njit
def normal_target(e, depth, vn0, dt, slop) -> float:
    """The normal velocity the contact asks for at the end of the step (row >= target),
    or NaN: the contact belongs to the next step.

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
      (2 g <= -vn0 dt): bounce now, as if touching; in the second half: NaN;
    - otherwise (a plastic contact, or a gap the approach does not close):
      v_n >= -g/dt, the gap may close this step but not overlap (a speculative
      contact: a plastic impact lands exactly on the surface, then stops)."""
    gap = -depth
    if gap <= slop:
        return -e * vn0 if vn0 < 0.0 else 0.0
    closing = -vn0 * dt  # how far the approach carries the bodies this step
    if e > 0.0 and gap < closing:
        return -e * vn0 if 2.0 * gap <= closing else np.nan
    return -gap / dt


@njit(inline=True)
def prepare(contacts, bodies, dt, beta, slop, stick_speed, fixed_tangents=False, threshold=0.0) -> None:
    """Each contact's rows (the normal, then its tangents: fixed while it sticks, the
    first along the slip while it slides, note 001, t = normalize(v_rel,t)), its approach
    velocity vn0 = J_n v and its slip, from the velocities at the start of the step
    (before external forces); its normal target (normal_target), the bias velocity
    beta/dt (delta - slop)+ (note 001, "de-penetration bias velocity") and its torque rows.
    fixed_tangents and threshold > 0 are the faults world.Phases describes."""
    bias = beta / dt
    for j in range(len(contacts.a)):
        a, b, p = contacts.a[j], contacts.b[j], contacts.point[j]
        # the normal as a tuple, as the arms and tangents are: _row_terms compiles once, not per type
        n = (contacts.n[j, 0], contacts.n[j, 1], contacts.n[j, 2])
        xa, xb = bodies.x[a], bodies.x[b]
        ra = (p[0] - xa[0], p[1] - xa[1], p[2] - xa[2])  # the arms from the centres to the point
        rb = (p[0] - xb[0], p[1] - xb[1], p[2] - xb[2])
        inv_ma, inv_mb, Ia, Ib = bodies.inv_mass[a], bodies.inv_mass[b], bodies.inv_I[a], bodies.inv_I[b]
        turns_a, turns_b = bodies.can_rotate[a], bodies.can_rotate[b]
        va, wa, vb, wb = bodies.v[a], bodies.w[a], bodies.v[b], bodies.w[b]
        _row_terms(contacts.normal[j], ra, rb, n, inv_ma, inv_mb, Ia, Ib, turns_a, turns_b)
        vn0 = contacts.vn0[j] = velocity(contacts.normal[j], va, wa, vb, wb)
        contacts.target[j] = normal_target(contacts.e[j], contacts.depth[j], vn0, dt, slop)
        if -threshold < vn0 < 0.0 and contacts.target[j] > 0.0:  # the planted threshold (never, at 0)
            contacts.target[j] = 0.0
        contacts.bias[j] = bias * max(contacts.depth[j] - slop, 0.0)
        contacts.sticks[j], contacts.mu[j] = True, contacts.mu_s[j]
        _torque_rows(contacts, j, Ia, Ib, turns_a, turns_b)
        if contacts.mu_s[j] == 0.0:
            continue  # frictionless: no tangent rows
        # relative velocity of the contact point; its tangential part is the slip
        pa, pb = _point_velocity(va, wa, ra), _point_velocity(vb, wb, rb)
        slip = (pb[0] - pa[0] - vn0 * n[0], pb[1] - pa[1] - vn0 * n[1], pb[2] - pa[2] - vn0 * n[2])
        speed = math.sqrt(slip[0] * slip[0] + slip[1] * slip[1] + slip[2] * slip[2])
        sticks = contacts.sticks[j] = speed < stick_speed
        contacts.mu[j] = contacts.mu_s[j] if sticks else contacts.mu_k[j]
        planar = contacts.planar[j]
        if sticks or planar or fixed_tangents:
            t = tangent_basis(n)
        else:  # sliding: the first tangent along the slip
            t = (slip[0] / speed, slip[1] / speed, slip[2] / speed)
        _row_terms(contacts.tangents[j, 0], ra, rb, t, inv_ma, inv_mb, Ia, Ib, turns_a, turns_b)
        contacts.n_tangents[j] = 1
        if not planar:  # the second tangent n x t1
            t2 = (n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0])
            _row_terms(contacts.tangents[j, 1], ra, rb, t2, inv_ma, inv_mb, Ia, Ib, turns_a, turns_b)
            contacts.n_tangents[j] = 2


@njit
def _torque_rows(contacts, j, Ia, Ib, turns_a, turns_b) -> None:
    """Rolling resistance and torsional friction as angular rows (_angular_row), each
    torque impulse bounded by its lever arm times the normal impulse, as friction is by
    mu Pn (sequential_impulses.py): rolling about the two tangent axes (one in 2D, the
    axis y normal to the plane), kept in the disc |Pr| <= rolling Pn; torsion about n,
    in [-torsion Pn, torsion Pn]. An axis no body can turn about (K = 0: a 2D body about
    n, bodies that cannot rotate) gets no row."""
    rows, count = contacts.torques[j], 0
    n = (contacts.n[j, 0], contacts.n[j, 1], contacts.n[j, 2])  # a tuple, as the tangent axes are: one compile
    if contacts.rolling[j] > 0.0:
        t1 = tangent_basis(n)
        count = 1 if contacts.planar[j] else 2
        _angular_row(rows[0], Ia, Ib, turns_a, turns_b, cross(n, t1) if contacts.planar[j] else t1)
        if count == 2:
            _angular_row(rows[1], Ia, Ib, turns_a, turns_b, cross(n, t1))
        for k in range(count):
            if not rows[k, K] > 0.0:
                count = 0
    contacts.n_rolling[j] = count
    if contacts.torsion[j] > 0.0:
        _angular_row(rows[count], Ia, Ib, turns_a, turns_b, n)
        contacts.n_torsion[j] = 1 if rows[count, K] > 0.0 else 0


@njit
def _point_velocity(v, w, r):
    """v + w x r."""
    return (v[0] + w[1] * r[2] - w[2] * r[1], v[1] + w[2] * r[0] - w[0] * r[2], v[2] + w[0] * r[1] - w[1] * r[0])


# --- the same numbers seen from Python -----------------------------------------------------------

class Row:
    """One constraint direction d of a contact between bodies a and b (rigid_body.RigidBody):
    d, r_a x d (ra_d), r_b x d (rb_d), d / m_a (ma), d / m_b (mb), I_a^-1 (r_a x d) (ia),
    I_b^-1 (r_b x d) (ib), K and mass = 1 / K."""

    __slots__ = ("a", "b", "terms")

    def __init__(self, a, b, ra, rb, d):
        """The row along d of a contact at arms ra, rb from a's and b's centres."""
        self.a, self.b, self.terms = a, b, np.empty(ROW_TERMS)
        _row_terms(self.terms, np.asarray(ra, dtype=float), np.asarray(rb, dtype=float), np.asarray(d, dtype=float),
                   a.inv_mass, b.inv_mass, a.inv_I, b.inv_I, a.can_rotate, b.can_rotate)

    @classmethod
    def of(cls, a, b, terms) -> Row:
        row = cls.__new__(cls)
        row.a, row.b, row.terms = a, b, np.array(terms, dtype=float)
        return row

    d = property(lambda self: tuple(self.terms[D:D + 3].tolist()))
    ra_d = property(lambda self: tuple(self.terms[RA_D:RA_D + 3].tolist()))
    rb_d = property(lambda self: tuple(self.terms[RB_D:RB_D + 3].tolist()))
    ma = property(lambda self: tuple(self.terms[MA:MA + 3].tolist()))
    mb = property(lambda self: tuple(self.terms[MB:MB + 3].tolist()))
    ia = property(lambda self: tuple(self.terms[IA:IA + 3].tolist()))
    ib = property(lambda self: tuple(self.terms[IB:IB + 3].tolist()))
    K = property(lambda self: float(self.terms[K]))
    mass = property(lambda self: float(self.terms[MASS]))

    def velocity(self) -> float:
        """J v: the relative velocity of b's point against a's along d."""
        return velocity(self.terms, self.a.v, self.a.w, self.b.v, self.b.w)

    def apply(self, P: float) -> None:
        """v += M^-1 J^T P: impulse P d on b at its contact point, -P d on a."""
        apply(self.terms, float(P), self.a.v, self.a.w, self.b.v, self.b.w)


def coupling(ri: Row, rj: Row) -> float:
    """J_i M^-1 J_j^T: how an impulse on row j changes the velocity of row i (the
    off-diagonal entries of note 000's A = J M^-1 J^T). coupling(r, r) == r.K."""
    total = 0.0
    for body_i, sign_i, arm_i in ((ri.a, -1.0, ri.ra_d), (ri.b, 1.0, ri.rb_d)):
        for body_j, sign_j, angular_j in ((rj.a, -1.0, rj.ia), (rj.b, 1.0, rj.ib)):
            if body_i is body_j and not body_i.static:
                total += sign_i * sign_j * (body_i.inv_mass * dot(ri.d, rj.d) + dot(arm_i, angular_j))
    return total


class Contact:
    """Contact j of a step's contacts (ContactArrays), read into Python (world.World.contacts): its bodies
    a and b (rigid_body.RigidBody), the fields of Contacts as floats and tuples (`target`
    None for a contact the next step takes), its rows as `Row`s (`normal`, `tangents`,
    `torques`) and impulses (`Pn`, lists `Pt` and `Pq`, one per row). A copy: changing it
    changes nothing in the world."""

    __slots__ = ("a", "b", "point", "n", "depth", "feature", "planar", "e", "mu_s", "mu_k", "rolling", "torsion",
                 "normal", "tangents", "torques", "n_rolling", "vn0", "target", "sticks", "mu", "bias", "Pn", "Pt",
                 "Pq", "warm")

    def __init__(self, c: ContactArrays, j: int, bodies: list):
        self.a, self.b = a, b = bodies[c.a[j]], bodies[c.b[j]]
        self.point, self.n = tuple(c.point[j].tolist()), tuple(c.n[j].tolist())
        self.depth, self.feature, self.planar = float(c.depth[j]), int(c.feature[j]), bool(c.planar[j])
        self.e, self.mu_s, self.mu_k = float(c.e[j]), float(c.mu_s[j]), float(c.mu_k[j])
        self.rolling, self.torsion = float(c.rolling[j]), float(c.torsion[j])
        self.vn0, self.bias, self.mu, self.sticks = float(c.vn0[j]), float(c.bias[j]), float(c.mu[j]), bool(c.sticks[j])
        target = float(c.target[j])
        self.target = None if math.isnan(target) else target
        self.warm = bool(c.warm[j])
        nt, nq = int(c.n_tangents[j]), int(c.n_rolling[j] + c.n_torsion[j])
        self.normal = Row.of(a, b, c.normal[j])
        self.tangents = tuple(Row.of(a, b, c.tangents[j, k]) for k in range(nt))
        self.torques = tuple(Row.of(a, b, c.torques[j, k]) for k in range(nq))
        self.n_rolling = int(c.n_rolling[j])
        self.Pn, self.Pt, self.Pq = float(c.Pn[j]), c.Pt[j, :nt].tolist(), c.Pq[j, :nq].tolist()
