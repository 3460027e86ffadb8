"""Many simultaneous contacts: a grid of balls dropped into a bin made of static boxes.

Why hard: the balls land together and settle into a pile in which every ball touches up
to a dozen others and the bin; hundreds of contacts form in the same few steps, all
coupled. An iterative solver must share each ball's weight among contacts it solves one
at a time (note 000, "iterating simultaneous collisions"); errors show as balls sinking
into each other, popping out of the pile with energy they never had, or squeezed through
a wall. The broad phase must also find the contacts among n balls without testing all
n^2 pairs (note 000, "per-object sums instead of O(N^2) search"; note 001, sweep).

Layout: k x k x k balls (r = 5 cm, 0.1 kg) on a grid of pitch 2.2 r, every other layer
shifted by 0.3 r in x and y so the columns are not balanced on each other; the bin is a
square of four static walls, 2.2 r k + 2 cm wide inside, on the ground. 2D: k x k discs
between two walls. Plastic (e = 0), mu = 0.5.

Invariants: energy never rises (nothing but gravity does work); after settling no two
bodies overlap by more than 0.5 % of a ball's size; no ball ends outside the bin.
"""
from __future__ import annotations

from cases.family import CaseFamily, Check
from cases.observables import deepest_overlap, energy_rise
from cases.robustness import bounded_penetration, free_flight_energy_tolerance, no_energy_gain
from cases.scene import Body, Box, Material, Rect, Scene, ball, ground

R = 0.05            # ball radius, m
SIZE = 2 * R
M = 0.1             # kg per ball
PITCH = 2.2 * R     # grid spacing, m
LIFT = 0.01         # bottom layer starts this far above the ground, m
WALL = 0.05         # wall half-thickness, m
G = 9.81
SETTLED_FRACTION = 0.6  # overlap is read over the last 40 % of the run

# Grid: 2 x 2 discs in 2D for 0.6 s (the default run: a smoke test); FULL_GRID has
# 2 x 2 x 2 balls, the full 6 x 6 x 6 pile (216 balls) and a 10 x 10 one in 2D, 3 s.
GRID = ({"k": 2, "dim": 2, "T": 0.6},)
FULL_GRID = ({"k": 2, "dim": 3, "T": 1.0}, {"k": 6, "dim": 3, "T": 3.0}, {"k": 10, "dim": 2, "T": 3.0})


def inner_half_width(k: int) -> float:
    return k * PITCH / 2 + 0.01


def ball_names(p) -> list[str]:
    n = p["k"] ** p["dim"]
    return [f"ball{i}" for i in range(n)]


def scene(p) -> Scene:
    k, dim = p["k"], p["dim"]
    W = inner_half_width(k)
    height = LIFT + k * PITCH + 0.1
    balls = []
    for layer in range(k):
        shift = 0.3 * R if layer % 2 else 0.0
        z = R + LIFT + layer * PITCH
        for i in range(k):
            for j in range(k if dim == 3 else 1):
                x = (i - (k - 1) / 2) * PITCH + shift
                y = (j - (k - 1) / 2) * PITCH + shift if dim == 3 else 0.0
                balls.append(Body(f"ball{len(balls)}", ball(R, dim), mass=M, position=(x, y, z)))
    walls = []
    for side in (-1, 1):
        offset = side * (W + WALL)
        if dim == 3:
            walls.append(Body(f"wall_x{side:+d}", Box((WALL, W + 2 * WALL, height / 2)), static=True,
                              position=(offset, 0, height / 2)))
            walls.append(Body(f"wall_y{side:+d}", Box((W, WALL, height / 2)), static=True,
                              position=(0, offset, height / 2)))
        else:
            walls.append(Body(f"wall_x{side:+d}", Rect((WALL, height / 2)), static=True,
                              position=(offset, 0, height / 2)))
    return Scene(bodies=(ground(),) + tuple(balls) + tuple(walls), gravity=(0, 0, -G),
                 material=Material(e=0.0, mu_s=0.5), dimension=dim)


def observe(traj, p) -> dict:
    sc = scene(p)
    W = inner_half_width(p["k"])
    escaped = 0
    for name in ball_names(p):
        x = traj.pos(name)[-1]
        outside = abs(x[0]) > W or (p["dim"] == 3 and abs(x[1]) > W) or x[2] < 0
        escaped += int(outside)
    return {
        "escaped": float(escaped),
        "penetration": deepest_overlap(traj, sc, SETTLED_FRACTION * p["T"]),
        "energy_rise": energy_rise(traj, sc),
    }


def expect(p, dt) -> list[Check]:
    total = M * len(ball_names(p))
    return [
        Check("escaped", "balls", 0.0, 0.0, "abs", "walls are solid: no ball leaves the bin"),
        bounded_penetration(SIZE),
        no_energy_gain(free_flight_energy_tolerance(total, G, dt, p["T"]),
                       "impacts are plastic; the tolerance is the sampled energy a position-first Euler "
                       "integrator gains in free flight, M g^2 dt T / 2"),
    ]


FAMILY = CaseFamily(
    name="robustness_pile",
    summary="a grid of balls dropped into a bin of static boxes: hundreds of simultaneous contacts; no energy gain, overlap or escape",
    source="simultaneous collisions and per-object contact search (note 000); energy of plastic impacts (note 001)",
    grid=GRID,
    scene=scene,
    duration=lambda p: p["T"],
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"{p['k']}^{p['dim']} balls,{p['dim']}D,T={p['T']:g}",
    tags=frozenset({"robustness"}),
    full_grid=FULL_GRID,
)
