"""Overlap recovery: bodies that start 25 % of their size inside the ground or each other.

Why hard: an overlap this deep never arises from motion at a sane time step, but it does
from user input, spawning and teleporting. An engine must push the bodies apart without
launching them. The note's de-penetration bias (note 001, "de-penetration bias velocity",
v = beta/dt (delta - slop)) put into the velocity turns a 5 cm overlap into a 10 m/s
launch at beta = 0.2, dt = 1e-3; split impulses or position projection move the body out
without kinetic energy; a soft contact is a compressed spring that springs back; an engine
that caps the push-out speed takes a long time.

Invariants (the scene asks for this overlap on purpose: `Scene.allowed_overlap`):
- recovery: after SETTLED no two bodies overlap by more than 0.5 % of a size;
- no launch: getting out needs only the potential energy of the rest configuration
  (each body resting on what is below it); the mechanical energy never exceeds that by
  more than the weight lifted by the allowed contact depth;
- the bodies then stay put (drift).
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Check
from cases.observables import deepest_overlap, drift, mechanical_energy
from cases.robustness import PENETRATION_FRACTION, bounded_drift, bounded_penetration
from cases.scene import Body, Material, Scene, ball, cube, ground

HALF = 0.1           # half-extent of a box, radius of a ball, m
SIZE = 2 * HALF
M = 1.0              # kg per body
G = 9.81
OVERLAP = 0.25       # of the size
T = 1.0              # simulated time, s
SETTLED = 0.5        # recovery is judged from here on, s

# Grid: a box sunk 25 % into the ground (3D and 2D), a box sunk 25 % into the box it rests
# on (2D); FULL_GRID adds the box on a box in 3D and a ball sunk into the ground.
GRID = ({"setup": "box_in_ground", "dim": 3}, {"setup": "box_in_ground", "dim": 2}, {"setup": "box_in_box", "dim": 2})
FULL_GRID = GRID + ({"setup": "box_in_box", "dim": 3}, {"setup": "ball_in_ground", "dim": 3})


def rest_heights(p) -> dict[str, float]:
    """Centre heights of the rest configuration: each body resting on what is below it."""
    if p["setup"] == "box_in_box":
        return {"box0": HALF, "box1": 3 * HALF}
    return {"body": HALF}


def scene(p) -> Scene:
    dim, depth = p["dim"], OVERLAP * SIZE
    if p["setup"] == "box_in_box":
        bodies = (Body("box0", cube(HALF, dim), mass=M, position=(0, 0, HALF)),
                  Body("box1", cube(HALF, dim), mass=M, position=(0, 0, 3 * HALF - depth)))
    else:
        shape = cube(HALF, dim) if p["setup"] == "box_in_ground" else ball(HALF, dim)
        bodies = (Body("body", shape, mass=M, position=(0, 0, HALF - depth)),)
    return Scene(bodies=(ground(),) + bodies, gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.5),
                 dimension=dim, allowed_overlap=depth * (1 + 1e-9))


def observe(traj, p) -> dict:
    sc = scene(p)
    rest = sum(M * G * z for z in rest_heights(p).values())
    return {
        "penetration": deepest_overlap(traj, sc, SETTLED),
        "energy_above_rest": max(float(np.max(mechanical_energy(traj, sc))) - rest, 0.0),
        "drift": drift(traj, list(rest_heights(p)), SETTLED),
    }


def expect(p, dt) -> list[Check]:
    n = len(rest_heights(p))
    lift = PENETRATION_FRACTION * SIZE
    return [
        bounded_penetration(SIZE),
        Check("energy_above_rest", "J", 0.0, n * M * G * lift, "abs",
              "pushing bodies apart needs only the rest configuration's potential energy; more is a launch "
              f"(tolerance: the weight lifted by the allowed contact depth, {lift:.3g} m)"),
        bounded_drift(SIZE),
    ]


FAMILY = CaseFamily(
    name="robustness_overlap",
    summary="bodies starting 25 % interpenetrated: pushed apart within 0.5 s without being launched, then at rest",
    source="de-penetration (note 001, bias velocity; note 003, interpenetration resolution); energy of the rest configuration",
    grid=GRID,
    scene=scene,
    duration=lambda p: T,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"{p['setup']},{p['dim']}D",
    tags=frozenset({"robustness"}),
    full_grid=FULL_GRID,
)
