"""Joints as constraint rows beside the contact rows.

A joint holds a function of the positions at zero, g(x) = 0; its rows are the velocity
level G v = 0 (note 004, "Contact stabilization - SPOOK scheme": G the constraint
Jacobian, lcp.py's J; note 001, "Joints": v_rel+ = 0 at the joint point), each row one
body's 6-block [d^T, (r x d)^T] as a contact row's (note 000, "Matrix form for rigid
bodies"). A contact row is unilateral (gamma >= 0, note 000, "non-pulling impulses"); a
joint's equality row has an unbounded impulse, -inf < lambda < inf: the boxed LCP of note
000 ("PGS for friction") with lo = -inf, hi = inf, i.e. no projection (pgs.py), and in note
004's mixed LCP a row with an equality ("projected Gauss-Seidel for the mixed LCP"). Such
rows are marked BILATERAL in Rows.normal.

Each row carries its position error g (metres or radians), which the formulation drives
back to zero: pgs.py, lemke.py and sequential_impulses.py by note 001's joint bias on
pseudo-velocities (beta/dt (x_1 - x_2), "joint impulses"; here -beta/dt g), spook.py by
note 004's -a g term with its regularisation eps.

The joint kinds (body a = the joint's body, pushed by +lambda d; body b = its parent, or
the static world, pushed by -lambda d); every angular row is [0, d] on a, [0, -d] on b:
- ball (point): three rows d = e_x, e_y, e_z at the anchor, g = d . (p_a - p_b) with
  p = x + R p_body, the anchor carried by each body;
- revolute (hinge): the ball's rows, and two angular rows keeping a's hinge axis n_a on
  b's n_b: d = t_k perpendicular to n_b, g = t_k . (n_b x n_a), the small turn of n_a
  away from n_b about t_k;
- prismatic (slider): two linear rows d = t_k perpendicular to b's axis n_b, at a's
  anchor against the point of b under it (r_b = p_a - x_b, which makes G the exact
  derivative of g = t_k . (p_a - p_b) also when b turns), and three angular rows holding
  the relative orientation: d = e_x, e_y, e_z, g = d . delta with the small rotation
  delta = 1/2 sum_k e_b,k x e_a,k over the three axes (n, u, n x u) each body carries
  (for delta small, e_a = e_b + delta x e_b, and the sum of e_b x (delta x e_b) is 2 delta);
- fixed (weld): the ball's three rows and the prismatic's three angular rows.

Then, per joint and in this order, the rows of its coordinate s (a hinge's angle about n,
atan2 of b's reference axis u_b to a's u_a; a slider's travel n_b . (p_a - p_b)), whose
rate is one row G = [0, n] / [0, -n] (hinge) or [n, r_a x n] / [-n, -r_b x n] (slider):
- friction > 0: a BOXED row, target 0, its impulse within -+ friction dt: Coulomb's law
  with a constant bound (note 000, "PGS for friction", mu gamma_n replaced by the joint's
  own friction force times the step);
- limits: two unilateral rows (Rows.normal = the row itself, as a contact's normal row),
  the lower on +s with gap s - lower, the upper on -s with gap upper - s, each with a
  contact's target (contact.normal_target: the limit is a contact on the coordinate;
  limit_e its Newton restitution, Rows.c_r) and its gap as g (SPOOK's q). A target NaN
  (a bounce that belongs to the next step) becomes -inf: the row cannot act this step.

`prepare` makes the rows at the step's start, `rhs` gives b = target - G u of the
velocity problem and `position_bias` the pseudo-velocity targets of the position repair.
Compiled (compiled.py).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from reference_impl.compiled import njit
from reference_impl.contact import normal_target
from reference_impl.lcp import (BILATERAL, BOXED, Bodies, Rows, inverse_mass_times_rows, lanes, row_velocity,
                                tangent_basis)
from reference_impl.vectors import cross, dot, mat_vec

BALL, REVOLUTE, PRISMATIC, FIXED = 0, 1, 2, 3
KINDS = {"ball": BALL, "revolute": REVOLUTE, "prismatic": PRISMATIC, "fixed": FIXED}
EQUALITY_ROWS = (3, 5, 5, 6)  # equality rows per kind
STATIC = -1  # the world as a joint's parent


class Joints(NamedTuple):
    """J joints and their rows (K: each joint's EQUALITY_ROWS, one more with friction, two
    more with limits), rows in joint order; `rows`, `g`, `target` are made again each step
    (`prepare`), `P` is kept (warm start)."""
    a: np.ndarray        # (J,) int: the joint's body
    b: np.ndarray        # (J,) int: its parent, or STATIC
    kind: np.ndarray     # (J,) int: BALL, REVOLUTE, PRISMATIC or FIXED
    p_a: np.ndarray      # (J, 3) the anchor in a's body frame
    p_b: np.ndarray      # (J, 3) the anchor in b's body frame (the world: a world point)
    n_a: np.ndarray      # (J, 3) the axis in a's body frame (unit)
    n_b: np.ndarray      # (J, 3) the axis in b's body frame (the world: world axis)
    u_a: np.ndarray      # (J, 3) a reference axis perpendicular to n, in a's body frame
    u_b: np.ndarray      # (J, 3) the same in b's body frame (world)
    lower: np.ndarray    # (J,) the coordinate's lower limit (rad or m), -inf: none
    upper: np.ndarray    # (J,) its upper limit, inf: none
    limit_e: np.ndarray  # (J,) the restitution at a limit
    friction: np.ndarray  # (J,) dry friction force (N) or torque (N m), 0: none
    rows: Rows           # (K,) rows
    g: np.ndarray        # (K,) position error of each row (a limit row: its gap)
    target: np.ndarray   # (K,) the velocity each row asks for (0 but on limit rows)
    P: np.ndarray        # (K,) each row's impulse of the last step, N s (or N m s)


def perpendicular(n) -> np.ndarray:
    """A unit vector perpendicular to the unit n (tangent_basis's first without a slip), in Python."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = helper - np.dot(helper, n) * n
    return t / np.linalg.norm(t)


def row_count(kind, limited, friction) -> int:
    """The rows of one joint."""
    return EQUALITY_ROWS[kind] + (1 if friction > 0.0 else 0) + (2 if limited else 0)


def new_joints(a, b, kind, p_a, p_b, n_a, n_b, u_a=None, u_b=None, lower=None, upper=None, limit_e=None,
               friction=None) -> Joints:
    """Joints from their columns (lists or arrays), rows not yet made. u_a, u_b (None: a
    perpendicular of n of tangent_basis), limits (None: none), limit_e and friction
    (None: 0) are optional."""
    kind = np.asarray(kind, np.int64).reshape(-1)
    J = len(kind)
    n_a, n_b = np.asarray(n_a, float).reshape(J, 3), np.asarray(n_b, float).reshape(J, 3)
    if u_a is None:  # a's axes as b's at the start
        u_b = np.array([perpendicular(n_b[j]) for j in range(J)]).reshape(J, 3)
        u_a = u_b.copy()
    lower = np.full(J, -np.inf) if lower is None else np.asarray(lower, float).reshape(J)
    upper = np.full(J, np.inf) if upper is None else np.asarray(upper, float).reshape(J)
    limit_e = np.zeros(J) if limit_e is None else np.asarray(limit_e, float).reshape(J)
    friction = np.zeros(J) if friction is None else np.asarray(friction, float).reshape(J)
    K = int(sum(row_count(kind[j], np.isfinite(lower[j]) or np.isfinite(upper[j]), friction[j])
                for j in range(J)))
    rows = Rows(np.empty(K, np.int64), np.empty(K, np.int64), np.zeros((K, 6)), np.zeros((K, 6)),
                np.full(K, BILATERAL, np.int64), np.zeros(K), np.zeros(K))
    return Joints(np.asarray(a, np.int64).reshape(J), np.asarray(b, np.int64).reshape(J), kind,
                  np.asarray(p_a, float).reshape(J, 3), np.asarray(p_b, float).reshape(J, 3), n_a, n_b,
                  np.asarray(u_a, float).reshape(J, 3), np.asarray(u_b, float).reshape(J, 3), lower, upper, limit_e,
                  friction, rows, np.zeros(K), np.zeros(K), np.zeros(K))


@njit
def _world(bodies, i, vector):
    """A body-frame vector of body i in the world (i STATIC: the vector is the world's)."""
    if i == STATIC:
        return (vector[0], vector[1], vector[2])
    return mat_vec(bodies.R[i], vector)


@njit
def _rate(bodies, i, J, arm_free) -> float:
    """Body i's share of a row's velocity G v from its velocities at the step's start
    (before external forces: v0, w0), J its 6-block (arm_free: the row has no linear part)."""
    if i == STATIC:
        return 0.0
    total = J[3] * bodies.w0[i, 0] + J[4] * bodies.w0[i, 1] + J[5] * bodies.w0[i, 2]
    if not arm_free:
        total += J[0] * bodies.v0[i, 0] + J[1] * bodies.v0[i, 1] + J[2] * bodies.v0[i, 2]
    return total


@njit
def prepare(joints, bodies, dt, slop) -> None:
    """Each joint's rows, position errors and targets at the bodies' present positions
    (the module docstring); the limit rows' approach rate from the velocities before
    external forces, as a contact's vn0 (contact.normal_target); friction bounds for a
    step of dt."""
    rows, k = joints.rows, 0
    for row in range(len(rows.a)):  # equality rows unless made otherwise below
        rows.normal[row], rows.mu[row], rows.c_r[row], joints.target[row] = BILATERAL, 0.0, 0.0, 0.0
    for j in range(len(joints.a)):
        a, b, kind = joints.a[j], joints.b[j], joints.kind[j]
        r_a = mat_vec(bodies.R[a], joints.p_a[j])
        p_a = (bodies.x[a, 0] + r_a[0], bodies.x[a, 1] + r_a[1], bodies.x[a, 2] + r_a[2])
        n_a, u_a = _world(bodies, a, joints.n_a[j]), _world(bodies, a, joints.u_a[j])
        n_b, u_b = _world(bodies, b, joints.n_b[j]), _world(bodies, b, joints.u_b[j])
        if b == STATIC:
            r_b, x_b = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
            p_b = (joints.p_b[j, 0], joints.p_b[j, 1], joints.p_b[j, 2])
        else:
            x_b = (bodies.x[b, 0], bodies.x[b, 1], bodies.x[b, 2])
            r_b = mat_vec(bodies.R[b], joints.p_b[j])
            p_b = (x_b[0] + r_b[0], x_b[1] + r_b[1], x_b[2] + r_b[2])
        gap = (p_a[0] - p_b[0], p_a[1] - p_b[1], p_a[2] - p_b[2])
        under = (p_a[0] - x_b[0], p_a[1] - x_b[1], p_a[2] - x_b[2])  # b's point under a's anchor
        if kind == BALL or kind == REVOLUTE or kind == FIXED:  # the anchor's three rows
            for e in range(3):
                d = np.zeros(3)
                d[e] = 1.0
                _linear(rows, k + e, a, b, d, r_a, r_b)
                joints.g[k + e] = gap[e]
            k += 3
        if kind == PRISMATIC:  # the anchor held on b's axis: two rows across it
            t_1, t_2 = tangent_basis(np.array(n_b), np.zeros(3))
            for t, row in ((t_1, k), (t_2, k + 1)):
                _linear(rows, row, a, b, t, r_a, under)
                joints.g[row] = dot(t, gap)
            k += 2
        if kind == REVOLUTE:  # the hinge's two angular rows
            t_1, t_2 = tangent_basis(np.array(n_b), np.zeros(3))
            turn = cross(n_b, n_a)
            for t, row in ((t_1, k), (t_2, k + 1)):
                _angular(rows, row, a, b, t)
                joints.g[row] = dot(t, turn)
            k += 2
        if kind == PRISMATIC or kind == FIXED:  # the relative orientation: three angular rows
            w_a, w_b = cross(n_a, u_a), cross(n_b, u_b)
            delta = np.zeros(3)
            for e_a, e_b in ((n_a, n_b), (u_a, u_b), (w_a, w_b)):
                turn = cross(e_b, e_a)
                for e in range(3):
                    delta[e] += 0.5 * turn[e]
            for e in range(3):
                d = np.zeros(3)
                d[e] = 1.0
                _angular(rows, k + e, a, b, d)
                joints.g[k + e] = delta[e]
            k += 3
        limited = joints.lower[j] > -np.inf or joints.upper[j] < np.inf
        if joints.friction[j] <= 0.0 and not limited:
            continue
        # the coordinate s and its row (+s): a hinge's angle, a slider's travel
        axis = np.array(n_b)
        if kind == REVOLUTE:
            s = math.atan2(dot(n_b, cross(u_b, u_a)), dot(u_b, u_a))
        else:
            s = dot(n_b, gap)
        if joints.friction[j] > 0.0:  # Coulomb friction in the joint: |P| <= friction dt
            _coordinate(rows, k, a, b, axis, r_a, under, kind == REVOLUTE, 1.0)
            rows.normal[k], rows.mu[k] = BOXED, joints.friction[j] * dt
            joints.g[k] = 0.0
            k += 1
        if limited:  # the lower limit on +s, the upper on -s: unilateral, a contact's target
            for sign, room in ((1.0, s - joints.lower[j]), (-1.0, joints.upper[j] - s)):
                _coordinate(rows, k, a, b, axis, r_a, under, kind == REVOLUTE, sign)
                rows.normal[k], rows.c_r[k] = k, joints.limit_e[j]
                rate = _rate(bodies, a, rows.J_a[k], kind == REVOLUTE) + _rate(bodies, b, rows.J_b[k],
                                                                                kind == REVOLUTE)
                goal = normal_target(joints.limit_e[j], -room, rate, dt, slop)
                joints.target[k] = -np.inf if np.isnan(goal) else goal
                joints.g[k] = room
                k += 1


@njit
def _linear(rows, k, a, b, d, r_a, r_b) -> None:
    """Row k: the anchor's velocity along d, a's against b's (note 000, [d^T, (r x d)^T])."""
    rows.a[k], rows.b[k] = a, b
    arm_a, arm_b = cross(r_a, d), cross(r_b, d)
    for e in range(3):
        rows.J_a[k, e], rows.J_a[k, 3 + e] = d[e], arm_a[e]
        rows.J_b[k, e], rows.J_b[k, 3 + e] = (-d[e], -arm_b[e]) if b != STATIC else (0.0, 0.0)


@njit
def _angular(rows, k, a, b, d) -> None:
    """Row k: a's angular velocity about d against b's ([0, d] on a, [0, -d] on b)."""
    rows.a[k], rows.b[k] = a, b
    for e in range(3):
        rows.J_a[k, e], rows.J_a[k, 3 + e] = 0.0, d[e]
        rows.J_b[k, e], rows.J_b[k, 3 + e] = 0.0, -d[e] if b != STATIC else 0.0


@njit
def _coordinate(rows, k, a, b, n, r_a, under, turning, sign) -> None:
    """Row k: sign times the joint coordinate's rate (a hinge's about n, a slider's along n)."""
    d = np.empty(3)
    for e in range(3):
        d[e] = sign * n[e]
    if turning:
        _angular(rows, k, a, b, d)
    else:
        _linear(rows, k, a, b, d, r_a, under)


@njit
def rhs(joints, u) -> np.ndarray:
    """b = target - G u of the joints' rows (u: (N, 6) velocities)."""
    out = row_velocity(joints.rows, u)
    for k in range(len(out)):
        out[k] = joints.target[k] - out[k]
    return out


@njit
def position_bias(joints, beta, dt, slop) -> np.ndarray:
    """The pseudo-velocity targets of the position repair (note 001, "joint impulses":
    v_bias = beta/dt (x_1 - x_2)): -beta/dt g on an equality row, beta/dt (overrun - slop)+
    on a limit row (as a contact's overlap, note 001's de-penetration bias), 0 on a
    friction row (whose bound position_rows sets to 0: friction resists no repair)."""
    bias = np.zeros(len(joints.g))
    for k in range(len(bias)):
        nk = joints.rows.normal[k]
        if nk == BILATERAL:
            bias[k] = -beta / dt * joints.g[k]
        elif nk >= 0:
            bias[k] = beta / dt * max(-joints.g[k] - slop, 0.0)
    return bias


@njit
def position_rows(joints) -> Rows:
    """The joints' rows for the position repair: a friction row's bound 0 (it takes no part)."""
    r = joints.rows
    mu = np.zeros(len(r.a))
    return Rows(r.a, r.b, r.J_a, r.J_b, r.normal, mu, r.c_r)


# --- the rows swept one by one (the sequential impulses, sequential_impulses.py) -----------

class Links(NamedTuple):
    """The joints' rows as the sequential impulses sweep them (note 001, "impulse update
    with accumulation"): per row M^-1 G^T of body a and of body b, its effective mass
    1 / (G M^-1 G^T) (0: a row no body can move, left alone), its velocity target, its
    position-repair target and accumulated impulses P (velocity) and Pp (pseudo-velocity)."""
    rows: Rows
    W_a: np.ndarray     # (K, 6)
    W_b: np.ndarray     # (K, 6)
    mass: np.ndarray    # (K,)
    target: np.ndarray  # (K,) joints.target
    bias: np.ndarray    # (K,) position_bias
    P: np.ndarray       # (K,) joints.P (the warm start on entry)
    Pp: np.ndarray      # (K,) zero on entry


@njit
def links(joints, bodies, beta, dt, slop) -> Links:
    """Links of the prepared joints (rigid_body.Bodies: its inverse masses and inertias)."""
    W_a, W_b = inverse_mass_times_rows(joints.rows, Bodies(bodies.inv_mass, bodies.inv_I))
    K = len(joints.g)
    mass = np.zeros(K)
    for k in range(K):
        diag = lanes(joints.rows.J_a[k], W_a[k]) + lanes(joints.rows.J_b[k], W_b[k])
        mass[k] = 1.0 / diag if diag > 0.0 else 0.0
    return Links(joints.rows, W_a, W_b, mass, joints.target, position_bias(joints, beta, dt, slop), joints.P,
                 np.zeros(K))


@njit
def apply_impulses(links, P, v, w) -> None:
    """v, w += M^-1 G^T P over the rows (the warm start)."""
    for k in range(len(P)):
        if P[k] != 0.0:
            _push(links, k, P[k], v, w)


@njit
def sweep(links, P, target, v, w, friction) -> float:
    """One Gauss-Seidel pass over the rows in order, accumulating each row's impulse and
    clamping the accumulated value (note 001, "impulse update with accumulation"):
    P = P + m (target - G v), then an equality row as it is, a limit row P >= 0, a
    friction row |P| <= its bound (friction False: a friction row is skipped, as in the
    position repair). Returns the largest velocity change |dP| / m."""
    r, largest = links.rows, 0.0
    for k in range(len(P)):
        m, nk = links.mass[k], r.normal[k]
        if m == 0.0 or (nk == BOXED and not friction) or target[k] == -np.inf and P[k] == 0.0:
            continue
        a, b = r.a[k], r.b[k]
        speed = 0.0
        for e in range(3):
            speed += r.J_a[k, e] * v[a, e] + r.J_a[k, 3 + e] * w[a, e]
            if b != STATIC:
                speed += r.J_b[k, e] * v[b, e] + r.J_b[k, 3 + e] * w[b, e]
        new = P[k] + m * (target[k] - speed) if target[k] > -np.inf else 0.0
        if nk == BOXED:
            new = -r.mu[k] if new < -r.mu[k] else (r.mu[k] if new > r.mu[k] else new)
        elif nk >= 0 and new < 0.0:
            new = 0.0
        d = new - P[k]
        if d != 0.0:
            P[k] = new
            _push(links, k, d, v, w)
            largest = max(largest, abs(d) / m)
    return largest


@njit
def _push(links, k, P, v, w) -> None:
    """Row k's impulse P on its bodies: v, w += M^-1 G^T P."""
    a, b = links.rows.a[k], links.rows.b[k]
    for e in range(3):
        v[a, e] += links.W_a[k, e] * P
        w[a, e] += links.W_a[k, 3 + e] * P
        if b != STATIC:
            v[b, e] += links.W_b[k, e] * P
            w[b, e] += links.W_b[k, 3 + e] * P
