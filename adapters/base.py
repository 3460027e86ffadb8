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
import sys
from abc import ABC, abstractmethod
from pathlib import Path
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from cases.family import UNIT_ROUNDOFF
from cases.relations import NEEDS as MODES
from cases.scene import (CONTACT_TORQUES, EFFECTS, IMPACT_MODEL_NEED, IMPACT_MODELS,  # noqa: F401 (re-exported)
                         JOINT_KINDS, RESTITUTION_LAW_NEED, RESTITUTION_LAWS, SHAPE_KINDS, Scene)
from cases.trajectory import ContactPoint




# How an engine represents a jointed body (Capabilities.coordinates): "maximal" every body
# keeps its six coordinates and a joint is constraint rows between them (Box2D, Pymunk,
# Rapier's impulse joints, PyBullet's constraints), which the solver holds to its tolerance
# and stabilisation; "reduced" the joint's own coordinates are the state (a hinge is one
# angle: MuJoCo, Drake, DART, PyBullet's multibodies), so the joint holds exactly.
COORDINATES = ("maximal", "reduced")

MODE_WORDS = {"threads": "thread pool to size", "worlds": "batched worlds",
              "save_restore": "save and restore of its whole state"}


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
    # How the scene is run (Capabilities.modes: an engine that does not declare the mode is
    # never given it): `threads` the size of the engine's thread pool (None: the adapter's
    # default, one thread); `world` (k, n): the scene as world k (from 0) of a batch of n
    # copies stepped together, world k's states reported (None: the scene alone)
    threads: int | None = None
    world: tuple[int, int] | None = None

    def __post_init__(self):
        if not (isinstance(self.dt, (int, float)) and math.isfinite(self.dt) and self.dt > 0):
            raise SettingsError(f"dt = {self.dt!r}: must be a finite number > 0 (seconds)")
        if self.dt > 0.1:
            raise SettingsError(f"dt = {self.dt!r}: must be <= 0.1 s for contact to mean anything")
        if self.iterations is not None and (not isinstance(self.iterations, int) or self.iterations < 1):
            raise SettingsError(f"iterations = {self.iterations!r}: must be a whole number >= 1")
        if self.threads is not None and (not isinstance(self.threads, int) or self.threads < 1):
            raise SettingsError(f"threads = {self.threads!r}: must be a whole number >= 1")
        if self.world is not None and not (isinstance(self.world, tuple) and len(self.world) == 2
                                           and all(isinstance(i, int) for i in self.world)
                                           and 0 <= self.world[0] < self.world[1]):
            raise SettingsError(f"world = {self.world!r}: must be (k, n), whole numbers with 0 <= k < n")


@dataclass(frozen=True)
class Capabilities:
    dimensions: frozenset[int]        # 2, 3 or both (3D engines embed 2D scenes in the x-z plane)
    # The shape kinds the engine represents (cases.scene.SHAPE_KINDS: sphere, box, plane,
    # circle, rect, capsule, cylinder, hull, polygon, mesh); a scene with another kind is
    # `unsupported` (cannot_run names it).
    shapes: frozenset[str]
    native_restitution: bool          # a restitution coefficient exists (else e is mapped, e.g. onto a spring-damper)
    static_kinetic: bool              # separate mu_s and mu_k
    contact_forces: bool              # normal forces can be read out
    iterations: bool                  # the solver has an iteration count to set
    contact_points: bool = False      # Simulation.contact_points reports each point's forces
    # Simulation.contact_points reports each point's geometry (bodies, point, normal, gap) as the
    # engine's detection found it, but not its forces (f_n and f_t NaN): an engine whose
    # bindings give the manifolds and not a per-point friction impulse. `contact_points`
    # implies it (`reports_geometry`).
    contact_geometry: bool = False
    # contact forces can be read also in a scene with joints (False where they are worked out from the bodies'
    # momenta, which a joint's impulses change too)
    contact_forces_beside_joints: bool = True
    contact_laws: frozenset[str] = frozenset()  # compliant laws of cases.scene.Compliance it models
    # How the engine resolves impacts at several contacts within one step (IMPACT_MODELS);
    # None: not declared.
    impact_model: str | None = None
    # The contact torques of cases.scene.CONTACT_TORQUES the engine models with the scene's
    # lever arm (rolling_resistance, torsional_friction); a pair asking for another: unsupported
    contact_torques: frozenset[str] = frozenset()
    # The restitution law at a frictional contact (cases.scene.RESTITUTION_LAWS): Newton's
    # with friction throughout (the notes' Newton-Coulomb impulse), or two-phase (friction in
    # a plastic impact, then restitution without friction).
    restitution_law: str = "newton"
    # The width of the floats the engine stores and steps its state in (64 or 32): the
    # round-off part of a check's tolerance follows it (cases.family.Check.roundoff).
    float_bits: int = 64
    # Settings.iterations counts sub-steps, each a whole velocity and position update: the
    # round-off a check allows is counted per sub-step (Simulation.iterations of them a step).
    substeps: bool = False
    # The ways to run a scene the engine offers, among cases.relations.NEEDS, which the
    # invariance battery compares with a plain run: "threads" (Settings.threads sizes its
    # thread pool), "worlds" (Settings.world = (k, n) runs the scene as world k of a batch),
    # "save_restore" (Simulation.save_state and restore_state carry its whole state). A
    # relation needing a mode the engine lacks is `unsupported`, with its why_not reason.
    modes: frozenset[str] = frozenset()
    # (effect, reason) for effects of cases.scene.EFFECTS the engine has the values for but
    # does not simulate (a solver that drops the rows), (shape kind, reason) for kinds of
    # SHAPE_KINDS it does not represent, and (mode, reason) for modes (cases.relations.NEEDS)
    # it lacks: said when a scene asks for one, or a relation needs one
    why_not: tuple[tuple[str, str], ...] = ()
    # The joint kinds of cases.scene.JOINT_KINDS the engine builds natively; `joint_limits`
    # whether it bounds a revolute or prismatic joint's coordinate; `coordinates` how it
    # represents a jointed body (COORDINATES); `loads` whether it applies a scene's constant
    # external forces and torques (cases.scene.Load). A scene asking for more: unsupported,
    # with the why_not reason of "joint", "limit" or "load" where the adapter gives one.
    joints: frozenset[str] = frozenset()
    joint_limits: bool = False
    joint_friction: bool = False  # a joint's dry friction (cases.scene.Joint.friction)
    limit_restitution: bool = False  # a restitution at a joint's limit (cases.scene.Joint.limit_e)
    coordinates: str | None = None
    loads: bool = False

    def __post_init__(self):
        unknown = set(self.shapes) - set(SHAPE_KINDS)
        if unknown:
            raise ValueError(f"shapes = {sorted(unknown)}: must be among {', '.join(SHAPE_KINDS)}")
        if self.impact_model is not None and self.impact_model not in IMPACT_MODELS:
            raise ValueError(f"impact_model = {self.impact_model!r}: must be one of {', '.join(IMPACT_MODELS)} or None")
        unknown = set(self.contact_torques) - set(CONTACT_TORQUES)
        if unknown:
            raise ValueError(f"contact_torques = {sorted(unknown)}: must be among {', '.join(CONTACT_TORQUES)}")
        if self.restitution_law not in RESTITUTION_LAWS:
            raise ValueError(f"restitution_law = {self.restitution_law!r}: must be one of {', '.join(RESTITUTION_LAWS)}")
        unknown = set(self.modes) - set(MODES)
        if unknown:
            raise ValueError(f"modes = {sorted(unknown)}: must be among {', '.join(MODES)}")
        lacking = set(SHAPE_KINDS) - set(self.shapes)
        unknown = {name for name, _ in self.why_not} - set(EFFECTS) - set(MODES) - lacking
        if unknown:
            raise ValueError(f"why_not names {sorted(unknown)}: must be among {', '.join(EFFECTS + MODES)} "
                             f"or the shapes the engine lacks ({', '.join(sorted(lacking))})")
        if self.float_bits not in UNIT_ROUNDOFF:
            raise ValueError(f"float_bits = {self.float_bits!r}: must be one of {', '.join(map(str, UNIT_ROUNDOFF))}")
        unknown = set(self.joints) - set(JOINT_KINDS)
        if unknown:
            raise ValueError(f"joints = {sorted(unknown)}: must be among {', '.join(JOINT_KINDS)}")
        if self.joints and self.coordinates not in COORDINATES:
            raise ValueError(f"coordinates = {self.coordinates!r}: an engine with joints says which it uses, "
                             f"{' or '.join(COORDINATES)}")

    def judged(self, checks, iterations: int | None = None) -> list:
        """`checks` at this engine's float width (cases.family.Check.at_precision), with
        `iterations` (the count in force) sub-steps a step if the engine sub-steps."""
        substeps = iterations if self.substeps and iterations else 1
        return [c.at_precision(self.float_bits, substeps) for c in checks]

    def cannot_run(self, scene: Scene, needs: frozenset[str] = frozenset()) -> str | None:
        """Why this engine cannot represent `scene` (and a case's extra `needs`), or None."""
        if scene.dimension not in self.dimensions:
            dims = " or ".join(f"{d}D" for d in sorted(self.dimensions))
            return f"{scene.dimension}D scene: the engine runs {dims} scenes only"
        kinds = {b.shape.kind for b in scene.bodies} - self.shapes
        if kinds:
            why = dict(self.why_not)
            return "; ".join(f"shape {kind} not available in this engine" + (f": {why[kind]}" if kind in why else "")
                             for kind in sorted(kinds))
        if not self.static_kinetic:
            for a, b in scene.contact_pairs():
                m = scene.material_of(a.name, b.name)
                if m.mu_k_ != m.mu_s:
                    return (f"mu_s = {m.mu_s} != mu_k = {m.mu_k_} for {a.name}/{b.name}: "
                            "the engine has one friction coefficient")
        for effect in CONTACT_TORQUES:
            if effect in scene.effects and effect not in self.contact_torques:
                a, b = next((a, b) for a, b in scene.contact_pairs()
                            if scene.material_of(a.name, b.name).torque(effect) > 0)
                d = scene.material_of(a.name, b.name).torque(effect)
                why = dict(self.why_not).get(effect, f"the engine has no {effect.replace('_', ' ')}")
                return f"{effect.replace('_', ' ')} = {d:g} m for {a.name}/{b.name}: {why}"
        why = dict(self.why_not)
        kinds = sorted({j.kind for j in scene.joints} - self.joints, key=JOINT_KINDS.index)
        if kinds:
            built = f"the engine builds {', '.join(sorted(self.joints))} joints only" if self.joints \
                else "the adapter builds no joints"
            return f"{', '.join(kinds)} joint asked for: {why.get('joint', built)}"
        if "limit" in scene.effects and not self.joint_limits:
            return f"joint limits asked for: {why.get('limit', 'the adapter builds no joint limits')}"
        if "limit_restitution" in scene.effects and not self.limit_restitution:
            return (f"a restitution at a joint limit asked for: "
                    f"{why.get('limit_restitution', 'the adapter maps no restitution at a joint limit')}")
        if "joint_friction" in scene.effects and not self.joint_friction:
            return f"joint friction asked for: {why.get('joint_friction', 'the adapter builds no joint friction')}"
        if "load" in scene.effects and not self.loads:
            return f"a constant external force or torque asked for: {why.get('load', 'the adapter applies no loads')}"
        laws = scene.contact_laws - self.contact_laws
        if laws:
            return (f"compliant contact ({', '.join(sorted(laws))} law) asked for: the engine does not "
                    "model that contact law")
        if "contact_forces" in needs and not self.contact_forces:
            return "the case reads contact forces, which this engine does not report"
        if "contact_points" in needs and not self.contact_points:
            why = (": it reports their geometry but not their forces" if self.contact_geometry
                   else ", which this adapter does not report")
            return "the case reads the forces at the engine's contact points" + why
        if "contact_geometry" in needs and not self.reports_geometry:
            return ("the case reads the engine's contact points (where, the normal, the gap), which this adapter "
                    "does not report")
        if "contact_forces" in needs and scene.joints and not self.contact_forces_beside_joints:
            return ("the case reads contact forces in a scene with joints: the engine's contact forces are worked "
                    "out from the bodies' momenta, which the joints' impulses change too")
        for need in sorted(needs):
            if need.startswith(IMPACT_MODEL_NEED):
                model = need[len(IMPACT_MODEL_NEED):]
                if model not in IMPACT_MODELS:
                    raise ValueError(f"need {need!r}: the impact model must be one of {', '.join(IMPACT_MODELS)}")
                if self.impact_model != model:
                    declared = (f"the engine resolves impacts as {self.impact_model}" if self.impact_model
                                else "the engine declares no impact model")
                    return f"the case checks the {model} impact model's closed form; {declared}"
            if need.startswith(RESTITUTION_LAW_NEED):
                law = need[len(RESTITUTION_LAW_NEED):]
                if law not in RESTITUTION_LAWS:
                    raise ValueError(f"need {need!r}: the restitution law must be one of {', '.join(RESTITUTION_LAWS)}")
                if self.restitution_law != law:
                    return (f"the case checks the {law} restitution law's closed form; the engine applies "
                            f"{self.restitution_law} restitution")
        return None

    @property
    def reports_geometry(self) -> bool:
        """Simulation.contact_points gives at least each point's geometry."""
        return self.contact_points or self.contact_geometry

    def cannot_run_as(self, mode: str) -> str | None:
        """Why the engine cannot run a scene in `mode` (cases.relations.NEEDS), or None."""
        if not mode or mode in self.modes:
            return None
        return dict(self.why_not).get(mode, f"the engine offers no {MODE_WORDS[mode]} (Capabilities.modes)")

    def describe(self) -> str:
        dims = "+".join(f"{d}D" for d in sorted(self.dimensions))
        flags = [f for f in ("native_restitution", "static_kinetic", "contact_forces", "iterations",
                             "contact_points")
                 if getattr(self, f)]
        if self.contact_geometry and not self.contact_points:
            flags.append("contact_geometry")
        laws = f"; compliant contact: {','.join(sorted(self.contact_laws))}" if self.contact_laws else ""
        impacts = f"; impacts: {self.impact_model or 'none declared'}"
        torques = f"; contact torques: {','.join(sorted(self.contact_torques))}" if self.contact_torques else ""
        restitution = f"; restitution: {self.restitution_law}"
        floats = f"; float{self.float_bits}" + (", sub-steps" if self.substeps else "")
        modes = f"; runs: {','.join(sorted(self.modes))}" if self.modes else ""
        joints = (f"; joints: {','.join(k for k in JOINT_KINDS if k in self.joints)}"
                  f"{' with limits' if self.joint_limits else ''}"
                  f"{' (a restitution at them)' if self.limit_restitution else ''}"
                  f"{' and friction' if self.joint_friction else ''} "
                  f"({self.coordinates} coordinates)"
                  if self.joints else "; joints: none")
        loads = ", loads" if self.loads else ""
        return f"{dims}; " + ", ".join(flags) + laws + impacts + torques + restitution + floats + modes + joints + loads


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

    # Bulk reads: the harness records a run by writing each step's raw state into one row of
    # a preallocated array and decoding all rows at once after the run (or a block at a
    # time), so recording costs a copy per step, not a dict of arrays. The defaults go
    # through states(); an adapter whose engine keeps its state in arrays overrides them.

    def body_order(self) -> list[str]:
        """The dynamic bodies in the order decode_states() returns them."""
        return list(self.states())

    def state_size(self) -> int:
        """Length of one raw state row (write_state)."""
        return 13 * len(self.body_order())

    def write_state(self, out: np.ndarray) -> None:
        """Write the state after the last step into the 1D row `out` (state_size long)."""
        for i, row in enumerate(self.states().values()):
            out[13 * i:13 * i + 13] = row

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        """(samples, bodies, 13) state rows (cases.trajectory layout) from stacked raw rows."""
        return raw.reshape(len(raw), -1, 13)

    # An engine that can step many times in one call may implement run(): the harness then
    # uses it where nothing is read between steps (no contact forces, no per-step reading).
    # The result must be bit for bit that of step() and write_state() in turn.
    run = None  # run(steps: int, out: np.ndarray) -> None: out[k] is the raw state after step k + 1

    @abstractmethod
    def contact_forces(self) -> dict[tuple[str, str], float]:
        """Normal force (N) per touching pair (cases.scene.pair_key) over the last step."""

    def contact_points(self) -> list[ContactPoint]:
        """Every contact point the solver acted on in the last step, with its normal and
        friction force (cases.trajectory.ContactPoint). Engines with
        `Capabilities.contact_points` implement it; engines with `Capabilities.contact_geometry`
        only give the forces as NaN (not read)."""
        raise NotImplementedError(f"{type(self).__name__} does not report contact points")

    def plant(self, change: str, size: float | None = None) -> "Simulation":
        """The planted-fault hook (adapters/planting.py): make the engine-internal `change`
        (a name of planting.CHANGES that the adapter lists in `plantable`) of `size` in
        this built world, and return the simulation to step: this one, or one built anew.
        Only an adapter's own code reaches into its engine this way."""
        raise NotImplementedError(f"{type(self).__name__} makes no planted change ({change!r} asked)")

    def save_state(self):
        """The engine's whole state after the last step, as a picklable object: what
        restore_state needs to continue in a freshly built simulation of the same scene
        exactly as this one would (its contact and warm-start caches included). Engines
        with the "save_restore" mode (Capabilities.modes) implement it."""
        raise NotImplementedError(f"{type(self).__name__} cannot save its state")

    def restore_state(self, state) -> None:
        """Continue from `state` (save_state of a simulation of the same scene and settings)."""
        raise NotImplementedError(f"{type(self).__name__} cannot restore a state")

    def close(self) -> None:
        """Free the engine's resources; safe to call twice."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


@dataclass(frozen=True)
class Tunable:
    """An engine-specific contact parameter an adapter accepts in `Settings.options`
    (for fitting engines to measured data): its range, default and meaning; `sweep`: the
    values `physval sweep` takes it over, an axis of its own beside dt (an error-controlled
    integrator's accuracy target), empty for a parameter that is not an accuracy knob."""
    low: float
    high: float
    default: float
    meaning: str
    sweep: tuple[float, ...] = ()


class Adapter(ABC):
    name: str
    capabilities: Capabilities
    package: str  # the PyPI distribution that provides the engine (for messages)
    # The releases of `package` the adapter works with, a PEP 440 specifier (">=3.2.6,<5");
    # the lower bound is a release the conformance battery ran on. None: not declared.
    # adapters.registry.version_problem checks the installed release against it.
    supported: str | None = None
    # The PyPI distributions one release of the engine is made of, each pinned to that release
    # when `physval versions` installs it (release_requirements). Empty: `package` alone (it
    # pins whatever else it needs, as mujoco 4.0.0 pins mujoco-core and mujoco-studio 4.0.0).
    packages: tuple[str, ...] = ()
    tunables: Mapping[str, Tunable] = {}  # Settings.options this adapter understands
    # The engine-internal changes its simulations make for a planted fault (names of
    # adapters/planting.py CHANGES, made by Simulation.plant): what no scene, setting or
    # read-out can say, such as a square friction cone or a velocity damping.
    plantable: frozenset[str] = frozenset()
    # The engine whose recorded known-deviation bands judge this adapter, where that is not
    # its own name: an engine with a planted fault named anew (adapters/planting.py Planted,
    # a user's `--adapter` file), judged as the engine it plants in. None: its own name.
    bands_of: str | None = None

    @abstractmethod
    def version(self) -> str:
        """The engine's version string."""

    def release_requirements(self, release: str) -> list[str]:
        """The pip requirements that install release `release` of this engine."""
        return [f"{p}=={release}" for p in self.packages or (self.package,)]

    def deviations_file(self) -> Path | None:
        """This engine's known-deviation file (physval/core/deviations.py): by default
        `xfails/<name>.txt` beside the adapter's module, so a plug-in ships its own."""
        module = sys.modules.get(type(self).__module__)
        where = getattr(module, "__file__", None)
        return Path(where).parent / "xfails" / f"{self.name}.txt" if where else None

    # In a default run (no cases named), an engine runs every family unless it names the
    # tags it runs (e.g. Drake's approximations other than its default and MuJoCo Warp:
    # {"core", "conformance"}; they also run the variants whose compliant contact law they
    # model).
    default_tags: frozenset[str] | None = None
    # ... and with default_tags, also every variant whose compliant law it models (a
    # configuration that changes only the continuous collision does not: `continuous_collision`)
    default_laws: bool = True
    # An engine whose step costs many times a compiled engine's (the reference's other
    # formulations) is left out of the default sweep, stress battery, benchmarks and
    # engine-wide readings, which repeat each scene many times: it runs there when named.
    slow: bool = False

    def continuous_collision(self, on: bool) -> bool:
        """`on`, as a bool: a configuration with the engine's continuous collision on (swept
        tests, bullets, speculative contacts) runs, in a default run, only the families
        tagged "swept" (cases/robustness/tunnelling.py), where it changes what happens;
        named, every family."""
        if on:
            self.default_tags, self.default_laws = frozenset({"swept"}), False
        return bool(on)

    def on_demand(self, scene: Scene) -> str | None:
        """Why a scene takes this engine too long for a default run (minutes), or None:
        such runs happen only when asked (--on-demand), unless `deferred` keeps them."""
        return None

    def deferred(self, scene: Scene, tags: frozenset[str]) -> str | None:
        """Why the run of `scene` (of a family with `tags`) waits for --on-demand, or None:
        the engine declares it on demand, and the family is none of the engine's default
        families (`default_tags`), which every run takes."""
        if self.default_tags is not None and tags & self.default_tags:
            return None
        return self.on_demand(scene)

    def options_in_force(self, settings: Settings) -> dict[str, float]:
        """Every tunable's value for this build: its default unless `settings.options`
        sets it (SettingsError for an unknown name or a value outside its range)."""
        unknown = set(settings.options) - set(self.tunables)
        if unknown:
            raise SettingsError(f"options {sorted(unknown)}: {self.name} understands {sorted(self.tunables) or 'none'}")
        out = {name: t.default for name, t in self.tunables.items()}
        for name, value in settings.options.items():
            t = self.tunables[name]
            if not t.low <= value <= t.high:
                raise SettingsError(f"options[{name!r}] = {value!r}: must lie in [{t.low}, {t.high}]")
            out[name] = float(value)
        return out

    def uncompiled(self) -> list:
        """What this engine's first run in a process compiles that its cache does not hold
        yet (a just-in-time compiler's work on a fresh install), as parts that compile
        apart, each hashable and picklable (the same part of two configurations is equal):
        the harness has its workers compile them at once (`compile_part`) before this
        engine's jobs, where its first jobs would compile them one after the other while the
        other workers wait for the cache. Default: none."""
        return []

    def compile_part(self, part) -> None:
        """Compile one part that `uncompiled` named into the engine's cache."""

    @abstractmethod
    def build(self, scene: Scene, settings: Settings) -> Simulation:
        """Build the scene; raise Unsupported if it cannot be represented faithfully."""
