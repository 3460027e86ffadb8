"""A ball spinning in place about the contact normal is stopped by torsional friction,
and by nothing else (note 001, "dry friction": the friction law F = mu F_n, here as a
torque about the normal; Euler's equation dL/dt = T).

The law (cases.scene.Material.torsional_friction): the contact exerts a torque about the
normal n opposing the relative spin, |tau_n| <= d_t N, d_t a length (MuJoCo's torsional
coefficient, Bullet's spinningFriction). The first family to test a contact torque about
the NORMAL: the contact point of a ball spinning about the vertical lies on the spin axis
and does not slide, so Coulomb friction, which every other family tests, exerts nothing
here; only the torsional law can stop the ball.

A ball (mass m, radius R, I = 2/5 m R^2 about any axis through its centre) rests on flat
ground, N = m g, spinning about +z at w0. Friction at the contact point: none (the point
is at rest). Torsional friction: tau = -d_t N sign(w), so
    I dw/dt = -d_t m g,   alpha = d_t m g / I = 5 d_t g / (2 R^2),
    w(t) = w0 - alpha t,  it stops at  t_spin = w0 / alpha = 2 R^2 w0 / (5 d_t g),
having turned w0^2 / (2 alpha) rad, and stays stopped (nothing drives it any more). The
deceleration is independent of the mass (tau and I both scale with m) and grows as
1 / R^2. With d_t = 0 (the control) the spin never decays: an engine that regularises its
friction rows, or realises a zero torsional coefficient as a small one (MuJoCo's condim 6
brings 1e-5 m), shows a decay the scene did not ask for; the control is judged tightly
enough to see a tenth of that (CONTROL_LEVER).

Discrete time: the torque impulse d_t N dt is exact each step, so w_n = w0 - alpha n dt
exactly, and the stop falls within one step.
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import rate, settle_time
from cases.scene import Body, Material, Scene, Sphere, ground

G = 9.81
MU = 0.5        # sliding friction of the pair (the torsional laws of MuJoCo and Bullet share its rows)
K = 0.4         # I / (m R^2) of a solid sphere
FIT_FROM = 0.05  # spin decelerations are fitted from here on, after the contact's start-up, s
T_CONTROL = 1.0  # simulated time of the control, s
AFTER_STOP = 0.2  # simulated time past the stop, s
# rad/s^2: 1 % of the smallest torsional deceleration the grid asks for (2.45 rad/s^2)
SPIN_TOL = 0.025
# The control (d_t = 0) is judged against the smallest torsional friction it must see: a
# tenth of the smallest lever arm an engine switches on by default (MuJoCo's condim-6
# torsional friction, 1e-5 m), which stops the spin of the control's 0.1 m ball at
# d_t g / (k R^2) = 2.45e-3 rad/s^2: MuJoCo's default lands at 10 tolerances (at 0.98
# under SPIN_TOL). A spin about the normal with no torsional friction is kept exactly.
CONTROL_LEVER = 1e-6  # m

# Grid: d_t = 2 mm and 1 mm on a 0.1 m ball (alpha 4.9 and 2.45 rad/s^2), 2 mm on a
# 0.05 m ball (alpha 19.6 rad/s^2: the 1 / R^2 law), each stopping in about 1 s; and the
# control without torsional friction.
GRID = (
    {"d_t": 0.002, "R": 0.1, "w0": 5.0},
    {"d_t": 0.001, "R": 0.1, "w0": 2.5},
    {"d_t": 0.002, "R": 0.05, "w0": 20.0},
    {"d_t": 0.0, "R": 0.1, "w0": 5.0},
)


# --- closed forms ---------------------------------------------------------------------

def spin_deceleration(d_t: float, radius: float, g: float = G, k: float = K) -> float:
    """alpha = d_t m g / I = d_t g / (k R^2)."""
    return d_t * g / (k * radius * radius)


def spin_time(w0: float, d_t: float, radius: float, g: float = G, k: float = K) -> float:
    return w0 / spin_deceleration(d_t, radius, g, k)


def spin(t, w0: float, d_t: float, radius: float, g: float = G, k: float = K):
    """w(t) = max(w0 - alpha t, 0)."""
    return np.maximum(w0 - spin_deceleration(d_t, radius, g, k) * np.asarray(t, float), 0.0)


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    R = p["R"]
    body = Body("ball", Sphere(R), mass=1.0, position=(0, 0, R), angular_velocity=(0, 0, p["w0"]))
    return Scene(bodies=(ground(), body), gravity=(0.0, 0.0, -G),
                 material=Material(e=0.0, mu_s=MU, torsional_friction=p["d_t"]))


def duration(p) -> float:
    if p["d_t"] == 0.0:
        return T_CONTROL
    return spin_time(p["w0"], p["d_t"], p["R"]) + AFTER_STOP


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    wz = traj.omega("ball")[:, 2]
    if p["d_t"] == 0.0:
        return {"spin_deceleration": -rate(traj, wz, FIT_FROM), "spin_after": float(wz[-1])}
    t_spin = spin_time(p["w0"], p["d_t"], p["R"])
    bound = spin_deceleration(p["d_t"], p["R"]) * traj.dt
    return {"spin_deceleration": -rate(traj, wz, FIT_FROM, 0.8 * t_spin),
            "spin_down_time": settle_time(traj, np.abs(wz), bound)}


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    if p["d_t"] == 0.0:
        why = "no torsional friction asked: nothing may slow the spin about the normal"
        tol = spin_deceleration(CONTROL_LEVER, p["R"])
        return [Check("spin_deceleration", "rad/s^2", 0.0, tol, "abs",
                      why + f"; {tol:.2g} rad/s^2 is what a lever of {CONTROL_LEVER:g} m would do, a tenth of the least "
                      "an engine adds by default (MuJoCo's 1e-5 m)"),
                Check("spin_after", "rad/s", p["w0"], tol * T_CONTROL, "abs",
                      why + "; the deceleration's tolerance over the run")]
    alpha = spin_deceleration(p["d_t"], p["R"])
    return [
        Check("spin_deceleration", "rad/s^2", alpha, SPIN_TOL, "abs",
              "the torque impulse d_t N dt is exact each step: w falls linearly; 1 % of the smallest deceleration "
              "the family asks for leaves room for a soft contact's normal-force ripple"),
        Check("spin_down_time", "s", spin_time(p["w0"], p["d_t"], p["R"]), 2 * dt, "abs",
              "the stop falls within a step, and 'stopped' is read one step of deceleration (alpha dt) early"),
    ]


def variant_id(p) -> str:
    return f"d_t={p['d_t']:g},R={p['R']:g},w0={p['w0']:g}"


FAMILY = CaseFamily(
    name="spin_down",
    summary="a ball spinning about the vertical on the ground stops at alpha = d_t m g / I in w0 / alpha under "
            "torsional friction d_t, and never slows without it",
    source="note 001 (CG3 II.5), dry friction as a torque about the normal, |tau_n| <= d_t F_n; Euler's "
           "equation I dw/dt = tau",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("torsional friction off", "d_t=0.002,R=0.1,w0=5"),
        Catch("torsional friction doubled", "d_t=0.002,R=0.1,w0=5"),
        Catch("contact torques", "d_t=0,R=0.1,w0=5"),
    ),
)
