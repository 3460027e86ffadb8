"""SPOOK: contact as a stiff, critically damped constraint solved for impulses (note 004,
"Contact stabilization - SPOOK scheme"):

    (G M^-1 G^T + Sigma) lambda = -a q - b G W - h G M^-1 f
    eps = 4 / (k h^2 (1 + 4d)),  a = 4 / (h (1 + 4d)),  b = 4d / (1 + 4d)
    W' = W + M^-1 (G^T lambda + h f)

with G the contact Jacobian (lcp.py's J), W the velocity at the start of the step, q the
gap of each contact (negative when overlapping), f the external forces, k the contact's
stiffness and d the number of steps over which an overlap is restored. Sigma = eps on
normal rows. The slides print "-a/h q" (1D) and "-a G q" (general) with a = 4/(h(1+4d)):
both are garbled; a q already has units of velocity, as lambda (an impulse) times
1/m does. Re-derived from the regularised step [M, -G^T; G, Sigma] [W'; lambda] =
[M W + h f; -a q + (1 - b) G W]. At rest (W' = W = 0) lambda = load h and
-q = eps lambda / a = load / k: the overlap settles at the spring's own deflection.
Measured (tests/reference/test_ref_formulations_spook.py): SPOOK steps a spring k with
damping c = k d h. Unilateral, it restores an overlap by a velocity a |q| and cannot pull
back: a body at rest 1 mm deep leaves at 0.235 m/s (h = 1 ms, d = 4). A contact seen
before it closes (the world's speculative reach, q > 0) brakes the approach instead.

Friction rows (lcp.py's pyramid) have no position to restore: their rhs is
-G_t W - h G_t M^-1 f (target: no tangential velocity after the step) and no
regularisation. SPOOK has no restitution: contacts are inelastic.
Solved by projected Gauss-Seidel (pgs.py) on the mixed LCP, as the note says.
Compiled (compiled.py), as is the world formulation "spook" below.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from reference_impl import pgs
from reference_impl.compiled import njit
from reference_impl.lcp import (BILATERAL, BOXED, Bodies, Rows, apply_velocity_change, row_velocity, stack_rows, store_impulses,
                                world_impulses, world_rows)


# world defaults: a stiff contact (a 1 kg box on its 4 corners sinks 0.025 um) whose
# overlap is restored over 4 steps
DEFAULT_K = 1e8   # N/m per contact point
DEFAULT_D = 4.0   # steps


@dataclass(frozen=True)
class SpookSettings:
    k: float                  # contact stiffness, N/m
    d: float = 4.0            # relaxation time in steps (tau = d h)
    pgs: pgs.PGSSettings = field(default_factory=pgs.PGSSettings)

    def __post_init__(self):
        if not self.k > 0:
            raise ValueError(f"k = {self.k!r}: the contact stiffness must be > 0 (N/m)")
        if not self.d >= 0:
            raise ValueError(f"d = {self.d!r}: the relaxation (in steps) must be >= 0")


class SpookStep(NamedTuple):
    u: np.ndarray       # (N, 6) velocities after the step
    lam: np.ndarray     # (K,) row impulses over the step
    sweeps: int


@njit
def parameters(k: float, d: float, h: float) -> tuple[float, float, float]:
    """(eps, a, b) of note 004."""
    eps = 4.0 / (k * h * h * (1.0 + 4.0 * d))
    a = 4.0 / (h * (1.0 + 4.0 * d))
    b = 4.0 * d / (1.0 + 4.0 * d)
    return eps, a, b


def step_velocities(rows: Rows, bodies: Bodies, W: np.ndarray, a_ext: np.ndarray, q: np.ndarray,
                    h: float, settings: SpookSettings, lam0: np.ndarray | None = None) -> SpookStep:
    """One SPOOK velocity update. W (N, 6) is the velocity at the start of the step,
    a_ext = M^-1 f (N, 6) the external acceleration (linear; angular), q the gap of each
    contact, one per normal row in row order (and a joint's error g per equality row,
    joints.py, in row order with them: both are note 004's q); lam0 warm-starts PGS."""
    return spook_velocities(rows, bodies, np.asarray(W, dtype=float), np.asarray(a_ext, dtype=float),
                            np.asarray(q, dtype=float), float(h), float(settings.k), float(settings.d),
                            int(settings.pgs.iterations), float(settings.pgs.tolerance),
                            np.zeros(len(rows.a)) if lam0 is None else np.asarray(lam0, dtype=float), lam0 is not None)


@njit
def spook_velocities(rows, bodies, W, a_ext, q, h, k, d, iterations, tolerance, lam0, warm) -> SpookStep:
    """step_velocities, PGS from lam0 when warm (else from zero)."""
    eps, a, b = parameters(k, d, h)
    GW, GA = row_velocity(rows, W), row_velocity(rows, a_ext)
    rhs, sigma, c = np.empty(len(GW)), np.zeros(len(GW)), 0
    for r in range(len(GW)):
        if rows.normal[r] == r or rows.normal[r] == BILATERAL:  # a normal (or limit) row's gap, a joint's g
            rhs[r] = -a * q[c] - b * GW[r] - h * GA[r]
            sigma[r] = eps
            c += 1
        else:
            rhs[r] = -GW[r] - h * GA[r]
    result = pgs.gauss_seidel(rows, bodies, rhs, iterations, tolerance, sigma, lam0, warm)
    return SpookStep(W + result.du + h * a_ext, result.gamma, result.sweeps)


class Settings(NamedTuple):
    k: float            # contact stiffness per contact point, N/m
    d: float            # relaxation, steps
    iterations: int     # PGS sweeps at most
    tolerance: float    # m/s
    warm_start: bool


def settings(config) -> Settings:
    found = SpookSettings(k=float(config.params.get("spook_k", DEFAULT_K)),
                          d=float(config.params.get("spook_d", DEFAULT_D)))  # checks them
    return Settings(found.k, found.d, config.iterations, float(config.tolerance), config.warm_start)


STAGES = ("warm_start", "velocity", "friction", "joints")
WARM_START, VELOCITY, FRICTION, JOINTS = 1, 2, 4, 8
JOINT_KINDS = frozenset({"ball", "revolute", "prismatic", "fixed"})  # the joints solve_joints takes (joints.py)
JOINT_LIMITS = JOINT_FRICTION = True  # limit rows (inelastic: no restitution at a limit), friction rows
LIMIT_RESTITUTION = False


def unsupported(world) -> str | None:
    """SPOOK is an inelastic contact model: it cannot give a pair restitution."""
    bouncy = sorted({m.e for m in (world.material, *world.pair_materials.values()) if m.e > 0.0})
    if bouncy:
        return (f"restitution e = {', '.join(f'{e:g}' for e in bouncy)} asked: SPOOK (note 004) "
                "models contact as a critically damped spring-constraint, which cannot bounce")
    return None


@njit
def solve(contacts, bodies, dt, settings) -> int:
    """World formulation "spook" (interface: reference_impl/__init__.py). Keys of
    config.params: "spook_k" (contact stiffness per contact point, N/m, default
    DEFAULT_K) and "spook_d" (relaxation in steps, default DEFAULT_D). W is the velocity
    before external forces (body.v0, body.w0), h M^-1 f what the world added since, q the
    contacts' -depth. Warm started from last step's impulses (config.warm_start); at most
    config.iterations PGS sweeps. No pseudo-velocities: SPOOK restores overlap itself."""
    rows, data, u = world_rows(contacts, bodies)
    W = np.empty_like(u)
    for i in range(len(u)):
        for e in range(3):
            W[i, e], W[i, 3 + e] = bodies.v0[i, e], bodies.w0[i, e]
    warm = settings.warm_start and np.any(contacts.Pn != 0.0)
    step = spook_velocities(rows, data, W, (u - W) / dt, -contacts.depth, dt, settings.k, settings.d,
                            settings.iterations, settings.tolerance, world_impulses(contacts), warm)
    apply_velocity_change(bodies, step.u - u, False)
    store_impulses(contacts, step.lam)
    return (WARM_START if warm else 0) | VELOCITY | (FRICTION if len(rows.a) > len(contacts.a) else 0)


@njit
def solve_joints(contacts, joints, bodies, dt, settings) -> int:
    """`solve` with the joints' rows (joints.py) after the contact rows. An equality row
    and a limit row are regularised and stabilised as a contact's normal row (note 004:
    eps on the diagonal, rhs -a q - b G W - h G M^-1 f, q = g the joint's position error,
    or the limit's gap, unilateral as a contact), with the contacts' k and d: a joint is a
    stiff spring of k N/m (N m/rad on an angular row) critically damped over d steps. A
    friction row is as a contact's tangent row (no regularisation, target G W' = 0) with
    its constant bound (joints.BOXED). No restitution at a limit (inelastic, as contacts).
    A limit row takes part once this step's motion (external forces, no impulse) would
    close its gap, or the gap is closed: note 004 writes q as an overlap, and a row with a
    gap q > 0 asks -a q - b G W > 0 once q < d h |G W|, braking the joint d steps before
    its stop (measured: limit_impact's rod met its limit at 5.3987 for 5.4206 rad/s; with
    the rule, 5.4140, as the other formulations' 5.4135)."""
    rows, data, u = world_rows(contacts, bodies)
    C, K, N = len(rows.a), len(joints.g), len(u)
    W = np.empty_like(u)
    for i in range(N):
        for e in range(3):
            W[i, e], W[i, 3 + e] = bodies.v0[i, e], bodies.w0[i, e]
    n = len(contacts.a)
    q, start = np.empty(n + K), np.empty(C + K)
    contact_start = world_impulses(contacts)
    for j in range(n):
        q[j] = -contacts.depth[j]
    for k in range(C):
        start[k] = contact_start[k]
    m = n
    free = row_velocity(joints.rows, u)  # each joint row's rate after this step's external forces, no impulse
    for k in range(K):  # q of the regularised rows, in row order
        if joints.rows.normal[k] != BOXED:
            q[m] = joints.g[k]
            if joints.rows.normal[k] == k and joints.g[k] > 0.0 and joints.g[k] + dt * free[k] > 0.0:
                # a limit this step's motion does not reach: no row (q = inf, rhs = -inf, lambda = 0).
                # Note 004's q is an overlap ("q the overlap (negative)"); a row with a gap q > 0
                # would ask -a q - b G W, and act once q < d h |G W|: d steps before the stop
                q[m] = np.inf
            m += 1
        start[C + k] = joints.P[k]
    warm = settings.warm_start and (np.any(contacts.Pn != 0.0) or np.any(joints.P != 0.0))
    step = spook_velocities(stack_rows(rows, joints.rows), data, W, (u - W) / dt, q[:m], dt, settings.k, settings.d,
                            settings.iterations, settings.tolerance, start, warm)
    apply_velocity_change(bodies, step.u - u, False)
    store_impulses(contacts, step.lam[:C])
    for k in range(K):
        joints.P[k] = step.lam[C + k]
    return (WARM_START if warm else 0) | VELOCITY | (FRICTION if C > n else 0) | JOINTS


def knobs(config) -> dict:
    """What this formulation does with the world's contacts, for the adapter's record."""
    return {"solver": "SPOOK (note 004) by projected Gauss-Seidel",
            "spook_k": float(config.params.get("spook_k", DEFAULT_K)),
            "spook_d": float(config.params.get("spook_d", DEFAULT_D)),
            "friction_set": "pyramid: |Pt_k| <= mu Pn on each tangent row, no regularisation",
            "restitution": "none: inelastic (scenes with e > 0 are refused)",
            "depenetration": "SPOOK's own -a q term (no pseudo-velocities)",
            "joints": "ball, revolute, prismatic and fixed joints as equality rows, limits as unilateral rows, "
                      "regularised and stabilised as the contacts (eps, -a g) with spook_k and spook_d, a limit's row only "
                      "once the step's motion reaches it; friction as a row within -+ friction dt; no restitution "
                      "at a limit",
            "iterations": config.iterations, "tolerance": config.tolerance, "warm_start": config.warm_start}
