"""Tiny and far: a stack of millimetre boxes, and a stack of 0.2 m boxes a kilometre from the origin.

Why hard: physics is scale-free, engines are not. Contact slop, speculative margins,
penetration thresholds and solver tolerances are absolute lengths and speeds chosen for
bodies of about a metre; a 1 mm box (1 mg, water's density) can sink through its own
size before such a threshold reacts, and its weight (1e-5 N) may sit below a force
tolerance. Far from the origin, float64 positions keep only about 1e-13 m of resolution
at 1 km (an engine in float32 keeps 6e-5 m), and a finite
stand-in for an infinite ground plane may simply end before the bodies.

Statics are the same at every scale and place (note 001, resting contact): the ground
carries the whole weight; nothing moves, overlaps or gains energy; every tolerance is a
fraction of the box size, so the checks scale with the scene.
"""
from __future__ import annotations

from cases.family import CaseFamily, Catch, Check
from cases.observables import deepest_overlap, drift, energy_rise, window_mean
from cases.robustness import (at_rest_energy_tolerance, bounded_drift, bounded_penetration, collapse_time,
                              no_energy_gain, stands)
from cases.scene import Body, Material, Scene, cube, ground

N = 3            # boxes per stack
G = 9.81
DENSITY = 1000.0  # kg/m^3 (water): mass of a cube of edge a is DENSITY a^3
T = 1.0          # simulated time, s
SETTLED = 0.5    # forces, drift and overlap are read from here on, s

# Grid: 1 mm cubes (1 mg) at the origin; 0.2 m cubes (8 kg) 1 km from the origin along x;
# in 2D (every engine runs it); FULL_GRID adds both in 3D.
GRID = tuple({"half": h, "x": x, "dim": 2} for h, x in ((0.5e-3, 0.0), (0.1, 1000.0)))
FULL_GRID = GRID + tuple({"half": h, "x": x, "dim": 3} for h, x in ((0.5e-3, 0.0), (0.1, 1000.0)))


def mass(half: float) -> float:
    return DENSITY * (2 * half) ** 3


def names() -> list[str]:
    return [f"box{k}" for k in range(N)]


def scene(p) -> Scene:
    h, x, dim = p["half"], p["x"], p["dim"]
    boxes = tuple(Body(name, cube(h, dim), mass=mass(h), position=(x, 0, h + 2 * h * k))
                  for k, name in enumerate(names()))
    return Scene(bodies=(ground(),) + boxes, gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.5), dimension=dim)


def observe(traj, p) -> dict:
    sc = scene(p)
    size = 2 * p["half"]
    return {
        "ground_force": window_mean(traj, traj.force("ground", "box0"), SETTLED),
        "standing_time": collapse_time(traj, names(), size),
        "penetration": deepest_overlap(traj, sc, SETTLED),
        "drift": drift(traj, names(), SETTLED),
        "energy_rise": energy_rise(traj, sc),
    }


def expect(p, dt) -> list[Check]:
    size, m = 2 * p["half"], mass(p["half"])
    return [
        Check("ground_force", "N", N * m * G, 1e-3, "rel",
              "statics: the ground carries the whole weight; 0.1 % of it as a mean would move the stack"),
        stands(T, size, dt),
        bounded_penetration(size),
        bounded_drift(size),
        no_energy_gain(at_rest_energy_tolerance(N * m, G, size),
                       "a resting stack may gain at most its weight lifted by 0.1 % of a box"),
    ]


FAMILY = CaseFamily(
    name="robustness_scale",
    summary="a stack of 1 mm boxes, and one 1 km from the origin: same statics at every scale and place, tolerances in box sizes",
    source="statics of resting contact (note 001); scale-free physics against absolute engine thresholds",
    grid=GRID,
    scene=scene,
    duration=lambda p: T,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"{'mm boxes' if p['half'] < 0.01 else 'far'},{p['dim']}D",
    needs=frozenset({"contact_forces"}),
    tags=frozenset({"robustness"}),
    full_grid=FULL_GRID,
    catches=(
        Catch("force read-out", "mm boxes,2D"),
        Catch("contact offset", "mm boxes,2D"),
    ),
)
