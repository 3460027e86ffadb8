"""Resting blocks: one box at rest and vertical stacks of 2 to 5 boxes.

Statics (note 001, resting contact): every box is at rest, so the net force on each is
zero, and the normal force at the interface below box k (counted from the ground, k = 0)
carries the weight of the boxes from k up:
    F_k = (n - k) m g.
This holds for the pair's total force; how it splits among a face's contact points is
indeterminate and is not checked. Bodies at rest do not penetrate and do not drift.
"""
from __future__ import annotations


from cases.family import CaseFamily, Catch, Check
from cases.observables import stack_readings
from cases.scene import Body, Material, Scene, cube, ground

HALF = 0.1   # half-extent of each cube, m
M = 1.0      # mass of each cube, kg
G = 9.81
T = 3.0      # simulated time, s
SETTLED = 1.0  # forces and drift are read from here on, s

# Grid: a single box, then stacks growing to 5 (each level adds one more force to carry);
# 2D variants (squares in the x-z plane) let 2D engines take part.
GRID = tuple({"n": n, "dim": 3} for n in range(1, 6)) + tuple({"n": n, "dim": 2} for n in (1, 3))


def names(n: int) -> list[str]:
    return [f"box{k}" for k in range(n)]


# --- closed form ----------------------------------------------------------------------

def interface_force(n: int, k: int, m: float = M, g: float = G) -> float:
    """Normal force below box k of an n-box stack: the weight of boxes k..n-1."""
    return (n - k) * m * g


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    n = p["n"]
    dim = p.get("dim", 3)
    boxes = tuple(Body(name, cube(HALF, dim), mass=M, position=(0, 0, HALF + 2 * HALF * k))
                  for k, name in enumerate(names(n)))
    return Scene(bodies=(ground(),) + boxes, gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.5), dimension=dim)


def duration(p) -> float:
    return T


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    return stack_readings(traj, names(p["n"]), HALF, SETTLED)


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    n = p["n"]
    checks = [Check(f"force_below_box{k}", "N", interface_force(n, k), 1e-3, "rel",
                    "momentum balance: a 0.1 % mean force error over 2 s would move a box 0.02 m")
              for k in range(n)]
    checks += [
        Check("penetration", "m", 0.0, 1e-3, "abs",
              "rigid boxes do not overlap; 1 mm (0.5 % of the box) is a solver's stabilising depth"),
        Check("drift", "m", 0.0, 2e-4, "abs",
              "bodies at rest stay: 0.1 % of the box size over 2 s, beyond which a stack walks visibly"),
    ]
    return checks


FAMILY = CaseFamily(
    name="resting_blocks",
    summary="a box at rest and stacks of 2 to 5 boxes: each interface carries the weight above it; no penetration, no drift",
    source="note 001 (CG3 II.5), resting contact; statics of a vertical stack",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    sweep_variants=("n=3", "n=3,2D"),  # what `physval sweep` varies dt and iterations on
    variant_id=lambda p: f"n={p['n']}" + (",2D" if p.get("dim", 3) == 2 else ""),
    needs=frozenset({"contact_forces"}),
    tags=frozenset({"core"}),
    catches=(
        Catch("force read-out", "n=1,2D"),
        Catch("contact offset", "n=1,2D"),
    ),
)
