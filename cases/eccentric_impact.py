"""Eccentric impact: a ball strikes a free rod off the rod's centre line (no gravity).

Closed form: one point contact, one impulse (note 004, "Newton Coulomb impulses and the
collision matrix"; note 001, "Inverse Mass Matrix of Contact", "Impact with Friction").
Body 1 is the ball, body 2 the rod; n points from 1 to 2; r_i runs from body i's centre
to the contact point; u = v_2 + w_2 x r_2 - (v_1 + w_1 x r_1) is the relative velocity of
the contact points (u_n = u . n < 0: approaching). An impulse J on body 2 (-J on body 1)
changes the velocities by
    v_1' = v_1 - J / M_1,  w_1' = w_1 - I_1^-1 (r_1 x J),
    v_2' = v_2 + J / M_2,  w_2' = w_2 + I_2^-1 (r_2 x J),
so u' - u = K J with the collision matrix
    K = K_1 + K_2,  K_i = 1/M_i 1 - r_i* I_i^-1 r_i*
(r* the cross-product matrix; note 001 writes r*^T I^-1 r*, the same matrix since
r*^T = -r*; note 004's slide drops the stars and the 1, re-derived here).
Newton-Coulomb (note 004): try sticking, u'_t = 0 and u'_n = -e u_n, i.e.
    J = K^-1 (u' - u);
keep it if |J_t| <= mu_s J_n, else slide along t = u_t / |u_t| with
    J = j (n - mu_k t),  j = -(1 + e) u_n / n^T K (n - mu_k t).
Frictionless (mu = 0): j = -(1 + e) u_n / n^T K n (note 001, "Frictionless Impact").

With friction and e > 0 the outcome depends on the restitution law the engine declares
(cases.scene.RESTITUTION_LAWS, closed forms in cases/impact_laws.py; each such variant
needs "restitution_law:<law>", and an engine that declares another law reports it
unsupported):
- "newton": the Newton-Coulomb impulse above, friction acting on the whole normal impulse;
- "two_phase": a plastic impact with friction, J_c = the Newton-Coulomb impulse at e = 0,
  which leaves u_c = u + K J_c with u_c . n = 0; then a normal impulse alone, j_r n with
  j_r = -e u_n / n^T K n, so that u'_n = -e u_n (Newton's law on the approach before the
  impact) and friction acts on J_c only: J = J_c + j_r n. A sliding ball's friction impulse
  is then 1/(1 + e) of the Newton-Coulomb one;
- "poisson": J_c as for two_phase, then a restitution impulse of normal part e J_c . n
  under Coulomb friction: the sliding strike's impulse is Newton's (the slip keeps its
  direction through both phases), the sticking one's is not (the slip before the impact
  enters the compression impulse J_c = -K^-1 u, so e J_c . n is not the normal impulse
  that restores -e u_n). Each variant whose outcome differs by law is in the grid once per
  law that gives another outcome (ids ending ",two_phase"; ",poisson" in the full grid, as
  no built-in engine declares Poisson's law).
  tests/test_closed_forms_impacts.py and tests/test_closed_forms_laws.py check the laws
  against the impulse-momentum equations solved phase by phase, and in impulse time.

Every variant lies in the x-z plane (the rod turns about y), where the note's sliding
direction (that of the slip before the impact) is also the direction of the slip after
it, so a simultaneous (LCP) solver and the note's law give the same impulse
(tests/test_closed_forms_impacts.py checks this and solves the impulse-momentum equations
independently). The bodies start touching, so the impact happens at once with exact
geometry; velocities are read when the ball flies free again.
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.impact_laws import (DEFAULT_GRID_LAWS, DEFAULT_LAW, IMPULSE_OF_LAW, law_label, law_needs, law_of,
                               outcomes_differ, with_laws)
from cases.observables import first_impact
from cases.scene import Body, Box, Material, Rect, Scene, ball

R = 0.1                 # ball radius, m
M_BALL, M_ROD = 1.0, 1.0  # kg
A, C = 0.05, 0.4        # rod half-thickness (x, y) and half-length (z), m
D = 0.25                # height of the contact point above the rod's centre, m
V_X = 2.0               # approach speed along the normal, m/s

# Grid: restitution (0.5, 1) of a frictionless strike that spins the rod; an oblique
# strike (slip 1 m/s along the face) with low friction (slides through the impact) and
# high friction (sticks: the ball is spun up); 2D variants (a disc against a rect in the
# x-z plane, inertia m r^2 / 2) let 2D engines take part.
GRID = (
    {"e": 0.5, "mu": 0.0, "v_t": 0.0, "dim": 3},
    {"e": 1.0, "mu": 0.0, "v_t": 0.0, "dim": 3},
    {"e": 0.5, "mu": 0.1, "v_t": -1.0, "dim": 3},   # slides
    {"e": 0.5, "mu": 1.0, "v_t": -1.0, "dim": 3},   # sticks
    {"e": 1.0, "mu": 0.0, "v_t": 0.0, "dim": 2},
    {"e": 0.5, "mu": 0.1, "v_t": -1.0, "dim": 2},   # slides
    {"e": 0.5, "mu": 1.0, "v_t": -1.0, "dim": 2},   # sticks
)
# More restitution values and a plastic strike, and friction near the stick/slide border.
FULL_GRID = GRID + tuple({"e": e, "mu": mu, "v_t": vt, "dim": dim}
                         for dim in (3, 2) for e in (0.0, 0.9)
                         for mu, vt in ((0.0, 0.0), (0.3, -1.0), (0.5, -1.0)))


# --- closed form --------------------------------------------------------------------------

def cross_matrix(r) -> np.ndarray:
    """r* with r* x = r x x."""
    x, y, z = r
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def body_collision_matrix(M: float, I_inv: np.ndarray, r) -> np.ndarray:
    """K_i = 1/M_i 1 - r_i* I_i^-1 r_i* (note 004, "The collision matrix")."""
    r_star = cross_matrix(r)
    return np.eye(3) / M - r_star @ I_inv @ r_star


def inverse_inertia(body: Body, dim: int) -> np.ndarray:
    """World inverse inertia of an unrotated body; a 2D body turns about y only."""
    I = body.principal_inertia
    return np.diag([1.0 / i for i in I]) if dim == 3 else np.diag([0.0, 1.0 / I[1], 0.0])


def setup(p, shift=(0.0, 0.0, 0.0)) -> dict:
    """Masses, inverse inertias, arms and velocities of the scene's two bodies. `shift`
    (a_1, a_2, b) moves the contact geometry as an engine that finds the contact late
    sees it: the ball a_1 into the rod (its arm shortens), the contact point a_2 into the
    rod and b along the face."""
    a_1, a_2, b_ = shift
    b, r = _bodies(p)
    return {"M_1": b.mass, "M_2": r.mass,
            "I_1_inv": inverse_inertia(b, p["dim"]), "I_2_inv": inverse_inertia(r, p["dim"]),
            "r_1": np.array([R - a_1, 0.0, 0.0]), "r_2": np.array([-A + a_2, 0.0, D + b_]),
            "n": np.array([1.0, 0.0, 0.0]),
            "v_1": np.array(b.velocity), "w_1": np.zeros(3), "v_2": np.zeros(3), "w_2": np.zeros(3)}


def velocities_after(p, shift=(0.0, 0.0, 0.0)) -> dict[str, np.ndarray]:
    """Post-impact v_1, w_1, v_2, w_2 and the impulse J, by the variant's restitution law."""
    s = setup(p, shift)
    K = (body_collision_matrix(s["M_1"], s["I_1_inv"], s["r_1"])
         + body_collision_matrix(s["M_2"], s["I_2_inv"], s["r_2"]))   # K = K_1 + K_2
    u = s["v_2"] + np.cross(s["w_2"], s["r_2"]) - s["v_1"] - np.cross(s["w_1"], s["r_1"])
    J = IMPULSE_OF_LAW[law_of(p)](K, u, s["n"], p["e"], p["mu"], p["mu"])
    return {"v_1": s["v_1"] - J / s["M_1"], "w_1": s["w_1"] - s["I_1_inv"] @ np.cross(s["r_1"], J),
            "v_2": s["v_2"] + J / s["M_2"], "w_2": s["w_2"] + s["I_2_inv"] @ np.cross(s["r_2"], J), "J": J}


def kinetic_energy(M: float, I_diag, v, w) -> float:
    return 0.5 * M * float(v @ v) + 0.5 * float(np.asarray(w) @ (np.asarray(I_diag) * w))


# --- scene --------------------------------------------------------------------------------

def _bodies(p) -> tuple[Body, Body]:
    dim = p["dim"]
    rod = Box((A, A, C)) if dim == 3 else Rect((A, C))
    striker = Body("ball", ball(R, dim), mass=M_BALL, position=(-A - R, 0.0, D), velocity=(V_X, 0.0, p["v_t"]))
    return striker, Body("rod", rod, mass=M_ROD)


def scene(p) -> Scene:
    return Scene(bodies=_bodies(p), gravity=(0.0, 0.0, 0.0),
                 material=Material(e=p["e"], mu_s=p["mu"]), dimension=p["dim"])


def duration(p) -> float:
    return 0.03  # the impact is the first step; MuJoCo's soft contact takes ~16 more


def law_differs(p, law: str) -> bool:
    """The closed form under `law` is not Newton's (beyond round-off of the approach speed)."""
    newton = {k: v for k, v in p.items() if k != "law"}
    return outcomes_differ(closed_form(dict(newton, law=law)), closed_form(newton), float(np.hypot(V_X, p["v_t"])))


def law_matters(p) -> bool:
    """The restitution laws give this variant different outcomes."""
    return any(law_differs(p, law) for law in IMPULSE_OF_LAW if law != "newton")


# --- observables --------------------------------------------------------------------------

def observe(traj, p) -> dict:
    """Velocities once the ball flies free again (a later touch, if any, is not read)."""
    _, k = first_impact(traj, "ball", (0.0, 0.0, 0.0))
    if k is None:
        k = len(traj.t) - 1
    out = {}
    for name, key in (("ball", "1"), ("rod", "2")):
        v, w = traj.vel(name)[k], traj.omega(name)[k]
        out[f"vx_{key}"], out[f"vz_{key}"], out[f"wy_{key}"] = float(v[0]), float(v[2]), float(w[1])
    b, r = _bodies(p)
    ke = [kinetic_energy(body.mass, body.principal_inertia, traj.vel(body.name)[i], traj.omega(body.name)[i])
          for i in (0, k) for body in (b, r)]
    out["energy_lost"] = ke[0] + ke[1] - ke[2] - ke[3]
    return out


# --- expectations -------------------------------------------------------------------------

def closed_form(p, shift=(0.0, 0.0, 0.0)) -> dict[str, float]:
    """Every metric's closed-form value (`shift`: see `setup`)."""
    after = velocities_after(p, shift)
    s = setup(p, shift)
    out = {}
    for key in ("1", "2"):
        v, w = after[f"v_{key}"], after[f"w_{key}"]
        out[f"vx_{key}"], out[f"vz_{key}"], out[f"wy_{key}"] = float(v[0]), float(v[2]), float(w[1])
    b, r = _bodies(p)
    out["energy_lost"] = (kinetic_energy(b.mass, b.principal_inertia, s["v_1"], s["w_1"])
                          - kinetic_energy(b.mass, b.principal_inertia, after["v_1"], after["w_1"])
                          - kinetic_energy(r.mass, r.principal_inertia, after["v_2"], after["w_2"]))
    return out


def expect(p, dt) -> list[Check]:
    exact = closed_form(p)
    # Contacts are found at step boundaries: an engine may resolve the impact a step early
    # (speculatively) or late, after a step of overlap (V_X dt deep) in which the sliding
    # ball moved |v_t| dt along the face; the contact point then lies anywhere in that
    # overlap. The closed form at the corners of that box bounds what this first-order
    # time-stepping error does to each metric (nothing, for a frictionless strike).
    depth, travel = V_X * dt, abs(p["v_t"]) * dt
    shifted = [closed_form(p, (a_1, a_2, b)) for a_1 in (0.0, depth) for a_2 in (0.0, depth)
               for b in (-travel, 0.0, travel)]
    speed = float(np.hypot(V_X, p["v_t"]))
    tol_v = 1e-6 * speed
    why_step = (f", plus the contact point anywhere in one step's overlap ({depth:.2g} m deep, "
                f"{travel:.2g} m along the face)")
    checks = []
    for metric, value in exact.items():
        step = max(abs(s[metric] - value) for s in shifted)
        if metric.startswith("w"):
            arm = float(np.linalg.norm(setup(p)["r_" + metric[-1]]))
            tol, unit, why = tol_v / arm, "rad/s", "the velocity tolerance at the contact point, tol_v / |r|"
        elif metric == "energy_lost":
            tol, unit = 2.0 * (M_BALL + M_ROD) * speed * tol_v, "J"
            why = "the velocity tolerance carried through dE = sum m v dv (both bodies, linear and angular)"
        else:
            tol, unit = tol_v, "m/s"
            why = "one impulse, no external force: exact to solver convergence (1e-6 of the approach speed)"
        checks.append(Check(metric, unit, value, tol + step, "abs", why + why_step))
    return checks


def strike_dt(p) -> float:
    """The time step. An engine may resolve the impact a step late, after the ball slid
    |v_t| dt along the face and sank V_X dt into it (see expect): with friction that moves
    the outcome by 0.3-2.3 % at 1e-3 s, so the rough strikes run at 1e-4 s (0.03-0.23 %).
    Frictionless, the contact's place does not matter: 1e-3 s."""
    return 1e-4 if p["mu"] > 0 else 1e-3


def variant_id(p) -> str:
    plane = ",2D" if p["dim"] == 2 else ""
    rough = f",mu={p['mu']},slip={-p['v_t']:g}" if p["mu"] > 0 else ""
    return f"e={p['e']}{rough}{law_label(p)}{plane}"


def needs(p) -> frozenset[str]:
    """The restitution law, where it changes the outcome (adapters.base Capabilities.restitution_law)."""
    return law_needs(p, law_matters(p))


# Each variant whose outcome depends on the restitution law also under each other law that
# changes it (cases/impact_laws.py; ids end ",two_phase", ",poisson"): the laws built-in
# engines declare in the grid, every law in the full grid.
GRID = with_laws(GRID, law_differs, (DEFAULT_LAW, *DEFAULT_GRID_LAWS))
FULL_GRID = with_laws(FULL_GRID, law_differs)


FAMILY = CaseFamily(
    name="eccentric_impact",
    summary="a ball strikes a free rod off its centre line: post-impact linear and angular velocities, frictionless and with sticking or sliding friction, by the restitution law the engine declares",
    source="note 004 (Umea VIS), collision matrix K and Newton-Coulomb impulse; note 001 (CG3 II.5), K_i = 1/M + r*^T I^-1 r*; the two-phase law derived in the module docstring",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=strike_dt,
    needs=needs,
    variant_id=variant_id,
    full_grid=FULL_GRID,
    catches=(
        Catch("restitution off", "e=0.5"),
        Catch("restitution doubled", "e=0.5"),
        Catch("inertia", "e=0.5"),
        Catch("friction off", "e=0.5,mu=1.0,slip=1"),
        Catch("friction doubled", "e=0.5,mu=0.1,slip=1"),
        Catch("restitution law", "e=0.5,mu=0.1,slip=1"),
        Catch("restitution law", "e=0.5,mu=1.0,slip=1"),
    ),
)
