"""A pinch grasp at the critical friction: two pads pressed on a block with force F hold its
weight m g exactly when 2 mu F >= m g (note 001, "dry friction": Coulomb's law at two
contacts; a grasp's static-friction margin).

The block (mass m) hangs between two pads, each on a prismatic joint to the world along x
(a slider: the pads cannot fall or turn) and pushed onto the block by a constant load F
(cases.scene.Load): each pad's contact carries the normal force N = F (the pad does not
move along x), so friction can hold up to 2 mu_s F. Gravity pulls the block down with m g:
    held     when 2 mu_s F >= m g (mu_s >= mu* = m g / (2 F)),
    slides   otherwise, at a = g - 2 mu_k F / m, downward.
The grid sweeps the ratio r = 2 mu F / (m g) across 1: at 0.8 and 1.25 far from the
threshold, at 0.98 and 1.02 within 2 % of it, so an engine that holds with more static
friction than mu_s, or lets go below it, by more than 2 % fails one of the two. From the
sliding variants' acceleration each engine's effective holding friction follows,
    mu_eff = m (g - a) / (2 F),
which is `holding_friction`: the grasp's friction as the engine realises it.

Tolerances as in cases/incline_threshold.py: symplectic Euler is exact for a constant
acceleration, so a sliding block's acceleration is left with the solver's convergence, a
velocity 1e-6 m/s off a step (1e-6 / dt in the fitted slope); mu_eff errs by m / (2 F) of
that. A held block does not move: 0.1 mm/s of creep would slide it out of a 5 cm grasp in
8 min. Readings start after SETTLE, when every engine's contacts carry the load (a
compliant contact takes its time scale, MuJoCo's 16 steps).
"""
from __future__ import annotations

from cases.family import CaseFamily, Catch, Check
from cases.observables import rate, window_mean
from cases.scene import Body, Joint, Load, Material, Scene, cube

G = 9.81
MASS = 1.0          # kg, the block
PAD_MASS = 0.5      # kg, each pad
HALF = 0.05         # m, the block's half-extent
PAD_HALF = (0.02, 0.05, 0.3)  # m, a pad's half-extents: thin along x, tall enough that a slipping block stays between them for T
F = 10.0            # N, each pad's load
HEIGHT = 1.0        # m, the block's centre
SETTLE = 0.1        # s before the readings (see the module docstring)
T = 0.4             # s
SLIDE_DISTANCE = 0.005  # m: "slides" means the block fell more than this in T (2 % above: 1.6 cm)
CRITICAL = MASS * G / (2.0 * F)  # mu*

# Grid: the ratio r = 2 mu F / (m g) at 0.8 and 1.25 (far from the threshold) and at 0.98
# and 1.02 (2 % either side) in 3D, and far either side in 2D.
GRID = tuple({"ratio": r, "dim": 3} for r in (0.8, 0.98, 1.02, 1.25)) + \
    tuple({"ratio": r, "dim": 2} for r in (0.8, 1.25))


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
    x = HALF + PAD_HALF[0]  # pads touching the block's faces
    block = Body("block", cube(HALF, dim), mass=MASS, position=(0.0, 0.0, HEIGHT))
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
    return {"slides": float(z[0] - z[-1] > SLIDE_DISTANCE),
            "sliding_acceleration": a,
            "holding_friction": MASS * (G - a) / (2.0 * F),
            "creep_rate": window_mean(traj, abs(vz), SETTLE)}


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    held = holds(p)
    checks = [Check("slides", "bool", float(not held), 0.0, "abs",
                    f"a verdict: fell more than {SLIDE_DISTANCE} m in {T} s or not (2 mu F >= m g holds)")]
    if held:
        return checks + [Check("creep_rate", "m/s", 0.0, 1e-4, "abs",
                               "a held block does not move; 0.1 mm/s would slide it out of a 5 cm grasp in 8 min")]
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
    return f"2muF/mg={p['ratio']:g}" + (",2D" if p["dim"] == 2 else "")


FAMILY = CaseFamily(
    name="pinch_grasp",
    summary="two pads pressed with F on a block hold its weight iff 2 mu F >= m g, swept across the threshold: "
            "each engine's effective holding friction",
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
        # planted on engines that run the variant as it is (the reference builds no joints yet)
        Catch("friction doubled", "2muF/mg=0.8", "mujoco"),
        Catch("static friction", "2muF/mg=0.98", "rapier"),
        Catch("gravity", "2muF/mg=0.8,2D", "pymunk"),
    ),
)
