"""Planting a fault: the adapter-layer hook through which physval tests its own power.

A fault changes ONE thing in what an engine is given, how it steps or what it reports, by
the size of a bug that ships (physval/faults.py holds physval's catalogue; a user may write
more). It is planted by wrapping the engine's adapter: `Planted(adapter, fault)` is an
adapter under the engine's own name, capabilities and known-deviation file, so the harness
judges the planted engine exactly as it judges the engine, and every check the fault moves
out of its tolerance (or out of its recorded band) comes out `fail`. A fault goes in
through one of four doors, each a method of `Fault` that does nothing by default:

- `scene(scene, capabilities)`: the scene the engine is given instead of the case's (a
  material, gravity, an inertia, a shape, the order of the bodies);
- `settings(settings)`: the settings it is built with (the time step);
- `change(capabilities)`: an engine-internal change, a (name, size) of CHANGES, that no scene
  or setting can say. The engine's own simulation makes it (`Simulation.plant`), and only
  where its adapter lists the name in `Adapter.plantable`; elsewhere the fault cannot be
  planted (`why_not`, `NotPlantable`);
- `simulation(sim)`: a wrapper of the built simulation, a `Passthrough` subclass that
  overrides what the fault changes: what the engine reports (`decode_states`, through which
  every recorded state goes, `contact_forces`, `contact_points`) or how it steps (`step`;
  the harness then steps one step at a time).

Nothing here, nor in a fault, reaches into an engine: the first two doors change what any
adapter is given, the fourth what any simulation's public methods return, and the third is
the adapter's own code. The core knows a planted fault only as an object its Context
carries to every worker (physval.core.context.Resolver wraps each adapter in `Planted`).
"""
from __future__ import annotations

import numpy as np

from adapters.base import Adapter, Capabilities, Settings, Simulation
from adapters.registry import EngineError
from cases.scene import Scene

# The engine-internal changes a simulation may make for a planted fault (Simulation.plant),
# by name: what each does in any engine, `size` its one number. An adapter lists those its
# simulations make in `Adapter.plantable`.
CHANGES = {
    "kinetic friction": "the kinetic friction coefficient mu_k times `size` in the engine's own material table "
                        "(the scene's vocabulary forbids mu_k > mu_s; an engine's table does not)",
    "square friction cone": "friction bounded by mu f_n along each of two tangent directions of a fixed frame "
                            "on its own instead of by the disc: sqrt(2) mu f_n at 45 deg to the frame",
    "velocity damping": "every body's linear and angular velocity decaying at `size` per second",
    "restitution threshold": "restitution off (e = 0) on contacts approaching slower than `size` m/s",
    "two-phase restitution": "friction acting on a plastic impact, then restitution applied without friction",
    # changes that break an invariance of cases.relations (physval.faults.INVARIANCE_FAULTS)
    "float32 positions": "every body's position rounded to single precision after each step",
    "handed drift": "every body's velocity turned `size` rad counter-clockwise about the world's z after each step",
    "cold sweeps": "`size` solver sweeps a step, each step's started from zero impulses (no warm start)",
    "cold restore": "a restored state (Simulation.restore_state) without its warm start: zero impulses after it",
    "world seed": "world k > 0 of a batch (Settings.world) started with each position moved by `size` m times a "
                  "normal draw seeded by k",
    "thread order": "with a thread pool (Settings.threads > 1), the time step one rounding longer (dt (1 + 2^-52)), "
                    "as a sum whose order depends on the threads",
}


class NotPlantable(EngineError):
    """The fault cannot be planted in this engine (an engine-internal change its adapter
    does not make); the message says which."""


class Fault:
    """What a fault changes; every door defaults to "nothing". A fault is picklable (a
    planted run's worker processes receive it) and equal to another of its class with the
    same attributes."""
    name = "none"

    def scene(self, scene: Scene, capabilities: Capabilities) -> Scene:
        """The scene the engine is given instead of the case's."""
        return scene

    def settings(self, settings: Settings) -> Settings:
        """The settings the engine is built with instead of the harness's."""
        return settings

    def change(self, capabilities: Capabilities) -> tuple[str, float | None] | None:
        """The engine-internal change (name of CHANGES, size) the engine makes, or None."""
        return None

    def simulation(self, sim: Simulation) -> Simulation:
        """The simulation the harness steps: `sim`, or a Passthrough wrapper of it."""
        return sim

    @property
    def summary(self) -> str:
        """The first paragraph of the fault's docstring, on one line."""
        return " ".join((self.__doc__ or "").split("\n\n")[0].split())

    def __eq__(self, other) -> bool:
        return type(other) is type(self) and vars(other) == vars(self)

    def __hash__(self) -> int:
        return hash((type(self).__qualname__, self.name))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


def why_not(adapter: Adapter, fault: Fault) -> str | None:
    """Why `fault` cannot be planted in `adapter` (the engine-internal change it needs is
    not one the adapter makes), or None."""
    change = fault.change(adapter.capabilities)
    if change is None:
        return None
    name = change[0]
    if name not in CHANGES:
        raise ValueError(f"fault {fault.name!r} asks for the change {name!r}: must be one of {', '.join(CHANGES)}")
    if name in adapter.plantable:
        return None
    makes = ", ".join(sorted(adapter.plantable)) or "none"
    return f"it needs the engine-internal change {name!r}, which {adapter.name} does not make (it makes: {makes})"


class Planted(Adapter):
    """An engine's adapter with one planted fault. It carries the engine's name (or `name`),
    capabilities, supported releases and known-deviation file, so the harness judges it as
    that engine. NotPlantable where the fault needs a change the adapter does not make."""

    def __init__(self, inner: Adapter, fault: Fault, name: str | None = None):
        why = why_not(inner, fault)
        if why:
            raise NotPlantable(f"fault {fault.name!r} cannot be planted in {inner.name}: {why}")
        self.inner, self.fault = inner, fault
        self.name = name or inner.name
        # named anew (a user's --adapter file): judged by the bands recorded for the engine
        self.bands_of = None if self.name == inner.name else (inner.bands_of or inner.name)
        for attribute in ("capabilities", "package", "supported", "packages", "tunables", "default_tags", "default_laws", "slow"):
            setattr(self, attribute, getattr(inner, attribute))

    def version(self) -> str:
        return f"{self.inner.version()} (planted fault: {self.fault.name})"

    def release_requirements(self, release: str) -> list[str]:
        return self.inner.release_requirements(release)

    def deviations_file(self):
        return self.inner.deviations_file()

    def on_demand(self, scene: Scene) -> str | None:
        return self.inner.on_demand(scene)

    def options_in_force(self, settings: Settings) -> dict[str, float]:
        return self.inner.options_in_force(settings)

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        fault, capabilities = self.fault, self.inner.capabilities
        sim = self.inner.build(fault.scene(scene, capabilities), fault.settings(settings))
        try:
            change = fault.change(capabilities)
            if change is not None:
                sim = sim.plant(*change)
            return PlantedSimulation(fault.simulation(sim), fault.name)
        except BaseException:
            sim.close()
            raise


class Passthrough(Simulation):
    """A built simulation passed through unchanged: a fault subclasses it and overrides the
    one thing it changes. Bulk stepping (`run`) passes through unless the subclass changes
    `step` or `write_state`; `states()` goes through an overridden `decode_states`."""

    def __init__(self, inner: Simulation):
        self.inner = inner
        self.effects = inner.effects
        self.iterations = inner.iterations
        own = type(self)
        self.run = inner.run if own.step is Passthrough.step and own.write_state is Passthrough.write_state else None

    @property
    def knobs(self) -> dict:
        return self.inner.knobs

    def step(self) -> None:
        self.inner.step()

    def states(self) -> dict[str, np.ndarray]:
        if type(self).decode_states is Passthrough.decode_states:
            return self.inner.states()
        raw = np.empty((1, self.state_size()))
        self.write_state(raw[0])
        return dict(zip(self.body_order(), self.decode_states(raw)[0]))

    def body_order(self) -> list[str]:
        return self.inner.body_order()

    def state_size(self) -> int:
        return self.inner.state_size()

    def write_state(self, out: np.ndarray) -> None:
        self.inner.write_state(out)

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        return self.inner.decode_states(raw)

    def contact_forces(self):
        return self.inner.contact_forces()

    def contact_points(self):
        return self.inner.contact_points()

    def save_state(self):
        return self.inner.save_state()

    def restore_state(self, state) -> None:
        self.inner.restore_state(state)

    def close(self) -> None:
        self.inner.close()


class PlantedSimulation(Passthrough):
    """The simulation a Planted adapter builds: its knobs name the planted fault."""

    def __init__(self, inner: Simulation, fault: str):
        super().__init__(inner)
        self.fault = fault

    @property
    def knobs(self) -> dict:
        return {**self.inner.knobs, "planted_fault": self.fault}
