"""A free rigid body: a box thrown spinning near its intermediate axis (Dzhanibekov).

No contact acts, so (note 001, "Multiple Contacts", equations of motion: dP/dt = F,
dL/dt = T):
- the centre of mass flies ballistically: v(t) = v_0 + g t, x(t) = x_0 + v_0 t + g t^2/2;
- the angular momentum in the world frame L = R I_0 R^T w and the kinetic energy of
  rotation E = w . L / 2 are constant.
Rotation about the axis of intermediate inertia is unstable: the body flips over
periodically. Torque-free Euler equations (I_1 < I_2 < I_3, body frame):
    I_1 dw_1/dt = (I_2 - I_3) w_2 w_3  (and cyclic).
With M^2 = |L|^2 and 2E, for M^2 > 2 E I_2 (Landau & Lifshitz, Mechanics, sec. 37;
for M^2 < 2 E I_2 swap the labels 1 and 3):
    w_2 = sqrt((2 E I_3 - M^2) / (I_2 (I_3 - I_2))) sn(tau, k),
    tau = t sqrt((I_3 - I_2)(M^2 - 2 E I_1) / (I_1 I_2 I_3)),
    k^2 = (I_2 - I_1)(2 E I_3 - M^2) / ((I_3 - I_2)(M^2 - 2 E I_1)).
sn changes sign every 2 K(k) in tau, so the intermediate-axis component (the body's y
axis projected on L) changes sign every
    T_flip = 2 K(k) / sqrt((I_3 - I_2)(M^2 - 2 E I_1) / (I_1 I_2 I_3)),
K the complete elliptic integral of the first kind (scipy.special.ellipk takes m = k^2).
The body starts with no spin about the third axis, where w_2 = sn is at its extreme
(tau = K), so the first flip comes after T_flip / 2. tests/test_closed_forms_impacts.py
checks both against Euler's equations integrated numerically.

Tolerances come from the integrator, not from the physics (which conserves exactly), at
the bar of a second-order rotation step (the reference's implicit midpoint rule keeps E
and L to round-off; a first-order step, such as explicit gyroscopic terms, drifts E by
dt/2 int w_dot . I w_dot, a thousand of these tolerances at this family's dt). A
second-order step errs per step by about dt^3 |y'''| / 6 (Runge-Kutta error constants
are at most 1/6); summed over the run and projected on each observable:
- E: w . I w''' = -3 w_dot . I w_ddot (differentiate w . I w_dot = 0 twice), so
  dE <= dt^2/2 int |w_dot|_I |w_ddot|_I dt;
- the world L = R L_b errs by R's error acting on L_b plus L_b's error:
  |dL|/|L| <= dt^2/6 int (|R''' L_b| + |L_b'''|) / |L| dt, with
  R''' = R (W^3 + 2 W W_dot + W_dot W + W_ddot), W the cross-product matrix of w;
- the flip time: those drifts of E and M move T_flip(E, M) (ill-conditioned near the
  separatrix M^2 = 2 E I_2: the larger part), and the step's phase error along the
  orbit shifts the flip by dt^2/6 int |w'''| / |w_dot| dt. The crossing is
  interpolated linearly; that errs by dt^2 |s''| / 8 |s'|, which vanishes to this order
  because s = I_2 w_2 ~ sn has s'' = 0 where it crosses zero.
tests/test_closed_forms_impacts.py checks that three second-order Runge-Kutta methods
stay within these bounds and explicit Euler does not. (Before the reference became
second order, the checks allowed one dt of explicit Euler's rates: 2.6-4.4 % of the
flip time.) The flip time is still ill-conditioned near the separatrix, so this family
steps at dt = 2e-4 and starts 20-30 deg off the intermediate axis.
Those three 3D checks (momentum_drift, energy_drift, flip_time) therefore measure the
engine's rotation integrator, not physics: they carry Check.measures = "integrator", and
the scorecard grades them under "integration order", apart from rotation and inertia.

The 3D box starts turned off the world axes (Q0: 40 deg about (1, 2, 2)/3), its spin given
in the world frame as R_0 w_b: every closed form above is frame-free (E, M, T_flip from
I and w_b; the observer reads L in the world and the body's y axis on it), so the turn
changes no expected value, while an adapter that reads the scene's angular velocity in
the body frame, or hands the engine its principal moments in other axes, starts another
motion and flips at another time. It is the first family to check the start spin's frame.

The 2D variant (a rect in the x-z plane, turning about y only) has no intermediate axis:
its spin is constant and its centre ballistic.
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import free_flight_error
from cases.roundoff import position_roundoff, velocity_roundoff
from cases.overlap import rotation_matrix
from cases.scene import Body, Box, Rect, Scene

HALF = (0.05, 0.1, 0.2)    # box half-extents, m: I_x > I_y > I_z, y the intermediate axis
MASS = 1.0                 # kg
G = 9.81
X0, V0 = (0.0, 0.0, 10.0), (1.0, 0.5, 3.0)  # thrown up and sideways (2D: no y)

# Grid: 5 rad/s about the intermediate axis with a wobble of 2 and 3 rad/s about the axis
# of least inertia (the smaller wobble flips later and is more sensitive to energy
# errors); the 2D variant spins about y, its only axis.
GRID = (
    {"spin": 5.0, "wobble": 2.0, "dim": 3},
    {"spin": 5.0, "wobble": 3.0, "dim": 3},
    {"spin": 5.0, "wobble": 0.0, "dim": 2},
)
# Faster spins and wobbles nearer the separatrix (weaker flip checks: at dt = 2e-4 the
# tolerance grows to 0.01-2.5 % of the flip time, against 0.002-0.003 % on GRID); run
# them with a smaller --dt for sharper ones.
FULL_GRID = GRID + tuple({"spin": s, "wobble": w, "dim": 3} for s in (5.0, 10.0) for w in (0.2, 1.0))
DT = 2e-4  # s: see the module docstring (the flip time's conditioning)
# the 3D box's start orientation (w, x, y, z): 40 deg about the axis (1, 2, 2)/3
Q0 = (math.cos(math.radians(20.0)), *(math.sin(math.radians(20.0)) * c / 3.0 for c in (1.0, 2.0, 2.0)))


def inertia(p) -> np.ndarray:
    """Principal inertia of the box (3D) or the rect (2D)."""
    shape = Box(HALF) if p["dim"] == 3 else Rect((HALF[0], HALF[2]))
    return np.array(shape.inertia(MASS))


def omega0(p) -> np.ndarray:
    return np.array([0.0, p["spin"], p["wobble"]])


# --- closed forms ---------------------------------------------------------------------------

def invariants(I, w) -> tuple[float, float]:
    """(2E, M^2) of a body with principal inertia I spinning at w (body frame)."""
    I, w = np.asarray(I, float), np.asarray(w, float)
    return float(I @ w**2), float((I * w) @ (I * w))


def flip_interval(I, E2: float, M2: float) -> float:
    """T_flip of a torque-free body with principal inertia I, 2E = E2 and M^2 = M2 (see the
    module docstring): the time between sign changes of the intermediate component."""
    from scipy.special import ellipk  # imported here: scipy's import costs every command 0.5 s
    I_1, I_2, I_3 = np.sort(np.asarray(I, float))
    if M2 < E2 * I_2:
        I_1, I_3 = I_3, I_1
    lam = math.sqrt((I_3 - I_2) * (M2 - E2 * I_1) / (I_1 * I_2 * I_3))
    k2 = (I_2 - I_1) * (E2 * I_3 - M2) / ((I_3 - I_2) * (M2 - E2 * I_1))
    return 2.0 * float(ellipk(k2)) / lam


def euler_rates(I, w) -> np.ndarray:
    """dw/dt = I^-1 ((I w) x w), torque-free Euler equations in the body frame."""
    return np.cross(I * w, w) / I


def euler_derivatives(I, w) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(w_dot, w_ddot, w''') of the torque-free Euler equations I w_dot = (I w) x w,
    differentiated in the body frame."""
    I = np.asarray(I, float)
    wd = euler_rates(I, w)
    wdd = (np.cross(I * wd, w) + np.cross(I * w, wd)) / I
    wddd = (np.cross(I * wdd, w) + 2.0 * np.cross(I * wd, wd) + np.cross(I * w, wdd)) / I
    return wd, wdd, wddd


def second_order_rates(I, w) -> np.ndarray:
    """The integrands of a second-order step's three drift bounds (module docstring):
    energy |w_dot|_I |w_ddot|_I, world angular momentum (|R''' L_b| + |L_b'''|) / |L|,
    phase |w'''| / |w_dot|."""
    I = np.asarray(I, float)
    wd, wdd, wddd = euler_derivatives(I, w)
    L = I * w
    R3_L = (np.cross(w, np.cross(w, np.cross(w, L))) + 2.0 * np.cross(w, np.cross(wd, L))
            + np.cross(wd, np.cross(w, L)) + np.cross(wdd, L))  # R^T R''' L_b
    return np.array([math.sqrt((wd @ (I * wd)) * (wdd @ (I * wdd))),
                     (np.linalg.norm(R3_L) + np.linalg.norm(I * wddd)) / np.linalg.norm(L),
                     np.linalg.norm(wddd) / np.linalg.norm(wd)])


def integrator_scales(I, w0, T: float, T_phase: float) -> tuple[float, float, float]:
    """(s_E, s_M, s_phase): second_order_rates integrated along the exact motion, the
    first two over [0, T], the phase over [0, T_phase]. A second-order step's bounds are
    dE <= dt^2/2 s_E, |dL|/|L| <= dt^2/6 s_M and a time shift <= dt^2/6 s_phase."""
    from scipy.integrate import solve_ivp  # imported here, as ellipk above
    I = np.asarray(I, float)

    def rates(t, y):
        return np.concatenate([euler_rates(I, y[:3]), second_order_rates(I, y[:3])])
    sol = solve_ivp(rates, (0.0, max(T, T_phase)), np.concatenate([w0, np.zeros(3)]), rtol=1e-10, atol=1e-12,
                    dense_output=True)
    return float(sol.sol(T)[3]), float(sol.sol(T)[4]), float(sol.sol(T_phase)[5])


# --- scene ----------------------------------------------------------------------------------

def _body(p) -> Body:
    if p["dim"] == 2:
        return Body("box", Rect((HALF[0], HALF[2])), mass=MASS, position=X0, velocity=(V0[0], 0.0, V0[2]),
                    angular_velocity=(0.0, p["spin"], 0.0))
    w_world = rotation_matrix(Q0) @ omega0(p)  # the body-frame spin w_b, turned into the world frame
    return Body("box", Box(HALF), mass=MASS, position=X0, orientation=Q0, velocity=V0,
                angular_velocity=tuple(float(c) for c in w_world))


def scene(p) -> Scene:
    return Scene(bodies=(_body(p),), gravity=(0.0, 0.0, -G), dimension=p["dim"])


def duration(p) -> float:
    if p["dim"] == 2:
        return 0.2
    # past the first flip, which comes after half an interval
    return 0.75 * flip_interval(inertia(p), *invariants(inertia(p), omega0(p)))


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    I = inertia(p)
    Rs = np.array([rotation_matrix(q) for q in traj.quat("box")])
    w = traj.omega("box")
    L = np.einsum("nij,nj->ni", Rs, I * np.einsum("nji,nj->ni", Rs, w))  # R I_0 R^T w
    E = 0.5 * np.einsum("ni,ni->n", w, L)
    g = np.array([0.0, 0.0, -G])
    v0 = np.array(_body(p).velocity)
    out = {"momentum_drift": float(np.max(np.linalg.norm(L - L[0], axis=1)) / np.linalg.norm(L[0])),
           "energy_drift": float(np.max(np.abs(E - E[0])) / E[0]),
           "com_velocity_error": float(np.max(np.linalg.norm(traj.vel("box") - v0 - g * traj.t[:, None], axis=1))),
           "com_position_error": free_flight_error(traj.pos("box"), X0, v0, g, traj.t, traj.dt)}
    if p["dim"] == 3:
        # the body's y axis on L (a world-fixed direction): changes sign at every flip
        s = np.einsum("ni,ni->n", Rs[:, :, 1], L)
        k = np.flatnonzero(np.sign(s[1:]) != np.sign(s[:-1]))
        crossings = traj.t[k] + traj.dt * s[k] / (s[k] - s[k + 1])  # linear interpolation
        out["flip_time"] = float(crossings[0]) if len(crossings) else math.inf
    return out


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    T = duration(p)
    scale = float(np.linalg.norm(X0)) + float(np.linalg.norm(V0)) * T + G * T * T
    v_max = float(np.linalg.norm(V0)) + G * T
    steps = max(1, round(T / dt))
    body = _body(p)
    checks = [
        Check("com_velocity_error", "m/s", 0.0, 1e-9 * v_max, "abs",
              "v += g dt (or g h per sub-step) is exact in every consistent integrator, to round-off: "
              "1e-9 of the speed in float64; at the engine's float width half an ulp of v a sub-step (a constant "
              "increment rounds the same way throughout a binade, cases/roundoff.py)",
              velocity_roundoff(steps, dt, body.velocity, (0.0, 0.0, -G))),
        Check("com_position_error", "m", 0.0, 1e-9 * scale, "abs",
              "free flight is a consistent one-step integrator's (x0 + v0 t + g t^2/2 + c g dt t, "
              "|c| <= 1/2: Euler either way, sub-stepped, exact), to round-off: 1e-9 of the reach in float64; at "
              "the engine's float width 3 times the error of this flight stepped in that arithmetic "
              "(cases/roundoff.py)", roundoff_at=position_roundoff(steps, dt, X0, body.velocity, (0.0, 0.0, -G))),
    ]
    if p["dim"] == 2:
        exact = "a spin about a principal axis is constant: exact in any integrator, to round-off"
        return checks + [Check("momentum_drift", "-", 0.0, 1e-9, "abs", exact),
                         Check("energy_drift", "-", 0.0, 1e-9, "abs", exact)]
    I, w0 = inertia(p), omega0(p)
    E2, M2 = invariants(I, w0)
    T_flip = flip_interval(I, E2, M2)
    s_E, s_M, s_phase = integrator_scales(I, w0, T, T_flip / 2.0)
    tol_E = dt**2 / 2.0 * s_E / (E2 / 2.0)
    tol_M = dt**2 / 6.0 * s_M
    # T_flip at the corners of those drifts (ill-conditioned near the separatrix: module
    # docstring), plus the phase a second-order step loses along the orbit up to the flip
    corners = [flip_interval(I, E2 * (1 + a * tol_E), M2 * (1 + b * tol_M) ** 2) for a in (-1, 1) for b in (-1, 1)]
    tol_T = max(abs(c - T_flip) for c in corners) / 2.0 + dt**2 / 6.0 * s_phase
    return checks + [
        Check("momentum_drift", "-", 0.0, tol_M, "abs",
              "second-order rotation step: L = R L_b errs by dt^3/6 (|R''' L_b| + |L_b'''|) per step, "
              "summed over the run", measures="integrator"),
        Check("energy_drift", "-", 0.0, tol_E, "abs",
              "second-order rotation step: E errs by dt^3/2 |w_dot|_I |w_ddot|_I per step "
              "(w . I w''' = -3 w_dot . I w_ddot), summed over the run", measures="integrator"),
        Check("flip_time", "s", T_flip / 2.0, tol_T, "abs",
              "T_flip(E, M) / 2 at the tolerated energy and momentum drifts, plus a second-order step's "
              "phase error dt^2/6 int |w'''| / |w_dot| up to the flip", measures="integrator"),
    ]


def variant_id(p) -> str:
    if p["dim"] == 2:
        return f"spin={p['spin']:g},2D"
    return f"spin={p['spin']:g},wobble={p['wobble']:g}"


FAMILY = CaseFamily(
    name="free_rigid_body",
    summary="a box thrown spinning near its intermediate axis: angular momentum and energy conserved, centre of mass ballistic, first flip at K(k)/lambda (elliptic integral)",
    source="note 001 (CG3 II.5), rigid-body equations of motion; Euler's equations, Landau & Lifshitz Mechanics sec. 37 (Dzhanibekov flip)",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=DT,
    variant_id=variant_id,
    full_grid=FULL_GRID,
    catches=(
        Catch("inertia axes", "spin=5,wobble=2"),
        Catch("angular velocity frame", "spin=5,wobble=2"),
        Catch("gravity", "spin=5,2D"),
        Catch("time step", "spin=5,2D"),
    ),
)
