"""Two blocks slide to a stop on the same ground, each pair with its own friction
(note 001, "dry friction"): the first family whose scene gives a pair of bodies a material
of its own (`Scene.pairs`), so an engine is judged on each pair's coefficient.

Blocks a and b (mass m, cube of half-size h) rest on the plane z = 0 and are launched in
opposite directions along x with the same speed v0. The ground-a pair has friction mu_a,
the ground-b pair mu_b. Each block is one contact with the ground, so the derivation of
`slide_to_stop` holds for each on its own: kinetic friction mu m g opposes the slip
(note 001: F_k = mu_k F_n, against the relative velocity), the block decelerates
uniformly and stops at
    d_i = v0^2 / (2 mu_i g)   after   t_i = v0 / (mu_i g),   i = a, b,
so d_a / d_b = mu_b / mu_a, whatever the engine's units or time step. The blocks start
apart and move apart: they never touch. Their own pair (the scene's default material) is
given min(mu_a, mu_b): it takes no part in the motion, and with it every per-body friction
rule the engines use (PyBullet's and Pymunk's product, Box2D's geometric mean, DART's min,
Drake's harmonic mean; Rapier chooses min) can express the table of three pairs, with the
ground's own value non-neutral under the product and the harmonic mean, so the variants
test how an adapter undoes its engine's rule, not only that it reads the pair table. (The
max rule cannot: the ground would need max(mu_a, mu_b), and so would the blocks' pair.)

What a mistake shows: an adapter that ignores the pair overrides runs both blocks at the
default min(mu_a, mu_b) (the faster block slides mu_b / mu_a too far); one that puts each
pair's value on both bodies of a product rule gets mu^2 (d times 1 / mu too far).

Discrete time, tolerances: as `slide_to_stop` (velocity-first or position-first Euler
moves the stop by v0 dt / 2, the partial last step by mu g dt^2).
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Check, plane_label
from cases.observables import settle_time
from cases.scene import Body, Material, Scene, cube, ground
from cases.slide_to_stop import G, HALF, stop_distance, stop_time

GAP = 0.1      # between the blocks at the start, m
V0 = 1.0       # launch speed of each block, m/s (slides of 0.06-0.26 m)
AFTER_STOP = 0.15  # s simulated past the later stop: 150 steps to see a block stay stopped
BLOCKS = ("a", "b")

# Grid: friction ratios 4 and 2.5, the high one on the first block in 3D and on the second
# in 2D (a pair mix-up shows as a factor, not a percentage); the 2D variant (squares in the
# x-z plane) for the 2D engines. Two variants: the reference's box-on-plane formulations
# step a box in 1-7 ms of Python a step.
GRID = (
    {"mu_a": 0.8, "mu_b": 0.2, "dim": 3},
    {"mu_a": 0.2, "mu_b": 0.5, "dim": 2},
)


def _mu(p, block: str) -> float:
    return p[f"mu_{block}"]


def _direction(block: str) -> float:
    return 1.0 if block == "a" else -1.0


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p.get("dim", 3)
    blocks = tuple(Body(name, cube(HALF, dim), mass=1.0,
                        position=(_direction(name) * (HALF + GAP / 2), 0.0, HALF),
                        velocity=(_direction(name) * V0, 0.0, 0.0))
                   for name in BLOCKS)
    return Scene(bodies=(ground(),) + blocks, gravity=(0.0, 0.0, -G),
                 material=Material(e=0.0, mu_s=min(p["mu_a"], p["mu_b"])),  # a-b: never touch
                 pairs=tuple(("ground", name, Material(e=0.0, mu_s=_mu(p, name))) for name in BLOCKS),
                 dimension=dim)


def duration(p) -> float:
    return stop_time(V0, min(p["mu_a"], p["mu_b"])) + AFTER_STOP


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    out = {}
    for name in BLOCKS:
        x = traj.pos(name)
        speed = np.linalg.norm(traj.vel(name)[:, :2], axis=1)  # along the ground
        out[f"stop_distance_{name}"] = float(np.linalg.norm(x[-1, :2] - x[0, :2]))
        # stopped once the speed stays below what friction removes in one step
        out[f"stop_time_{name}"] = settle_time(traj, speed, _mu(p, name) * G * traj.dt)
    return out


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    checks = []
    for name in BLOCKS:
        mu = _mu(p, name)
        checks += [
            Check(f"stop_distance_{name}", "m", stop_distance(V0, mu), V0 * dt / 2 + mu * G * dt * dt, "abs",
                  f"v0 dt / 2 = {V0 * dt / 2:.2g} m: position updated with the new or the old velocity, "
                  "plus the partial last step"),
            Check(f"stop_time_{name}", "s", stop_time(V0, mu), 2 * dt, "abs",
                  "the stop falls within a step, and 'stopped' is read one step of friction (mu g dt) early"),
        ]
    return checks


def variant_id(p) -> str:
    return f"mu_a={p['mu_a']},mu_b={p['mu_b']}{plane_label(p)}"


FAMILY = CaseFamily(
    name="pair_friction",
    summary="two blocks on one ground, each pair its own mu, stop after v0^2/(2 mu_i g): per-pair friction",
    source="note 001 (CG3 II.5), dry friction F_k = mu_k F_n, per pair of bodies",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
)
