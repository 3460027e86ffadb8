"""A regular n-gon prism on an incline: it tips over its downhill edge when the incline is
steeper than pi/n, and at each edge impact its spin drops by a ratio that angular momentum
about the new pivot sets (note 001, "dry friction"; note 004, "The collision matrix" and
"Newton Coulomb impulses").

The prism: a regular n-gon of circumradius R (its corners R from the axis, its faces
a = R cos(pi/n) from it, its sides s = 2 R sin(pi/n) wide) extruded 2 L along y, given as
a convex hull (`Hull` of its 2 n corners), mass m; about its axis
    I_c = m R^2 (2 + cos(2 pi/n)) / 6
(the polar moment of the regular n-gon; the square's m R^2/3, the hexagon's 5/12 m R^2).
It lies on a face on a plane inclined at theta (downhill +x; the incline is built by
tilting gravity, as in cases/incline_threshold.py), released at rest.

Tipping (statics). The ground's force on the face must act within the face. With friction
holding (tan(theta) <= mu_s), the weight is the only other force, so the ground's force is
-m g, along the line of gravity through the centre, which meets the face a tan(theta)
downhill of its middle. The face reaches s/2 downhill, so the prism stays while
a tan(theta) <= s/2, i.e. tan(theta) <= tan(pi/n):
    it tips when theta > pi/n, and it does so without sliding when mu_s > tan(theta).
The grid sets theta 2 deg either side of pi/n (n = 4: 45 deg, mu = 1.2; n = 12: 15 deg).

The edge impact (note 004's sticking impulse). Turning about its downhill edge P at
omega-, the prism lands on its next face, whose far edge V strikes the incline. A plastic
(e = 0), sticking impact there: the impulse J = K^-1 (u' - u) with the collision matrix
K = 1/m 1 - r* I^-1 r* (r = V - G) brings V to rest, u' = 0 (J in the friction cone is
checked below), so afterwards the prism turns about V. J acts at V, gravity is finite, and
the old edge P carries no impulse (it lifts: after the impact it moves off the incline at
omega+ s, so the simultaneous-impact LCP leaves its impulse at 0), so the angular momentum
about V, L_V = I_c omega + m (G - V) x v_G, is the same before and after:
    before (turning about P, v_G = omega- x (G - P)):  L_V = (I_c + m (G-V).(G-P)) omega-
                                                           = (I_c + m R^2 cos(2 pi/n)) omega-,
    after (turning about V):                           L_V = (I_c + m R^2) omega+,
since |G - P| = |G - V| = R and the two edges are 2 pi/n apart seen from the axis. So
    omega+ / omega- = 1 - m R^2 (1 - cos(2 pi/n)) / I_V,   I_V = I_c + m R^2,
                    = (2 + 7 cos(2 pi/n)) / (8 + cos(2 pi/n))    for the regular n-gon:
0.25 for the square, 0.647 for the hexagon, 0.798 for n = 8, 0.909 for n = 12. The
impulse's slope is |J_t| / J_n = cot(pi/n) (1 - rho) / (1 + rho) (rho the ratio): 0.27 for
n = 8, 0.18 for n = 12, inside mu = 1.2.

Between impacts the prism turns about one edge as a pendulum: omega^2 grows by
2 m g R [sin(theta) (sin phi - sin phi0) - cos(theta) (cos phi - cos phi0)] / I_V (phi the
angle of G - P from the incline's normal, from -pi/n to pi/n), from rest to
    omega1-^2 = 2 m g s sin(theta) / I_V    at the first impact
(the centre drops s sin(theta) in height over a face). The edge holds only while the
incline pushes on it: N / m = g cos(theta) - omega^2 R cos(phi) - alpha R sin(phi) >= 0
(alpha = m g R sin(phi + theta) / I_V). For n <= 6 it does not: the square, the pentagon and
the hexagon fly off their edge before their next face lands (N < 0 near phi = pi/n), so
their impact is no edge impact. For n = 8 the first roll holds (N >= 0.31 m g) and the
second barely (0.06 m g); for n = 12 the first four hold (>= 0.25 m g). The impacts read
are those after a roll whose N stays above 0.2 m g (`clean_impacts`): one for n = 8, two
for n = 12. Friction holds every roll read (F / N <= 0.43, `friction_needed`).

Checks:
- `tips`: turned through more than pi/n about its axis in the run (1) or not (0);
- stays (theta < pi/n): `tilt`, the largest turn in the second half, and `creep_rate`, the
  mean downhill speed there;
- tips, n >= 8: `energy_lost`, the mechanical energy lost before the first impact as a
  fraction of m g s sin(theta) (0: the edge neither slips nor dissipates), and
  `spin_ratio_k` = omega+ / omega- at the k-th edge impact.

Reading the impacts: omega_y (the spin about the axis, positive rolling downhill) grows
through every roll (alpha > 0 for theta > pi/n) and drops only at an impact, so each
impact is a run of falling samples whose drop exceeds a quarter of the expected one;
omega- is its first sample, omega+ its last. A compliant contact spreads an impact over
several steps and the run with it.

Sources: note 004 (Umea, Visual Interactive Simulation): the collision matrix K and the
sticking impulse J = K^-1 (u' - u); note 001 (CG3 II.5): dry friction, contact types
(edge-face); the regular polygon's polar moment; statics of a body on an incline.
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import mechanical_energy, window_mean, window_samples
from cases.scene import Body, Hull, Material, Scene, ground, tilted_gravity

R = 0.1          # circumradius, m
L = 0.1          # half-length along the axis (y), m
M = 1.0          # kg
G = 9.81
MU = 1.2         # above tan(theta) on every incline of the grid (1.07 at 47 deg) and the impacts' 0.6
OFFSET = 2.0     # deg either side of pi/n
T = 0.8          # s: n = 8's first impact at 0.47 s, n = 12's second at 0.55 s (closed form: impact_times)
CLEAN = 0.2      # fraction of m g the edge must keep pressing with through a roll for its impact to be read
MAX_IMPACTS = 2  # impacts read at most

# Grid: the threshold either side for the square (45 deg: the steepest, mu = 1.2 holds it)
# and for n = 12 (15 deg); the impacts on n = 8 (one) and n = 12 (two), the polygons whose
# rolls stay on their edge (n <= 6 fly off theirs before the next face lands).
GRID = (
    {"n": 4, "side": -1},
    {"n": 4, "side": 1},
    {"n": 8, "side": 1},
    {"n": 12, "side": -1},
    {"n": 12, "side": 1},
)


# --- geometry -------------------------------------------------------------------------------

def prism(n: int) -> Hull:
    """The regular n-gon prism about y: its corners R from the axis, at angles
    -pi/2 + pi/n + 2 pi k/n in the x-z plane, so that a face lies flat at the bottom."""
    return Hull(tuple((R * math.cos(b), y, R * math.sin(b))
                      for b in (-math.pi / 2 + math.pi / n + 2 * math.pi * k / n for k in range(n)) for y in (-L, L)))


def apothem(n: int) -> float:
    return R * math.cos(math.pi / n)


def side(n: int) -> float:
    return 2.0 * R * math.sin(math.pi / n)


def theta(p) -> float:
    """The incline: pi/n, OFFSET degrees below (side -1) or above (+1)."""
    return math.pi / p["n"] + p["side"] * math.radians(OFFSET)


# --- closed forms ---------------------------------------------------------------------------

def inertia_axis(n: int, m: float = M) -> float:
    """I_c: about the axis, the regular n-gon's polar moment m R^2 (2 + cos(2 pi/n)) / 6."""
    return m * R**2 * (2.0 + math.cos(2 * math.pi / n)) / 6.0


def inertia_edge(n: int, m: float = M) -> float:
    """I_V = I_c + m R^2: about an edge (parallel axes)."""
    return inertia_axis(n, m) + m * R**2


def tips(th: float, n: int, mu_s: float = MU) -> bool:
    """It tips over its downhill edge (theta > pi/n) while friction holds it (tan <= mu_s)."""
    return th > math.pi / n and math.tan(th) <= mu_s


def spin_ratio(n: int) -> float:
    """omega+ / omega- at a plastic, sticking edge impact: 1 - m R^2 (1 - cos(2 pi/n)) / I_V."""
    return 1.0 - M * R**2 * (1.0 - math.cos(2 * math.pi / n)) / inertia_edge(n)


def impulse_slope(n: int) -> float:
    """|J_t| / J_n of the edge impact: cot(pi/n) (1 - rho) / (1 + rho)."""
    rho = spin_ratio(n)
    return (1.0 - rho) / (1.0 + rho) / math.tan(math.pi / n)


def omega_squared(phi, phi0: float, omega0: float, th: float, n: int):
    """omega^2 turning about an edge, from omega0 at phi0 to phi (the angle of G - P from the
    incline's normal, positive downhill): energy, with the centre R from the edge."""
    return omega0**2 + 2 * M * G * R / inertia_edge(n) * (
        math.sin(th) * (np.sin(phi) - math.sin(phi0)) - math.cos(th) * (np.cos(phi) - math.cos(phi0)))


def first_impact_spin(th: float, n: int) -> float:
    """omega1-: from rest on a face to the next face, the centre dropping s sin(theta)."""
    return math.sqrt(2 * M * G * side(n) * math.sin(th) / inertia_edge(n))


def _roll(th: float, n: int, omega0: float, samples: int = 401):
    """(phi, omega^2, alpha) over one roll from phi = -pi/n at omega0 to pi/n."""
    phi = np.linspace(-math.pi / n, math.pi / n, samples)
    return phi, omega_squared(phi, -math.pi / n, omega0, th, n), M * G * R * np.sin(phi + th) / inertia_edge(n)


def edge_load(th: float, n: int, omega0: float) -> np.ndarray:
    """N / (m g) on the pivot edge over a roll starting at omega0: the centre's acceleration
    about the edge (omega^2 R inwards, alpha R across) against gravity's normal part."""
    phi, w2, alpha = _roll(th, n, omega0)
    return (G * math.cos(th) - w2 * R * np.cos(phi) - alpha * R * np.sin(phi)) / G


def friction_needed(th: float, n: int, omega0: float) -> float:
    """The largest |F| / N on the pivot edge over a roll (where N > 0)."""
    phi, w2, alpha = _roll(th, n, omega0)
    F = -w2 * R * np.sin(phi) + alpha * R * np.cos(phi) - G * math.sin(th)
    N = G * math.cos(th) - w2 * R * np.cos(phi) - alpha * R * np.sin(phi)
    return float(np.max(np.abs(F) / np.where(N > 0, N, np.nan)))


def impact_spins(th: float, n: int, count: int) -> list[tuple[float, float]]:
    """(omega-, omega+) at the first `count` edge impacts, from rest on a face."""
    out, omega0 = [], 0.0
    for _ in range(count):
        before = math.sqrt(float(omega_squared(math.pi / n, -math.pi / n, omega0, th, n)))
        omega0 = spin_ratio(n) * before
        out.append((before, omega0))
    return out


def clean_impacts(th: float, n: int) -> int:
    """How many impacts (at most MAX_IMPACTS) end rolls during which the edge keeps pressing
    with at least CLEAN m g: those read."""
    k, omega0 = 0, 0.0
    while k < MAX_IMPACTS and edge_load(th, n, omega0).min() >= CLEAN:
        k += 1
        omega0 = impact_spins(th, n, k)[-1][1]
    return k


def impact_times(th: float, n: int, count: int) -> list[float]:
    """When the first `count` impacts happen, s: the pendulum about each edge integrated
    (time = integral of dphi / omega; from rest, the first roll starts where omega = 0, so it
    is integrated from a small turn on, where the motion is exponential)."""
    from scipy.integrate import solve_ivp
    lam2 = M * G * R / inertia_edge(n)
    times, t, omega0 = [], 0.0, 0.0
    for _ in range(count):
        hit = lambda _, y: y[0] - math.pi / n  # noqa: E731
        hit.terminal = True
        sol = solve_ivp(lambda _, y: (y[1], lam2 * math.sin(y[0] + th)), (0.0, 10.0), (-math.pi / n, omega0),
                        events=hit, rtol=1e-10, atol=1e-12)
        t += float(sol.t_events[0][0])
        times.append(t)
        omega0 = spin_ratio(n) * float(sol.y_events[0][0][1])
    return times


# --- scene ----------------------------------------------------------------------------------

def scene(p) -> Scene:
    body = Body("prism", prism(p["n"]), mass=M, position=(0.0, 0.0, apothem(p["n"])))
    return Scene(bodies=(ground(), body), gravity=tilted_gravity(theta(p), G), material=Material(e=0.0, mu_s=MU))


def duration(p) -> float:
    return T


# --- observables ----------------------------------------------------------------------------

def turned(traj) -> np.ndarray:
    """The turn about +y (rolling downhill positive) at every sample, unwrapped, rad: from
    the body x axis in the world, (cos psi, ., -sin psi)."""
    q = traj.quat("prism")
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.unwrap(np.arctan2(-2 * (x * z - w * y), 1 - 2 * (y * y + z * z)))


def impacts(omega: np.ndarray, least: float) -> list[tuple[int, int]]:
    """(first, last) sample of each run of falling spin whose drop exceeds `least`."""
    out, k = [], 0
    falling = np.diff(omega) < 0.0
    while k < len(falling):
        if not falling[k]:
            k += 1
            continue
        j = k
        while j < len(falling) and falling[j]:
            j += 1
        if omega[k] - omega[j] > least:
            out.append((k, j))
        k = j
    return out


def observe(traj, p) -> dict:
    n, th = p["n"], theta(p)
    psi = turned(traj)
    out = {"tips": float(np.max(psi) > math.pi / n)}
    if not tips(th, n):
        half = duration(p) / 2
        out["tilt"] = float(np.max(np.abs(psi[window_samples(traj, half)])))
        out["creep_rate"] = window_mean(traj, np.abs(traj.vel("prism")[:, 0]), half)
        return out
    count = clean_impacts(th, n)
    if not count:
        return out
    omega = traj.omega("prism")[:, 1]
    spins = impact_spins(th, n, count)
    found = impacts(omega, 0.25 * min(a - b for a, b in spins))
    energy = mechanical_energy(traj, scene(p))
    before = found[0][0] if found else len(omega) - 1
    out["energy_lost"] = float((energy[0] - energy[before]) / (M * G * side(n) * math.sin(th)))
    for i in range(count):  # no such impact: 0, which misses by the ratio itself
        out[f"spin_ratio_{i + 1}"] = float(omega[found[i][1]] / omega[found[i][0]]) if i < len(found) else 0.0
    return out


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    n, th = p["n"], theta(p)
    checks = [Check("tips", "bool", float(tips(th, n)), 0.0, "abs",
                    f"a verdict: turned more than pi/n = {180 / n:g} deg about its axis in {T} s or not "
                    f"(the incline {OFFSET:g} deg {'above' if p['side'] > 0 else 'below'} pi/n)")]
    if not tips(th, n):
        tilt = 1e-3 / side(n)
        checks += [
            Check("tilt", "rad", 0.0, tilt, "abs",
                  f"a resting face may sink 1 mm (the resting families' overlap) more at its downhill edge than at "
                  f"its uphill one: 1 mm over the face's {side(n) * 1e3:.3g} mm"),
            Check("creep_rate", "m/s", 0.0, 1e-4, "abs",
                  "a sticking prism does not move; 0.1 mm/s would walk it its own size in 30 min"),
        ]
        return checks
    count = clean_impacts(th, n)
    if not count:
        return checks
    spins = impact_spins(th, n, count)
    I_V = inertia_edge(n)
    # alpha about the edge just before an impact (phi = pi/n) and just after (phi = -pi/n)
    alpha_before = M * G * R * math.sin(th + math.pi / n) / I_V
    alpha_after = M * G * R * math.sin(th - math.pi / n) / I_V
    # Symplectic Euler keeps a modified energy H - (dt/2) omega tau (tau = I_V alpha, the
    # gravity torque about the edge): at the impact H is off it by up to dt omega1- tau,
    # a fraction dt alpha / omega1- of the energy gained (1/2 I_V omega1-^2); the sample
    # read is up to a step before the impact, as much again.
    lost = 2 * dt * alpha_before / spins[0][0]
    checks.append(Check("energy_lost", "1", 0.0, lost, "abs",
                        f"symplectic Euler's energy about a pivot is good to dt alpha/omega = {lost / 2:.2g} of the energy "
                        "gained, read up to a step before the impact: twice that (the edge neither slips nor "
                        "dissipates)"))
    rho = spin_ratio(n)
    for i, (before, _) in enumerate(spins):
        # The impulse acts at V and leaves L_V as it was; gravity's torque about V acts through
        # the impact step and the step read after it: omega+ up to 2 alpha_after dt high; the
        # sample before the impact is up to alpha_before dt short of omega-, which the ratio
        # carries as rho alpha_before dt / omega-.
        tol = (2 * alpha_after + rho * alpha_before) * dt / before
        checks.append(Check(f"spin_ratio_{i + 1}", "1", rho, tol, "abs",
                            f"angular momentum about the new edge; gravity's torque about it over 2 steps "
                            f"(2 alpha+ dt) and the sample before it a step early (rho alpha- dt), over "
                            f"omega- = {before:.3g} rad/s: {tol:.2g}"))
    return checks


def variant_id(p) -> str:
    return f"n={p['n']},theta=pi/n{p['side'] * OFFSET:+g}deg"


FAMILY = CaseFamily(
    name="prism_incline",
    summary="a regular n-gon prism hull on an incline tips over its edge above pi/n (not below), and each edge "
            "impact cuts its spin by 1 - m R^2 (1 - cos(2 pi/n)) / I_edge (angular momentum about the new edge)",
    source="note 004 (collision matrix K, sticking impulse J = K^-1 (u' - u)); note 001 (CG3 II.5), dry friction, "
           "edge-face contact; statics of a body on an incline; the regular polygon's polar moment",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("friction off", "n=12,theta=pi/n+2deg"),
        Catch("friction off", "n=12,theta=pi/n-2deg"),
    ),
)
