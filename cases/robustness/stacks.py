"""Tall stacks, pyramids and long rest: structures that must simply stand.

Why hard: every box of a vertical stack of n boxes carries the weight of those above, so
an iterative solver must carry load through n contacts. Projected Gauss-Seidel moves
information one contact per sweep and its error falls slowly with n (note 004,
"pairwise iterative solvers"); what it leaves unsolved each step shows as sinking, sway
and finally collapse, and warm starting (note 001, "inter-timestep persistence") only
helps if contacts keep their identity from step to step. A pyramid adds contacts that
share bodies sideways (each box rests on two below). A long rest accumulates whatever
drift a step leaves: 1 um per step is 6 cm after 60 s at dt = 1e-3.

Statics (note 001, resting contact): the ground carries the whole weight N m g (N boxes);
nothing moves, overlaps or gains energy. Vertical stacks are `resting_blocks`' scene
(defined there once); the pyramid is a wall in the x-z plane: row k (k = 0 at the ground)
has base - k boxes, each centred over the gap between two boxes of the row below.
"""
from __future__ import annotations

import functools

from cases import resting_blocks
from cases.family import CaseFamily, Catch, Check
from cases.observables import deepest_overlap, drift, energy_rise, window_mean
from cases.robustness import (at_rest_energy_tolerance, bounded_drift, bounded_penetration, collapse_time,
                              no_energy_gain, stands)
from cases.scene import Body, Material, Scene, cube, ground

HALF, M, G = resting_blocks.HALF, resting_blocks.M, resting_blocks.G
SIZE = 2 * HALF
GAP = 0.1 * HALF  # between neighbours of a pyramid row (1 cm): each box rests on the two below only
SETTLED = 0.5     # drift and overlap are read from here on, s

# Grid (the default run): a pyramid of base 3 in 2D (six boxes, each upper box on two
# below; stacks up to 10 are resting_blocks' and stack_forces'). One small variant, as
# the reference engine is plain Python.
GRID = ({"structure": "pyramid", "n": 3, "dim": 2, "T": 1.0},)
# Full grid (physval stress --long): the base-3 pyramid in 3D; stacks of 10 and 20 for
# 3 s; pyramids of base 10 and 20 (55 and 210 boxes) for 1 s (the plain-Python reference
# takes ~1 s per step for the 55-box one in 3D); 3D and 2D; three-box stacks resting 60 s.
FULL_GRID = ({"structure": "pyramid", "n": 3, "dim": 3, "T": 1.0},) + \
            tuple({"structure": "stack", "n": n, "dim": d, "T": 3.0} for n in (10, 20) for d in (3, 2)) + \
            tuple({"structure": "pyramid", "n": n, "dim": d, "T": 1.0} for n in (10, 20) for d in (3, 2)) + \
            tuple({"structure": "stack", "n": 3, "dim": d, "T": 60.0} for d in (3, 2))


def count(p) -> int:
    """Number of boxes: n for a stack, n (n + 1) / 2 for a pyramid of base n."""
    n = p["n"]
    return n if p["structure"] == "stack" else n * (n + 1) // 2


def pyramid(base: int, dim: int) -> Scene:
    boxes = []
    for row in range(base):
        width = base - row
        for i in range(width):
            x = (i - (width - 1) / 2) * (SIZE + GAP)
            boxes.append(Body(f"box{row}_{i}", cube(HALF, dim), mass=M, position=(x, 0, HALF + SIZE * row)))
    return Scene(bodies=(ground(),) + tuple(boxes), gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.5),
                 dimension=dim)


def scene(p) -> Scene:
    return _scene(p["structure"], p["n"], p["dim"])


@functools.lru_cache(maxsize=8)
def _scene(structure: str, n: int, dim: int) -> Scene:
    """Built once per process: validating a 210-box pyramid's 22,000 pairs takes seconds."""
    if structure == "stack":
        return resting_blocks.scene({"n": n, "dim": dim})
    return pyramid(n, dim)


def duration(p) -> float:
    return p["T"]


def observe(traj, p) -> dict:
    sc = scene(p)
    names = [b.name for b in sc.dynamic_bodies]
    ground_force = sum(traj.force("ground", name) for name in names)
    return {
        "standing_time": collapse_time(traj, names, SIZE),
        "ground_force": window_mean(traj, ground_force, SETTLED),
        "penetration": deepest_overlap(traj, sc, SETTLED),
        "drift": drift(traj, names, SETTLED),
        "energy_rise": energy_rise(traj, sc),
    }


def expect(p, dt) -> list[Check]:
    n = count(p)
    return [
        stands(p["T"], SIZE, dt),
        Check("ground_force", "N", n * M * G, 1e-3, "rel",
              "statics: the ground carries the whole weight; 0.1 % of it as a mean would move the structure"),
        bounded_penetration(SIZE),
        bounded_drift(SIZE),
        no_energy_gain(at_rest_energy_tolerance(n * M, G, SIZE),
                       "a resting structure may gain at most its weight lifted by 0.1 % of a box"),
    ]


def variant_id(p) -> str:
    return f"{p['structure']},n={p['n']},{p['dim']}D,T={p['T']:g}"


FAMILY = CaseFamily(
    name="robustness_stacks",
    summary="tall stacks, pyramids and long rest stand: no collapse, the ground carries the weight, no overlap, drift or energy gain",
    source="statics of resting contact (note 001); why hard: PGS convergence with stack height (note 004)",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    needs=frozenset({"contact_forces"}),
    tags=frozenset({"robustness"}),
    full_grid=FULL_GRID,
    catches=(
        Catch("force read-out", "pyramid,n=3,2D,T=1"),
    ),
)
