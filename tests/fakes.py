"""Stand-in engines for testing the harness itself: they need no physics package."""
from __future__ import annotations

import numpy as np

from adapters.base import Adapter, Capabilities, Simulation, Unsupported
from adapters.frames import state_row

ALL_SHAPES = frozenset({"sphere", "box", "plane", "circle", "rect"})


class Ballistic(Simulation):
    """Every dynamic body flies free under gravity (symplectic Euler); contact is ignored."""

    def __init__(self, scene, settings, blow_up_at=None, crash_at=None):
        self.scene, self.dt = scene, settings.dt
        self.x = {b.name: np.array(b.position, float) for b in scene.dynamic_bodies}
        self.v = {b.name: np.array(b.velocity, float) for b in scene.dynamic_bodies}
        self.q = {b.name: b.orientation for b in scene.dynamic_bodies}
        self.g = np.array(scene.gravity, float)
        self.k, self.blow_up_at, self.crash_at = 0, blow_up_at, crash_at
        self.knobs = {"integrator": "symplectic Euler"}
        self.effects = frozenset(scene.effects & {"gravity"})
        self.iterations = None
        self.closed = 0

    def step(self):
        self.k += 1
        if self.crash_at is not None and self.k >= self.crash_at:
            raise RuntimeError("engine crashed")
        for n in self.v:
            self.v[n] = self.v[n] + self.g * self.dt
            self.x[n] = self.x[n] + self.v[n] * self.dt
            if self.blow_up_at is not None and self.k >= self.blow_up_at:
                self.v[n] = self.v[n] * np.nan

    def states(self):
        return {n: state_row(self.x[n], self.q[n], self.v[n], (0, 0, 0)) for n in self.x}

    def contact_forces(self):
        return {}

    def close(self):
        self.closed += 1


class FakeAdapter(Adapter):
    package = "none"

    def __init__(self, name="fake", blow_up_at=None, crash_at=None, crash_on_build=False, unsupported=None,
                 dimensions=frozenset({2, 3}), contact_forces=True):
        self.name = name
        self.capabilities = Capabilities(dimensions=dimensions, shapes=ALL_SHAPES, native_restitution=True,
                                         static_kinetic=True, contact_forces=contact_forces, iterations=False)
        self.blow_up_at, self.crash_at = blow_up_at, crash_at
        self.crash_on_build, self.unsupported = crash_on_build, unsupported
        self.built = []

    def version(self):
        return "0.0"

    def build(self, scene, settings):
        if self.unsupported:
            raise Unsupported(self.unsupported)
        if self.crash_on_build:
            raise MemoryError("out of memory inside the engine")
        sim = Ballistic(scene, settings, self.blow_up_at, self.crash_at)
        self.built.append(sim)
        return sim
