"""The closed forms of the impact, cradle, stack, free-body and Hertz families against
independent derivations: impulse-momentum equations solved as one linear system,
event-driven collisions, free-body equations, Euler's equations and Hertz's law
integrated numerically, the contact-duration integral by quadrature. The compliant
variants (not in the default grid: see cases/hertz_impact.py) run here on the engines
they are meant for, reference-hertz and reference-hooke."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.integrate import quad, solve_ivp

from adapters import registry
from cases import eccentric_impact as ei
from cases import free_rigid_body as fr
from cases import hertz_impact as hi
from cases import newtons_cradle as nc
from cases import stack_forces as sf
from cases.impact_laws import newton_impulse
from cases.observables import free_flight_error


def cross_matrix(r) -> np.ndarray:
    x, y, z = r
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


# --- eccentric impact ---------------------------------------------------------------------

def impulse_momentum(M_1, I_1, M_2, I_2, r_1, r_2, v_1, v_2, n, e, mu, planar, w_1=None, w_2=None,
                     target=None, normal_impulse=None):
    """Post-impact (v_1, w_1, v_2, w_2, J) from the impulse-momentum equations of both
    bodies and the contact law, as one linear system (no collision matrix): unknowns
    v_1', w_1', v_2', w_2', J (and the sliding magnitude j). Bodies start spinning at w_1,
    w_2 (default none). Sticking: u' = target n, target = -e u_n unless given. Sliding (if
    sticking needs |J_t| > mu J_n): n . u' = target and J = j (n - mu t), t along the slip
    before the impact. Given `normal_impulse` P, the normal row is n . J = P instead of the
    normal velocity (Poisson's restitution phase). A planar body keeps w_x = w_z = 0 (its
    x and z inertia rows are replaced by w = 0)."""
    w_1 = np.zeros(3) if w_1 is None else np.asarray(w_1, float)
    w_2 = np.zeros(3) if w_2 is None else np.asarray(w_2, float)
    I_1, I_2 = np.diag(I_1), np.diag(I_2)
    u = v_2 + np.cross(w_2, r_2) - v_1 - np.cross(w_1, r_1)
    u_n = u @ n
    target = -e * u_n if target is None else target
    t = (u - u_n * n) / max(np.linalg.norm(u - u_n * n), 1e-300)

    def solve(sticking: bool) -> np.ndarray:
        size = 16 if not sticking else 15
        A, b = np.zeros((size, size)), np.zeros(size)
        V1, W1, V2, W2, JJ = (slice(3 * i, 3 * i + 3) for i in range(5))
        A[0:3, V1], A[0:3, JJ], b[0:3] = M_1 * np.eye(3), np.eye(3), M_1 * v_1          # M_1 v_1' + J = M_1 v_1
        A[3:6, W1], A[3:6, JJ], b[3:6] = I_1, cross_matrix(r_1), I_1 @ w_1              # I_1 w_1' + r_1 x J = I_1 w_1
        A[6:9, V2], A[6:9, JJ], b[6:9] = M_2 * np.eye(3), -np.eye(3), M_2 * v_2          # M_2 v_2' - J = M_2 v_2
        A[9:12, W2], A[9:12, JJ], b[9:12] = I_2, -cross_matrix(r_2), I_2 @ w_2           # I_2 w_2' - r_2 x J = I_2 w_2
        if planar:
            for row, W in ((3, W1), (9, W2)):
                for axis in (0, 2):
                    A[row + axis, :], b[row + axis] = 0.0, 0.0
                    A[row + axis, W.start + axis] = 1.0
        # u' = v_2' + w_2' x r_2 - v_1' - w_1' x r_1, with w x r = -r* w
        U = np.zeros((3, size))
        U[:, V2], U[:, W2], U[:, V1], U[:, W1] = np.eye(3), -cross_matrix(r_2), -np.eye(3), cross_matrix(r_1)
        if sticking:
            A[12:15], b[12:15] = U, target * n
        else:
            A[12], b[12] = n @ U, target
            A[13:16, JJ], A[13:16, 15] = np.eye(3), -(n - mu * t)                         # J - j (n - mu t) = 0
        if normal_impulse is not None:  # n . J = P in place of the normal velocity row
            A[12], b[12] = 0.0, normal_impulse
            A[12, JJ] = n
            if sticking:  # the sticking rows: only the tangential velocity vanishes
                A[13:15], b[13:15] = np.linalg.svd(np.outer(n, n))[0][:, 1:].T @ U, 0.0
        return np.linalg.solve(A, b)

    x = solve(True)
    J = x[12:15]
    if mu == 0.0 or np.linalg.norm(J - (J @ n) * n) > mu * (J @ n):
        x = solve(False)
    return x[0:3], x[3:6], x[6:9], x[9:12], x[12:15]


def from_scene(p):
    """The impulse-momentum inputs read off the case's scene: masses, inertias, and the
    contact point where the ball's surface meets the rod's face (normal x)."""
    scene = ei.scene(p)
    b, r = scene.body("ball"), scene.body("rod")
    n = np.array([1.0, 0.0, 0.0])
    point = np.array(b.position) + b.shape.radius * n
    assert point[0] == pytest.approx(r.position[0] - r.shape.half_extents[0], abs=1e-12)  # on the face
    return dict(M_1=b.mass, I_1=b.principal_inertia, M_2=r.mass, I_2=r.principal_inertia,
                r_1=point - np.array(b.position), r_2=point - np.array(r.position),
                v_1=np.array(b.velocity), v_2=np.array(r.velocity), n=n, e=p["e"], mu=p["mu"],
                planar=p["dim"] == 2)


def poisson(**inputs):
    """Poisson's law phase by phase: the plastic impact with friction, then from the
    velocities it leaves an impact whose normal impulse is e times the first's."""
    e = inputs["e"]
    v_1, w_1, v_2, w_2, J_c = impulse_momentum(**{**inputs, "e": 0.0})
    v_1, w_1, v_2, w_2, J_r = impulse_momentum(**{**inputs, "v_1": v_1, "v_2": v_2}, w_1=w_1, w_2=w_2,
                                               normal_impulse=e * (J_c @ inputs["n"]))
    return v_1, w_1, v_2, w_2, J_c + J_r


def two_phase(**inputs):
    """The two-phase law phase by phase: the impulse-momentum system of a plastic impact
    with friction, then, from the velocities it leaves, one of a frictionless impact whose
    normal velocity ends at -e times the approach before the first phase."""
    e = inputs["e"]
    u_n = (inputs["v_2"] - inputs["v_1"]) @ inputs["n"]
    v_1, w_1, v_2, w_2, J_c = impulse_momentum(**{**inputs, "e": 0.0})
    v_1, w_1, v_2, w_2, J_r = impulse_momentum(**{**inputs, "v_1": v_1, "v_2": v_2, "mu": 0.0}, w_1=w_1, w_2=w_2,
                                               target=-e * u_n)
    return v_1, w_1, v_2, w_2, J_c + J_r


@pytest.mark.parametrize("p", ei.FULL_GRID, ids=ei.variant_id)
def test_eccentric_impact_solves_the_impulse_momentum_equations(p):
    law = {"two_phase": two_phase, "poisson": poisson, "newton": impulse_momentum}[ei.law_of(p)]
    v_1, w_1, v_2, w_2, J = law(**from_scene(p))
    after = ei.velocities_after(p)
    for got, want in ((after["v_1"], v_1), (after["w_1"], w_1), (after["v_2"], v_2), (after["w_2"], w_2),
                      (after["J"], J)):
        assert got == pytest.approx(want, abs=1e-12)


@settings(max_examples=60, deadline=None)
@given(m1=st.floats(0.1, 10.0), m2=st.floats(0.1, 10.0), e=st.floats(0.0, 1.0), mu=st.floats(0.0, 2.0),
       d=st.floats(-0.3, 0.3), vt=st.floats(-2.0, 2.0), dim=st.sampled_from([2, 3]))
def test_newton_coulomb_impulse_against_the_linear_system(m1, m2, e, mu, d, vt, dim):
    """The collision-matrix law (note 004) and the impulse-momentum system agree for any
    masses, offset, slip and friction of the planar strike."""
    I_1 = (0.4 * m1 * ei.R**2,) * 3 if dim == 3 else (0.5 * m1 * ei.R**2,) * 3
    I_2 = tuple(m2 * (a * a + c * c) / 3.0 for a, c in ((ei.A, ei.C), (ei.A, ei.C), (ei.A, ei.A)))
    I_1_inv = np.diag([1.0 / i for i in I_1]) if dim == 3 else np.diag([0.0, 1.0 / I_1[1], 0.0])
    I_2_inv = np.diag([1.0 / i for i in I_2]) if dim == 3 else np.diag([0.0, 1.0 / I_2[1], 0.0])
    r_1, r_2, n = np.array([ei.R, 0, 0]), np.array([-ei.A, 0, d]), np.array([1.0, 0, 0])
    v_1 = np.array([2.0, 0.0, vt])
    if mu > 0 and abs(vt) < 1e-3:
        vt = 1e-3  # the note's sliding direction needs slip
        v_1[2] = vt
    K = ei.body_collision_matrix(m1, I_1_inv, r_1) + ei.body_collision_matrix(m2, I_2_inv, r_2)
    J = newton_impulse(K, -v_1, n, e, mu, mu)
    *_, J_ref = impulse_momentum(m1, I_1, m2, I_2, r_1, r_2, v_1, np.zeros(3), n, e, mu, dim == 2)
    assert J == pytest.approx(J_ref, abs=1e-9)


def test_grid_has_a_sticking_and_a_sliding_strike_whose_slip_keeps_its_direction():
    """A sliding strike's slip keeps its sign through the impact, so the note's direction
    (slip before) is the one a simultaneous solver uses (slip after): the same impulse."""
    kinds = set()
    for p in ei.GRID:
        if p["mu"] == 0 or ei.law_of(p) != "newton":  # the two-phase law: test_two_phase_friction_...
            continue
        s, after = ei.setup(p), ei.velocities_after(p)
        J, n = after["J"], s["n"]
        u_t = (s["v_2"] - s["v_1"])[2]
        u_after = (after["v_2"] + np.cross(after["w_2"], s["r_2"])
                   - after["v_1"] - np.cross(after["w_1"], s["r_1"]))
        u_t_after = u_after[2]
        J_t, J_n = abs(J[2]), J @ n
        if J_t < p["mu"] * J_n - 1e-12:
            kinds.add("sticks")
            assert u_t_after == pytest.approx(0.0, abs=1e-12)
        else:
            kinds.add("slides")
            assert J_t == pytest.approx(p["mu"] * J_n, rel=1e-12)
            assert np.sign(u_t_after) == np.sign(u_t) and abs(u_t_after) > 0.05
    assert kinds == {"sticks", "slides"}


@pytest.mark.parametrize("dim", [3, 2])
def test_two_phase_friction_acts_on_the_compression_impulse_only(dim):
    """A ball sliding through the impact: friction mu J_n acts on the plastic phase's normal
    impulse, 1/(1 + e) of Newton's; its spin (from friction alone) is 1/(1 + e) of Newton's,
    and both laws give the same normal approach-to-departure ratio -e."""
    newton = {"e": 0.5, "mu": 0.1, "v_t": -1.0, "dim": dim}
    phased = dict(newton, law="two_phase")
    w_n, w_p = ei.velocities_after(newton)["w_1"][1], ei.velocities_after(phased)["w_1"][1]
    assert w_p == pytest.approx(w_n / 1.5, rel=1e-12)
    for p in (newton, phased):
        s, after = ei.setup(p), ei.velocities_after(p)
        u_n = s["v_2"] @ s["n"] - s["v_1"] @ s["n"]
        u_after = after["v_2"] + np.cross(after["w_2"], s["r_2"]) - after["v_1"] - np.cross(after["w_1"], s["r_1"])
        assert u_after @ s["n"] == pytest.approx(-0.5 * u_n, rel=1e-12)


def test_the_restitution_law_is_a_declared_capability():
    """An engine is judged by the closed form of the law it declares: the Newton variants are
    unsupported on a two-phase engine and the reverse."""
    from adapters.base import Capabilities
    base = dict(dimensions=frozenset({2, 3}), shapes=frozenset({"sphere", "box", "circle", "rect"}),
                native_restitution=True, static_kinetic=True, contact_forces=True, iterations=True)
    newton, phased = Capabilities(**base), Capabilities(**base, restitution_law="two_phase")
    for v in ei.FAMILY.variants:
        scene, needs = ei.scene(v.params), ei.FAMILY.needs_of(v.params)
        law = ei.law_of(v.params) if ei.law_matters(v.params) else None
        assert (newton.cannot_run(scene, needs) is None) == (law in (None, "newton"))
        assert (phased.cannot_run(scene, needs) is None) == (law in (None, "two_phase"))
    if registry.available("box2d"):
        assert registry.get("box2d").capabilities.restitution_law == "two_phase"


@pytest.mark.parametrize("p", ei.FULL_GRID, ids=ei.variant_id)
def test_eccentric_impacts_never_gain_energy(p):
    assert ei.closed_form(p)["energy_lost"] >= -1e-12


# --- Newton's cradle ----------------------------------------------------------------------

def event_driven_row(x, v, r, m):
    """Exact rigid collisions of balls on a line with e = 1: advance to the earliest
    contact, resolve that pair by momentum and Newton's law, repeat until no neighbours
    approach."""
    x, v = np.array(x, float), np.array(v, float)
    for _ in range(1000):
        gaps, closing = np.diff(x) - 2.0 * r, v[:-1] - v[1:]
        times = np.where(closing > 0, gaps / np.where(closing > 0, closing, 1.0), np.inf)
        i = int(np.argmin(times))
        if not math.isfinite(times[i]):
            return v
        x += v * times[i]
        A = np.array([[m, m], [-1.0, 1.0]])
        v[i], v[i + 1] = np.linalg.solve(A, [m * v[i] + m * v[i + 1], -(v[i + 1] - v[i])])
    raise RuntimeError("no end to the collisions")


@pytest.mark.parametrize("p", nc.GRID, ids=nc.variant_id)
def test_cradle_closed_form_is_the_sequence_of_pair_impacts(p):
    scene = nc.scene(p)
    balls = [scene.body(n) for n in nc.names()]
    got = event_driven_row([b.position[0] for b in balls], [b.velocity[0] for b in balls], nc.R, nc.M)
    assert nc.sequential_velocities(p["k"]) == pytest.approx(got, abs=1e-12)
    assert [c.expected for c in nc.expect(p, 1e-3)][:nc.N] == [0.0] * (nc.N - p["k"]) + [nc.V] * p["k"]


def test_compliant_row_conserves_and_hertz_disperses_less_than_hooke():
    """Note 001 (Herrmann & Seitz): dispersion falls as the force-law exponent grows. The
    last ball carries most of the energy with Hertz's law and less with Hooke's; neither
    reaches the dispersion-free cradle (all of it)."""
    share = {}
    for p in nc.COMPLIANT_GRID:
        v = np.array(nc.compliant_velocities(p))
        assert nc.M * v.sum() == pytest.approx(nc.M * nc.V * p["k"], rel=1e-9)
        assert 0.5 * nc.M * (v @ v) == pytest.approx(0.5 * nc.M * nc.V**2 * p["k"], rel=1e-8)
        share[p["law"]] = v[-1] ** 2 / (nc.V**2 * p["k"])
    assert share["hooke"] < share["hertz"] < 1.0
    assert share["hertz"] > 0.97 and share["hooke"] < 0.9  # 0.978 and 0.888


def hooke_row_exactly(p) -> np.ndarray:
    """Final velocities of the touching row under F = k xi, solved exactly: between
    events the row is linear, m x'' = -k L x + f (L the Laplacian of the pairs in contact,
    f their rest-length terms), so its modes move as cos and sin (and the centre of mass
    freely); an event is a pair parting (xi falls to 0) or closing (a gap falls to 0),
    found by bisection on the exact motion. No time stepping, no scipy integrator."""
    k_s, m, n = p["stiffness"], nc.M, nc.N
    x = 2.0 * nc.R * np.arange(n, dtype=float)
    v = np.array([nc.V] * p["k"] + [0.0] * (n - p["k"]))
    active = np.ones(n - 1, dtype=bool)  # all touching; the first pair closes at once

    def motion(x0, v0, active):
        L, f = np.zeros((n, n)), np.zeros(n)
        for j in np.flatnonzero(active):  # pair j, j + 1 pushes apart with k (2R - (x_j+1 - x_j))
            L[j:j + 2, j:j + 2] += [[1.0, -1.0], [-1.0, 1.0]]
            f[j] -= 2.0 * nc.R
            f[j + 1] += 2.0 * nc.R
        lam, Q = np.linalg.eigh(k_s / m * L)
        z0, w0, b = Q.T @ x0, Q.T @ v0, Q.T @ (k_s / m * f)
        def at(t):
            z, w = np.empty(n), np.empty(n)
            for i, l in enumerate(lam):
                if l > 1e-9 * k_s / m:
                    om, zc = math.sqrt(l), b[i] / l
                    z[i] = zc + (z0[i] - zc) * math.cos(om * t) + w0[i] / om * math.sin(om * t)
                    w[i] = -(z0[i] - zc) * om * math.sin(om * t) + w0[i] * math.cos(om * t)
                else:  # the centre of mass (b[i] = 0: the pair forces cancel)
                    z[i], w[i] = z0[i] + w0[i] * t, w0[i]
            return Q @ z, Q @ w
        return at

    def overlap(x):
        return 2.0 * nc.R - np.diff(x)

    for _ in range(100):
        at = motion(x, v, active)
        # the first event: an active pair's overlap or an open pair's gap through zero
        grid = np.linspace(0.0, 1e-2, 20001)[1:]
        sign = np.where(active, 1.0, -1.0)
        hit = next((t for t in grid if np.any(sign * overlap(at(t)[0]) < 0.0)), None)
        if hit is None:
            return v if not active.any() else at(grid[-1])[1]
        lo, hi = hit - (grid[1] - grid[0]), hit
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if np.all(sign * overlap(at(mid)[0]) >= 0.0) else (lo, mid)
        x, v = at(hi)
        xi = overlap(x)
        active = np.where(active, xi > 0.0, xi >= 0.0)
    raise RuntimeError("no end to the events")


def verlet_row(p, h: float = 2e-8) -> np.ndarray:
    """Final velocities of the touching row under its force law, by velocity Verlet at a
    fixed step h (second order, time-reversible): another integrator than the case's
    adaptive DOP853, run until every pair has parted and no neighbours approach."""
    H, r = nc.force_law(p)
    x = 2.0 * nc.R * np.arange(nc.N, dtype=float)
    v = np.array([nc.V] * p["k"] + [0.0] * (nc.N - p["k"]))

    def accel(x):
        F = H * np.maximum(2.0 * nc.R - np.diff(x), 0.0) ** r
        a = np.zeros(nc.N)
        a[:-1] -= F / nc.M
        a[1:] += F / nc.M
        return a
    a = accel(x)
    for step in range(10**7):
        x = x + h * v + 0.5 * h * h * a
        a_new = accel(x)
        v = v + 0.5 * h * (a + a_new)
        a = a_new
        if step % 1000 == 0 and np.all(np.diff(x) > 2.0 * nc.R) and np.all(np.diff(v) >= 0.0):
            return v
    raise RuntimeError("the row did not part")


@pytest.mark.parametrize("p", nc.COMPLIANT_GRID, ids=nc.variant_id)
def test_compliant_row_a_second_way(p):
    """The compliant cradle's expected velocities (scipy DOP853 on the equations of motion)
    against a second derivation: Hooke's row solved exactly between contact events, Hertz's
    by velocity Verlet at 2e-8 s (its 0.6 ms contacts in 30 000 steps: O(h^2) ~ 1e-9)."""
    got = hooke_row_exactly(p) if p["law"] == "hooke" else verlet_row(p)
    assert nc.compliant_velocities(p) == pytest.approx(list(got), abs=1e-7 * nc.V)


# --- stack forces -------------------------------------------------------------------------

@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(0.1, 100.0), min_size=2, max_size=10))
def test_stack_forces_from_free_body_equations(masses):
    # box k: F_k - F_{k+1} = m_k g, F_n = 0
    n, g = len(masses), 9.81
    A = np.eye(n) - np.eye(n, k=1)
    F = np.linalg.solve(A, g * np.array(masses))
    assert [sf.interface_force(masses, k, g) for k in range(n)] == pytest.approx(F, rel=1e-12)


def test_stack_mass_patterns_and_heights():
    assert sf.box_masses({"n": 4, "masses": "heavy-light"}) == [10.0, 1.0, 10.0, 1.0]
    assert sf.box_masses({"n": 3, "masses": "light-heavy"}) == [1.0, 10.0, 1.0]
    assert max(p["n"] for p in sf.GRID) == 10 and {p["n"] for p in sf.FULL_GRID} == set(range(2, 11))


# --- free rigid body ----------------------------------------------------------------------

def euler_crossings(I, w0, T):
    """Times at which w_2 (the intermediate axis) changes sign, Euler's equations
    integrated to 1e-12."""
    sol = solve_ivp(lambda t, w: fr.euler_rates(I, w), (0.0, T), w0, method="DOP853", rtol=1e-12, atol=1e-12,
                    events=lambda t, w: w[1], dense_output=True)
    return sol.t_events[0]


@pytest.mark.parametrize("w0", [(0.0, 5.0, 2.0), (0.0, 5.0, 3.0), (0.0, 10.0, 0.2), (2.0, 5.0, 0.0), (0.5, 10.0, 0.0)],
                         ids=str)
def test_flip_times_against_eulers_equations(w0):
    """Perturbed about the least (z) or the largest (x) inertia axis: both sides of the
    separatrix M^2 = 2 E I_2."""
    I, w0 = fr.inertia({"dim": 3}), np.array(w0)
    T_flip = fr.flip_interval(I, *fr.invariants(I, w0))
    z = euler_crossings(I, w0, 3.6 * T_flip)
    assert z[0] == pytest.approx(T_flip / 2, rel=1e-7)        # starts at the extreme of w_2
    assert np.diff(z) == pytest.approx([T_flip] * (len(z) - 1), rel=1e-7)


def runge_kutta_2(alpha: float):
    """The two-stage second-order Runge-Kutta step with its second stage at alpha dt
    (1/2: explicit midpoint, 1: Heun, 2/3: Ralston), on Euler's equations."""
    def step(I, w, dt):
        k1 = fr.euler_rates(I, w)
        k2 = fr.euler_rates(I, w + alpha * dt * k1)
        return w + dt * ((1.0 - 1.0 / (2.0 * alpha)) * k1 + k2 / (2.0 * alpha))
    return step


def explicit_euler(I, w, dt):
    return w + dt * fr.euler_rates(I, w)


def drifts(step, I, w0, T, dt, T_flip):
    """(max |dE|/E, max |d|L||/|L|, |first flip - T_flip/2|) of the body-frame step over T."""
    w = np.array(w0, float)
    E0, L0, ws = I @ w**2, np.linalg.norm(I * w), [w]
    for _ in range(int(round(T / dt))):
        w = step(I, w, dt)
        ws.append(w)
    ws = np.array(ws)
    s = ws[:, 1]
    k = np.flatnonzero(np.sign(s[1:]) != np.sign(s[:-1]))[0]
    flip = (k + s[k] / (s[k] - s[k + 1])) * dt
    return (np.max(np.abs(np.einsum("ni,i,ni->n", ws, I, ws) / E0 - 1.0)),
            np.max(np.abs(np.linalg.norm(ws * I, axis=1) / L0 - 1.0)), abs(flip - T_flip / 2.0))


@pytest.mark.parametrize("w0", [(0.0, 5.0, 2.0), (0.0, 10.0, 0.2)], ids=str)
def test_second_order_bounds_hold_for_runge_kutta_2_and_fail_explicit_euler(w0):
    """The family's bounds (dt^2/2 s_E, dt^2/6 s_M, dt^2/6 s_phase) hold for the three
    classic second-order Runge-Kutta steps at two dt, whose drifts shrink at least
    fourfold when dt halves (Heun's invariants: eightfold). Explicit Euler (first order)
    exceeds them."""
    I, w0 = fr.inertia({"dim": 3}), np.array(w0)
    E2, M2 = fr.invariants(I, w0)
    T_flip = fr.flip_interval(I, E2, M2)
    T = 0.75 * T_flip
    s_E, s_M, s_phase = fr.integrator_scales(I, w0, T, T_flip / 2.0)
    for alpha in (0.5, 1.0, 2.0 / 3.0):
        found = []
        for dt in (1e-3, 5e-4):
            dE, dL, dT = drifts(runge_kutta_2(alpha), I, w0, T, dt, T_flip)
            assert dE <= dt**2 / 2 * s_E / (E2 / 2) and dL <= dt**2 / 6 * s_M and dT <= dt**2 / 6 * s_phase
            found.append((dE, dL, dT))
        assert np.all(np.array(found[1]) <= 1.1 * np.array(found[0]) / 4)  # second order at least
    dE, dL, dT = drifts(explicit_euler, I, w0, T, 5e-4, T_flip)
    assert dE > 100 * 5e-4**2 / 2 * s_E / (E2 / 2) and dL > 10 * 5e-4**2 / 6 * s_M


def _flight(scheme: str, x0, v0, g, dt: float, steps: int, substeps: int = 1):
    """Free flight stepped by hand by `scheme`: positions at every step (steps + 1 rows)."""
    x, v, h, out = np.array(x0, float), np.array(v0, float), dt / substeps, [np.array(x0, float)]
    for _ in range(steps):
        for _ in range(substeps):
            if scheme == "velocity_first":     # semi-implicit (symplectic) Euler
                v = v + g * h
                x = x + v * h
            elif scheme == "position_first":   # explicit Euler
                x = x + v * h
                v = v + g * h
            elif scheme == "verlet":           # velocity Verlet
                x = x + v * h + 0.5 * g * h * h
                v = v + g * h
            elif scheme == "rk4":              # classical Runge-Kutta on (x, v)' = (v, g)
                k1x, k1v = v, g
                k2x, k2v = v + 0.5 * h * k1v, g
                k3x, k3v = v + 0.5 * h * k2v, g
                k4x, k4v = v + h * k3v, g
                x = x + h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x)
                v = v + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
        out.append(x.copy())
    return np.array(out)


FLIGHT = (np.array([0.0, 0.0, 10.0]), np.array([1.0, 0.5, 3.0]), np.array([0.0, 0.0, -9.81]), 1e-3, 1000)


@pytest.mark.parametrize("scheme,substeps", [("velocity_first", 1), ("position_first", 1), ("verlet", 1), ("rk4", 1),
                                             ("velocity_first", 4), ("position_first", 4), ("velocity_first", 64)])
def test_free_flight_band_accepts_every_consistent_integrator(scheme, substeps):
    """Euler either way, velocity Verlet, RK4 and sub-stepped Euler (Box2D's 4 sub-steps)
    all lie in the band x0 + v0 t + g t^2/2 + c g dt t, |c| <= 1/2, to round-off; so does
    the analytic parabola."""
    x0, v0, g, dt, n = FLIGHT
    t = np.arange(n + 1) * dt
    x = _flight(scheme, x0, v0, g, dt, n, substeps)
    assert free_flight_error(x, x0, v0, g, t, dt) < 1e-11
    exact = x0 + v0 * t[:, None] + 0.5 * g * t[:, None] ** 2
    assert free_flight_error(exact, x0, v0, g, t, dt) < 1e-12
    # the scheme's c, as the helper's docstring gives it
    c = {"velocity_first": 0.5, "position_first": -0.5}.get(scheme, 0.0) / substeps
    assert np.max(np.abs(x - exact - c * g * dt * t[:, None])) < 1e-11


@pytest.mark.parametrize("scheme", ["velocity_first", "position_first", "verlet"])
def test_free_flight_band_rejects_a_wrong_g_or_dt(scheme):
    """9.80 for 9.81, or a step 1 % longer than the dt the samples are read at, leave a
    parabola the band cannot take: far above round-off (the old 1e-9 m and the float32
    bounds of the free-flight checks alike)."""
    x0, v0, g, dt, n = FLIGHT
    t = np.arange(n + 1) * dt
    weak = _flight(scheme, x0, v0, g * 9.80 / 9.81, dt, n)
    assert free_flight_error(weak, x0, v0, g, t, dt) > 5e-4
    slow = _flight(scheme, x0, v0, g, 1.01 * dt, n)
    assert free_flight_error(slow, x0, v0, g, t, dt) > 5e-3
    # one dimension (the conformance battery's free fall from rest)
    fall = _flight(scheme, x0[2:], [0.0], g[2:], dt, n)
    assert free_flight_error(fall, x0[2:], [0.0], g[2:], t, dt) < 1e-11
    assert free_flight_error(_flight(scheme, x0[2:], [0.0], g[2:] * 9.80 / 9.81, dt, n), x0[2:], [0.0], g[2:], t,
                             dt) > 5e-4
    assert free_flight_error(_flight(scheme, x0[2:], [0.0], g[2:], 1.01 * dt, n), x0[2:], [0.0], g[2:], t,
                             dt) > 5e-4


# --- Hertz impact -------------------------------------------------------------------------

def test_hertz_duration_constant_by_quadrature():
    """2 int_0^1 du / sqrt(1 - u^(5/2)) = (4/5) B(2/5, 1/2) = 2.9432; with xi_max it is
    2.868 (m*^2 / (R* E*^2 v))^(1/5), the brief's 2.87."""
    integral = 2.0 * quad(lambda u: 1.0 / math.sqrt(1.0 - u**2.5), 0.0, 1.0, limit=200)[0]
    m_eff, R_star, E_star, v = 3.0, 0.04, 1e11, 2.0
    H = 4.0 / 3.0 * E_star * math.sqrt(R_star)
    c = hi.hertz_impact(m_eff, H, v)
    assert c["contact_duration"] == pytest.approx(integral * c["max_overlap"] / v, rel=1e-9)
    assert integral == pytest.approx(2.9432, abs=1e-4)
    assert c["contact_duration"] == pytest.approx(2.868 * (m_eff**2 / (R_star * E_star**2 * v)) ** 0.2, rel=1e-3)


def test_hertz_constant_is_the_notes_for_equal_spheres():
    """H = 4/3 G/(1 - nu) sqrt(R/2) (note 001) with G = E / (2 (1 + nu))."""
    E, nu, R = 200e9, 0.3, 0.1
    G = E / (2.0 * (1.0 + nu))
    assert hi.hertz_constant(E, nu, R, R) == pytest.approx(4.0 / 3.0 * G / (1.0 - nu) * math.sqrt(R / 2.0), rel=1e-12)


@pytest.mark.parametrize("p", hi.COMPLIANT_GRID, ids=hi.variant_id)
def test_compliant_impact_by_integrating_the_force_law(p):
    """m* xi'' = -F(xi) from xi = 0, xi' = v until xi returns to 0: duration, largest
    overlap and peak force; the bodies leave with e = 1 (momentum and Newton's law)."""
    m_1, m_2 = hi.masses(p)
    m_eff = m_1 * m_2 / (m_1 + m_2)
    H, r = (hi.hertz_constant(p["E"], p["nu"], p["r1"], p["r2"]), 1.5) if p["law"] == "hertz" else (p["stiffness"], 1.0)
    v = hi.V1 - hi.V2

    def parted(t, y):
        return y[0] if t > 0 else 1.0
    parted.terminal, parted.direction = True, -1

    def deepest(t, y):
        return y[1]
    sol = solve_ivp(lambda t, y: [y[1], -H * max(y[0], 0.0) ** r / m_eff], (0.0, 1.0), [0.0, v],
                    method="DOP853", rtol=1e-12, atol=1e-15, events=[parted, deepest], max_step=1e-6)
    t_c = sol.t_events[0][0]
    xi_max = float(sol.y_events[1][0][0])
    c = hi.compliant_closed_form(p)
    assert c["contact_duration"] == pytest.approx(t_c, rel=1e-6)
    assert c["max_overlap"] == pytest.approx(xi_max, rel=1e-6)
    assert c["peak_force"] == pytest.approx(H * xi_max**r, rel=1e-5)
    assert sol.y_events[0][0][1] == pytest.approx(-v, rel=1e-6)
    v1, v2 = np.linalg.solve([[m_1, m_2], [-1.0, 1.0]], [m_1 * hi.V1 + m_2 * hi.V2, v])
    assert hi.velocities_after(m_1, m_2, hi.V1, hi.V2) == pytest.approx((v1, v2), abs=1e-12)


# --- the compliant variants: in the grid, run by the engines that model their law ----------

@pytest.mark.parametrize("module", [hi, nc], ids=["hertz_impact", "newtons_cradle"])
def test_compliant_variants_run_only_where_their_law_is_modelled(module):
    """tests/test_cases.py judges them on reference-hertz and reference-hooke (the default
    plan holds every formulation on every variant); every rigid engine, and the compliant
    formulation of the other law, reports them unsupported, naming the law, instead of
    failing for want of a modulus."""
    from physval.core import Context
    from physval.core.plan import plan
    family = module.FAMILY
    compliant = [v for v in family.variants if "law" in v.params]
    assert {v.params["law"] for v in compliant} == {"hertz", "hooke"}
    engines = ["reference", "reference-pgs", "reference-hertz", "reference-hooke"]
    jobs, _ = plan({family.name: list(family.variants)}, engines, Context().resolver(), False)
    for v in compliant:
        assert {j.engine for j in jobs if j.variant.id == v.id} == set(engines)
        modelling = f"reference-{v.params['law']}"
        for engine in engines:
            reason = registry.get(engine).capabilities.cannot_run(family.scene(v.params))
            if engine == modelling:
                assert reason is None
            else:
                assert reason and v.params["law"] in reason
