"""The engine contract: every engine is one adapter file implementing `Adapter`.

An adapter declares what its engine can represent (`Capabilities`), builds an
engine-neutral `cases.scene.Scene` into a `Simulation` with explicit `Settings`, and the
simulation steps, reports body states and contact normal forces, and keeps a record
(`knobs`) of every engine parameter the adapter set, including every default it switched
off. Adapters translate; they never judge (no assertions on physics) and never import the
harness.
"""
from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from cases.scene import Scene
from cases.trajectory import ContactPoint


# "simultaneous": one impulse problem over all contacts of the step, restitution applied to
#   each contact's own approach velocity (two touching balls dropped on the ground leave it
#   together at e v);
# "sequential": contacts resolved one after another as two-body impacts, so an impulse
#   travels through a chain of touching bodies (Newton's cradle; the top ball of a dropped
#   pair is launched faster than e v);
# "compliant": contacts are springs (dampers) acting over several steps; the outcome
#   depends on the stiffnesses and lies between the two.
IMPACT_MODELS = ("simultaneous", "sequential", "compliant")
# A case that checks one model's closed form names it in its needs, e.g.
# "impact_model:sequential"; an engine that declares another model (or none) reports the
# variant unsupported (Capabilities.cannot_run).
IMPACT_MODEL_NEED = "impact_model:"


class Unsupported(Exception):
    """The engine cannot represent this scene; the message says why."""


class SettingsError(ValueError):
    """A setting outside its allowed range; the message names the field."""


@dataclass(frozen=True)
class Settings:
    dt: float                      # time step, s
    iterations: int | None = None  # solver iterations; None: the adapter's stated default
    # engine-specific contact parameters by name (Adapter.tunables), e.g. MuJoCo's
    # contact time scale; empty: the adapter's stated defaults
    options: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self):
        if not (isinstance(self.dt, (int, float)) and math.isfinite(self.dt) and self.dt > 0):
            raise SettingsError(f"dt = {self.dt!r}: must be a finite number > 0 (seconds)")
        if self.dt > 0.1:
            raise SettingsError(f"dt = {self.dt!r}: must be <= 0.1 s for contact to mean anything")
        if self.iterations is not None and (not isinstance(self.iterations, int) or self.iterations < 1):
            raise SettingsError(f"iterations = {self.iterations!r}: must be a whole number >= 1")


@dataclass(frozen=True)
class Capabilities:
    dimensions: frozenset[int]        # 2, 3 or both (3D engines embed 2D scenes in the x-z plane)
    shapes: frozenset[str]            # kinds from cases.scene: sphere, box, plane, circle, rect
    native_restitution: bool          # a restitution coefficient exists (else e is mapped, e.g. onto a spring-damper)
    static_kinetic: bool              # separate mu_s and mu_k
    contact_forces: bool              # normal forces can be read out
    iterations: bool                  # the solver has an iteration count to set
    contact_points: bool = False      # Simulation.contact_points reports each point's forces
    contact_laws: frozenset[str] = frozenset()  # compliant laws of cases.scene.Compliance it models
    # How the engine resolves impacts at several contacts within one step (IMPACT_MODELS);
    # None: not declared.
    impact_model: str | None = None

    def __post_init__(self):
        if self.impact_model is not None and self.impact_model not in IMPACT_MODELS:
            raise ValueError(f"impact_model = {self.impact_model!r}: must be one of {', '.join(IMPACT_MODELS)} or None")

    def cannot_run(self, scene: Scene, needs: frozenset[str] = frozenset()) -> str | None:
        """Why this engine cannot represent `scene` (and a case's extra `needs`), or None."""
        if scene.dimension not in self.dimensions:
            dims = " or ".join(f"{d}D" for d in sorted(self.dimensions))
            return f"{scene.dimension}D scene: the engine runs {dims} scenes only"
        kinds = {b.shape.kind for b in scene.bodies} - self.shapes
        if kinds:
            return f"shape {', '.join(sorted(kinds))} not available in this engine"
        if not self.static_kinetic:
            for a, b in scene.contact_pairs():
                m = scene.material_of(a.name, b.name)
                if m.mu_k_ != m.mu_s:
                    return (f"mu_s = {m.mu_s} != mu_k = {m.mu_k_} for {a.name}/{b.name}: "
                            "the engine has one friction coefficient")
        laws = scene.contact_laws - self.contact_laws
        if laws:
            return (f"compliant contact ({', '.join(sorted(laws))} law) asked for: the engine does not "
                    "model that contact law")
        if "contact_forces" in needs and not self.contact_forces:
            return "the case reads contact forces, which this engine does not report"
        for need in sorted(needs):
            if need.startswith(IMPACT_MODEL_NEED):
                model = need[len(IMPACT_MODEL_NEED):]
                if model not in IMPACT_MODELS:
                    raise ValueError(f"need {need!r}: the impact model must be one of {', '.join(IMPACT_MODELS)}")
                if self.impact_model != model:
                    declared = (f"the engine resolves impacts as {self.impact_model}" if self.impact_model
                                else "the engine declares no impact model")
                    return f"the case checks the {model} impact model's closed form; {declared}"
        return None

    def describe(self) -> str:
        dims = "+".join(f"{d}D" for d in sorted(self.dimensions))
        flags = [f for f in ("native_restitution", "static_kinetic", "contact_forces", "iterations",
                             "contact_points")
                 if getattr(self, f)]
        laws = f"; compliant contact: {','.join(sorted(self.contact_laws))}" if self.contact_laws else ""
        impacts = f"; impacts: {self.impact_model}" if self.impact_model else ""
        return f"{dims}; shapes {','.join(sorted(self.shapes))}; " + ", ".join(flags) + laws + impacts


class Simulation(ABC):
    """One built world. `knobs` records every engine parameter the adapter set, by the
    engine's own name, with JSON-able values; `effects` the effects it simulates."""

    knobs: dict
    effects: frozenset[str]
    iterations: int | None  # the iteration count in force (None: the engine has none)

    @abstractmethod
    def step(self) -> None:
        """Advance by one time step."""

    @abstractmethod
    def states(self) -> dict[str, np.ndarray]:
        """Every dynamic body's state: 13 numbers, see cases.trajectory."""

    @abstractmethod
    def contact_forces(self) -> dict[tuple[str, str], float]:
        """Normal force (N) per touching pair (cases.scene.pair_key) over the last step."""

    def contact_points(self) -> list[ContactPoint]:
        """Every contact point the solver acted on in the last step, with its normal and
        friction force (cases.trajectory.ContactPoint). Engines with
        `Capabilities.contact_points` implement it."""
        raise NotImplementedError(f"{type(self).__name__} does not report contact points")

    def close(self) -> None:
        """Free the engine's resources; safe to call twice."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


@dataclass(frozen=True)
class Tunable:
    """An engine-specific contact parameter an adapter accepts in `Settings.options`
    (for fitting engines to measured data): its range, default and meaning."""
    low: float
    high: float
    default: float
    meaning: str


class Adapter(ABC):
    name: str
    capabilities: Capabilities
    package: str  # the PyPI distribution that provides the engine (for messages)
    tunables: Mapping[str, Tunable] = {}  # Settings.options this adapter understands

    @abstractmethod
    def version(self) -> str:
        """The engine's version string."""

    @abstractmethod
    def build(self, scene: Scene, settings: Settings) -> Simulation:
        """Build the scene; raise Unsupported if it cannot be represented faithfully."""
