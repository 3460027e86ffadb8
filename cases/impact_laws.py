"""Restitution laws at one frictional contact: the impulse J of a point impact (a library
for the impact families; cases.scene.RESTITUTION_LAWS names the laws an engine declares).

Every law takes the collision matrix K (u' - u = K J, note 004 "The collision matrix"), the
approach velocity u of the contact points (u_n = u . n < 0) and the normal n, and returns
the impulse J on the body n points into. With friction and e > 0 the laws differ, because
K couples the normal and tangential directions (a lever arm) or a slip is there to oppose:

- "newton" (note 004, "Newton Coulomb impulses for rigid bodies"): try sticking,
  u' = -e u_n n, J = K^-1 (u' - u), kept if |J_t| <= mu_s J_n; else slide along t with
  J = j (n - mu_k t), j = -(1 + e) u_n / n^T K (n - mu_k t). Newton's kinematic
  restitution, friction acting on the whole normal impulse.
- "two_phase": a plastic impact with friction (the Newton-Coulomb impulse at e = 0, which
  leaves u_c with u_c . n = 0), then a normal impulse alone up to Newton's u'_n = -e u_n,
  j_r = (-e u_n - u_c . n) / n^T K n: friction acts on the compression impulse only (Box2D,
  Box3D and Rapier apply restitution in a pass of its own after the solve).
- "poisson" (Poisson's hypothesis: the restitution impulse is e times the compression
  impulse; Stronge, "Impact Mechanics", ch. 4): the compression phase as in two_phase,
  J_c; then a restitution phase whose normal impulse is e J_c . n, with Coulomb friction
  again: try sticking, (u_c + K dJ)_t = 0 with dJ . n = e J_c . n, kept if
  |dJ_t| <= mu_s dJ . n; else slide, dJ = e (J_c . n) (n - mu_k t). J = J_c + dJ.

Sliding direction t: the slip before the phase, u_t / |u_t|; where there is none (a body
landing without slip), the slip the sticking impulse would have to prevent, opposite its
tangential part: J = j (n - mu t) then pushes on as far as friction allows. Each phase
sticks or slides throughout, as Coulomb's law integrated in impulse time does where the
slip keeps its direction within a phase (a symmetric, planar impact) or the impulse sticks
with room: tests/test_closed_forms_laws.py integrates each law in impulse time (Stronge's
method) and solves each phase as an impulse-momentum system, and the families choose
their variants inside those regimes.

Without friction, or with e = 0, or with a K that does not couple n to the tangent plane
and no slip, the three laws give the same impulse (law_matters says so per case).
"""
from __future__ import annotations

import numpy as np

from cases.scene import RESTITUTION_LAWS

DEFAULT_LAW = "newton"


def _tangent(v, n) -> np.ndarray:
    return v - (v @ n) * n


def _sliding_direction(u_t, J_stick_t) -> np.ndarray:
    """t: along the slip, or (no slip) against the sticking impulse's tangential part."""
    if np.linalg.norm(u_t) > 0.0:
        return u_t / np.linalg.norm(u_t)
    if np.linalg.norm(J_stick_t) > 0.0:
        return -J_stick_t / np.linalg.norm(J_stick_t)
    return np.zeros_like(u_t)


def newton_impulse(K, u, n, e: float, mu_s: float, mu_k: float) -> np.ndarray:
    """Newton-Coulomb (module docstring); frictionless (mu = 0) j n with
    j = -(1 + e) u_n / n^T K n (note 001, "Frictionless Impact")."""
    K, u, n = np.asarray(K, float), np.asarray(u, float), np.asarray(n, float)
    u_n = u @ n
    J_t = np.zeros(3)
    if mu_s > 0.0:
        J = np.linalg.solve(K, -e * u_n * n - u)    # sticking: u' = -e u_n n
        J_t = _tangent(J, n)
        if np.linalg.norm(J_t) <= mu_s * (J @ n):
            return J
    t = _sliding_direction(_tangent(u, n), J_t) if mu_k > 0.0 else np.zeros(3)
    j = -(1.0 + e) * u_n / (n @ K @ (n - mu_k * t))
    return j * (n - mu_k * t)


def two_phase_impulse(K, u, n, e: float, mu_s: float, mu_k: float) -> np.ndarray:
    """The plastic Newton-Coulomb impulse, then a frictionless normal one up to -e u_n."""
    K, u, n = np.asarray(K, float), np.asarray(u, float), np.asarray(n, float)
    J_c = newton_impulse(K, u, n, 0.0, mu_s, mu_k)
    u_c = u + K @ J_c
    j_r = (-e * (u @ n) - u_c @ n) / (n @ K @ n)
    return J_c + max(j_r, 0.0) * n


def poisson_impulse(K, u, n, e: float, mu_s: float, mu_k: float) -> np.ndarray:
    """The plastic Newton-Coulomb impulse J_c, then a restitution impulse of normal part
    e J_c . n under Coulomb friction (module docstring)."""
    K, u, n = np.asarray(K, float), np.asarray(u, float), np.asarray(n, float)
    J_c = newton_impulse(K, u, n, 0.0, mu_s, mu_k)
    P_r = e * (J_c @ n)
    if P_r <= 0.0:
        return J_c
    u_c = u + K @ J_c
    dJ_t = np.zeros(3)
    if mu_s > 0.0:
        # unknown dJ: (u_c + K dJ) has no tangential part, and dJ . n = P_r; in a basis
        # (t1, t2, n): two rows of the tangent of K dJ + u_c, one of n . dJ
        t1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(n, t1)
        A = np.array([t1 @ K, t2 @ K, n])
        dJ = np.linalg.solve(A, np.array([-(t1 @ u_c), -(t2 @ u_c), P_r]))
        dJ_t = _tangent(dJ, n)
        if np.linalg.norm(dJ_t) <= mu_s * P_r:
            return J_c + dJ
    t = _sliding_direction(_tangent(u_c, n), dJ_t) if mu_k > 0.0 else np.zeros(3)
    return J_c + P_r * (n - mu_k * t)


IMPULSE_OF_LAW = {"newton": newton_impulse, "two_phase": two_phase_impulse, "poisson": poisson_impulse}
assert set(IMPULSE_OF_LAW) == set(RESTITUTION_LAWS), "a closed form for every declared law"


def law_of(p: dict) -> str:
    """A variant's restitution law (its params' "law"; Newton's unless named)."""
    return p.get("law", DEFAULT_LAW)


def law_label(p: dict) -> str:
    """',two_phase' or ',poisson' for a variant id; '' for Newton's."""
    return f",{law_of(p)}" if law_of(p) != DEFAULT_LAW else ""


# The laws besides Newton's that a built-in engine declares (Box2D, Box3D, Rapier: the
# two-phase law): their variants are in the default grids. Poisson's, which no built-in
# engine declares, are in the full grids (--full), for a plug-in that does
# (tests/test_closed_forms_laws.py keeps this list current).
DEFAULT_GRID_LAWS = ("two_phase",)


def with_laws(grid, differs, laws=RESTITUTION_LAWS) -> tuple[dict, ...]:
    """The grid, each variant whose outcome differs by law (differs(p, law): the closed
    form under `law` is not Newton's) followed by one variant per such law of `laws`."""
    out = []
    for p in grid:
        out.append(p)
        out += [dict(p, law=law) for law in laws if law != DEFAULT_LAW and differs(p, law)]
    return tuple(out)


def law_needs(p: dict, matters: bool) -> frozenset[str]:
    """The need "restitution_law:L" of a variant whose outcome depends on the law."""
    return frozenset({f"restitution_law:{law_of(p)}"}) if matters else frozenset()


def outcomes_differ(a: dict[str, float], b: dict[str, float], scale: float) -> bool:
    """Two closed forms' metrics differ by more than round-off (1e-9 of `scale`)."""
    return any(abs(a[k] - b[k]) > 1e-9 * scale for k in a)
