"""Compliant contact: touching bodies overlap by xi and push apart with F = H xi^r
(note 001, "Elastic Impact Details", "Hertz Constant", "Analyzing Newton's Cradle"):
Hertz r = 1.5, Hooke r = 1. Both are elastic (e = 1 up to the integrator's error).

Hertz constant. The note gives, for two spheres of one material and radius R,
    H = 4/3 G / (1 - nu) sqrt(R / 2).
The general form (Hertz 1882; Johnson, Contact Mechanics, eq. 4.23) is
    H = 4/3 E* sqrt(R*),  1/E* = (1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2,  1/R* = 1/R_1 + 1/R_2.
For equal spheres R* = R/2 and, with E = 2 G (1 + nu), E* = E / (2 (1 - nu^2)) = G / (1 - nu):
the two agree. A plane is R = inf; a rigid body E = inf.

The overlap is integrated with small steps (velocity Verlet: x += h v + h^2/2 a;
v += h/2 (a + a')), which keeps the elastic energy to O(h^2) and so e = 1 to O(h^2);
in the world the steps subdivide one outer step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from reference_impl import lcp
from reference_impl.compiled import njit
from reference_impl.geometry import SPHERE
from reference_impl.lcp import Bodies, Contact, Rows, build_rows, inverse_mass_matrix, jacobian


def hertz_constant_equal_spheres(G: float, nu: float, R: float) -> float:
    """H = 4/3 G / (1 - nu) sqrt(R/2) (note 001, "Hertz Constant")."""
    return 4.0 / 3.0 * G / (1.0 - nu) * math.sqrt(R / 2.0)


def youngs_modulus(G: float, nu: float) -> float:
    """E = 2 G (1 + nu) for an isotropic material."""
    return 2.0 * G * (1.0 + nu)


def effective_modulus(E_1: float, nu_1: float, E_2: float, nu_2: float) -> float:
    """E* with 1/E* = (1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2 (E = inf: rigid)."""
    return 1.0 / ((1.0 - nu_1**2) / E_1 + (1.0 - nu_2**2) / E_2)


@njit
def effective_radius(R_1: float, R_2: float = math.inf) -> float:
    """R* with 1/R* = 1/R_1 + 1/R_2 (R = inf: a plane)."""
    return 1.0 / (1.0 / R_1 + 1.0 / R_2)


@njit
def hertz_constant(E_star: float, R_star: float) -> float:
    """H = 4/3 E* sqrt(R*)."""
    return 4.0 / 3.0 * E_star * math.sqrt(R_star)


@dataclass(frozen=True)
class ForceLaw:
    H: float          # N / m^r
    r: float = 1.5    # 1.5 Hertz, 1.0 Hooke

    def force(self, xi: float) -> float:
        """Repulsive force at overlap xi; zero when apart (a contact cannot pull)."""
        return self.H * xi**self.r if xi > 0.0 else 0.0


class Substeps(NamedTuple):
    u: np.ndarray             # (N, 6) velocities at the end
    displacement: np.ndarray  # (N, 6) integral of u over the steps (linear; small rotation)
    xi: np.ndarray            # (C,) overlaps at the end
    impulse: np.ndarray       # (C,) integral of each contact's force, N s


def integrate(rows: Rows, bodies: Bodies, u: np.ndarray, a_ext: np.ndarray, xi: np.ndarray,
              laws: list[ForceLaw], h: float, n: int) -> Substeps:
    """n velocity-Verlet steps of h (kick, drift, kick) for frictionless normal rows
    (lcp.py) pushing with laws[c].force(xi_c): u += h/2 (a_ext + M^-1 J^T F(xi));
    xi -= h J u (J u > 0: separating); u += h/2 (a_ext + M^-1 J^T F(xi)). The contact
    geometry (normal, arms) is held fixed over the n steps."""
    return substeps(rows, bodies, np.asarray(u, dtype=float), np.asarray(a_ext, dtype=float),
                    np.array(xi, dtype=float), np.array([law.H for law in laws], dtype=float),
                    np.array([law.r for law in laws], dtype=float), float(h), int(n))


@njit(inline=True)
def substeps(rows, bodies, u, a_ext, xi, H, r, h, n) -> Substeps:
    """integrate, with each contact's law as H[c] xi^r[c]."""
    J = jacobian(rows, len(bodies.m_inv))          # dense: (C, 6N), few contacts
    B = inverse_mass_matrix(bodies) @ J.T          # M^-1 J^T
    U, displacement, xi, impulse = _velocity_verlet(J, B, u.ravel().copy(), a_ext.ravel().copy(), xi.copy(),
                                                    H, r, h, n)
    return Substeps(U.reshape(u.shape), displacement.reshape(u.shape), xi, impulse)


@njit
def _velocity_verlet(J, B, U, A, xi, H, r, h, n):
    """integrate's n steps on the flat velocity U (6N,), A = M^-1 f flat: (U, displacement,
    xi, impulse) at the end."""
    displacement, impulse = np.zeros_like(U), np.zeros(len(xi))
    F = _push(H, r, xi)
    for _ in range(n):
        U += 0.5 * h * (A + B @ F)
        impulse += 0.5 * h * F
        displacement += h * U
        xi -= h * (J @ U)
        F = _push(H, r, xi)
        U += 0.5 * h * (A + B @ F)
        impulse += 0.5 * h * F
    return U, displacement, xi, impulse


@njit
def _push(H, r, xi):
    """ForceLaw(H[c], r[c]).force(xi[c]) of every contact c."""
    F = np.zeros(len(xi))
    for c in range(len(xi)):
        F[c] = H[c] * xi[c] ** r[c] if xi[c] > 0.0 else 0.0
    return F


@dataclass(frozen=True)
class CentralImpact:
    v_1: float        # velocities after the bodies separate, m/s
    v_2: float
    xi_max: float     # largest overlap, m
    duration: float   # time in contact, s


def central_impact(m_1: float, m_2: float, v_1: float, v_2: float, law: ForceLaw,
                   h: float, max_steps: int = 10_000_000) -> CentralImpact:
    """Two bodies on a line (x) meeting at t = 0 with v_1 > v_2 (body 1 behind body 2),
    the overlap starting at zero; integrated with `integrate` until they separate. The
    contact's end is placed by linear interpolation of the overlap to zero."""
    if not v_1 > v_2:
        raise ValueError(f"v_1 = {v_1} <= v_2 = {v_2}: the bodies do not approach")
    bodies = Bodies(np.array([1.0 / m_1, 1.0 / m_2]), np.zeros((2, 3, 3)))
    x = np.array([1.0, 0.0, 0.0])
    rows = build_rows([Contact(1, 0, np.zeros(3), np.zeros(3), x)], np.zeros((2, 6)))
    u = np.zeros((2, 6))
    u[:, 0] = v_1, v_2
    xi, t, xi_max, no_force = np.zeros(1), 0.0, 0.0, np.zeros((2, 6))
    for _ in range(max_steps):
        step = integrate(rows, bodies, u, no_force, xi, [law], h, 1)
        xi_max = max(xi_max, float(step.xi[0]))
        if step.xi[0] <= 0.0:
            end = t + h * xi[0] / (xi[0] - step.xi[0])
            return CentralImpact(float(step.u[0, 0]), float(step.u[1, 0]), xi_max, end)
        u, xi, t = step.u, step.xi, t + h
    raise RuntimeError(f"still in contact after {max_steps} steps of {h} s")


# --- world formulation "compliant" (interface: reference_impl/__init__.py) -----------------
# Keys of config.params: "compliant_law" ("hertz", default, or "hooke"); for Hertz the
# material of every body, "compliant_E" (Young's modulus, Pa, default steel 200e9) and
# "compliant_nu" (Poisson's ratio, default 0.3); for Hooke "compliant_k" (N/m per contact
# point, default 1e7); "compliant_substeps" (velocity-Verlet steps per outer step,
# default 1000). Contacts must be seen before they overlap: the world's speculative reach
# (a step's travel) finds them, but World.collide drops those whose normal_target is None
# (e > 0 and the gap closes late in the step), so such a contact is first seen up to
# |v| dt / 2 deep and the force law launches the bodies apart (see
# tests/reference/test_ref_formulations_world.py: test_hertz_contact_from_a_gap).

DEFAULTS = {"compliant_law": "hertz", "compliant_E": 200e9, "compliant_nu": 0.3,
            "compliant_k": 1e7, "compliant_substeps": 1000}


def _param(config, key):
    return config.params.get(key, DEFAULTS[key])


class Settings(NamedTuple):
    hertz: bool       # Hertz's law (else Hooke's)
    E_star: float     # Hertz: the pair's effective modulus E* (one material for every body), Pa
    k: float          # Hooke: N/m per contact point
    substeps: int     # velocity-Verlet steps per outer step


def settings(config) -> Settings:
    E, nu = float(_param(config, "compliant_E")), float(_param(config, "compliant_nu"))
    return Settings(_param(config, "compliant_law") == "hertz", effective_modulus(E, nu, E, nu),
                    float(_param(config, "compliant_k")), int(_param(config, "compliant_substeps")))


STAGES = ("substeps",)


def unsupported(world) -> str | None:
    materials = (world.material, *world.pair_materials.values())
    law = _param(world.config, "compliant_law")
    if law not in ("hertz", "hooke"):
        return f"compliant_law = {law!r}: 'hertz' or 'hooke'"
    if sum(not b.static for b in world.bodies) + min(1, sum(b.static for b in world.bodies)) < 2:
        return None  # nothing can touch (one body, as a loaded free body): no contact law asked
    inelastic = sorted({m.e for m in materials if m.e != 1.0})
    if inelastic:
        return (f"restitution e = {', '.join(f'{e:g}' for e in inelastic)} asked: Hertz and Hooke "
                "contact (note 001) are elastic, e = 1")
    if any(m.mu_s > 0.0 for m in materials):
        return "friction asked: the compliant formulation has a normal force law only"
    if law == "hertz":
        kinds = sorted({b.shape.kind for b in world.bodies} - {"sphere", "plane"})
        if kinds:
            return f"Hertz's law holds for spheres on spheres or planes, not {', '.join(kinds)}"
    return None


@njit
def solve(contacts, bodies, dt, settings) -> int:
    rows, data, u = lcp.world_rows(contacts, bodies)
    rows = lcp.normal_rows(rows)
    C = len(contacts.a)
    H, r = np.empty(C), np.empty(C)
    for j in range(C):
        if settings.hertz:  # H = 4/3 E* sqrt(R*), a plane's radius infinite
            a, b = contacts.a[j], contacts.b[j]
            R_a = bodies.radius[a] if bodies.shape[a] == SPHERE else np.inf
            R_b = bodies.radius[b] if bodies.shape[b] == SPHERE else np.inf
            H[j], r[j] = hertz_constant(settings.E_star, effective_radius(R_a, R_b)), 1.5
        else:
            H[j], r[j] = settings.k, 1.0
    n = settings.substeps
    W = np.empty_like(u)
    for i in range(len(u)):
        for e in range(3):
            W[i, e], W[i, 3 + e] = bodies.v0[i, e], bodies.w0[i, e]
    step = substeps(rows, data, W, (u - W) / dt, contacts.depth.copy(), H, r, dt / n, n)
    lcp.apply_velocity_change(bodies, step.u - u, False)
    # the world moves positions by dt (v + vp): make that the substeps' displacement
    lcp.apply_velocity_change(bodies, step.displacement / dt - step.u, True)
    for j in range(C):
        contacts.Pn[j] = step.impulse[j]
        for t in range(contacts.n_tangents[j]):
            contacts.Pt[j, t] = 0.0
    return 1


# A force law must see a contact from the moment the shapes touch, not one step later
# (the world's impulse formulations leave contacts that touch late in a step to the next).
KEEP_LATE_CONTACTS = True


def knobs(config) -> dict:
    """What this formulation does with the world's contacts, for the adapter's record."""
    law = _param(config, "compliant_law")
    chosen = ["compliant_law", "compliant_substeps"] + (["compliant_E", "compliant_nu"] if law == "hertz"
                                                        else ["compliant_k"])
    return {**{key: _param(config, key) for key in chosen},
            "integrator": "velocity Verlet substeps inside the outer step",
            "restitution": "none beyond the force law's elasticity (e = 1 only)",
            "friction": "none (refused)"}
