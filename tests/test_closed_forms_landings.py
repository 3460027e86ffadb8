"""The closed forms of oblique_landing, slow_impact and brick_tumble against independent routes: the
impulse-momentum equations of one body with a full inertia tensor solved as one
saddle-point (KKT) system in generalised velocities (no collision matrix), the world
inertia from scipy's rotation, the ball's textbook sliding-impact formula, the grid's
regimes (sliding slip keeps its direction; sticking inside a friction pyramid), torque-free
precession integrated to show the observer's angular momentum is what free flight keeps,
the slow ball's start gap, and the brick's support function, its rest-face basin (found by
steepest descent) and its release arc."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from cases import brick_tumble as bt
from cases import oblique_landing as ol
from cases import slow_impact as si

VARIANTS = [v.params for v in ol.FAMILY.variants]
IDS = [v.id for v in ol.FAMILY.variants]


def world_inertia(p) -> np.ndarray:
    """R diag(I) R^T with R from scipy (quaternion w, x, y, z reordered to x, y, z, w)."""
    w, x, y, z = ol.orientation(p)
    R = Rotation.from_quat([x, y, z, w]).as_matrix()
    I = ol._body(p).principal_inertia
    return R @ np.diag(I) @ R.T


def kkt_phase(p, x, mu: float, target: float | None = None, normal_impulse: float | None = None):
    """(v', w', J) of one impact phase from generalised velocities x = (v, w): M x' = M x +
    G^T J with G = [1, -r*] (u = v + w x r), solved as a saddle-point system in the six
    velocities and the impulse. Sticking: G x' = target n (or, given `normal_impulse` P:
    no tangential slip and n . J = P). Sliding (sticking outside the cone): the same normal
    condition and J = j (n - mu t), t along the slip before the phase (none: against the
    sticking impulse's tangential part). A 2D body keeps w_x = w_z = 0 (rows replaced)."""
    n = np.array([0.0, 0.0, 1.0])
    r = ol.lever(p)
    I_w = world_inertia(p) if p["dim"] == 3 else np.diag([1.0, ol._body(p).principal_inertia[1], 1.0])
    Mg = np.zeros((6, 6))
    Mg[:3, :3], Mg[3:, 3:] = ol.M * np.eye(3), I_w
    rx = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    G = np.hstack([np.eye(3), -rx])
    u = G @ x
    u_t = u - u[2] * n

    def planar(A, b):
        if p["dim"] == 2:
            for i in (3, 5):
                A[i, :] = 0.0
                A[i, i] = 1.0
                b[i] = 0.0
        return A, b

    # sticking: [M -G^T; G 0] [x'; J] = [M x; u']  (Poisson: the normal row n . J = P)
    A = np.zeros((9, 9))
    A[:6, :6], A[:6, 6:], A[6:, :6] = Mg, -G.T, G
    b = np.concatenate([Mg @ x, (target or 0.0) * n])
    if normal_impulse is not None:
        A[8, :], b[8] = 0.0, normal_impulse
        A[8, 8] = 1.0
    if p["dim"] == 2:  # the planar body: its contact point moves in x-z; keep y rows out
        A[7, :] = 0.0
        A[7, 7] = 1.0
        b[7] = 0.0
    sol = np.linalg.solve(*planar(A, b))
    J = sol[6:]
    if mu == 0.0 or np.linalg.norm(J[:2]) > mu * J[2]:
        slip = u_t if np.linalg.norm(u_t) > 0 else -(J - J[2] * n)
        t = slip / max(np.linalg.norm(slip), 1e-300)
        d = n - mu * t if mu > 0 else n
        A = np.zeros((7, 7))
        A[:6, :6], A[:6, 6] = Mg, -G.T @ d
        if normal_impulse is None:
            A[6, :6], b = n @ G, np.concatenate([Mg @ x, [target]])
        else:
            A[6, 6], b = 1.0, np.concatenate([Mg @ x, [normal_impulse]])
        sol = np.linalg.solve(*planar(A, b))
        J = sol[6] * d
    return sol[:3], sol[3:6], J


def kkt_impact(p):
    """(v', w', J) by the variant's restitution law, phase by phase (cases/impact_laws.py):
    Newton: one phase to -e u_n; two-phase: a plastic phase with friction, then a
    frictionless one to -e u_n; Poisson: the plastic phase, then one whose normal impulse is
    e times the first's."""
    x = np.concatenate([ol.start_velocity(p), p["w"]])
    u_n = (ol.start_velocity(p) + np.cross(p["w"], ol.lever(p)))[2]
    law = p.get("law", "newton")
    if law == "newton":
        return kkt_phase(p, x, p["mu"], target=-ol.E * u_n)
    v, w, J_c = kkt_phase(p, x, p["mu"], target=0.0)
    x = np.concatenate([v, w])
    if law == "two_phase":
        v, w, J_r = kkt_phase(p, x, 0.0, target=-ol.E * u_n)
    else:
        v, w, J_r = kkt_phase(p, x, p["mu"], normal_impulse=ol.E * J_c[2])
    return v, w, J_c + J_r


@pytest.mark.parametrize("p", [p for p in VARIANTS if "law" not in p],
                         ids=[i for i, p in zip(IDS, VARIANTS) if "law" not in p])
def test_regimes_are_unambiguous(p):
    """Sliding variants keep the slip's direction through the impact (so the note's law,
    the LCP's and the impact integrated in impulse time agree) and do not come near to
    sticking; sticking variants hold inside the inscribed friction pyramid. (The other
    laws' variants: tests/test_closed_forms_laws.py integrates them in impulse time.)"""
    if p["mu"] == 0.0:
        return
    r = ol.lever(p)
    u = ol.start_velocity(p) + np.cross(p["w"], r)
    J = ol.impulse({**p, "mu": math.inf})
    ratio = np.linalg.norm(J[:2]) / J[2]
    cf = ol.after_impact(p)
    slip_after = np.array([cf["slip_x"], cf.get("slip_y", 0.0)])
    if ol.sticks(p):
        assert ratio < p["mu"] / math.sqrt(2) and np.linalg.norm(slip_after) < 1e-12
    else:
        assert ratio > 1.1 * p["mu"]
        before = u[:2] / np.linalg.norm(u[:2])
        assert slip_after @ before == pytest.approx(np.linalg.norm(slip_after), rel=1e-9)  # parallel, same way
        assert np.linalg.norm(slip_after) > 0.1


def test_the_ball_obeys_the_textbook_sliding_impact():
    """A sliding ball: J_n = (1 + e) m V, the slip drops by mu J_n (1/m + R^2 / I) along
    itself, the centre's tangential velocity by mu J_n / m, the spin by R mu J_n / I."""
    for p in VARIANTS:
        if p["body"] != "ball" or ol.sticks(p) or "law" in p:  # Newton's law
            continue
        I = ol._body(p).principal_inertia[1]
        u = ol.start_velocity(p) + np.cross(p["w"], ol.lever(p))
        t = u[:2] / np.linalg.norm(u[:2])
        Jn = (1 + ol.E) * ol.M * ol.V
        cf = ol.after_impact(p)
        assert cf["vx"] == pytest.approx(p["vx"] - p["mu"] * Jn / ol.M * t[0], abs=1e-12)
        k_t = 1 / ol.M + ol.R**2 / I
        assert cf["slip_x"] == pytest.approx(u[0] - p["mu"] * Jn * k_t * t[0], abs=1e-12)


def test_the_turned_brick_has_no_principal_axis_along_the_world():
    """The corner pose's world inertia is full (every product of inertia non-zero), its
    principal moments are the brick's three distinct ones, and one corner is lowest by
    more than a millimetre."""
    p = next(q for q in VARIANTS if q["pose"] == "corner")
    I_w = world_inertia(p)
    assert ol.world_inertia(p, ol.orientation(p)) == pytest.approx(I_w, abs=1e-15)
    off = I_w[~np.eye(3, dtype=bool)]
    assert np.all(np.abs(off) > 1e-4)
    a, b, c = ol.SIDES
    moments = sorted(ol.M * np.array([b * b + c * c, a * a + c * c, a * a + b * b]) / 3)
    assert sorted(np.linalg.eigvalsh(I_w)) == pytest.approx(moments, abs=1e-15)
    assert len(set(np.round(moments, 6))) == 3
    z = np.sort((ol.vertices(3) @ ol.rotation(ol.orientation(p)).T)[:, 2])
    assert z[1] - z[0] > 1e-3
    assert ol.scene(p).body("body").position[2] == pytest.approx(-z[0], abs=1e-15)  # the corner at the ground


def test_free_flight_keeps_the_angular_momentum_the_observer_reads():
    """After the corner impact the brick precesses (w turns in the world frame): Euler's
    equations integrated for 20 ms keep L = R I R^T w, and w itself moves by far more than
    the tolerance, which is why the family reads L."""
    p = next(q for q in VARIANTS if q["pose"] == "corner" and q["mu"] == 0.0)
    I = np.array(ol._body(p).principal_inertia)
    R0 = ol.rotation(ol.orientation(p))
    cf = ol.after_impact(p)
    L0 = np.array([cf["Lx"], cf["Ly"], cf["Lz"]])
    w_body0 = (R0.T @ L0) / I

    def rhs(_, y):
        w, R = y[:3], y[3:].reshape(3, 3)
        dw = np.array([(I[1] - I[2]) * w[1] * w[2] / I[0], (I[2] - I[0]) * w[2] * w[0] / I[1],
                       (I[0] - I[1]) * w[0] * w[1] / I[2]])
        W = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        return np.concatenate([dw, (R @ W).ravel()])

    sol = solve_ivp(rhs, (0.0, 0.02), np.concatenate([w_body0, R0.ravel()]), rtol=1e-11, atol=1e-13)
    w_b, R = sol.y[:3, -1], sol.y[3:, -1].reshape(3, 3)
    assert R @ (I * w_b) == pytest.approx(L0, abs=1e-9)
    w_world0, w_world = R0 @ w_body0, R @ w_b
    assert np.linalg.norm(w_world - w_world0) > 1e-3


def test_slow_ball_touches_inside_its_third_step_and_has_time_to_leave():
    for v in si.FAMILY.variants:
        p = v.params
        s = si.scene(p)
        gap = s.body("ball").position[2] - si.R
        assert gap / p["v"] == pytest.approx(2.5 * si.DT, rel=1e-12)
        # after the touch, MuJoCo's ~20-step contact and five free steps fit in the run
        assert 2.5 * si.DT + 25 * si.DT < si.T
        checks = {c.metric: c for c in si.FAMILY.expect(p, si.DT)}
        assert checks["rebound"].expected == pytest.approx(si.E * p["v"], rel=1e-15)


# --- brick tumble: support function, critical values, release arc, rest face --------------------


def test_brick_support_is_the_depth_of_the_lowest_vertex():
    """sigma(n) = a |n_1| + b |n_2| + c |n_3| against the vertices rotated by scipy."""
    rng = np.random.default_rng(2)
    verts = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * np.array(bt.SIDES)
    for _ in range(200):
        R = Rotation.random(random_state=rng)
        x, y, z, w = R.as_quat()
        assert bt.support((w, x, y, z), 3) == pytest.approx(-np.min((verts @ R.as_matrix().T)[:, 2]), abs=1e-12)


def test_brick_barrier_is_the_lowest_saddle_between_rest_faces():
    """Brute force: on a dense set of directions n, wherever n leaves the region of the a-face
    (its nearest face minimum, by steepest descent of sigma, changes) sigma is at least
    sqrt(a^2 + b^2); that value is reached (the a-b edge)."""
    rng = np.random.default_rng(3)
    n = rng.normal(size=(60_000, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    h = np.array(bt.SIDES)
    radius = 0.02  # neighbours this close in n differ in sigma by at most radius |h|
    sigma = np.abs(n) @ h
    # the face minimum sigma descends to from n, by steps along -grad sigma on the sphere
    m = n.copy()
    for _ in range(300):
        g = np.sign(m) * h
        g -= np.sum(g * m, axis=1)[:, None] * m
        m -= 0.01 * g
        m /= np.linalg.norm(m, axis=1)[:, None]
    face = np.argmax(np.abs(m), axis=1) * 2 + (m[np.arange(len(m)), np.argmax(np.abs(m), axis=1)] > 0)
    a_up = face == 1  # +e_1: lying on the a-face with the body x axis up
    # boundary of that basin: points in it with a neighbour (near in n) outside it
    from scipy.spatial import cKDTree
    tree = cKDTree(n)
    pairs = tree.query_pairs(radius, output_type="ndarray")
    cross = pairs[a_up[pairs[:, 0]] != a_up[pairs[:, 1]]]
    edge_sigma = np.minimum(sigma[cross[:, 0]], sigma[cross[:, 1]])
    assert edge_sigma.min() >= bt.barrier(3) - radius * np.linalg.norm(h)
    assert edge_sigma.min() == pytest.approx(bt.barrier(3), abs=radius * np.linalg.norm(h))


@pytest.mark.parametrize("p", bt.GRID, ids=bt.variant_id)
def test_brick_release_lies_in_the_a_face_basin_below_the_barrier(p):
    """sigma rises monotonically along the tilt from lying flat (so the release is in the
    a-face's part of the sublevel set), the release energy is below m g s* with room for a
    solver's depth, the lowest feature is an edge (tilt about y) or one corner, and the
    a-face is the one down at release."""
    angles = np.linspace(0.0, math.radians(bt.TILT[p["tilt"]]), 200)
    s = [bt.support(bt.orientation(p, a), p["dim"]) for a in angles]
    assert s[0] == pytest.approx(bt.SIDES[0], abs=1e-12) and np.all(np.diff(s) > 0)
    assert bt.margin(p) > 20 * bt.PENETRATION
    q = bt.orientation(p)
    w, x, y, z = q
    R = Rotation.from_quat([x, y, z, w]).as_matrix()
    ys = (-1, 1) if p["dim"] == 3 else (0,)
    verts = np.array([(i, j, k) for i in (-1, 1) for j in ys for k in (-1, 1)]) * np.array(bt.SIDES)
    zs = (verts @ R.T)[:, 2]
    lowest = np.sum(np.isclose(zs, zs.min(), atol=1e-12))
    assert lowest == (2 if (p["tilt"] == "y" and p["dim"] == 3) else 1)
    assert R[2, 0] > 0.98  # the body x axis nearly up: the a-face down
    assert bt.energy_dissipated(p) == pytest.approx(bt.M * bt.G * (bt.H - zs.min() - bt.SIDES[0]),
                                                     abs=1e-12)
