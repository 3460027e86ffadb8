"""Stack forces: vertical stacks of up to 10 boxes, equal or alternating heavy and light.

Statics (note 001, "Contact Force Approach": a resting contact carries what keeps the
bodies at rest). Box k (counted from the ground, k = 0) of an n-box stack is at rest, so
the force from below balances its weight and the force from above:
    F_k - F_{k+1} - m_k g = 0,  F_n = 0   =>   F_k = g sum_{j >= k} m_j,
the weight of the boxes from k up, whatever the masses. As in `resting_blocks`, the
pair's total force is checked, not its split among a face's contact points
(indeterminate); bodies at rest do not penetrate and do not drift. Tall stacks and mass
ratios are what iterative solvers find hard: Gauss-Seidel converges slowly when a light
box sits between heavy ones (note 004, "pairwise iterative solvers ... 1/N
convergence"). Measured: the reference's 200 sweeps leave a 2D 10-box 10:1 stack walking
0.4 mm/s (1000 sweeps: none), Pymunk's 10 leave a 10-box stack leaning (0.03 deg).
"""
from __future__ import annotations

from cases.family import CaseFamily, Catch, Check
from cases.observables import stack_readings
from cases.scene import Body, Material, Scene, cube, ground

HALF = 0.1     # half-extent of each cube, m
M = 1.0        # kg, the light box
RATIO = 10.0   # heavy / light
G = 9.81
T = 0.4        # simulated time, s: boxes start exactly touching, forces build up in steps
SETTLED = 0.2  # forces, penetration and vertical drift are read from here on, s

# Grid: 10 boxes (twice the height resting_blocks reaches) alternating 1 kg and 10 kg
# from the bottom, so every box above the first rests on one ten times lighter or
# heavier (the hard case for Gauss-Seidel), in 2D, where Pymunk takes part and the stack
# costs half what it does in 3D; and 4 such boxes in 3D (four corner contacts per face).
# Kept to what the run's time budget allows: a 10-box stack costs DART 40-70 ms a step;
# FULL_GRID has every height, mass pattern and dimension.
GRID = (
    {"n": 10, "masses": "light-heavy", "dim": 2},
    {"n": 4, "masses": "light-heavy", "dim": 3},
)
# Every height from 2 to 10 in each mass pattern, 3D and 2D.
FULL_GRID = tuple({"n": n, "masses": m, "dim": d} for d in (3, 2)
                  for m in ("equal", "heavy-light", "light-heavy") for n in range(2, 11))


def names(n: int) -> list[str]:
    return [f"box{k}" for k in range(n)]


def box_masses(p) -> list[float]:
    """Masses bottom to top: equal; heavy-light alternates 10 kg and 1 kg from the bottom;
    light-heavy starts with the light one."""
    n, kind = p["n"], p["masses"]
    if kind == "equal":
        return [M] * n
    first_heavy = kind == "heavy-light"
    return [RATIO * M if (k % 2 == 0) == first_heavy else M for k in range(n)]


# --- closed form ----------------------------------------------------------------------------

def interface_force(masses: list[float], k: int, g: float = G) -> float:
    """Normal force below box k: the weight of boxes k..n-1."""
    return g * sum(masses[k:])


# --- scene ----------------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p["dim"]
    boxes = tuple(Body(name, cube(HALF, dim), mass=m, position=(0, 0, HALF + 2 * HALF * k))
                  for k, (name, m) in enumerate(zip(names(p["n"]), box_masses(p))))
    return Scene(bodies=(ground(),) + boxes, gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.5), dimension=dim)


def duration(p) -> float:
    return T


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    return stack_readings(traj, names(p["n"]), HALF, SETTLED)


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    masses = box_masses(p)
    window = T - SETTLED
    checks = [Check(f"force_below_box{k}", "N", interface_force(masses, k), 1e-3, "rel",
                    f"momentum balance: a 0.1 % mean force error over {window:g} s would move a box "
                    f"{0.5 * 1e-3 * G * window**2 * 1e3:.1g} mm")
              for k in range(p["n"])]
    checks += [
        Check("penetration", "m", 0.0, 1e-3, "abs",
              "rigid boxes do not overlap; 1 mm (0.5 % of the box) is a solver's stabilising depth"),
        Check("drift", "m", 0.0, 1e-4 * window, "abs",
              f"bodies at rest stay: 0.1 mm/s of creep over {window:g} s walks a stack visibly in a minute (along "
              f"the ground over the whole run, in any direction from {SETTLED} s on)"),
    ]
    return checks


def variant_id(p) -> str:
    return f"n={p['n']},{p['masses']}" + (",2D" if p["dim"] == 2 else "")


FAMILY = CaseFamily(
    name="stack_forces",
    summary="stacks of up to 10 boxes, equal or alternating 10:1 masses: each interface carries the weight above it; no penetration, no drift",
    source="note 001 (CG3 II.5), resting contact; statics of a vertical stack",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    needs=frozenset({"contact_forces"}),
    full_grid=FULL_GRID,
    catches=(
        Catch("force read-out", "n=4,light-heavy"),
        Catch("contact offset", "n=4,light-heavy"),
    ),
)
