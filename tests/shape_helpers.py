"""Small scenes the adapters' shape-mapping tests share: a regular polygon on a face, a body
resting on a ground, a shape dropped beside its primitive twin."""
from __future__ import annotations

import math

import numpy as np
import pytest

from adapters.base import Settings
from cases.scene import Body, Material, Scene, ground, quat_about_y

G = 9.81
DT = 1e-3
# a quarter turn about y takes body z onto world x: a capsule or cylinder lies on its side
ON_ITS_SIDE = quat_about_y(math.pi / 2)


def regular_polygon(n: int, circumradius: float) -> tuple[tuple[float, float], ...]:
    """Corners (x, z) of a regular n-gon about its centroid with an edge at the bottom
    (its outward normal -z), so that it rests on that face at its apothem R cos(pi / n)."""
    phase = -math.pi / 2 - math.pi / n  # edge 0's midpoint straight down
    return tuple((circumradius * math.cos(phase + 2 * math.pi * k / n),
                  circumradius * math.sin(phase + 2 * math.pi * k / n)) for k in range(n))


def assert_same_points(built, given, atol: float) -> None:
    """The engine's points are the scene's, each within `atol`, in any order."""
    built, given = np.asarray(built, float), np.asarray(given, float)
    assert built.shape == given.shape, f"{len(built)} points built, but should be the scene's {len(given)}"
    nearest = np.linalg.norm(built[:, None] - given[None], axis=2)
    assert np.all(nearest.min(axis=1) <= atol) and len(set(nearest.argmin(axis=1))) == len(given), \
        f"built points {built.tolist()}, but should be the scene's {given.tolist()}"


def settle(adapter, body: Body, steps: int, dimension: int = 3, ground_body: Body | None = None,
           material: Material = Material(mu_s=0.5)) -> tuple[np.ndarray, float]:
    """`body` on a ground (the plane z = 0 unless `ground_body`) under gravity for `steps`
    steps: its last state row and the mean normal force of its ground pair over the last
    100 steps (momentum read-outs jitter step to step by float32 velocities)."""
    under = ground_body or ground()
    scene = Scene(bodies=(under, body), gravity=(0.0, 0.0, -G), material=material, dimension=dimension)
    with adapter.build(scene, Settings(dt=DT)) as sim:
        force = 0.0
        for k in range(steps):
            sim.step()
            if k >= steps - 100:
                force += sim.contact_forces().get(tuple(sorted((under.name, body.name))), 0.0) / 100
        return sim.states()[body.name], force


def assert_rests(adapter, shape, orientation, height: float, atol: float = 1e-6, rel: float = 1e-5) -> None:
    """A 2 kg body of `shape` placed on the plane at `height` in `orientation` stays there
    (within `atol`, m) without turning (1e-6), and the ground carries its weight (within
    `rel` of m g) over the last 100 of 300 steps. The tolerances are the engine's: each test
    says why."""
    body = Body("b", shape, mass=2.0, position=(0.0, 0.0, height), orientation=orientation)
    state, force = settle(adapter, body, 300)
    assert state[2] == pytest.approx(height, abs=atol), f"rests at z = {state[2]}, but should at {height}"
    assert np.allclose(state[3:7], orientation, atol=1e-6), f"turned to {state[3:7]}: it rolled or tipped"
    assert force == pytest.approx(2.0 * G, rel=rel), f"the ground carries {force} N, but should carry m g"


def landing(adapter, shape, dimension: int, steps: int = 600, settings: Settings = Settings(dt=DT)) -> np.ndarray:
    """The states (steps, 13) of a body of `shape` (1 kg) dropped tilted and sliding onto the
    ground (e = 0.3, mu = 0.5): it lands on a corner, bounces, tips onto a face and slides."""
    body = Body("b", shape, mass=1.0, position=(0.0, 0.0, 0.3), orientation=quat_about_y(0.3),
                velocity=(0.5, 0.0, 0.0))
    scene = Scene(bodies=(ground(), body), gravity=(0.0, 0.0, -G), material=Material(e=0.3, mu_s=0.5),
                  dimension=dimension)
    with adapter.build(scene, settings) as sim:
        out = np.empty((steps, 13))
        for k in range(steps):
            sim.step()
            out[k] = sim.states()["b"]
        return out
