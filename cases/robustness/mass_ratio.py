"""Mass ratios of 100:1 and 1000:1: a heavy box on a light one, and a light box on a heavy one.

Why hard: the light box sits between two contacts whose impulses differ by the heavy
box's weight. Gauss-Seidel solves one contact at a time; each impulse that holds the heavy
box up kicks the light box by (M / m) times its own weight impulse, which the other contact
must then undo, so the error shrinks per sweep by a factor that tends to 1 as m / M -> 0
(note 004, "pairwise iterative solvers": convergence slows with the conditioning of
G M^-1 G^T, whose entries here differ by M / m). Soft contacts sink under the heavy load
by an amount set by the light box's mass. Light on heavy is the benign order (the control).

Statics (note 001, resting contact), boxes counted from the ground (k = 0 below):
    force below box 0 = (m0 + m1) g,   force below box 1 = m1 g;
nothing moves, overlaps or gains energy.
"""
from __future__ import annotations

from cases.family import CaseFamily, Catch, Check
from cases.observables import deepest_overlap, drift, energy_rise, window_mean
from cases.robustness import (at_rest_energy_tolerance, bounded_drift, bounded_penetration, collapse_time,
                              no_energy_gain, stands)
from cases.scene import Body, Material, Scene, cube, ground

HALF = 0.1    # half-extent of both boxes, m
SIZE = 2 * HALF
M_LIGHT = 1.0  # kg
G = 9.81
T = 1.0        # simulated time, s
SETTLED = 0.5  # forces, drift and overlap are read from here on, s

# Grid: the hard order (heavy on light) at 1000:1 in 3D, and in 2D so 2D engines take
# part. FULL_GRID adds 100:1 and the benign order (light on heavy).
GRID = ({"ratio": 1000, "order": "heavy_on_light", "dim": 3}, {"ratio": 1000, "order": "heavy_on_light", "dim": 2})
FULL_GRID = tuple({"ratio": r, "order": o, "dim": d} for r in (100, 1000)
                  for o in ("heavy_on_light", "light_on_heavy") for d in (3, 2))


def masses(p) -> tuple[float, float]:
    """(bottom, top) masses, kg."""
    heavy = M_LIGHT * p["ratio"]
    return (M_LIGHT, heavy) if p["order"] == "heavy_on_light" else (heavy, M_LIGHT)


def interface_forces(p, g: float = G) -> tuple[float, float]:
    """Normal force below the bottom box and below the top box, N (statics)."""
    m0, m1 = masses(p)
    return (m0 + m1) * g, m1 * g


def scene(p) -> Scene:
    dim = p["dim"]
    m0, m1 = masses(p)
    return Scene(bodies=(ground(),
                         Body("box0", cube(HALF, dim), mass=m0, position=(0, 0, HALF)),
                         Body("box1", cube(HALF, dim), mass=m1, position=(0, 0, 3 * HALF))),
                 gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.5), dimension=dim)


def observe(traj, p) -> dict:
    sc = scene(p)
    names = ("box0", "box1")
    return {
        "force_below_box0": window_mean(traj, traj.force("ground", "box0"), SETTLED),
        "force_below_box1": window_mean(traj, traj.force("box0", "box1"), SETTLED),
        "standing_time": collapse_time(traj, names, SIZE),
        "penetration": deepest_overlap(traj, sc, SETTLED),
        "drift": drift(traj, names, SETTLED),
        "energy_rise": energy_rise(traj, sc),
    }


def expect(p, dt) -> list[Check]:
    f0, f1 = interface_forces(p)
    why = "statics of a resting stack: a 0.1 % mean force error over 0.5 s would move the box 1 mm"
    return [
        Check("force_below_box0", "N", f0, 1e-3, "rel", why),
        Check("force_below_box1", "N", f1, 1e-3, "rel", why),
        stands(T, SIZE, dt),
        bounded_penetration(SIZE),
        bounded_drift(SIZE),
        no_energy_gain(at_rest_energy_tolerance(sum(masses(p)), G, SIZE),
                       "a resting pair may gain at most its weight lifted by 0.1 % of a box"),
    ]


FAMILY = CaseFamily(
    name="robustness_mass_ratio",
    summary="a heavy box on a light one and the reverse (100:1, 1000:1): interface forces carry the weight; no collapse, overlap, drift or energy gain",
    source="statics of resting contact (note 001); why hard: Gauss-Seidel conditioning with the mass ratio (note 004)",
    grid=GRID,
    scene=scene,
    duration=lambda p: T,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"{p['order']},{p['ratio']}:1,{p['dim']}D",
    needs=frozenset({"contact_forces"}),
    tags=frozenset({"robustness"}),
    full_grid=FULL_GRID,
    catches=(
        Catch("force read-out", "heavy_on_light,1000:1,2D"),
        Catch("contact offset", "heavy_on_light,1000:1,2D"),
    ),
)
