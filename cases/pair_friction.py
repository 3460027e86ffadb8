"""Two blocks slide to a stop on one ground, or one on the other, each pair of bodies with
its own friction (note 001, "dry friction"): the first family whose scene gives a pair of
bodies a material of its own (`Scene.pairs`), so an engine is judged on each pair's
coefficient.

Three bodies, three pairs: ground-a (mu_a), ground-b (mu_b), a-b (mu_ab). Blocks a and b
are cubes of mass m, half-size h. Two layouts, so that every pair slides in some variant:
- "side": a and b rest on the plane z = 0 and are launched apart along x at the same speed
  v0. Each is one contact with the ground, so the derivation of `slide_to_stop` holds for
  each on its own: kinetic friction mu m g opposes the slip (note 001: F_k = mu_k F_n,
  against the relative velocity), the block decelerates uniformly and stops at
      d_i = v0^2 / (2 mu_i g)   after   t_i = v0 / (mu_i g),   i = a, b.
  The blocks never touch: a-b takes no part.
- "stack": b rests on a, a on the ground, both launched along +x at v0. With mu_ab < mu_a
  b slides forward on a from the start: friction mu_ab m g brakes b and pushes a forward,
  the ground brakes a with mu_a (2 m) g (a carries b's weight). Each deceleration is
  constant: b's mu_ab g, a's (2 mu_a - mu_ab) g, larger, so a stops first, and stays (the
  ground can hold 2 mu_a m g, b drags with mu_ab m g), while b slides on to rest:
      d_a = v0^2 / (2 (2 mu_a - mu_ab) g),   d_b = v0^2 / (2 mu_ab g),
  and b ends d_b - d_a ahead of a, on its top face. Ground and b never touch.
In each layout the pair that does not touch is still a pair of the table an adapter
undoes its engine's rule for: its value is chosen so that the engines' rules can express
the table (the product, the harmonic mean (Drake), the arithmetic and geometric means
(Newton, Box2D), and either the min rule (DART) or the max rule (PhysX): no table with two
different touching values suits both, so each layout has a variant for each, its
friction ratio below 2 so the harmonic and arithmetic means can too; an engine that cannot
express a table reports that variant unsupported). A pair's value that only an inversion
of the whole table gets right thus moves a block in the other layout.

What a mistake shows: an adapter that ignores the pair overrides runs every pair at the
default mu_ab (side: one block slides mu_a / mu_ab as far; stack: the ground brakes a at
mu_ab, and a slides 2.3 times as far); one that inverts the product rule where its engine
combines by another rule (or the reverse) gets other values on the touching pairs; one
that puts each pair's value on both bodies of a product rule gets mu^2.

Discrete time: a block braked by a constant deceleration a from v0 stops, stepped with
Euler velocity first (semi-implicit), at v0^2 / (2a) - v0 dt / 2 + a dt^2 phi (1 - phi) / 2,
and position first at + v0 dt / 2 + the same (phi: where in its last step the stop falls;
tests/test_closed_forms_pairs.py steps both). The stop-distance band is v0 dt: each Euler
order uses half of it (and a dt^2 / 8 at most), the other half is room for a contact that
grips a step earlier or later (Pymunk's square, which starts exactly touching, stops
0.5 mm long at v0 = 1 m/s); a 5 % error in one pair's mu moves a stop by 3.4 bands or
more, in every pair's by 2.4 or more (tests/test_closed_forms_pairs.py).
"""
from __future__ import annotations

import numpy as np

from cases.family import CaseFamily, Catch, Check, plane_label
from cases.observables import settle_time
from cases.scene import Body, Material, Scene, cube, ground
from cases.slide_to_stop import G, HALF, stop_distance, stop_time

GAP = 0.1      # side layout: between the blocks at the start, m
V0 = {"side": 1.0, "stack": 0.7}  # launch speed, m/s: side slides of 0.10-0.17 m; stack 0.036 and 0.083 m
AFTER_STOP = 0.15  # s simulated past the later stop: 150 steps to see a block stay stopped
BLOCKS = ("a", "b")

# Grid: each layout with the pair that does not touch at the max of the touching values
# (max-rule engines) and at their min (min-rule engines), friction ratio 5:3; 3D and 2D
# (squares in the x-z plane) split so that the 2D engines see both layouts too.
GRID = (
    {"layout": "side", "mu_a": 0.5, "mu_b": 0.3, "mu_ab": 0.3, "dim": 3},
    {"layout": "side", "mu_a": 0.3, "mu_b": 0.5, "mu_ab": 0.5, "dim": 2},
    {"layout": "stack", "mu_a": 0.5, "mu_b": 0.5, "mu_ab": 0.3, "dim": 3},
    {"layout": "stack", "mu_a": 0.5, "mu_b": 0.3, "mu_ab": 0.3, "dim": 2},
)


def deceleration(p, block: str) -> float:
    """Block's constant deceleration while it slides (module docstring), m/s^2."""
    if p["layout"] == "side":
        return p[f"mu_{block}"] * G
    return (2.0 * p["mu_a"] - p["mu_ab"]) * G if block == "a" else p["mu_ab"] * G


def _mu_equivalent(p, block: str) -> float:
    """The mu that brakes a lone block as this block is braked: deceleration / g."""
    return deceleration(p, block) / G


def _direction(p, block: str) -> float:
    return -1.0 if p["layout"] == "side" and block == "b" else 1.0


# --- scene ----------------------------------------------------------------------------

def _position(p, block: str) -> tuple[float, float, float]:
    if p["layout"] == "stack":
        return (0.0, 0.0, HALF if block == "a" else 3.0 * HALF)
    return (_direction(p, block) * (HALF + GAP / 2), 0.0, HALF)


def scene(p) -> Scene:
    dim = p.get("dim", 3)
    v0 = V0[p["layout"]]
    blocks = tuple(Body(name, cube(HALF, dim), mass=1.0, position=_position(p, name),
                        velocity=(_direction(p, name) * v0, 0.0, 0.0))
                   for name in BLOCKS)
    return Scene(bodies=(ground(),) + blocks, gravity=(0.0, 0.0, -G),
                 material=Material(e=0.0, mu_s=p["mu_ab"]),  # the a-b pair
                 pairs=tuple(("ground", name, Material(e=0.0, mu_s=p[f"mu_{name}"])) for name in BLOCKS),
                 dimension=dim)


def duration(p) -> float:
    return max(stop_time(V0[p["layout"]], _mu_equivalent(p, b)) for b in BLOCKS) + AFTER_STOP


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    out = {}
    for name in BLOCKS:
        x = traj.pos(name)
        speed = np.linalg.norm(traj.vel(name)[:, :2], axis=1)  # along the ground
        out[f"stop_distance_{name}"] = float(np.linalg.norm(x[-1, :2] - x[0, :2]))
        # stopped once the speed stays below what friction removes in one step
        out[f"stop_time_{name}"] = settle_time(traj, speed, deceleration(p, name) * traj.dt)
    return out


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    v0 = V0[p["layout"]]
    checks = []
    for name in BLOCKS:
        mu = _mu_equivalent(p, name)
        checks += [
            Check(f"stop_distance_{name}", "m", stop_distance(v0, mu), v0 * dt, "abs",
                  f"v0 dt = {v0 * dt:.2g} m: the two Euler orders stop v0 dt / 2 either side of v0^2 / (2a) (plus "
                  "a dt^2 / 8 for where the last step ends), and as much again for a contact that grips a step "
                  "early or late"),
            Check(f"stop_time_{name}", "s", stop_time(v0, mu), 2 * dt, "abs",
                  "the stop falls within a step, and 'stopped' is read one step of friction (a dt) early"),
        ]
    return checks


def variant_id(p) -> str:
    return f"{p['layout']},mu_a={p['mu_a']},mu_b={p['mu_b']},mu_ab={p['mu_ab']}{plane_label(p)}"


FAMILY = CaseFamily(
    name="pair_friction",
    summary="two blocks on one ground or stacked, each pair its own mu, stop after v0^2/(2a) with a set by each "
            "pair's friction: per-pair friction, every pair sliding in some variant",
    source="note 001 (CG3 II.5), dry friction F_k = mu_k F_n, per pair of bodies",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("combine rule", "side,mu_a=0.5,mu_b=0.3,mu_ab=0.3"),
        Catch("combine rule", "stack,mu_a=0.5,mu_b=0.5,mu_ab=0.3"),
        Catch("pair materials", "side,mu_a=0.5,mu_b=0.3,mu_ab=0.3"),
        Catch("pair materials", "stack,mu_a=0.5,mu_b=0.5,mu_ab=0.3"),
        Catch("friction off", "side,mu_a=0.5,mu_b=0.3,mu_ab=0.3"),
        Catch("friction doubled", "stack,mu_a=0.5,mu_b=0.5,mu_ab=0.3"),
    ),
)
