"""Tunnelling: a small fast sphere (a bullet) against a thin free plate.

Why hard: at 50-100 m/s the bullet (2 cm across) moves 5-10 cm per step of 1 ms, five
to ten times the plate's thickness (1 cm). The start is placed so that no sample of a
discrete engine ever overlaps the plate: one step the bullet is `gap` in front of it, the
next it is wholly behind it. Only continuous collision detection (swept volumes, note 003
"tunnelling") or speculative contacts that look a whole step ahead can see the impact; an
engine that tests positions at the steps only lets the bullet pass through (note 002,
"sequential vs parallel resolution with CCD").

Two gaps tell the two apart. At 1.75 cm (every speed) a speculative contact found up to
2 cm apart (Box2D's and Box3D's four linear slops) sees the plate in the step before; at
5 cm (100 m/s only: the bullet must still land wholly behind the 1 cm plate after its 10 cm
step) no engine's speculative distance reaches it, and only a swept test (PyBullet's swept
sphere, Rapier's CCD, Box2D's and Box3D's bullets, PhysX's CCD, MuJoCo 4's speculative
contacts, which find the time of impact within the step) stops the bullet. The engines'
continuous-collision options are configurations of their own (adapters/registry.py:
pybullet-ccd, mujoco-speculative, rapier-ccd, box2d-bullet, box3d-bullet, physx-ccd), whose
default family this is (tag "swept"); without them the pass-through is each engine's recorded deviation.

Invariants: the bullet does not end behind the plate; no external force acts (no
gravity), so momentum is conserved; the impact is elastic (e = 1), so energy is never
gained. The plate (1 kg) is hit through its centre, so it only translates; the bullet
(10 g) comes back at (m - M) / (m + M) of its speed (central impact, note 001), which the
core case `central_impact` checks; here only the invariants are judged.
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Check
from cases.observables import energy_rise, momentum
from cases.robustness import momentum_conserved, no_energy_gain
from cases.scene import Body, Box, Material, Rect, Scene, ball

R = 0.01             # bullet radius, m
M_BULLET = 0.01      # kg
PLATE = (0.005, 0.1, 0.1)  # plate half-extents (1 cm thick), m
M_PLATE = 1.0        # kg
GAP = 0.0175         # m: the bullet's last gap before the plate (step samples), by default
FAR = 0.05           # m: the far gap, beyond every engine's speculative distance (module notes)
APPROACH = 0.2       # m flown before that last sample: 4 steps at 50 m/s, 2 at 100 m/s
T = 0.05             # simulated time, s

# Grid: 50 and 100 m/s in 3D, 100 m/s in 2D (a disc against a thin rect); at 100 m/s also
# from the far gap.
GRID = ({"v": 50.0, "dim": 3}, {"v": 100.0, "dim": 3}, {"v": 100.0, "dim": 2},
        {"v": 100.0, "dim": 3, "gap": FAR}, {"v": 100.0, "dim": 2, "gap": FAR})


def start(p) -> float:
    """The bullet's start x: APPROACH before the sample at which its front is `gap` from the
    plate's face (the steps land on it: APPROACH is a whole number of steps at each speed)."""
    return -(PLATE[0] + R + p.get("gap", GAP)) - APPROACH


def scene(p) -> Scene:
    dim = p["dim"]
    plate = Box(PLATE) if dim == 3 else Rect((PLATE[0], PLATE[2]))
    return Scene(bodies=(Body("bullet", ball(R, dim), mass=M_BULLET, position=(start(p), 0, 0),
                              velocity=(p["v"], 0, 0), rotates=False),
                         Body("plate", plate, mass=M_PLATE)),
                 gravity=(0, 0, 0), material=Material(e=1.0), dimension=dim)


def observe(traj, p) -> dict:
    sc = scene(p)
    P = momentum(traj, sc)
    behind = traj.pos("bullet")[-1, 0] > traj.pos("plate")[-1, 0]
    return {
        "tunnelled": 1.0 if behind else 0.0,
        "momentum_change": float(np.max(np.linalg.norm(P - P[0], axis=1))),
        "energy_rise": energy_rise(traj, sc),
    }


def expect(p, dt) -> list[Check]:
    energy = 0.5 * M_BULLET * p["v"] ** 2
    return [
        Check("tunnelled", "1 = passed through", 0.0, 0.0, "abs",
              "rigid bodies never pass through each other, at any speed"),
        momentum_conserved(M_BULLET * p["v"]),
        no_energy_gain(1e-3 * energy, "0.1 % of the impact energy: far above round-off, and a bullet "
                                      "pushed out of a late-found overlap gains more"),
    ]


FAMILY = CaseFamily(
    name="robustness_tunnelling",
    summary="a 2 cm bullet at 50-100 m/s against a 1 cm free plate: it must not pass through; momentum kept, no energy gained",
    source="tunnelling and swept volumes (note 003), CCD (note 002); momentum and energy of an elastic impact (note 001)",
    grid=GRID,
    scene=scene,
    duration=lambda p: T,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"v={p['v']:g},{p['dim']}D" + (f",gap={p['gap'] * 100:g}cm" if "gap" in p else ""),
    tags=frozenset({"robustness", "swept"}),
)
