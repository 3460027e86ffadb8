"""Warm starting when a load disappears: a heavy plank knocked off a stack of light boxes.

Why hard: a warm-started solver begins each step from last step's contact impulses
(note 001, "inter-timestep persistence"). Under a 100 kg plank, the contacts of a stack of
three 1 kg boxes carry about 100 times their own weight. When the plank leaves within one
step, those stored impulses are applied to boxes that no longer carry it: the top box gets
an upward kick of about M g dt / m (1 m/s here) that the iterations must take back. With
too few iterations, or a clamp on the accumulated impulse that lets it stay, the stack
jumps: energy injected.

The vocabulary has no "remove a body" event and no way to hand an engine stored impulses,
so the load is removed by physics: the plank (half-extents 0.3 x 0.1 x 0.1 m) overhangs the
stack, and two 100 kg balls thrown up from the ground under the overhang hit it at the
same moment (plastic impact, e = 0), lifting it off at once. Every engine builds its own
stored impulses during the 0.15 s before the hit, as it would before any real removal.

Kinematics: a ball thrown up at V0 from the ground meets the plank, D above its top, at
t_hit with D = V0 t - g t^2 / 2, at v_hit = V0 - g t_hit; two balls of mass m_b and the
plank (at rest) then move together at v_up = 2 m_b v_hit / (2 m_b + M) and come back down
to the stack 2 v_up / g later. The stack is judged from just before the hit until 80 % of
that return time.

Invariants: a rigid stack that is unloaded releases no energy: its boxes stay at rest
(they may come back up by the depth each interface was allowed to sink, 0.5 % of a box);
the whole scene only loses energy (the impact is plastic).
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Check
from cases.observables import energy_rise, mechanical_energy, window_samples
from cases.robustness import (PENETRATION_FRACTION, collapse_time, free_flight_energy_tolerance,
                              no_energy_gain, stands)
from cases.scene import Body, Box, Material, Rect, Scene, ball, cube, ground

HALF = 0.1          # light box half-extent, m
SIZE = 2 * HALF
M_LIGHT = 1.0       # kg per light box
N_LIGHT = 3
PLANK = (0.3, 0.1, 0.1)  # half-extents of the heavy plank, m
BALL_R = 0.05       # lifting balls, m
BALL_X = 0.2        # their x, under the overhang (clear of the stack, whose half-width is 0.1)
V0 = 4.0            # upward throw, m/s
G = 9.81

# Grid: the plank 1000 times a light box in 2D (rects and discs, so 2D engines take part);
# FULL_GRID adds 100 times, and 3D. The lifting balls weigh as much as the plank each.
GRID = ({"ratio": 1000, "dim": 2},)
FULL_GRID = tuple({"ratio": r, "dim": d} for r in (100, 1000) for d in (3, 2))


def light_names() -> list[str]:
    return [f"box{k}" for k in range(N_LIGHT)]


def stack_top() -> float:
    return N_LIGHT * SIZE


def hit_time(g: float = G) -> float:
    """When the balls' tops reach the plank's underside (the smaller root of D = V0 t - g t^2/2)."""
    D = stack_top() - 2 * BALL_R
    return (V0 - math.sqrt(V0 * V0 - 2 * g * D)) / g


def lift_speed(ratio: float, g: float = G) -> float:
    """Common upward speed of plank and balls after the plastic hit, m/s."""
    M = ratio * M_LIGHT
    v_hit = V0 - g * hit_time(g)
    return 2 * M * v_hit / (2 * M + M)


def window(p) -> tuple[float, float]:
    """Judged from 5 ms before the hit to 80 % of the plank's flight back to the stack."""
    t_hit = hit_time()
    return t_hit - 0.005, t_hit + 0.8 * 2 * lift_speed(p["ratio"]) / G


def scene(p) -> Scene:
    dim, M = p["dim"], p["ratio"] * M_LIGHT
    boxes = tuple(Body(name, cube(HALF, dim), mass=M_LIGHT, position=(0, 0, HALF + SIZE * k))
                  for k, name in enumerate(light_names()))
    plank_shape = Box(PLANK) if dim == 3 else Rect((PLANK[0], PLANK[2]))
    plank = Body("plank", plank_shape, mass=M, position=(0, 0, stack_top() + PLANK[2]))
    balls = tuple(Body(name, ball(BALL_R, dim), mass=M, position=(x, 0, BALL_R), velocity=(0, 0, V0))
                  for name, x in (("ball_left", -BALL_X), ("ball_right", BALL_X)))
    return Scene(bodies=(ground(),) + boxes + (plank,) + balls, gravity=(0, 0, -G),
                 material=Material(e=0.0, mu_s=0.5), dimension=dim)


def duration(p) -> float:
    return window(p)[1]


def observe(traj, p) -> dict:
    sc = scene(p)
    light = Scene(bodies=tuple(b for b in sc.bodies if b.name in light_names() or b.static),
                  gravity=sc.gravity, material=sc.material, dimension=sc.dimension)
    t0, _ = window(p)
    start = int(window_samples(traj, t0)[0])
    stack_energy = mechanical_energy(traj, light)[start:]
    return {
        "stack_energy_gain": float(max(np.max(stack_energy) - stack_energy[0], 0.0)),
        "standing_time": collapse_time(traj, light_names(), SIZE),
        "energy_rise": energy_rise(traj, sc),
    }


def expect(p, dt) -> list[Check]:
    # each box may rise back by the depth each interface below it was allowed to sink
    sink = PENETRATION_FRACTION * SIZE
    allowed = sum(M_LIGHT * G * (k + 1) * sink for k in range(N_LIGHT))
    total = N_LIGHT * M_LIGHT + 3 * p["ratio"] * M_LIGHT
    return [
        Check("stack_energy_gain", "J", 0.0, allowed, "abs",
              "an unloaded rigid stack releases nothing: its boxes may come back up by the depth each "
              f"interface was allowed to sink (0.5 % of a box, {allowed:.3g} J in all); more is energy the "
              "solver injected (stale warm-start impulses)"),
        stands(duration(p), SIZE, dt),
        no_energy_gain(free_flight_energy_tolerance(total, G, dt, duration(p)),
                       "the hit is plastic; the tolerance is the sampled energy a position-first Euler "
                       "integrator gains in free flight, M g^2 dt T / 2"),
    ]


FAMILY = CaseFamily(
    name="robustness_warm_start",
    summary="a heavy plank knocked off a light stack in one step: the stack must not jump (stored impulses inject no energy)",
    source="warm starting (note 001, inter-timestep persistence); rigid unloading releases no energy",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=lambda p: f"plank={p['ratio']}:1,{p['dim']}D",
    tags=frozenset({"robustness"}),
    full_grid=FULL_GRID,
)
