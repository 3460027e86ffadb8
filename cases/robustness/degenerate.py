"""Degenerate landings: a box that lands exactly edge-on or vertex-on.

Why hard: contact geometry is degenerate at the moment of impact (note 001, "contact
types: vertex-face, edge-edge, degenerate"). Edge-on, the two faces next to the edge meet
the ground at the same angle, so the separating axis test has a tie and the contact
normal, the number of contact points and their ids can flip from step to step; vertex-on,
three faces tie. The landing is also an unstable balance: a perfect engine keeps the box
balanced until round-off tips it (about 3 s at this size), a real one tips it at once to
either side; both are right. What is never right is energy from nowhere, a box sinking
into the ground, or a blow-up (the runner reports `unstable` for NaN or a runaway speed).

Layout: a 0.2 m cube, 1 kg, its lowest edge (rotated 45 deg about y) or lowest vertex
(body diagonal turned to point straight down) 5 cm above the ground, released at rest;
e = 0, mu = 0.5. 2D: a square landing on a corner.

Invariants: energy never rises (the landing is plastic and friction only takes energy);
from LANDED on, the box never overlaps the ground by more than 0.5 % of its size.
"""
from __future__ import annotations

import math

from cases.family import CaseFamily
from cases.observables import deepest_overlap, energy_rise
from cases.robustness import bounded_penetration, free_flight_energy_tolerance, no_energy_gain
from cases.scene import Body, Material, Scene, cube, ground, quat_about_y

HALF = 0.1
SIZE = 2 * HALF
M = 1.0
G = 9.81
DROP = 0.05     # lowest point above the ground at release, m
T = 2.0         # simulated time, s
LANDED = 0.3    # the box has landed (free fall of DROP takes 0.1 s) and settled its impact by then, s

# Grid: edge-on and vertex-on in 3D, corner-on in 2D.
GRID = ({"landing": "edge", "dim": 3}, {"landing": "vertex", "dim": 3}, {"landing": "edge", "dim": 2})


def orientation(landing: str) -> tuple[float, float, float, float]:
    """Edge down: 45 deg about y. Vertex down: the rotation taking the body diagonal
    (1, 1, 1)/sqrt 3 to (0, 0, -1): about (-1, 1, 0)/sqrt 2 by acos(-1/sqrt 3)."""
    if landing == "edge":
        return quat_about_y(math.pi / 4)
    angle = math.acos(-1.0 / math.sqrt(3.0))
    s = math.sin(angle / 2) / math.sqrt(2.0)
    return (math.cos(angle / 2), -s, s, 0.0)


def lowest_depth(landing: str) -> float:
    """Depth of the lowest point below the centre: half sqrt 2 (edge), half sqrt 3 (vertex)."""
    return HALF * (math.sqrt(2.0) if landing == "edge" else math.sqrt(3.0))


def scene(p) -> Scene:
    box = Body("box", cube(HALF, p["dim"]), mass=M, orientation=orientation(p["landing"]),
               position=(0, 0, DROP + lowest_depth(p["landing"])))
    return Scene(bodies=(ground(), box), gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.5), dimension=p["dim"])


def observe(traj, p) -> dict:
    sc = scene(p)
    return {"energy_rise": energy_rise(traj, sc), "penetration": deepest_overlap(traj, sc, LANDED, samples=40)}


def expect(p, dt):
    return [
        no_energy_gain(free_flight_energy_tolerance(M, G, dt, 2 * math.sqrt(2 * DROP / G)),
                       "the landing is plastic and friction only takes energy; the tolerance is the sampled "
                       "energy a position-first Euler integrator gains in free flight, M g^2 dt T / 2, over "
                       "twice the drop's fall time (the tip off the edge falls 4 cm more)"),
        bounded_penetration(SIZE),
    ]


FAMILY = CaseFamily(
    name="robustness_degenerate",
    summary="a box landing exactly edge-on or vertex-on: tied contact features; no energy gain, no sinking, no blow-up",
    source="degenerate contact types (note 001); plastic landing and Coulomb friction only dissipate",
    grid=GRID,
    scene=scene,
    duration=lambda p: T,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"{p['landing']}-on,{p['dim']}D",
    tags=frozenset({"robustness"}),
)
