"""A pinch grasp at the critical friction: two pads pressed on a body with force F hold its
weight m g exactly when 2 mu F >= m g (note 001, "dry friction": Coulomb's law at two
contacts; a grasp's static-friction margin).

The body (mass m) hangs between two pads, each on a prismatic joint to the world along x
(a slider: the pads cannot fall or turn) and pushed onto the body by a constant load F
(cases.scene.Load): each pad's contact carries the normal force N = F (the pad does not
move along x), so friction can hold up to 2 mu_s F. Gravity pulls the body down with m g:
    held     when 2 mu_s F >= m g (mu_s >= mu* = m g / (2 F)),
    slides   otherwise, at a = g - 2 mu_k F / m, downward.
The grid sweeps the ratio r = 2 mu F / (m g) across 1: at 0.8 and 1.25 far from the
threshold, at 0.98 and 1.02 within 2 % of it, so an engine that holds with more static
friction than mu_s, or lets go below it, by more than 2 % fails one of the two.

Two bodies, and what each measures:

- **The ball** (`shape: ball`, a sphere of radius HALF, ids `...,ball`): each pad touches it
  at one point, c1 = (-R, 0, 0) and c2 = (+R, 0, 0) from its centre, so the two friction
  forces are determinate. With linear velocity v and angular velocity w, the points slip
  against the static pads at
      u1 = v + w x c1 = (v_x, v_y - R w_z, v_z + R w_y),
      u2 = v + w x c2 = (v_x, v_y + R w_z, v_z - R w_y).
  Held (no slip at either point): v_y - R w_z = v_y + R w_z = 0 and v_z + R w_y = v_z - R w_y
  = 0, so v = 0 and w_y = w_z = 0; w_x, a turn about the line through both points, slips
  neither, but no force at a point on that line has a moment about it, so from rest it stays
  0. The friction forces f1, f2 (vertical) then balance the weight, f1 + f2 = m g, and their
  moments about the centre, R (f1 - f2) about y, cancel: f1 = f2 = m g / 2, each within
  mu_s F exactly when 2 mu_s F >= m g. Sliding (2 mu F < m g): with w = 0 both points slip
  down at v_z, each friction is mu_k F upward, their moments cancel, so w stays 0 and the
  ball falls without spin at a = g - 2 mu_k F / m. (A spin w_y with R |w_y| < |v_z| would
  slip one point faster than the other, but both downward, at the same friction mu_k F:
  nothing drives it.)
  So the ball's sliding variants give each engine's effective holding friction,
      mu_eff = m (g - a) / (2 F),
  which is `holding_friction`: the grasp's friction as the engine realises it; and its
  `spin_rate` (the largest |w| over the run) shows whether the engine splits the two
  determinate forces evenly.
- **The block** (a cube of half-extent HALF, the ids without a shape): each pad meets it over
  a face, so a 3D contact solver has four coplanar corner points per pad, and how the
  pad's load and friction split over them is indeterminate (note 000: the LCP need not have
  a unique solution). A symmetric split gives the same closed forms as the ball; a solver
  that splits unevenly across y gives the friction a moment about the pads' normal, turns
  the block, tilts each corner's slip and lets it slide faster than g - 2 mu F / m (the
  reference's sequential impulses, SPOOK and Lemke, DART's NSGS, PyBullet's solvers; held
  from turning, the sequential impulses and SPOOK slide at the closed form; on the ball the
  reference's formulations and DART meet every closed form, PyBullet its acceleration).
  So the 3D block measures how an engine resolves an indeterminate face grasp, the common
  case in robot hands, not its friction; its bands record that. In 2D a pad meets the square at two points along z, whose split has no moment about the plane's
  normal (the friction is vertical, at the same x): the 2D block's motion is determinate too.

Tolerances as in cases/incline_threshold.py: symplectic Euler is exact for a constant
acceleration, so a sliding body's acceleration is left with the solver's convergence, a
velocity 1e-6 m/s off a step (1e-6 / dt in the fitted slope); mu_eff errs by m / (2 F) of
that. A held body does not move: 0.1 mm/s of creep would slide it out of a 5 cm grasp in
8 min. The ball's spin: an uneven split of the two frictions by the force the acceleration
tolerance admits, m tol_a, turns it at R m tol_a / I = 5 tol_a / (2 R) (I = 2/5 m R^2),
which over the run reaches 5 tol_a T / (2 R). Readings start after SETTLE, when every
engine's contacts carry the load (a compliant contact takes its time scale, MuJoCo's 16
steps).
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import rate, window_mean
from cases.scene import Body, Joint, Load, Material, Scene, Sphere, cube

G = 9.81
MASS = 1.0          # kg, the held body (block or ball)
PAD_MASS = 0.5      # kg, each pad
HALF = 0.05         # m, the block's half-extent and the ball's radius
PAD_HALF = (0.02, 0.05, 0.3)  # m, a pad's half-extents: thin along x, tall enough that a slipping block stays between them for T
F = 10.0            # N, each pad's load
HEIGHT = 1.0        # m, the held body's centre
SETTLE = 0.1        # s before the readings (see the module docstring)
T = 0.4             # s
SLIDE_DISTANCE = 0.005  # m: "slides" means the body fell more than this in T (2 % above: 1.6 cm)
CRITICAL = MASS * G / (2.0 * F)  # mu*

# Grid: the ratio r = 2 mu F / (m g) at 0.8 and 1.25 (far from the threshold) and at 0.98
# and 1.02 (2 % either side): the block in 3D, the block far either side in 2D, and the ball
# (determinate: the engines' holding friction) at the 3D ratios.
RATIOS_3D = (0.8, 0.98, 1.02, 1.25)
GRID = tuple({"ratio": r, "dim": 3} for r in RATIOS_3D) + \
    tuple({"ratio": r, "dim": 2} for r in (0.8, 1.25)) + \
    tuple({"ratio": r, "dim": 3, "shape": "ball"} for r in RATIOS_3D)


def shape_of(p) -> str:
    """"ball" or "block" (the grid's variants without a shape: their ids predate the ball)."""
    return p.get("shape", "block")


def friction(p) -> float:
    return p["ratio"] * CRITICAL


def holds(p) -> bool:
    return 2.0 * friction(p) * F >= MASS * G


def sliding_acceleration(mu: float) -> float:
    """a = g - 2 mu F / m (downward), while 2 mu F < m g."""
    return G - 2.0 * mu * F / MASS


# --- scene ----------------------------------------------------------------------------------

def _pad_shape(dim: int):
    from cases.scene import Box, Rect
    return Box(PAD_HALF) if dim == 3 else Rect((PAD_HALF[0], PAD_HALF[2]))


def scene(p) -> Scene:
    dim = p["dim"]
    x = HALF + PAD_HALF[0]  # pads touching the block's faces, or the ball at one point each
    held = Sphere(HALF) if shape_of(p) == "ball" else cube(HALF, dim)
    block = Body("block", held, mass=MASS, position=(0.0, 0.0, HEIGHT))
    left = Body("left", _pad_shape(dim), mass=PAD_MASS, position=(-x, 0.0, HEIGHT))
    right = Body("right", _pad_shape(dim), mass=PAD_MASS, position=(x, 0.0, HEIGHT))
    return Scene(bodies=(block, left, right), gravity=(0.0, 0.0, -G), dimension=dim,
                 material=Material(e=0.0, mu_s=friction(p)),
                 joints=(Joint("prismatic", "left", None, anchor=left.position, axis=(1.0, 0.0, 0.0)),
                         Joint("prismatic", "right", None, anchor=right.position, axis=(1.0, 0.0, 0.0))),
                 loads=(Load("left", force=(F, 0.0, 0.0)), Load("right", force=(-F, 0.0, 0.0))))


def duration(p) -> float:
    return T


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    z = traj.pos("block")[:, 2]
    vz = traj.vel("block")[:, 2]
    a = -rate(traj, vz, SETTLE)  # downward
    out = {"slides": float(z[0] - z[-1] > SLIDE_DISTANCE),
           "sliding_acceleration": a,
           "holding_friction": MASS * (G - a) / (2.0 * F),
           "creep_rate": window_mean(traj, abs(vz), SETTLE)}
    if shape_of(p) == "ball":
        out["spin_rate"] = float(np.max(np.linalg.norm(traj.omega("block"), axis=1)))
    return out


# --- expectations ---------------------------------------------------------------------------

def spin_tolerance(dt: float) -> float:
    """The ball's spin an uneven split of its two frictions by m tol_a reaches over the run:
    R m tol_a / I T = 5 tol_a T / (2 R) (the module docstring)."""
    return 5.0 * (1e-6 / dt) * T / (2.0 * HALF)


def expect(p, dt) -> list[Check]:
    held = holds(p)
    checks = [Check("slides", "bool", float(not held), 0.0, "abs",
                    f"a verdict: fell more than {SLIDE_DISTANCE} m in {T} s or not (2 mu F >= m g holds)")]
    if shape_of(p) == "ball":
        checks.append(Check("spin_rate", "rad/s", 0.0, spin_tolerance(dt), "abs",
                            "the two point frictions' moments cancel, held or sliding: no spin; an uneven split by "
                            "the acceleration's tolerance m tol_a turns the ball at 5 tol_a / (2 R) over T"))
    if held:
        return checks + [Check("creep_rate", "m/s", 0.0, 1e-4, "abs",
                               "a held body does not move; 0.1 mm/s would slide it out of a 5 cm grasp in 8 min")]
    tol_a = 1e-6 / dt
    mu = friction(p)
    return checks + [
        Check("sliding_acceleration", "m/s^2", sliding_acceleration(mu), tol_a, "abs",
              f"symplectic Euler is exact for constant acceleration; solver convergence (1e-6 m/s a step) / dt = "
              f"{tol_a:.2g} m/s^2"),
        Check("holding_friction", "-", mu, MASS * tol_a / (2.0 * F), "abs",
              "mu_eff = m (g - a) / (2 F) from the sliding acceleration: its tolerance times m / (2 F)"),
    ]


def variant_id(p) -> str:
    return f"2muF/mg={p['ratio']:g}" + (",2D" if p["dim"] == 2 else "") + (",ball" if shape_of(p) == "ball" else "")


FAMILY = CaseFamily(
    name="pinch_grasp",
    summary="two pads pressed with F on a ball (or a block) hold its weight iff 2 mu F >= m g, swept across the "
            "threshold: each engine's effective holding friction (the ball's two point contacts are determinate; "
            "the block's face contacts are not, in 3D)",
    source="note 001 (CG3 II.5), dry friction (Coulomb) at two contacts; the pads on sliders, pressed by "
           "constant loads",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        # planted on the reference, whose ball grasps meet the closed forms (its 3D block
        # grasps turn, the indeterminate split: the module docstring)
        Catch("friction doubled", "2muF/mg=0.8,ball"),
        Catch("static friction", "2muF/mg=0.98,ball"),
        Catch("gravity", "2muF/mg=0.8,ball"),
    ),
)
