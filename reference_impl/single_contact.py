"""One contact at a time: the impulse for a particle against a wall, for two particles,
and for two rigid bodies (collision matrix K and the Newton-Coulomb impulse).

Sign convention throughout (that of notes 000 and 004; note 001 is the same with its
body 2 as our a): the impulse +p acts on body a and -p on body b; the normal n points
from b towards a; u = u_a - u_b is the relative velocity of the contact points, so
u . n < 0 means the bodies approach. A static body (wall, ground) has 1/m = 0 and a zero
inverse inertia. Every function returns the impulse p on body a.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from reference_impl.compiled import njit
from reference_impl.contact import RA_D, RB_D
from reference_impl.lcp import world_rows
from reference_impl.pgs import repair_overlap


@njit
def _split(u: np.ndarray, n: np.ndarray) -> tuple[float, np.ndarray]:
    """Normal speed u_n = u . n and tangential vector u_t = u - u_n n."""
    u_n = float(u @ n)
    return u_n, u - u_n * n


# --- particles (note 002, "Particle-obstacle collision (friction)" and "Restitution and
# friction in two-particle case") ---------------------------------------------------------

def particle_pair_impulse(m_a: float, m_b: float, v_a, v_b, n, c_r: float, mu: float) -> np.ndarray:
    """Impulse on particle a: normal gamma = -(1 + c_r) m_eff v_n with
    m_eff = (1/m_a + 1/m_b)^-1, friction gamma_f = min(mu gamma, m_eff |v_t|) against the
    tangential relative velocity (note 002). The note writes m v_t for two particles; the
    impulse that zeroes the relative tangential velocity is m_eff v_t (re-derived).
    m_b = math.inf makes b a fixed obstacle (m_eff = m_a)."""
    v_a, v_b, n = (np.asarray(x, dtype=float) for x in (v_a, v_b, n))
    v_n, v_t = _split(v_a - v_b, n)
    if v_n >= 0.0:  # separating or resting: no collision
        return np.zeros(3)
    m_eff = 1.0 / (1.0 / m_a + 1.0 / m_b)
    gamma = -(1.0 + c_r) * m_eff * v_n
    speed_t = float(np.linalg.norm(v_t))
    if speed_t == 0.0:
        return gamma * n
    gamma_f = min(mu * gamma, m_eff * speed_t)
    return gamma * n - gamma_f * v_t / speed_t


def particle_obstacle_impulse(m: float, v, n, c_r: float, mu: float) -> np.ndarray:
    """Particle against a fixed obstacle (note 002): v_n+ = -c_r v_n, so
    gamma = -(1 + c_r) m v_n (the slide's "gamma = -(1 + c_r) v_n" drops the mass), and
    gamma_f = min(mu gamma, m v_t)."""
    return particle_pair_impulse(m, math.inf, v, np.zeros(3), n, c_r, mu)


# --- rigid bodies: the collision matrix (note 004, "The collision matrix"; note 001,
# "Inverse Mass Matrix of Contact") -------------------------------------------------------

def cross_matrix(r) -> np.ndarray:
    """r* with r* x = r x x."""
    return _cross_matrix(np.asarray(r, dtype=float))


@njit
def _cross_matrix(r):
    x, y, z = r[0], r[1], r[2]
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def body_collision_matrix(m_inv: float, I_inv, r) -> np.ndarray:
    """K_i = 1/M_i 1 - r_i* I_i^-1 r_i* (note 004; note 001 writes r*^T I^-1 r*, the same
    matrix since r*^T = -r*): the change of the contact point's velocity per unit impulse."""
    return _body_collision_matrix(float(m_inv), np.asarray(I_inv, dtype=float), np.asarray(r, dtype=float))


@njit
def _body_collision_matrix(m_inv, I_inv, r):
    r_star = _cross_matrix(r)
    return m_inv * np.eye(3) - r_star @ I_inv @ r_star


def collision_matrix(m_inv_a: float, I_inv_a, r_a, m_inv_b: float, I_inv_b, r_b) -> np.ndarray:
    """K = K_a + K_b: the change of the relative contact velocity u is K p (note 001)."""
    return body_collision_matrix(m_inv_a, I_inv_a, r_a) + body_collision_matrix(m_inv_b, I_inv_b, r_b)


def newton_coulomb_impulse(K, u, n, e: float, mu_s: float, mu_k: float) -> np.ndarray:
    """The Newton-Coulomb impulse (note 004, "Newton Coulomb impulses for rigid bodies";
    note 001, "Impact with Friction - Calculations").

    Try sticking: u'_t = 0, u'_n = -e u_n, p = K^-1 (u' - u). Keep it if it lies in the
    static cone |p_t| <= mu_s p_n. Otherwise slide along t = u_t / |u_t| with
    p = j (n - mu_k t), j = -(1 + e) u_n / n^T K (n - mu_k t).

    Energy: for spheres (K n parallel to n, K isotropic in the tangent plane) the impulse
    never adds kinetic energy for e <= 1. When K couples normal and tangential directions
    (an off-centre contact of a non-spherical body) it can: sticking then may need a
    tangential impulse along the slip, and sliding keeps one direction t even when the
    slip reverses during the impact (measured in
    tests/reference/test_ref_formulations_single_contact.py). With no tangential velocity
    (u_t = 0) the note's t is undefined; we slide against the sticking impulse's tangential
    part, t = -p_t / |p_t|, which is the note's t for spheres.
    """
    return _newton_coulomb_impulse(np.asarray(K, dtype=float), np.asarray(u, dtype=float),
                                   np.asarray(n, dtype=float), float(e), float(mu_s), float(mu_k))


@njit
def _newton_coulomb_impulse(K, u, n, e, mu_s, mu_k):
    u_n, u_t = _split(u, n)
    if u_n >= 0.0:  # separating or resting: no impact
        return np.zeros(3)
    u_target = -e * u_n * n
    p = np.linalg.solve(K, u_target - u)
    p_n, p_t = _split(p, n)
    if np.linalg.norm(p_t) <= mu_s * p_n:
        return p
    speed_t = float(np.linalg.norm(u_t))
    # a slip at round-off level (1e-12 of |u|, e.g. a normal approach seen in a turned
    # frame) has no direction of its own: treat it as no slip
    no_slip = speed_t <= 1e-12 * float(np.linalg.norm(u))
    t = -p_t / float(np.linalg.norm(p_t)) if no_slip else u_t / speed_t
    denominator = float(n @ K @ (n - mu_k * t))
    if denominator <= 0.0:
        raise ValueError("n^T K (n - mu_k t) <= 0: no sliding impulse can stop the approach "
                         "(mu_k too large for this contact's K)")
    j = -(1.0 + e) * u_n / denominator
    return j * (n - mu_k * t)


def energy_change(p, u_minus, du) -> float:
    """dE = dp . (v_rel- + dv_rel / 2) (note 001, "Change in Total Energy"): the change of
    the two bodies' kinetic energy from the impulse p, given the relative contact velocity
    before (u_minus) and its change du = K p."""
    p, u_minus, du = (np.asarray(x, dtype=float) for x in (p, u_minus, du))
    return float(p @ (u_minus + 0.5 * du))


# --- world formulation "single_contact" (interface: reference_impl/__init__.py) -------------

class Settings(NamedTuple):
    iterations: int           # sweeps at most (config.iterations)
    position_iterations: int  # sweeps of the overlap repair
    tolerance: float          # m/s
    slop: float               # m (config.slop: newton_target)


def settings(config) -> Settings:
    return Settings(config.iterations, config.position_iterations, float(config.tolerance), float(config.slop))


STAGES = ("impulses", "position")
IMPULSES, POSITION = 1, 2


@njit
def solve(contacts, bodies, dt, settings) -> int:
    """Note 004's pairwise loop ("loop through the collision set and solve collisions
    pair-wise, and hope..."): sweep the contacts in the world's order; a contact whose
    normal velocity is below its target (newton_target) by more than config.tolerance
    gets the Newton-Coulomb impulse that lifts it to the target (e_eff = -target / u_n);
    until a sweep finds none, at most config.iterations sweeps. Impulses only push and are
    never taken back (no accumulation, unlike sequential impulses). Then the overlap
    repair of pgs.repair_overlap."""
    c, C = contacts, len(contacts.a)
    tangents = np.zeros((C, 2, 3))  # each contact's tangent directions
    for j in range(C):
        for k in range(c.n_tangents[j]):
            for e in range(3):
                tangents[j, k, e] = c.tangents[j, k, e]
    ra_n = np.ascontiguousarray(c.normal[:, RA_D:RA_D + 3])  # the normal row's r x n
    rb_n = np.ascontiguousarray(c.normal[:, RB_D:RB_D + 3])
    Pn, Pt = np.zeros(C), np.zeros((C, 2))  # impulses are never taken back: no warm start
    pairwise_loop(c.a, c.b, c.point, c.n, ra_n, rb_n, tangents, c.n_tangents, c.e, c.mu_s, c.mu_k, c.depth,
                  c.target, bodies.x, bodies.inv_mass, bodies.inv_I, bodies.v, bodies.w, Pn, Pt,
                  settings.iterations, settings.tolerance, settings.slop)
    for j in range(C):
        c.Pn[j] = Pn[j]
        for k in range(c.n_tangents[j]):
            c.Pt[j, k] = Pt[j, k]
    rows, data, _ = world_rows(contacts, bodies)
    if repair_overlap(contacts, bodies, rows, data, settings.position_iterations, settings.tolerance):
        return IMPULSES | POSITION
    return IMPULSES


@njit(inline=True)
def pairwise_loop(a, b, point, n, ra_n, rb_n, tangents, n_tangents, e, mu_s, mu_k, depth, target,
                  x, inv_mass, inv_I, v, w, Pn, Pt, iterations, tolerance, slop):
    """The sweeps of solve, in place on the bodies' v, w and the contacts' impulses Pn, Pt
    (the world's contact j: its bodies a[j], b[j], pushed along n[j] on b)."""
    C = len(a)
    u_start = np.array([_normal_velocity(v, w, a[j], b[j], n[j], ra_n[j], rb_n[j]) for j in range(C)])
    # each contact's arms and collision matrix K (note 004): positions do not move during
    # the loop, so they are computed once; our body a is the world's b (pushed along +n,
    # see the module docstring)
    r_a, r_b, K = np.empty((C, 3)), np.empty((C, 3)), np.empty((C, 3, 3))
    for j in range(C):
        A, B = a[j], b[j]
        r_a[j], r_b[j] = point[j] - x[A], point[j] - x[B]
        K[j] = (_body_collision_matrix(inv_mass[B], inv_I[B], r_b[j])
                + _body_collision_matrix(inv_mass[A], inv_I[A], r_a[j]))
    u = np.empty(3)
    for _ in range(iterations):
        worst = 0.0
        for j in range(C):
            u_n = _normal_velocity(v, w, a[j], b[j], n[j], ra_n[j], rb_n[j])
            goal = newton_target(e[j], depth[j], target[j], u_n, u_start[j], slop)
            if u_n >= goal - tolerance or u_n >= 0.0:  # met, or no approach to reverse
                continue
            worst = max(worst, goal - u_n)
            A, B = a[j], b[j]
            _point_velocity_difference(u, v[B], w[B], r_b[j], v[A], w[A], r_a[j])
            p = _newton_coulomb_impulse(K[j], u, n[j], -goal / u_n, mu_s[j], mu_k[j])
            for body, r, sign in ((B, r_b[j], 1.0), (A, r_a[j], -1.0)):  # +p on our a, -p on our b
                dv = sign * inv_mass[body] * p
                dw = sign * inv_I[body] @ np.cross(r, p)
                for k in range(3):
                    v[body, k] += dv[k]
                    w[body, k] += dw[k]
            Pn[j] += p[0] * n[j, 0] + p[1] * n[j, 1] + p[2] * n[j, 2]
            for k in range(n_tangents[j]):
                d = tangents[j, k]
                Pt[j, k] += p[0] * d[0] + p[1] * d[1] + p[2] * d[2]
        if worst == 0.0:
            break


@njit
def _point_velocity_difference(u, v_a, w_a, r_a, v_b, w_b, r_b) -> None:
    """u = (v_a + w_a x r_a) - (v_b + w_b x r_b): the relative velocity of the contact
    points (note 004), written into u."""
    u[0] = (v_a[0] + (w_a[1] * r_a[2] - w_a[2] * r_a[1])) - (v_b[0] + (w_b[1] * r_b[2] - w_b[2] * r_b[1]))
    u[1] = (v_a[1] + (w_a[2] * r_a[0] - w_a[0] * r_a[2])) - (v_b[1] + (w_b[2] * r_b[0] - w_b[0] * r_b[2]))
    u[2] = (v_a[2] + (w_a[0] * r_a[1] - w_a[1] * r_a[0])) - (v_b[2] + (w_b[0] * r_b[1] - w_b[1] * r_b[0]))


@njit
def _normal_velocity(v, w, a, b, d, ra_d, rb_d):
    """contact.Row.velocity of the normal row: d . (v_b - v_a) + (r_b x d) . w_b - (r_a x d) . w_a."""
    va, wa, vb, wb = v[a], w[a], v[b], w[b]
    return (d[0] * (vb[0] - va[0]) + d[1] * (vb[1] - va[1]) + d[2] * (vb[2] - va[2])
            + rb_d[0] * wb[0] + rb_d[1] * wb[1] + rb_d[2] * wb[2]
            - ra_d[0] * wa[0] - ra_d[1] * wa[1] - ra_d[2] * wa[2])


@njit
def newton_target(e, depth, target, u_n, u_0, slop):
    """The normal velocity a touching contact must reach when the loop comes to it:
    Newton's law on its approach at that moment (note 004: each pair's collision is solved
    with its own velocities). The approach it had at the start of the step is taken
    before external forces (contact.target = -e vn0, see sequential_impulses.py); the
    approach the other pairs' impulses gave it since the loop began, u_n - u_0 < 0, is
    reversed by e too. Without that second part a row of touching balls (vn0 = 0 inside
    the row) took every impulse plastically: a Newton's cradle with e = 1 lost 75 % of its
    energy in 0.5 s instead of passing the pulse down the row."""
    induced = u_n - u_0
    if e == 0.0 or induced >= 0.0 or depth < -slop:
        return target
    return target - e * induced


def knobs(config) -> dict:
    """What this formulation does with the world's contacts, for the adapter's record."""
    return {"impulses": "pairwise Newton-Coulomb (note 004), swept until no contact approaches; never taken back",
            "friction": "mu_s decides sticking, mu_k acts while sliding, one direction per impact",
            "restitution": "lifts v_n to contact.normal_target (-e vn0)",
            "depenetration": "split impulse: PGS on pseudo-velocities",
            "iterations": config.iterations, "tolerance": config.tolerance}
