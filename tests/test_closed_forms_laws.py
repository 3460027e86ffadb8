"""The restitution laws' closed forms (cases/impact_laws.py) against the impact integrated
in impulse time (Stronge, "Impact Mechanics", ch. 4; Routh's method): the normal impulse p
is the clock, the contact velocity moves by du = K (n + f) dp with Coulomb's law at every
instant (f = -mu t along the slip; sticking while the tangential force that holds it is
within mu; slip starting where it is not), and each law is an end condition:
- Newton: until u_n = -e u_n(0);
- two-phase: with friction until u_n = 0, then without friction until u_n = -e u_n(0);
- Poisson: with friction until u_n = 0 at p_c, then on until p = (1 + e) p_c.
This is a different route from the families' algebraic phases (try sticking, else slide
for a whole phase): the two agree only where each phase sticks or slides along one
direction, so this also checks that every law variant of eccentric_impact,
oblique_landing and edge_landing lies in such a regime. And the laws agree where they
must: frictionless, plastic, or (Poisson and Newton) without slip to oppose."""
from __future__ import annotations

import numpy as np
import pytest

from cases import eccentric_impact as ei
from cases import edge_landing as el
from cases import impact_laws as laws
from cases import oblique_landing as ol
from cases.scene import RESTITUTION_LAWS

STEPS = 4000  # impulse steps over the whole impact: exact within a phase of constant friction


def integrate(K, u0, n, e: float, mu: float, law: str) -> np.ndarray:
    """The impulse J of an impact integrated in normal impulse (module docstring)."""
    K, u0, n = np.asarray(K, float), np.asarray(u0, float), np.asarray(n, float)
    basis = np.linalg.svd(np.outer(n, n))[0][:, 1:]          # two tangent directions
    K_tt, K_tn = basis.T @ K @ basis, basis.T @ K @ n
    u_n0 = u0 @ n
    dp = -(1.0 + e) * u_n0 / (n @ K @ n) * 3.0 / STEPS       # 3 times the frictionless impulse: room
    u, P, p = u0.copy(), np.zeros(3), 0.0
    p_c = None
    friction = mu

    def force(u_t) -> np.ndarray:
        """f (world) at slip u_t (tangent coordinates)."""
        if np.linalg.norm(u_t) > 1e-12 * abs(u_n0):
            return -friction * basis @ (u_t / np.linalg.norm(u_t))
        hold = -np.linalg.solve(K_tt, K_tn) if friction > 0 else np.zeros(2)  # du_t = 0
        if np.linalg.norm(hold) <= friction:
            return basis @ hold
        return friction * basis @ (hold / np.linalg.norm(hold))

    for _ in range(20 * STEPS):
        u_t = basis.T @ u
        f = force(u_t)
        rate = K @ (n + f)
        step = dp
        # a slip that would reverse within the step stops where it reaches zero
        du_t = basis.T @ rate
        if np.linalg.norm(u_t) > 1e-12 * abs(u_n0) and (u_t + step * du_t) @ u_t < 0.0:
            step = min(step, -(u_t @ du_t) / (du_t @ du_t))
        # the phase's end within the step
        if p_c is None and law != "newton" and (u + step * rate) @ n >= 0.0:
            step = -(u @ n) / (rate @ n)
        elif law == "newton" and (u + step * rate) @ n >= -e * u_n0:
            step = (-e * u_n0 - u @ n) / (rate @ n)
        elif p_c is not None and law == "poisson" and p + step >= (1.0 + e) * p_c:
            step = (1.0 + e) * p_c - p
        elif p_c is not None and law == "two_phase" and (u + step * rate) @ n >= -e * u_n0:
            step = (-e * u_n0 - u @ n) / (rate @ n)
        u, P, p = u + step * rate, P + step * (n + f), p + step
        if law == "newton" and u @ n >= -e * u_n0 * (1 - 1e-13):
            return P
        if p_c is None and law != "newton" and u @ n >= -1e-13 * abs(u_n0):
            p_c = p
            if law == "two_phase":
                friction = 0.0
            if e == 0.0:
                return P
        if p_c is not None and law == "poisson" and p >= (1.0 + e) * p_c * (1 - 1e-13):
            return P
        if p_c is not None and law == "two_phase" and u @ n >= -e * u_n0 * (1 - 1e-13):
            return P
    raise AssertionError("the impact did not end")


# --- every law variant of the three families: (K, u, n, e, mu, law, closed-form J) ----------

def eccentric(p):
    s = ei.setup(p)
    K = (ei.body_collision_matrix(s["M_1"], s["I_1_inv"], s["r_1"])
         + ei.body_collision_matrix(s["M_2"], s["I_2_inv"], s["r_2"]))
    u = s["v_2"] - s["v_1"]
    return K, u, s["n"], p["e"], p["mu"], laws.law_of(p), ei.velocities_after(p)["J"]


def oblique(p):
    r = ol.lever(p)
    K = ei.body_collision_matrix(ol.M, ol.inverse_inertia(p), r)
    u = ol.start_velocity(p) + np.cross(p["w"], r)
    return K, u, ol.N, ol.E, p["mu"], laws.law_of(p), ol.impulse(p)


def edge(p):
    n = np.array([0.0, 0.0, 1.0])
    return (el.collision_matrix(el.lever(p), el.inertia(p)), -el.V_IN * n, n, el.E, p["mu"], laws.law_of(p),
            el.impact_impulse(el.lever(p), p["mu"], el.E, el.V_IN, laws.law_of(p), el.inertia(p)))


CASES = ([(f"eccentric_impact[{v.id}]", eccentric, v.params) for v in ei.FAMILY.all_variants if v.params["mu"] > 0]
         + [(f"oblique_landing[{v.id}]", oblique, v.params) for v in ol.FAMILY.all_variants if v.params["mu"] > 0]
         + [(f"edge_landing[{v.id}]", edge, v.params) for v in el.FAMILY.all_variants if v.params["mu"] > 0])


@pytest.mark.parametrize("inputs,p", [(f, p) for _, f, p in CASES], ids=[i for i, _, _ in CASES])
def test_each_law_variant_is_the_impact_integrated_in_impulse_time(inputs, p):
    K, u, n, e, mu, law, J = inputs(p)
    J_ref = integrate(K, u, n, e, mu, law)
    assert J == pytest.approx(J_ref, abs=1e-9 * np.linalg.norm(J_ref))


@pytest.mark.parametrize("inputs,p", [(f, p) for _, f, p in CASES], ids=[i for i, _, _ in CASES])
def test_a_variant_without_its_own_law_variant_has_one_outcome_under_every_law(inputs, p):
    """with_laws leaves out a law's variant only where that law's impulse is Newton's."""
    K, u, n, e, mu, law, J = inputs(p)
    if law != "newton":
        return
    fam = {"eccentric": ei, "oblique": ol, "edge": el}[inputs.__name__]
    ids = {v.id for v in fam.FAMILY.all_variants}
    for other in RESTITUTION_LAWS:
        has_variant = fam.variant_id(dict(p, law=other)) in ids
        same = np.allclose(laws.IMPULSE_OF_LAW[other](K, u, n, e, mu, mu), J, atol=1e-9 * np.linalg.norm(J))
        assert has_variant or same, f"{other}: a different impulse but no variant"


def test_the_default_grids_hold_every_law_a_built_in_engine_declares():
    """Law variants of the laws built-in engines declare are in the default grids
    (impact_laws.DEFAULT_GRID_LAWS); the others (Poisson's) in the full grids only."""
    from adapters import registry
    declared = {registry.get(name).capabilities.restitution_law for name in registry.engine_names()
                if registry.available(name)}
    assert declared <= {laws.DEFAULT_LAW, *laws.DEFAULT_GRID_LAWS}, declared
    for fam in (ei, ol, el):
        in_grid = {laws.law_of(v.params) for v in fam.FAMILY.variants}
        assert in_grid <= {laws.DEFAULT_LAW, *laws.DEFAULT_GRID_LAWS}


@pytest.mark.parametrize("law", RESTITUTION_LAWS)
def test_the_laws_agree_without_friction_or_restitution(law):
    """Frictionless or plastic, every law is Newton's: one normal impulse, or the plastic
    Newton-Coulomb one."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        A = rng.normal(size=(3, 3))
        K = A @ A.T + 0.1 * np.eye(3)
        n = np.array([0.0, 0.0, 1.0])
        u = np.array([*rng.normal(size=2), -1.0 - rng.random()])
        for e, mu in ((rng.random(), 0.0), (0.0, rng.random())):
            assert laws.IMPULSE_OF_LAW[law](K, u, n, e, mu, mu) == pytest.approx(
                laws.newton_impulse(K, u, n, e, mu, mu), abs=1e-12)


def test_poisson_is_newton_without_slip_and_differs_with_it():
    """Sticking on a coupled K: with no slip before the impact Poisson's impulse is Newton's
    (the compression impulse is -u_n K^-1 n / ..., and e times it restores -e u_n); with a
    slip to stop it is not (the brick's sticking edge landing)."""
    n = np.array([0.0, 0.0, 1.0])
    K = el.collision_matrix(el.lever({"tilt": "y", "dim": 3}))
    u = np.array([0.0, 0.0, -2.0])
    assert laws.poisson_impulse(K, u, n, 0.5, 5.0, 5.0) == pytest.approx(laws.newton_impulse(K, u, n, 0.5, 5.0, 5.0),
                                                                         abs=1e-12)
    u = np.array([0.3, 0.0, -2.0])
    assert np.linalg.norm(laws.poisson_impulse(K, u, n, 0.5, 5.0, 5.0) - laws.newton_impulse(K, u, n, 0.5, 5.0, 5.0)) \
        > 1e-3
