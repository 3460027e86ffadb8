"""Newton's cradle with e = 1, for many periods, in a box without gravity.

Why hard: a striker hits a row of touching balls. Every contact of the row is active at
once, so how the impulse travels depends on whether contacts are resolved one after the
other (a pulse: one ball out) or together (the row shares the push), and on the contact
law (note 001, "Newton's cradle and dispersion": Hooke r = 1 spreads the pulse, Hertz
r = 1.5 keeps it). Which of these an engine does is its model; what every model must do
with e = 1 is keep the kinetic energy, impact after impact: a solver that loses or gains
a fraction of it per simultaneous impact drifts visibly over many periods (note 004,
"Newton-Coulomb ... simultaneous restitution" can gain).

Layout (no gravity, frictionless, e = 1 for every pair, balls do not rotate): a striker
at 1 m/s, GAP from a row of four touching balls (r = 5 cm, 1 kg); static walls GAP beyond
each end of the row. With one ball out, one cycle (striker in, far ball to its wall and
back, striker to its wall and back) takes 6 GAP / v = 0.3 s; 2 s is about 7 cycles, the
long variant (FULL_GRID) 20 s, about 67. A variant without walls lets momentum be judged.

Invariants: with walls the kinetic energy never rises and is kept at the end; without
walls momentum is conserved as well.
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import mechanical_energy, momentum
from cases.robustness import momentum_conserved
from cases.scene import Body, Box, Material, Rect, Scene, ball

R = 0.05       # ball radius, m
M = 1.0        # kg per ball
N_ROW = 4      # touching balls in the row
GAP = 0.05     # striker to row, and each end to its wall, m
V = 1.0        # striker speed, m/s
WALL = (0.05, 0.2, 0.2)  # wall half-extents, m
ENERGY_TOLERANCE = 1e-3  # of the initial kinetic energy

# Grid: walls, 2 s, in 2D; no walls (momentum), 0.5 s, 3D. FULL_GRID: walls in 3D, 2 s
# and 20 s, and 20 s in 2D.
GRID = ({"walls": True, "dim": 2, "T": 2.0}, {"walls": False, "dim": 3, "T": 0.5})
FULL_GRID = GRID + ({"walls": True, "dim": 3, "T": 2.0}, {"walls": True, "dim": 3, "T": 20.0},
                    {"walls": True, "dim": 2, "T": 20.0})


def scene(p) -> Scene:
    dim = p["dim"]
    x_row = [2 * R * i for i in range(N_ROW)]
    striker = Body("striker", ball(R, dim), mass=M, position=(-2 * R - GAP, 0, 0), velocity=(V, 0, 0), rotates=False)
    row = tuple(Body(f"ball{i}", ball(R, dim), mass=M, position=(x, 0, 0), rotates=False) for i, x in enumerate(x_row))
    walls = ()
    if p["walls"]:
        shape = Box(WALL) if dim == 3 else Rect((WALL[0], WALL[2]))
        left = -2 * R - GAP - R - GAP - WALL[0]
        right = x_row[-1] + R + GAP + WALL[0]
        walls = (Body("wall_left", shape, static=True, position=(left, 0, 0)),
                 Body("wall_right", shape, static=True, position=(right, 0, 0)))
    return Scene(bodies=(striker,) + row + walls, gravity=(0, 0, 0), material=Material(e=1.0), dimension=dim)


def observe(traj, p) -> dict:
    sc = scene(p)
    E = mechanical_energy(traj, sc)
    out = {"energy_rise": float(max(np.max(E) - E[0], 0.0)), "energy_loss": float(E[0] - E[-1])}
    if not p["walls"]:
        P = momentum(traj, sc)
        out["momentum_change"] = float(np.max(np.linalg.norm(P - P[0], axis=1)))
    return out


def expect(p, dt) -> list[Check]:
    E0 = 0.5 * M * V * V
    tol = ENERGY_TOLERANCE * E0
    checks = [
        Check("energy_rise", "J", 0.0, tol, "abs",
              "elastic impacts (e = 1) without gravity: kinetic energy never rises; 0.1 % of it is far above "
              "round-off and below any visible speed-up"),
        Check("energy_loss", "J", 0.0, tol, "abs",
              "every impact is elastic (e = 1): energy is kept over the whole run; 0.1 % lost is below any "
              "visible slowing"),
    ]
    if not p["walls"]:
        checks.append(momentum_conserved(M * V, impacts=N_ROW))  # the striker's and the row's contacts
    return checks


FAMILY = CaseFamily(
    name="robustness_cradle",
    summary="Newton's cradle (e = 1) between two walls without gravity, many cycles: energy kept, never gained; momentum kept without walls",
    source="Newton's cradle and dispersion (note 001); simultaneous restitution (note 004); elastic impacts keep energy",
    grid=GRID,
    scene=scene,
    duration=lambda p: p["T"],
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"{'walls' if p['walls'] else 'free'},{p['dim']}D,T={p['T']:g}",
    tags=frozenset({"robustness"}),
    full_grid=FULL_GRID,
    catches=(
        Catch("restitution off", "walls,2D,T=2"),
        Catch("damping", "walls,2D,T=2"),
    ),
)
