"""An exact pivoting solver for small contact LCPs: Lemke's complementary pivoting method,
used as the check on pgs.py (note 000, "Solving the LCP system": PGS is "popular and
simple", this is its exact counterpart; note 001, "Use spatial LCP solver").

lemke(M, q) finds z with w = M z + q >= 0, z >= 0, z . w = 0. With a lexicographic ratio
test it cannot cycle, and for the positive semi-definite M of frictionless contact it
finds a solution whenever one exists. Cost: O(n^2) per pivot, a few n pivots typically.

contact_lcp(A, b, rows) states lcp.py's boxed problem in that form. Friction set: the
same pyramid as lcp.py, written as the standard friction-polyhedron LCP (Stewart and
Trinkle 1996; Anitescu and Potra 1997): the tangent impulse is D beta, beta >= 0, with
the four directions d = +-t1 +-t2 (the box's corners, so conv(mu gamma_n d) is exactly
the box |gamma_t1|, |gamma_t2| <= mu gamma_n; +-t in a 2D scene), and a slack speed
lambda per contact:

    w_n = A_nn gamma_n + A_nt D beta - b_n                       >= 0  _|_  gamma_n >= 0
    w_D = D^T A_tn gamma_n + D^T A_tt D beta - D^T b_t + E lambda >= 0  _|_  beta >= 0
    w_l = mu gamma_n - E^T beta                                  >= 0  _|_  lambda >= 0

At a solution lambda = |v_t1| + |v_t2| and beta rests on the corners that oppose the
sliding velocity most: maximal dissipation over the box, which is what PGS's per-row
clamps converge to.

Numerics: the dense tableau is pivoted in place (Gauss-Jordan). On degenerate contact
sets (a box face on four corners: 24 rows of rank 14) a pivot can run through a
near-singular basis and lose the solution; lemke() checks its result against the
original problem and raises LemkeFailure rather than return a wrong one, and
lemke_or_retry (what the world formulation calls) solves such a step again, more
carefully, so a run never stops on one.

Compiled (compiled.py), as is the world formulation "lemke" below.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from reference_impl import joints as joint_rows, lcp
from reference_impl.compiled import njit
from reference_impl.lcp import BILATERAL, BOXED, Rows


class LemkeFailure(RuntimeError):
    """Ray termination or the pivot budget ran out: no solution found."""


# The retries after a failed check (see lemke_or_retry): the same problem with the tableau
# refactored from the original data at every pivot, then with a proximal term eps I,
# eps relative to M's largest diagonal entry.
RETRY_EPS = (0.0, 1e-10, 1e-8, 1e-6)


@njit
def lemke_or_retry(M: np.ndarray, q: np.ndarray, tally: np.ndarray) -> np.ndarray:
    """lemke(M, q); if its check fails (a degenerate contact set: a box face on four
    corners), again with the tableau recomputed from M and q at every pivot (no
    accumulated rounding, O(n^3) a pivot), then for M + eps I with eps in RETRY_EPS
    times max(diag M). Every result passed lemke's check, so it solves the original LCP
    to eps |z| (M z + q >= -eps z): an impulse at most 1e-6 of itself off, where the
    engines' CFM changes it by 1e-5 (DART) or more. Measured over every variant of the
    incline, slide, tumbling, edge-landing, isotropy and resting-block families: the
    in-place pass failed 2455 of 77071 solves, refactoring alone solved 2138 of those,
    a 1e-10 term the other 317; none was left unsolved. Counts into `tally`: [0] the
    solves, [1] the in-place passes that failed, [2 + k] the retries with RETRY_EPS[k]
    that failed (TALLY entries)."""
    tally[0] += 1
    z, solved = _attempt(M, q, False)
    if solved:
        return z
    tally[1] += 1
    d = max(np.max(np.abs(np.diag(M))), 1e-300)
    for k in range(len(RETRY_EPS)):
        z, solved = _attempt(M + RETRY_EPS[k] * d * np.eye(len(q)), q, True)
        if solved:
            return z
        tally[2 + k] += 1
    raise LemkeFailure("no solution: Lemke failed its check on the problem and on every retry (RETRY_EPS)")


TALLY = 2 + len(RETRY_EPS)  # the entries of lemke_or_retry's tally


@njit
def _attempt(M: np.ndarray, q: np.ndarray, refactor: bool) -> tuple[np.ndarray, bool]:
    """(lemke(M, q), True), or (zeros, False) where it raised (a LemkeFailure: compiled code
    catches every exception or none). The one try of lemke_or_retry's attempts, in a
    function of its own: numba 0.68 on Python 3.12 lets an exception escape a try in a loop
    once the loop has caught one (or a try followed by a second one), so a retry's
    LemkeFailure left the compiled world step uncaught and crashed the process; on 3.11 the
    same code caught it."""
    solved = False
    z = np.zeros(len(q))
    try:
        z = lemke(M, q, -1, refactor)
        solved = True
    except Exception:
        solved = False
    return z, solved


@njit
def lemke(M: np.ndarray, q: np.ndarray, max_pivots: int = -1, refactor: bool = False) -> np.ndarray:
    """z solving the LCP (M, q), checked; max_pivots < 0: 50 (n + 1); refactor: recompute
    the tableau from M and q after every pivot (slower, no accumulated rounding)."""
    n = len(q)
    if n == 0 or np.all(q >= 0.0):
        return np.zeros(n)
    max_pivots = 50 * (n + 1) if max_pivots < 0 else max_pivots
    return _pivoting(np.ascontiguousarray(M), np.ascontiguousarray(q), max_pivots, refactor)


@njit
def _pivoting(M, q, max_pivots, refactor):
    """Lemke's method on (M, q), n >= 1 and some q < 0 (see lemke)."""
    n = len(q)
    # tableau of  I w - M z - e z0 = q ; columns: w (0..n-1), z (n..2n-1), z0 (2n), rhs
    T0 = np.hstack((np.eye(n), -M, -np.ones((n, 1)), q.reshape((n, 1))))
    T = T0.copy()
    basis = np.arange(n)  # basic variable of each row
    z0 = 2 * n
    scale = max(1.0, np.max(np.abs(M)), np.max(np.abs(q)))
    tiny = 1e-12 * scale         # rounding level of a tableau entry
    pivot_floor = 1e-9 * scale   # smallest pivot element: see below

    # z0 enters where q is most negative: afterwards every rhs is >= 0
    leaving = _pivot(T, T0, basis, np.argmin(T[:, -1]), z0, refactor, tiny)
    for _ in range(max_pivots):
        entering = leaving + n if leaving < n else leaving - n  # complement of what left
        col = T[:, entering]
        # A pivot element must be well above rounding: on degenerate contact sets (a box
        # face on four corners) an entry that is zero in exact arithmetic comes out as
        # 1e-12-sized noise, and pivoting on it makes the basis near-singular (cond 1e12,
        # measured) and loses the solution a few pivots later.
        candidates = np.flatnonzero(col > pivot_floor)
        if candidates.size == 0:
            # z0 at rounding level: the last pivot was a tie that z0 should have won (the
            # ratio test's tie band is relative to the ratio, z0's rhs is not), and the
            # basis already solves the LCP. Seen once in 30 000 random friction problems.
            at = np.flatnonzero(basis == z0)
            if at.size and T[at[0], -1] <= tiny:
                return _checked_solution(M, q, T, basis, scale)
            raise LemkeFailure("ray termination: the LCP has no solution Lemke can reach")
        leaving = _pivot(T, T0, basis, _ratio_test(T, candidates, col, basis, z0, n), entering, refactor, tiny)
        if leaving == z0:
            return _checked_solution(M, q, T, basis, scale)
    raise LemkeFailure("no solution within the pivot budget (50 (n + 1) by default)")


@njit
def _pivot(T, T0, basis, row, col, refactor, tiny):
    """Make `col` basic in `row` (Gauss-Jordan on the tableau, or refactored from T0);
    returns the variable that left."""
    n = len(basis)
    leaving = basis[row]
    basis[row] = col
    if refactor:
        singular = False
        try:
            T[:] = np.linalg.solve(T0[:, basis], T0)
        except Exception:  # numba cannot raise inside an except block
            singular = True
        if singular:
            raise LemkeFailure("a singular basis")
    else:
        T[row] /= T[row, col]
        for i in range(n):  # T[others] -= outer(T[others, col], T[row])
            if i != row:
                f = T[i, col]
                for j in range(T.shape[1]):
                    T[i, j] -= f * T[row, j]
    # the basic solution must stay >= 0; rounding leaves -1e-16-sized entries that
    # would turn into negative ratios and steer the next pivots: set them to zero
    for i in range(n):
        if -tiny < T[i, -1] < 0.0:
            T[i, -1] = 0.0
    return leaving


@njit
def _checked_solution(M, q, T, basis, scale):
    """z of the current basis (z0 taken as 0), checked against the original problem:
    pivots on a near-singular basis (degenerate contact sets) can lose the solution,
    and a wrong one is never returned."""
    n = len(q)
    x = np.zeros(2 * n + 1)
    x[basis] = T[:, -1]
    z = np.maximum(x[n:2 * n], 0.0)
    w = M @ z + q
    if w.min() < -1e-9 * scale or abs(z @ w) > 1e-9 * scale * (1.0 + z.sum()):
        raise LemkeFailure("pivoting lost accuracy: min(Mz + q) or z.(Mz + q) beyond 1e-9 of the problem's scale")
    return z


@njit
def _ratio_test(T, candidates, col, basis, z0, n):
    """The leaving row: minimum of rhs / col; ties broken lexicographically by the rows of
    B^-1 / col (B^-1 sits in the w columns), which rules out cycling on degenerate
    problems such as a box resting on four corners. z0 leaves whenever it may."""
    ratio = T[candidates, -1] / col[candidates]
    tied = candidates[ratio <= ratio.min() + 1e-12 * (1.0 + abs(ratio.min()))]
    for r in tied:
        if basis[r] == z0:
            return int(r)
    for j in range(n):
        if tied.size == 1:
            break
        key = T[tied, j] / col[tied]
        tied = tied[key <= key.min() + 1e-12 * (1.0 + abs(key.min()))]
    return int(tied[0])


# the corners d of the box |gamma_t,k| <= 1 in a contact's tangent plane (columns), by
# the number of tangent rows: 1 in a 2D scene (a segment), 2 in 3D (a square)
CORNERS_2D = np.array([[1.0, -1.0]])
CORNERS_3D = np.array([[1.0, 1.0, -1.0, -1.0], [1.0, -1.0, 1.0, -1.0]])


def contact_lcp(A: np.ndarray, b: np.ndarray, rows: Rows) -> np.ndarray:
    """gamma solving lcp.py's boxed LCP A gamma - b exactly (friction pyramid)."""
    return pyramid_lcp(np.asarray(A, dtype=float), np.asarray(b, dtype=float), rows, np.zeros(TALLY, np.int64))


@njit
def pyramid_lcp(A, b, rows, tally) -> np.ndarray:
    """contact_lcp, counting into `tally` (lemke_or_retry). A joint's friction row (BOXED,
    joints.py) is a one-row pyramid whose bound is its own constant Rows.mu: two beta
    (+-its direction) and a slack speed lambda with w_l = mu - E^T beta (the constant in q
    where a contact has mu gamma_n); such rows come after every contact's tangent rows."""
    K = len(rows.a)
    n_tangents = np.zeros(K, np.int64)  # per normal row; rows come as a normal row, then its tangents
    for k in range(K):
        if rows.normal[k] >= 0 and rows.normal[k] != k:
            n_tangents[rows.normal[k]] += 1
    normal_rows = np.array([k for k in range(K) if rows.normal[k] == k], dtype=np.int64)
    tangent_rows = np.array([k for k in range(K) if rows.normal[k] != k], dtype=np.int64)
    boxed = np.array([k for k in range(K) if rows.normal[k] == BOXED], dtype=np.int64)
    if len(tangent_rows) == 0:
        return lemke_or_retry(A, -b, tally)
    frictional = np.array([j for j in range(len(normal_rows)) if n_tangents[normal_rows[j]] > 0], dtype=np.int64)
    nn, nc = len(normal_rows), len(frictional)
    nf = nc + len(boxed)
    n_beta = 2 * len(boxed)
    for j in frictional:
        n_beta += 2 if n_tangents[normal_rows[j]] == 1 else 4
    D = np.zeros((len(tangent_rows), n_beta))  # gamma_t = D beta
    E = np.zeros((n_beta, nf))                 # sums each contact's beta
    U = np.zeros((nf, nn))                     # mu gamma_n of each frictional contact
    row = col = 0
    for c in range(nf):
        corners = CORNERS_2D if c >= nc or n_tangents[normal_rows[frictional[c]]] == 1 else CORNERS_3D
        _put_block(D, row, col, corners)
        for beta in range(corners.shape[1]):
            E[col + beta, c] = 1.0
        if c < nc:
            j = frictional[c]
            U[c, j] = rows.mu[normal_rows[j] + 1]
        row, col = row + corners.shape[0], col + corners.shape[1]
    A_nn, A_nt = _take(A, normal_rows, normal_rows), _take(A, normal_rows, tangent_rows)
    A_tn, A_tt = _take(A, tangent_rows, normal_rows), _take(A, tangent_rows, tangent_rows)
    size = nn + n_beta + nf
    M = np.zeros((size, size))
    _put_block(M, 0, 0, A_nn)
    _put_block(M, 0, nn, A_nt @ D)
    _put_block(M, nn, 0, D.T @ A_tn)
    _put_block(M, nn, nn, D.T @ A_tt @ D)
    _put_block(M, nn, nn + n_beta, E)
    _put_block(M, nn + n_beta, 0, U)
    _put_block(M, nn + n_beta, nn, -E.T)
    q, b_t = np.zeros(size), np.empty(len(tangent_rows))
    for i in range(nn):
        q[i] = -b[normal_rows[i]]
    for i in range(len(tangent_rows)):
        b_t[i] = b[tangent_rows[i]]
    D_b = D.T @ b_t  # -D^T b_t, negated after (exactly the same numbers)
    for i in range(n_beta):
        q[nn + i] = -D_b[i]
    for c in range(len(boxed)):  # a joint friction row's constant bound
        q[nn + n_beta + nc + c] = rows.mu[boxed[c]]
    z = lemke_or_retry(M, q, tally)
    gamma, t = np.zeros(K), D @ np.ascontiguousarray(z[nn:nn + n_beta])
    for i in range(nn):
        gamma[normal_rows[i]] = z[i]
    for i in range(len(tangent_rows)):
        gamma[tangent_rows[i]] = t[i]
    return gamma


@njit
def _put_block(M, row, col, B) -> None:
    """M[row:row + B.shape[0], col:col + B.shape[1]] = B."""
    for i in range(B.shape[0]):
        for j in range(B.shape[1]):
            M[row + i, col + j] = B[i, j]


@njit
def _take(A, rows, columns):
    """A[np.ix_(rows, columns)]."""
    out = np.empty((len(rows), len(columns)))
    for i in range(len(rows)):
        for j in range(len(columns)):
            out[i, j] = A[rows[i], columns[j]]
    return out


@njit
def mixed_lcp(A, b, rows, tally) -> np.ndarray:
    """gamma of the contact rows and a joint's limit and friction rows (pyramid_lcp's
    problem) and lambda of a joint's equality rows (BILATERAL, joints.py: free variables,
    A gamma - b = 0 there) together. The free variables are eliminated (the standard
    reduction of a mixed LCP; note 004's "mixed LCP"): lambda = A_JJ^+ (b_J - A_JC gamma),
    which leaves the LCP of pyramid_lcp on the Schur complement A_CC - A_CJ A_JJ^+ A_JC
    with b_C - A_CJ A_JJ^+ b_J, solved exactly. A_JJ^+ is the pseudo-inverse: a planar
    body's rows out of its plane, and a hinge's angular rows on a ball that cannot turn,
    are zero. A limit row whose target is -inf (its bounce belongs to the next step,
    joints.py) cannot act: it is left out, gamma = 0."""
    K = len(b)
    contact = np.array([k for k in range(K) if rows.normal[k] != BILATERAL and np.isfinite(b[k])], dtype=np.int64)
    joint = np.array([k for k in range(K) if rows.normal[k] == BILATERAL], dtype=np.int64)
    A_CC, A_CJ, A_JC, A_JJ = _take(A, contact, contact), _take(A, contact, joint), _take(A, joint, contact), \
        _take(A, joint, joint)
    inverse = np.linalg.pinv(A_JJ)
    b_C, b_J = b[contact], b[joint]
    gamma = np.zeros(K)
    if len(contact):
        gamma_C = pyramid_lcp(A_CC - A_CJ @ inverse @ A_JC, b_C - A_CJ @ (inverse @ b_J), _select(rows, contact),
                              tally)
        for k in range(len(contact)):
            gamma[contact[k]] = gamma_C[k]
        b_J = b_J - A_JC @ gamma_C
    lam = inverse @ b_J
    for k in range(len(joint)):
        gamma[joint[k]] = lam[k]
    return gamma


@njit
def _select(rows, index) -> Rows:
    """The rows `index` (increasing), each tangent row's `normal` moved to its normal row's
    new place (a row whose normal row is left out cannot be: index keeps whole contacts)."""
    where = np.full(len(rows.a), -1, np.int64)
    for k in range(len(index)):
        where[index[k]] = k
    normal = np.empty(len(index), np.int64)
    for k in range(len(index)):
        nk = rows.normal[index[k]]
        normal[k] = where[nk] if nk >= 0 else nk
    return Rows(rows.a[index], rows.b[index], rows.J_a[index], rows.J_b[index], normal, rows.mu[index],
                rows.c_r[index])


class Settings(NamedTuple):
    tally: np.ndarray  # lemke_or_retry's counts over the world's steps (TALLY entries)
    beta: float        # a joint's position error corrected per step (config.beta)
    slop: float        # a joint limit's overrun left alone (config.slop), m or rad


def settings(config) -> Settings:
    return Settings(np.zeros(TALLY, np.int64), float(config.beta), float(config.slop))


STAGES = ("velocity", "friction", "position", "joints")
VELOCITY, FRICTION, POSITION, JOINTS = 1, 2, 4, 8
JOINT_KINDS = frozenset({"ball", "revolute", "prismatic", "fixed"})  # the joints solve_joints takes (joints.py)
JOINT_LIMITS = JOINT_FRICTION = LIMIT_RESTITUTION = True  # limit rows (with limit_e), friction rows


@njit
def solve(contacts, bodies, dt, settings) -> int:
    """World formulation "lemke" (interface: reference_impl/__init__.py): the same LCP as
    formulation "pgs" (see pgs.solve), solved exactly; the overlap repair on
    pseudo-velocities is solved exactly too. Dense: meant for small systems."""
    rows, data, u = lcp.world_rows(contacts, bodies)
    gamma = pyramid_lcp(lcp.delassus(rows, data), lcp.world_rhs(contacts, rows, u), rows, settings.tally)
    lcp.apply_velocity_change(bodies, lcp.velocity_change(rows, data, gamma), False)
    lcp.store_impulses(contacts, gamma)
    stages = VELOCITY | (FRICTION if len(rows.a) > len(contacts.a) else 0)
    bias = lcp.world_bias(contacts, bodies)
    if np.any(bias > 0.0):
        stages |= POSITION
        normal = lcp.normal_rows(rows)
        P = lemke_or_retry(lcp.delassus(normal, data), -bias, settings.tally)
        lcp.apply_velocity_change(bodies, lcp.velocity_change(normal, data, P), True)
    return stages


@njit
def solve_joints(contacts, joints, bodies, dt, settings) -> int:
    """`solve` with the joints' rows (joints.py) after the contact rows, the equality rows
    free variables of one mixed LCP (mixed_lcp), the limit rows unilateral and the
    friction rows boxed, solved exactly; then the overlap repair with the joint rows'
    pseudo-velocity targets (joints.position_bias) beside the contacts' (as pgs.py's
    solve_joints)."""
    rows, data, u = lcp.world_rows(contacts, bodies)
    C, K = len(rows.a), len(joints.g)
    every = lcp.stack_rows(rows, joints.rows)
    rhs, contact_rhs, joint_rhs = np.empty(C + K), lcp.world_rhs(contacts, rows, u), joint_rows.rhs(joints, u)
    for k in range(C):
        rhs[k] = contact_rhs[k]
    for k in range(K):
        rhs[C + k] = joint_rhs[k]
    gamma = mixed_lcp(lcp.delassus(every, data), rhs, every, settings.tally)
    lcp.apply_velocity_change(bodies, lcp.velocity_change(every, data, gamma), False)
    lcp.store_impulses(contacts, gamma[:C])
    for k in range(K):
        joints.P[k] = gamma[C + k]
    stages = VELOCITY | (FRICTION if C > len(contacts.a) else 0) | JOINTS
    overlap = lcp.world_bias(contacts, bodies)
    joint_bias = joint_rows.position_bias(joints, settings.beta, dt, settings.slop)
    n = len(overlap)
    bias = np.empty(n + K)
    for k in range(n):
        bias[k] = overlap[k]
    for k in range(K):
        bias[n + k] = joint_bias[k]
    if np.any(bias != 0.0):
        stages |= POSITION
        normal = lcp.stack_rows(lcp.normal_rows(rows), joint_rows.position_rows(joints))
        P = mixed_lcp(lcp.delassus(normal, data), bias, normal, settings.tally)
        lcp.apply_velocity_change(bodies, lcp.velocity_change(normal, data, P), True)
    return stages


def knobs(config) -> dict:
    """What this formulation does with the world's contacts, for the adapter's record."""
    return {"solver": "Lemke, lexicographic pivoting on a dense tableau; refuses a result that fails its check "
                      "and retries, refactoring at every pivot, with M + eps max(diag M) I, eps in "
                      f"{', '.join(f'{e:g}' for e in RETRY_EPS)} (degenerate contact sets)",
            "friction_set": "pyramid as a friction-polyhedron LCP (corners +-t1 +-t2)",
            "restitution": "v_n+ >= contact.normal_target (-e vn0, vn0 before external forces)",
            "depenetration": "split impulse: Lemke on pseudo-velocities", "warm_start": False,
            "joints": "ball, revolute, prismatic and fixed joints as free variables of a mixed LCP, eliminated "
                      "through the pseudo-inverse of their block (Schur complement); limits unilateral rows with a "
                      "contact's target (limit_e its restitution), friction a one-row pyramid bounded by friction dt; "
                      "position error taken back on pseudo-velocities (-beta/dt g)"}
