"""Joints as bilateral (equality) constraint rows beside the contact rows.

A joint holds a function of the positions at zero, g(x) = 0; its rows are the velocity
level G v = 0 (note 004, "Contact stabilization - SPOOK scheme": G the constraint
Jacobian, lcp.py's J), each row one body's 6-block [d^T, (r x d)^T] as a contact row's
(note 000, "Matrix form for rigid bodies"). A contact row is unilateral (gamma >= 0, note
000, "non-pulling impulses"); a joint row is an equality, its impulse unbounded,
-inf < lambda < inf: the boxed LCP of note 000 ("PGS for friction") with lo = -inf,
hi = inf, i.e. no projection (pgs.py), and in note 004's mixed LCP a row with an equality
("projected Gauss-Seidel for the mixed LCP"). Rows are marked BILATERAL in Rows.normal.

Each row also carries its position error g (metres or radians), which the formulation
drives back to zero: pgs.py by note 000's bias on pseudo-velocities (-beta/dt g, as the
overlap repair), spook.py by note 004's -a g term with its regularisation eps.

The joint kinds (body a = the joint's body, pushed by +lambda d; body b = its parent, or
the static world, pushed by -lambda d):
- ball (point): three rows d = e_x, e_y, e_z at the anchor, g = d . (p_a - p_b) with
  p = x + R p_body, the anchor carried by each body;
- revolute (hinge): the ball's rows, and two angular rows keeping a's hinge axis n_a on
  b's n_b: G = [0, t_k] on a, [0, -t_k] on b, t_1, t_2 perpendicular to n_b, and
  g = t_k . (n_b x n_a), the small turn of n_a away from n_b about t_k.
Compiled (compiled.py).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reference_impl.compiled import njit
from reference_impl.lcp import Rows, tangent_basis
from reference_impl.vectors import cross, dot, mat_vec

BILATERAL = -1  # Rows.normal of an equality row: no bound on its impulse
BALL, REVOLUTE = 0, 1
KINDS = {"ball": BALL, "revolute": REVOLUTE}
ROW_COUNT = (3, 5)  # rows per kind
STATIC = -1  # the world as a joint's parent


class Joints(NamedTuple):
    """J joints and their rows (K = sum of ROW_COUNT over the joints), rows in joint
    order; `rows`, `g` are made again each step (`prepare`), `P` is kept (warm start)."""
    a: np.ndarray       # (J,) int: the joint's body
    b: np.ndarray       # (J,) int: its parent, or STATIC
    kind: np.ndarray    # (J,) int: BALL or REVOLUTE
    p_a: np.ndarray     # (J, 3) the anchor in a's body frame
    p_b: np.ndarray     # (J, 3) the anchor in b's body frame (the world: a world point)
    n_a: np.ndarray     # (J, 3) the hinge axis in a's body frame (unit)
    n_b: np.ndarray     # (J, 3) the hinge axis in b's body frame (the world: world axis)
    rows: Rows          # (K,) rows, normal = BILATERAL
    g: np.ndarray       # (K,) position error of each row
    P: np.ndarray       # (K,) each row's impulse of the last step, N s (or N m s)


def new_joints(a, b, kind, p_a, p_b, n_a, n_b) -> Joints:
    """Joints from their columns (lists or arrays), rows not yet made."""
    kind = np.asarray(kind, np.int64).reshape(-1)
    K = int(sum(ROW_COUNT[k] for k in kind))
    J = len(kind)
    rows = Rows(np.empty(K, np.int64), np.empty(K, np.int64), np.zeros((K, 6)), np.zeros((K, 6)),
                np.full(K, BILATERAL, np.int64), np.zeros(K), np.zeros(K))
    return Joints(np.asarray(a, np.int64).reshape(J), np.asarray(b, np.int64).reshape(J), kind,
                  np.asarray(p_a, float).reshape(J, 3), np.asarray(p_b, float).reshape(J, 3),
                  np.asarray(n_a, float).reshape(J, 3), np.asarray(n_b, float).reshape(J, 3),
                  rows, np.zeros(K), np.zeros(K))


@njit
def prepare(joints, bodies) -> None:
    """Each joint's rows and position errors at the bodies' present positions."""
    rows, k = joints.rows, 0
    for j in range(len(joints.a)):
        a, b = joints.a[j], joints.b[j]
        r_a = mat_vec(bodies.R[a], joints.p_a[j])
        n_a = mat_vec(bodies.R[a], joints.n_a[j])
        if b == STATIC:
            r_b = (0.0, 0.0, 0.0)
            p_b = (joints.p_b[j, 0], joints.p_b[j, 1], joints.p_b[j, 2])
            n_b = (joints.n_b[j, 0], joints.n_b[j, 1], joints.n_b[j, 2])
        else:
            r_b = mat_vec(bodies.R[b], joints.p_b[j])
            p_b = (bodies.x[b, 0] + r_b[0], bodies.x[b, 1] + r_b[1], bodies.x[b, 2] + r_b[2])
            n_b = mat_vec(bodies.R[b], joints.n_b[j])
        for e in range(3):  # the anchor's three rows
            d = np.zeros(3)
            d[e] = 1.0
            _linear(rows, k + e, a, b, d, r_a, r_b)
            joints.g[k + e] = bodies.x[a, e] + r_a[e] - p_b[e]
        k += 3
        if joints.kind[j] == REVOLUTE:  # the hinge's two angular rows
            t_1, t_2 = tangent_basis(np.array(n_b), np.zeros(3))
            turn = cross(n_b, n_a)
            for t, row in ((t_1, k), (t_2, k + 1)):
                rows.a[row], rows.b[row] = a, b
                for e in range(3):
                    rows.J_a[row, e], rows.J_a[row, 3 + e] = 0.0, t[e]
                    rows.J_b[row, e], rows.J_b[row, 3 + e] = 0.0, -t[e] if b != STATIC else 0.0
                joints.g[row] = dot(t, turn)
            k += 2


@njit
def _linear(rows, k, a, b, d, r_a, r_b) -> None:
    """Row k: the anchor's velocity along d, a's against b's (note 000, [d^T, (r x d)^T])."""
    rows.a[k], rows.b[k] = a, b
    arm_a, arm_b = cross(r_a, d), cross(r_b, d)
    for e in range(3):
        rows.J_a[k, e], rows.J_a[k, 3 + e] = d[e], arm_a[e]
        if b != STATIC:
            rows.J_b[k, e], rows.J_b[k, 3 + e] = -d[e], -arm_b[e]
