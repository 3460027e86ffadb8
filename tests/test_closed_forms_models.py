"""The closed forms of the impact-model families against independent derivations.

- column_impact: the simultaneous model by solving its LCP (note 000) directly, over every
  active set, from the contact Jacobian; the sequential model by an event-driven
  simulation with real gaps and collision times (no sweeps, no 'one pair at a time'
  assumption), for two different gap patterns; and the need "impact_model:<model>" that
  sends each variant to the engines declaring its model.
- edge_landing: the collision matrix against the rigid-body impulse equations; the
  Newton-Coulomb impulse against the conditions that define the impact (Newton's law at
  the contact point, the friction cone, sticking or sliding against the resulting slip,
  no energy created), which have one solution.
- face_landing: the four-corner simultaneous LCP gives pure translation at e v_in, and a
  corner struck alone the spin the family's tolerance reason quotes.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial.transform import Rotation

from adapters.base import Capabilities
from cases import column_impact as ci
from cases import edge_landing as el
from cases import face_landing as fl
from cases.scene import Body, Material, Scene, ball, ground


# --- column impact: the simultaneous LCP, solved over active sets ------------------------------

def lcp_by_active_sets(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """gamma >= 0 with w = A gamma + b >= 0 and gamma . w = 0, by trying every set of active
    contacts (A positive definite: exactly one set works)."""
    k = len(b)
    found = []
    for active in itertools.product((False, True), repeat=k):
        S = np.flatnonzero(active)
        gamma = np.zeros(k)
        if S.size:
            gamma[S] = np.linalg.solve(A[np.ix_(S, S)], -b[S])
        w = A @ gamma + b
        if np.all(gamma >= -1e-12) and np.all(w >= -1e-12):
            found.append(gamma)
    assert len(found) == 1, f"{len(found)} complementary solutions"
    return found[0]


def simultaneous_by_lcp(masses, velocities, e):
    """Velocities after the impact from note 000's LCP: contact i between bodies i and i+1
    of the line (rear to front); its normal velocity is v_{i+1} - v_i, an impulse gamma_i
    pushes i back and i+1 forward; restitution asks w = v_n+ + e min(v_n-, 0) >= 0."""
    inv_m = np.array([0.0 if math.isinf(m) else 1.0 / m for m in masses])
    n = len(masses)
    J = np.zeros((n - 1, n))
    for i in range(n - 1):
        J[i, i], J[i, i + 1] = -1.0, 1.0
    v = np.asarray(velocities, float)
    A = J @ np.diag(inv_m) @ J.T
    vn = J @ v
    gamma = lcp_by_active_sets(A, vn + e * np.minimum(vn, 0.0))
    assert np.all(gamma > 0), "every contact is active (the family's claim)"
    return v + inv_m * (J.T @ gamma)


@pytest.mark.parametrize("p", [v.params for v in ci.FAMILY.variants if v.params["model"] == "simultaneous"],
                         ids=lambda p: ci.variant_id(p))
def test_simultaneous_closed_form_is_the_lcp_solution(p):
    masses, velocities = ci.setup_bodies(p)
    expected = simultaneous_by_lcp(masses, velocities, p["e"])
    got, _ = ci.model_velocities(p)
    assert got == pytest.approx(list(expected), abs=1e-12)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.lists(st.floats(0.05, 20.0), min_size=3, max_size=5), st.integers(0, 3), st.floats(0.0, 1.0),
       st.booleans())
def test_simultaneous_group_impact_for_any_masses(masses, split, e, wall):
    """Pressed groups either side of the one approaching contact leave as two rigid bodies,
    for any masses, split and e; with a wall (the ground) in front."""
    split = min(split, len(masses) - 2)
    if wall:
        masses = masses[:-1] + [math.inf]
        split = len(masses) - 2
    velocities = [1.0] * (split + 1) + [0.0] * (len(masses) - split - 1)
    got = ci.simultaneous_velocities(masses, velocities, e)
    assert got == pytest.approx(list(simultaneous_by_lcp(masses, velocities, e)), abs=1e-9)


# --- column impact: the sequential model by event-driven simulation ----------------------------

def two_body_impact(m_a, m_b, v_a, v_b, e):
    """Momentum conservation and v_b' - v_a' = -e (v_b - v_a), as a 2x2 linear system; a
    wall (m_b = inf) keeps v_b."""
    if math.isinf(m_b):
        return -e * v_a + (1 + e) * v_b, v_b
    A = np.array([[m_a, m_b], [-1.0, 1.0]])
    rhs = np.array([m_a * v_a + m_b * v_b, -e * (v_b - v_a)])
    return tuple(np.linalg.solve(A, rhs))


def event_driven(masses, velocities, e, gaps):
    """Point bodies on a line with the given gaps between neighbours: advance to the next
    collision (the smallest gap / closing speed), apply the two-body impact, repeat until
    no pair will ever meet."""
    v = list(map(float, velocities))
    gaps = list(map(float, gaps))
    for _ in range(10_000):
        times = [(gaps[i] / (v[i] - v[i + 1]), i) for i in range(len(v) - 1) if v[i] - v[i + 1] > 1e-15]
        if not times:
            return v
        tau, i = min(times)
        gaps = [g - tau * (v[j] - v[j + 1]) for j, g in enumerate(gaps)]
        gaps[i] = 0.0
        v[i], v[i + 1] = two_body_impact(masses[i], masses[i + 1], v[i], v[i + 1], e)
    raise AssertionError("no end")


@pytest.mark.parametrize("p", [v.params for v in ci.FAMILY.variants if v.params["model"] == "sequential"],
                         ids=lambda p: ci.variant_id(p))
@pytest.mark.parametrize("gaps", [(1e-3, 1e-3), (1e-3, 3.7e-3), (2.9e-6, 1e-6)])
def test_sequential_closed_form_is_the_event_driven_outcome(p, gaps):
    masses, velocities = ci.setup_bodies(p)
    got, _ = ci.model_velocities(p)
    assert got == pytest.approx(event_driven(masses, velocities, p["e"], gaps), abs=1e-12)


@pytest.mark.parametrize("p", [v.params for v in ci.FAMILY.variants if v.params["model"] == "simultaneous"],
                         ids=lambda p: ci.variant_id(p))
def test_the_two_models_differ_where_the_family_checks_them(p):
    """Each setup tells the models apart by far more than the velocity tolerance."""
    seq = ci.outcome({**p, "model": "sequential"})
    sim = ci.outcome(p)
    assert max(abs(seq[k] - sim[k]) for k in sim) > 0.2 * ci.V


def test_quoted_sequential_outcomes():
    """The module docstring's figures."""
    landing = ci.outcome({"setup": "landing", "e": 1.0, "model": "sequential", "dim": 3})
    assert landing["v_top"] / ci.V == pytest.approx(2.636, abs=1e-3)
    assert landing["v_bottom"] / ci.V == pytest.approx(0.636, abs=1e-3)
    strike = ci.outcome({"setup": "strike", "e": 0.5, "model": "sequential", "dim": 3})
    assert [strike[k] / ci.V for k in ("v_striker", "v_row0", "v_row1")] == pytest.approx([0.203, 0.234, 0.5625],
                                                                                           abs=1e-3)


def test_sequential_order_must_be_unique():
    with pytest.raises(ValueError, match="at once"):
        ci.sequential_velocities([1.0, 1.0, 1.0, 1.0], [1.0, 0.0, 1.0, 0.0], 1.0)


# --- the need "impact_model:<model>" -------------------------------------------------------------

def _caps(model):
    return Capabilities(dimensions=frozenset({3}), shapes=frozenset({"sphere", "plane"}), native_restitution=True,
                        static_kinetic=True, contact_forces=True, iterations=True, impact_model=model)


def test_impact_model_need_selects_the_engines_of_that_model():
    scene = Scene((ground(), Body("b", ball(0.1), mass=1.0, position=(0, 0, 0.2))), material=Material(e=0.5))
    assert _caps("simultaneous").cannot_run(scene, frozenset({"impact_model:simultaneous"})) is None
    reason = _caps("simultaneous").cannot_run(scene, frozenset({"impact_model:sequential"}))
    assert "sequential" in reason and "simultaneous" in reason
    assert "declares no impact model" in _caps(None).cannot_run(scene, frozenset({"impact_model:sequential"}))
    with pytest.raises(ValueError, match="impact model"):
        _caps("simultaneous").cannot_run(scene, frozenset({"impact_model:poisson"}))
    with pytest.raises(ValueError, match="impact_model"):
        _caps("poisson")


# Each engine's declared impact model (or none, where its runs follow neither) is checked
# against a run of touching balls landing: tests/test_declared_models.py.


def test_column_variants_need_their_model():
    for v in ci.FAMILY.variants:
        needs = ci.FAMILY.needs_of(v.params)
        assert needs == (frozenset() if v.params["model"] == "any" else {f"impact_model:{v.params['model']}"})


# --- edge landing: collision matrix and Newton-Coulomb impulse ------------------------------------

def contact_velocity_change(r, P, inertia=None):
    """Change of the contact point's velocity from the impulse P at r, from the rigid-body
    impulse equations: dv = P / m, dw = I^-1 (r x P), du = dv + dw x r (I the world-frame
    tensor; default the cube's el.I 1)."""
    dw = np.cross(r, P) / el.I if inertia is None else np.linalg.solve(inertia, np.cross(r, P))
    return P / el.M + np.cross(dw, r)


@settings(max_examples=100, deadline=None, derandomize=True)
@given(st.lists(st.floats(-0.2, 0.2), min_size=3, max_size=3), st.lists(st.floats(-5, 5), min_size=3, max_size=3))
def test_collision_matrix_is_the_impulse_response(r, P):
    r, P = np.asarray(r), np.asarray(P)
    assert el.collision_matrix(r) @ P == pytest.approx(contact_velocity_change(r, P), abs=1e-12)


def impact_conditions(r, P, mu, e, v_in, inertia=None):
    """Post-impact contact velocity u' and whether it sticks, after asserting what defines
    the impact: u'_n = e v_in, the impulse inside the cone, and either no slip or
    |P_t| = mu P_n against the slip."""
    u = np.array([0.0, 0.0, -v_in]) + contact_velocity_change(r, P, inertia)
    assert u[2] == pytest.approx(e * v_in, abs=1e-12)
    P_t, u_t = P[:2], u[:2]
    assert np.linalg.norm(P_t) <= mu * P[2] + 1e-12
    if np.linalg.norm(u_t) <= 1e-12:
        return u, True
    assert np.linalg.norm(P_t) == pytest.approx(mu * P[2], abs=1e-12)
    assert P_t @ u_t == pytest.approx(-np.linalg.norm(P_t) * np.linalg.norm(u_t), abs=1e-12)
    return u, False


@pytest.mark.parametrize("p", [v.params for v in el.FAMILY.variants], ids=lambda p: el.variant_id(p))
def test_edge_impulse_meets_the_impact_conditions(p):
    r, v_in, I_w = el.lever(p), el.impact_speed(), el.inertia(p)
    P = el.impact_impulse(r, p["mu"], el.E, v_in, inertia_w=I_w)
    _, stuck = impact_conditions(r, P, p["mu"], el.E, v_in, I_w)
    assert stuck == el.sticks(p) == (p["mu"] == 0.8)
    v = np.array([0.0, 0.0, -v_in]) + P / el.M
    w = np.linalg.solve(I_w, np.cross(r, P))
    assert 0.5 * el.M * v @ v + 0.5 * w @ I_w @ w <= 0.5 * el.M * v_in**2  # no energy created
    cf = el.after_impact(p)
    assert cf["contact_rebound"] == pytest.approx(el.E * v_in, abs=1e-12)
    assert cf["off_axis_spin"] == pytest.approx(0.0, abs=1e-12)  # the motion stays in the symmetry plane


@settings(max_examples=100, deadline=None, derandomize=True)
@given(st.floats(1.0, 40.0), st.floats(0.0, 1.5), st.floats(0.0, 1.0), st.booleans())
def test_newton_coulomb_impulse_for_any_tilt_friction_and_restitution(tilt, mu, e, corner):
    """The conditions hold over tilts, friction and restitution (a tilt about y or about the
    face diagonal, the lever from the cube's corners), and no energy is created."""
    p = {"tilt": "diag" if corner else "y", "mu": mu, "dim": 3}
    angle = math.radians(tilt)
    u = el.axis(p)
    R = Rotation.from_rotvec(angle * u).as_matrix()
    world = el.corners(el.HALF, 3) @ R.T
    r = world[np.isclose(world[:, 2], world[:, 2].min(), atol=1e-12)].mean(axis=0)
    P = el.impact_impulse(r, mu, e, 1.0)
    impact_conditions(r, P, mu, e, 1.0)
    w = np.cross(r, P) / el.I
    v = np.array([0.0, 0.0, -1.0]) + P / el.M
    assert 0.5 * el.M * v @ v + 0.5 * el.I * w @ w <= 0.5 * el.M + 1e-12
    assert np.linalg.norm(w - (w @ u) * u) == pytest.approx(0.0, abs=1e-9)


def test_edge_geometry():
    """The lever from scipy's rotation: the edge's midpoint a (cos + sin) below the centre,
    or the single corner sqrt 2 sin + cos; the start (GAP above, moving down) reaches the
    ground at V_IN at the touch time, by the free-fall position and velocity."""
    for v in el.FAMILY.variants:
        p = v.params
        if el.is_hull(p):  # the prism's edge: test_hull_edge_lever_and_inertia
            continue
        angle = math.radians(el.TILT[p["tilt"]])
        R = Rotation.from_rotvec(angle * el.axis(p)).as_matrix()
        assert el.rotation(el.orientation(p)) == pytest.approx(R, abs=1e-12)
        sigma = math.cos(angle) + (math.sin(angle) if p["tilt"] == "y" else math.sqrt(2) * math.sin(angle))
        assert -el.lever(p)[2] == pytest.approx(el.HALF * sigma, abs=1e-12)
        assert el.lever(p) @ el.axis(p) == pytest.approx(0.0, abs=1e-12)
        t, v0 = el.touch_time(), el.start_speed()
        assert v0 * t + 0.5 * el.G * t * t == pytest.approx(el.GAP, rel=1e-12)
        assert v0 + el.G * t == pytest.approx(el.V_IN, rel=1e-12)
        assert el.scene(p).body("box").position[2] + el.lever(p)[2] == pytest.approx(el.GAP, abs=1e-15)


def test_edge_sticking_ratio_is_the_quoted_one():
    """|p_t| / p_n of the sticking impulse: 0.40 (edge), 0.65 (corner), whatever e and v_in."""
    for tilt, ratio in (("y", 0.40), ("diag", 0.65)):
        for e, v_in in ((0.5, 1.0), (0.0, 3.0)):
            P = el.impact_impulse(el.lever({"tilt": tilt, "dim": 3}), math.inf, e, v_in)
            assert np.linalg.norm(P[:2]) / P[2] == pytest.approx(ratio, abs=0.005)


def test_hull_edge_lever_and_inertia():
    """The hexagonal prism on its edge: the lever is the bottom edge's midpoint (corners at
    +-30 deg, a cos 30 from the axis, HALF below the centre) turned 15 deg about y; the world
    tensor is the prism's principal moments turned the same way, checked against the
    moments by hand (I_z = 5/12 m a^2, I_x = I_y = m (5/24 a^2 + a^2/3)); and the frictionless
    impulse from K equals two corner impulses of the rigid-body LCP sharing the edge
    (note 000's rows n . (v + w x r) at both corners, least-norm)."""
    a, m = el.HALF, el.M
    p = {"tilt": "y", "mu": 0.0, "dim": 3, "shape": "hull"}
    assert el.HEX_PRISM.inertia(m) == pytest.approx((m * (5 / 24 + 1 / 3) * a**2,) * 2 + (5 / 12 * m * a**2,), rel=1e-12)
    R = Rotation.from_rotvec(math.radians(el.TILT["y"]) * np.array([0.0, 1.0, 0.0])).as_matrix()
    assert el.lever(p) == pytest.approx(R @ np.array([a * math.cos(math.pi / 6), 0.0, -a]), abs=1e-12)
    I_w = el.inertia(p)
    assert I_w == pytest.approx(R @ np.diag(el.HEX_PRISM.inertia(m)) @ R.T, abs=1e-15)
    ends = [R @ np.array([a * math.cos(math.pi / 6), y, -a]) for y in (-a / 2, a / 2)]
    n, v_in = np.array([0.0, 0.0, 1.0]), el.impact_speed()
    J = np.array([np.concatenate([n, np.cross(r, n)]) for r in ends])
    Minv = np.block([[np.eye(3) / m, np.zeros((3, 3))], [np.zeros((3, 3)), np.linalg.inv(I_w)]])
    u = np.concatenate([[0.0, 0.0, -v_in], np.zeros(3)])
    gamma = np.linalg.lstsq(J @ Minv @ J.T, -(1 + el.E) * (J @ u), rcond=None)[0]
    after = u + Minv @ J.T @ gamma
    cf = el.after_impact(p)
    assert after[2] == pytest.approx(cf["vz_after"], abs=1e-12) and after[4] == pytest.approx(cf["spin_after"], abs=1e-12)
    assert np.delete(after, [2, 4]) == pytest.approx(np.zeros(4), abs=1e-12)  # planar: no slide without friction, spin about y only


# --- face landing ---------------------------------------------------------------------------------

def corner_impacts(levers, e, v_in, inertia=None):
    """Velocity and spin after every listed corner strikes at once (note 000's LCP with the
    rigid-body rows n . (v + w x r)): the active set is all of them; A is singular (four
    contacts, three motions they constrain), so the impulses come as the least-norm
    solution, which is complementary here."""
    n = np.array([0.0, 0.0, 1.0])
    J = np.array([np.concatenate([n, np.cross(r, n)]) for r in levers])  # row: (n, r x n)
    inertia = [2 / 3 * fl.M * fl.HALF**2] * 3 if inertia is None else inertia  # the cube's by default
    Minv = np.diag([1 / fl.M] * 3 + [1 / i for i in inertia])
    u = np.concatenate([[0.0, 0.0, -v_in], np.zeros(3)])
    A = J @ Minv @ J.T
    b = (1 + e) * (J @ u)
    gamma = np.linalg.lstsq(A, -b, rcond=None)[0]
    assert np.all(gamma >= 0) and A @ gamma + b == pytest.approx(np.zeros(len(levers)), abs=1e-12)
    after = u + Minv @ J.T @ gamma
    return after[:3], after[3:]


@pytest.mark.parametrize("e", [0.0, 0.5])
def test_face_landing_is_pure_translation(e):
    a, v_in = fl.HALF, fl.impact_speed()
    face = [np.array([x, y, -a]) for x in (-a, a) for y in (-a, a)]
    v, w = corner_impacts(face, e, v_in)
    assert v == pytest.approx([0.0, 0.0, e * v_in], abs=1e-12)
    assert w == pytest.approx(np.zeros(3), abs=1e-12)
    assert (e * v_in) ** 2 / (2 * fl.G) == pytest.approx(fl.rebound_height(e), abs=1e-12)


@pytest.mark.parametrize("e", [0.0, 0.5])
def test_hull_face_landing_is_pure_translation(e):
    """The hexagonal prism hull lands on its six bottom corners at once: the same LCP with
    the prism's own inertia (the scene vocabulary's polyhedral integral) leaves it in pure
    translation at e v_in; and the six corners are the hull's lowest, HALF below the centre."""
    corners = np.asarray(fl.HEX_PRISM.vertices)
    bottom = corners[corners[:, 2] == corners[:, 2].min()]
    assert len(bottom) == 6 and bottom[0, 2] == pytest.approx(-fl.HALF)
    assert np.linalg.norm(bottom[:, :2], axis=1) == pytest.approx(np.full(6, fl.HALF))
    v, w = corner_impacts(list(bottom), e, fl.impact_speed(), inertia=fl.HEX_PRISM.inertia(fl.M))
    assert v == pytest.approx([0.0, 0.0, e * fl.impact_speed()], abs=1e-12)
    assert w == pytest.approx(np.zeros(3), abs=1e-12)
    assert fl.scene({"e": e, "mu": 0.0, "dim": 3, "shape": "hull"}).body("box").shape is fl.HEX_PRISM


@pytest.mark.parametrize("e, spin", [(0.0, 12.9), (0.5, 19.3)])
def test_one_corner_alone_spins_the_cube(e, spin):
    """The tolerance reason's figure: one corner struck alone (a detector that reports one
    point first) spins the cube at 13 rad/s (e = 0) to 19 rad/s (e = 0.5)."""
    a = fl.HALF
    _, w = corner_impacts([np.array([a, a, -a])], e, fl.impact_speed())
    assert np.linalg.norm(w) == pytest.approx(spin, abs=0.05)
