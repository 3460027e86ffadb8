"""The project's reference engine (`reference_impl/`) behind the engine contract.

`ReferenceAdapter(formulation, name, params)` runs one formulation of reference_impl: "si"
(sequential impulses, the default, registered as "reference") or any other module of
reference_impl with a `solve` (named "reference-<formulation>" unless `name` says
otherwise), with `params` as its `Config.params`. The scene maps one to one: the
engine has pair materials (e, mu_s, mu_k) and the shapes it declares (sphere, box, plane,
capsule, cylinder, hull, static triangle mesh; circle and rect in 2D; a scene with another
is `unsupported`), so nothing is combined or approximated: spheres, boxes and planes meet by
closed-form routines, the other shapes by GJK on their support functions
(reference_impl/gjk.py). It has no damping, sleeping or restitution threshold to
switch off; the knobs record every setting of `reference_impl.config.Config` in force.

2D scenes (x-z plane) run as planar bodies: positions stay at y = 0, rotation about y only.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from adapters.base import Adapter, Capabilities, Settings, Simulation, Unsupported
from adapters.frames import state_row
from adapters.planting import Passthrough
from cases.scene import Body, Box, Capsule, Circle, Cylinder, Hull, Mesh, Plane, Rect, Scene, Sphere, pair_key
from cases.trajectory import ContactPoint
from reference_impl import geometry, gjk
from reference_impl.config import Config
from reference_impl.contact import contact_arrays, new_contacts
from reference_impl.rigid_body import RigidBody
from reference_impl.world import (Material, Saved, World, compile_half, formulation as find_formulation,
                                  uncompiled_halves)

DEFAULT = Config()  # the engine's stated defaults (iterations: DEFAULT.iterations)

# How each formulation resolves impacts at several contacts of one step (adapters.base
# IMPACT_MODELS), measured on two touching balls driven into the ground and a ball struck
# into a row of two touching ones (cases/column_impact.py): "si", "pgs", "lemke" and
# "acceleration_lcp" solve one problem over all contacts, each contact's restitution on
# its own approach velocity (both balls leave the ground at e v; the struck row leaves as
# one body), exactly; "single_contact" sweeps pairs with each contact's target fixed at the
# step's start and never takes an impulse back, which passes an impact on pair by pair: the
# sequential model's closed form, exactly, for touching balls landing (e = 1 and 0.5,
# tests/test_declared_models.py) and for a row struck at e = 1; a pressed contact's target
# is 0, so a row struck at e = 0.5 misses it (a known deviation); "spook" solves one
# regularised problem over all contacts per step (inelastic only); "compliant" contacts are
# springs.
IMPACT_MODEL = {"compliant": "compliant", "single_contact": "sequential"}  # every other formulation: "simultaneous"


# No formulation declares a run on demand (Adapter.on_demand): with their loops compiled
# (reference_impl/compiled.py) the slowest default variant, pairwise Newton-Coulomb on a
# 10-box stack, takes seconds, not minutes. A run measured over the per-job limit (Lemke's
# pivoting on the 3D pinch grasps, a degenerate LCP of the pads' coplanar face corners: up to
# 300 ms a step) waits for --on-demand as any engine's does (physval.core.plan, from the
# shipped cost table). Scenes large by design (the robustness families' many-body variants)
# are in the families' full grids (physval run --full), for every engine.


class ReferenceAdapter(Adapter):
    package = "physval"
    supported = None  # part of physval itself: no engine release to check
    capabilities = Capabilities(
        dimensions=frozenset({2, 3}),
        shapes=frozenset({"sphere", "box", "plane", "circle", "rect", "capsule", "cylinder", "hull", "mesh"}),
        native_restitution=True,
        static_kinetic=True,
        contact_forces=True,
        iterations=True,
        contact_points=True,
        impact_model="simultaneous",
        # the default formulation's torque rows (reference_impl/sequential_impulses.py); the
        # others have none and report such pairs unsupported
        contact_torques=frozenset({"rolling_resistance", "torsional_friction"}),
        # a whole state: the bodies' rows and the warm start (World.save, ReferenceSimulation.save_state);
        # a batch of worlds: n worlds of the scene stepped in turn (ReferenceBatch), which
        # share nothing but the process and its compiled loops
        modes=frozenset({"save_restore", "worlds"}),
        why_not=(("threads", "the reference steps on one thread: it has no pool"),
                 ("polygon", "the reference's 2D narrow phase is closed-form for circles and rects only; its GJK "
                             "(reference_impl/gjk.py) takes 3D shapes"),
                 ("joint", "this formulation solves contact rows only: joints are rows of the sequential impulses "
                           "('si'), 'pgs', 'lemke' and 'spook' (reference_impl/joints.py)"),
                 ("limit_restitution", "SPOOK (note 004) is inelastic: a limit row, as a contact, is a critically "
                                       "damped spring-constraint, which cannot bounce")),
        # constant forces and torques, integrated with gravity before every formulation's solve
        # (reference_impl/world.py, World.load)
        loads=True,
    )

    def __init__(self, formulation: str = "si", name: str | None = None, params: dict | None = None):
        find_formulation(formulation)  # an unknown name fails here, not mid-run
        self.formulation = formulation
        # planted faults reach into the default formulation's solver only (ReferenceSimulation.plant)
        self.plantable = PLANTABLE if formulation == "si" else frozenset()
        self.params = dict(params or {})  # formulation settings (Config.params)
        self.name = name or ("reference" if formulation == "si" else f"reference-{formulation}")
        # every formulation runs every family it can represent in a default run (their
        # inner loops are compiled: all seven over all families cost ~260 CPU s); `slow`
        # keeps the formulations other than the default out of the readings that repeat a
        # scene many times (sweeps, stress, bench) unless named
        self.slow = formulation != "si"
        self.capabilities = replace(self.capabilities, impact_model=IMPACT_MODEL.get(formulation, "simultaneous"))
        if formulation != "si":  # only the sequential impulses have torque rows
            self.capabilities = replace(self.capabilities, contact_torques=frozenset())
        module = find_formulation(formulation)
        joints = getattr(module, "JOINT_KINDS", frozenset())
        if joints:  # rows beside the contacts' (reference_impl/joints.py)
            self.capabilities = replace(self.capabilities, joints=joints, coordinates="maximal",
                                        joint_limits=getattr(module, "JOINT_LIMITS", False),
                                        joint_friction=getattr(module, "JOINT_FRICTION", False),
                                        limit_restitution=getattr(module, "LIMIT_RESTITUTION", False))
        if formulation == "compliant":  # the one force law it is configured with
            law = self.params.get("compliant_law", "hertz")
            self.capabilities = replace(self.capabilities, contact_laws=frozenset({law}))

    def version(self) -> str:
        from reference_impl import __version__
        return f"reference_impl {__version__} ({self.formulation})"

    def world_of(self, scene: Scene, settings: Settings) -> World:
        """The reference's World of `scene` as `build` makes it, without the engine contract
        around it: for readings that look inside a step (World.begin_step, contact_problem,
        end_step; the Pinocchio oracle reads its contact problems)."""
        reason = self.capabilities.cannot_run(scene)
        if reason:
            raise Unsupported(reason)
        return reference_world(scene, self._config(scene, settings))

    def _config(self, scene: Scene, settings: Settings) -> Config:
        return Config(formulation=self.formulation, params={**self.params, **_compliance_params(scene)},
                      iterations=settings.iterations or DEFAULT.iterations)

    def uncompiled(self) -> list:
        """The halves of the step (reference_impl/world.py) numba's cache lacks for this
        formulation: ("begin",), the same for every formulation, and ("end", formulation,
        params) and ("end_joints", ...), this one's."""
        return [self.part(half) for half in uncompiled_halves(Config(formulation=self.formulation, params=self.params))]

    def part(self, half: str) -> tuple:
        """The part (uncompiled) that compiles `half` of this formulation's step (part_config)."""
        return (half,) if half == "begin" else (half, self.formulation, tuple(sorted(self.params.items())))

    def compile_part(self, part) -> None:
        compile_half(part_config(part), part[0])

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene)
        if reason:
            raise Unsupported(reason)
        config = self._config(scene, settings)
        if settings.world is not None:
            return ReferenceBatch([ReferenceSimulation(scene, settings.dt, config) for _ in range(settings.world[1])],
                                  settings.world[0])
        return ReferenceSimulation(scene, settings.dt, config)


def _shape(body: Body):
    s = body.shape
    if isinstance(s, Sphere):
        return geometry.Sphere(s.radius)
    if isinstance(s, Box):
        return geometry.Box(tuple(float(h) for h in s.half_extents))
    if isinstance(s, Plane):
        return geometry.Plane(tuple(float(c) for c in s.normal), float(s.offset))
    if isinstance(s, Circle):
        return geometry.Circle(s.radius)
    if isinstance(s, Rect):
        return geometry.Rect(tuple(float(h) for h in s.half_extents))
    if isinstance(s, Capsule):
        return geometry.Capsule(float(s.radius), float(s.half_length))
    if isinstance(s, Cylinder):
        return geometry.Cylinder(float(s.radius), float(s.half_length))
    if isinstance(s, Hull):
        return geometry.Hull(tuple(tuple(float(c) for c in v) for v in s.vertices))
    if isinstance(s, Mesh):
        return geometry.Mesh(tuple(tuple(float(c) for c in v) for v in s.vertices),
                             tuple(tuple(int(i) for i in t) for t in s.triangles))
    raise Unsupported(f"shape {s.kind}: not available in the reference engine")


def _compliance_params(scene: Scene) -> dict:
    """The compliant formulation's material from the scene's cases.scene.Compliance (it
    takes one material for the whole world: every pair that may touch must ask for the same)."""
    found = {scene.material_of(a.name, b.name).compliance for a, b in scene.contact_pairs()}
    if found <= {None}:  # rigid (or nothing can touch)
        return {}
    if len(found) > 1:
        raise Unsupported("pairs ask for different contact laws or materials (or some for rigid contact): "
                          "the compliant formulation takes one material for the whole world")
    c = found.pop()
    if c.law == "hertz":
        return {"compliant_law": "hertz", "compliant_E": c.E, "compliant_nu": c.nu}
    return {"compliant_law": "hooke", "compliant_k": c.k}


def _material(m) -> Material:
    return Material(e=float(m.e), mu_s=float(m.mu_s), mu_k=float(m.mu_k_),
                    rolling=float(m.rolling_resistance), torsion=float(m.torsional_friction))


def reference_world(scene: Scene, config: Config) -> World:
    """The reference's World of `scene` under `config` (reference_impl/world.py): its
    bodies, pair materials, joints and loads; Unsupported where the formulation cannot
    represent the scene."""
    planar = scene.dimension == 2
    world = World(gravity=scene.gravity, material=_material(scene.material), config=config)
    for b in scene.bodies:
        if b.static:
            world.add(RigidBody(b.name, _shape(b), x=b.position, q=b.orientation, static=True,
                                planar=planar))
        else:
            world.add(RigidBody(b.name, _shape(b), b.mass, b.principal_inertia, x=b.position,
                                q=b.orientation, v=b.velocity, w=b.angular_velocity if b.rotates else (0, 0, 0),
                                can_rotate=b.rotates, planar=planar))
    by_name = {body.name: body for body in world.bodies}
    for a, b, m in scene.pairs:
        world.set_material(by_name[a], by_name[b], _material(m))
    for j in scene.joints:
        world.join(j.kind, by_name[j.body], None if j.parent is None else by_name[j.parent], j.anchor,
                   j.unit_axis, j.limits, j.limit_e, j.friction)
    for load in scene.loads:
        world.load(by_name[load.body], load.force, load.torque)
    reason = world.unsupported()
    if reason:
        raise Unsupported(f"formulation {config.formulation!r}: {reason}")
    return world


def part_config(part: tuple) -> Config:
    """The Config a part of ReferenceAdapter.uncompiled compiles under."""
    return Config(formulation=part[1], params=dict(part[2])) if len(part) > 1 else Config()


class ReferenceSimulation(Simulation):
    def __init__(self, scene: Scene, dt: float, config: Config):
        self._dt = dt
        self.iterations = config.iterations
        planar = scene.dimension == 2
        world = reference_world(scene, config)
        self._world = world
        self._dynamic = [body for body in world.bodies if not body.static]
        self._cold_restore = False  # a planted fault (plant: "cold restore")
        self._stages: set[tuple[str, ...]] = set()
        self._knobs = {
            "formulation": config.formulation,
            "iterations": config.iterations,
            "tolerance": config.tolerance,
            "beta": config.beta,
            "slop": config.slop,
            "position_iterations": config.position_iterations,
            "warm_start": config.warm_start,
            "stick_speed": config.stick_speed,
            "margin": config.margin,
            "params": dict(config.params),
            "integrator": "symplectic Euler: velocity, then position",
            "gravity": list(world.gravity),
            "material": asdict(world.material),
            "pair_materials": [{"pair": [a, b], **asdict(_material(m))} for a, b, m in scene.pairs],
            "planar": planar,
            # how a scene Plane is built: the exact half-space (every vertex of a box within
            # the margin is a contact point, so a face lands on all its corners at once)
            "ground": "plane",
            # how shapes meet (reference_impl/geometry.py dispatches, gjk.py for the convex rest)
            "narrow_phase": "closed form for sphere, box, plane (circle, rect); GJK and EPA on support functions, "
                            "points by clipping on the features, for capsule, cylinder, hull; a mesh through its "
                            f"bounding-volume tree, each triangle by GJK (cylinder rim: {gjk.RIM} samples per cap)",
            "bodies": {body.name: {"static": body.static, "can_rotate": body.can_rotate}
                       for body in world.bodies},
        }
        # what the formulation in force does (its friction set, restitution, depenetration):
        # described by that formulation alone, so the record names the solver that runs
        self._knobs.update(world.solver.knobs(config))
        self.effects = self._built_effects(scene)


    def _built_effects(self, scene: Scene) -> frozenset[str]:
        """What the built world simulates: the world runs a stage only when needed."""
        world = self._world
        fx = set()
        if any(g != 0.0 for g in world.gravity):
            fx.add("gravity")
        joined = {frozenset((j.body, j.parent)) for j in world.joints}  # never collide
        pairs = [(a, b) for i, a in enumerate(world.bodies) for b in world.bodies[i + 1:]
                 if not (a.static and b.static) and frozenset((a.index, b.index)) not in joined]
        if pairs:
            fx.add("contact")
            mats = [world.material_of(a, b) for a, b in pairs]
            if any(m.e > 0 for m in mats):
                fx.add("restitution")
            if any(m.mu_s > 0 for m in mats):
                fx.add("friction")
            if any(m.rolling > 0 for m in mats):
                fx.add("rolling_resistance")
            if any(m.torsion > 0 for m in mats):
                fx.add("torsional_friction")
        if any(b.can_rotate for b in self._dynamic):
            fx.add("rotation")
        if world.joints:
            fx.add("joint")
            if any(np.isfinite(j.limits).any() for j in world.joints):
                fx.add("limit")
                if any(j.limit_e > 0.0 for j in world.joints):
                    fx.add("limit_restitution")
            if any(j.friction > 0.0 for j in world.joints):
                fx.add("joint_friction")
        if any(any(c != 0.0 for c in (*f, *t)) for f, t in world.loads.values()):
            fx.add("load")
        return frozenset(fx)

    @property
    def knobs(self) -> dict:
        stages = sorted({s for run in self._stages for s in run})
        return {**self._knobs, "stages_ran": stages}

    def step(self) -> None:
        self._world.step(self._dt)
        self._stages.add(self._world.stages)

    def states(self):
        return {b.name: state_row(b.x, b.q, b.v, b.w) for b in self._dynamic}

    def body_order(self) -> list[str]:
        return [b.name for b in self._dynamic]

    def write_state(self, out: np.ndarray) -> None:
        i = 0
        for b in self._dynamic:
            out[i:i + 3], out[i + 3:i + 7], out[i + 7:i + 10], out[i + 10:i + 13] = b.x, b.q, b.v, b.w
            i += 13

    def contact_forces(self):
        return {pair_key(a, b): P / self._dt for (a, b), P in self._world.normal_impulses.items()}

    def contact_points(self):
        """The world's contacts of the last step. A reference Contact pushes its body b
        along n (contact.Row.apply: P d on b, -P d on a), so b is the contract's a."""
        points = []
        for c in self._world.contacts:
            f_t = np.zeros(3)
            for row, P in zip(c.tangents, c.Pt):
                f_t += P * np.asarray(row.d)
            points.append(ContactPoint(c.b.name, c.a.name, np.array(c.point, dtype=float),
                                       np.array(c.n, dtype=float), c.Pn / self._dt, f_t / self._dt,
                                       -float(c.depth)))
        return points

    def close(self) -> None:
        """Nothing to free: the world is plain Python objects."""

    # --- the "save_restore" mode (Capabilities.modes) ----------------------------------------

    def save_state(self) -> Saved:
        """The world's state between steps (World.save): every body's row and the warm start
        (the last step's contacts with their impulses): all a step reads that the scene does
        not give."""
        return self._world.save()

    def restore_state(self, state: Saved) -> None:
        if self._cold_restore:  # the planted "cold restore": the warm start lost
            state = state._replace(features={}, contacts=contact_arrays(new_contacts(0)),
                                   pairs=np.zeros((0, 2), np.int64), impulses=np.zeros(0))
        self._world.restore(state)

    # --- planted faults (adapters/planting.py) ------------------------------------------

    def plant(self, change: str, size: float | None = None) -> Simulation:
        """The planted changes of the default formulation (ReferenceAdapter.plantable), in
        the world's own material table and solver: the other formulations make none."""
        world = self._world
        if change == "kinetic friction":
            def scaled(m):
                return _UncheckedMaterial(m.e, m.mu_s, m.mu_k * size, m.rolling, m.torsion)
            world.pair_materials = {k: scaled(m) for k, m in world.pair_materials.items()}
            world.configure(material=scaled(world.material))
        elif change == "square friction cone":  # a per-row clamp on the fixed tangent basis
            world.configure(friction_set="pyramid", tangents="fixed")
        elif change == "restitution threshold":  # slow approaches target v_n+ = 0
            world.configure(restitution_threshold=size)
        elif change == "two-phase restitution":  # v_n+ = 0, then normal impulses up to -e v_n-
            world.configure(restitution_law="two-phase")
        elif change == "velocity damping":
            return _Damped(self, size)
        elif change == "float32 positions":
            return _AfterStep(self, _float32_positions)
        elif change == "handed drift":
            return _AfterStep(self, _turned_about_z(size))
        elif change == "cold sweeps":  # `size` sweeps from zero impulses
            world.configure(config=replace(world.config, iterations=int(size), warm_start=False))
        elif change == "cold restore":
            self._cold_restore = True
        elif change == "world seed":  # the scene alone is world 0 of a batch of one: exact
            pass
        else:
            return super().plant(change, size)
        return self


PLANTABLE = frozenset({"kinetic friction", "square friction cone", "restitution threshold", "two-phase restitution",
                       "velocity damping", "float32 positions", "handed drift", "cold sweeps", "cold restore",
                       "world seed"})


@dataclass(frozen=True)
class _UncheckedMaterial:
    """The world's material record without its mu_k <= mu_s check (the world only reads
    these numbers): a planted kinetic friction above the static one."""
    e: float
    mu_s: float
    mu_k: float
    rolling: float
    torsion: float

    @property
    def torques(self) -> bool:
        return self.rolling > 0.0 or self.torsion > 0.0


class _Damped(Passthrough):
    """The world with v *= (1 - c dt) and w *= (1 - c dt) on every body after each step."""

    def __init__(self, sim: ReferenceSimulation, c: float):
        super().__init__(sim)
        self._keep, self._dynamic = 1.0 - c * sim._dt, sim._dynamic

    def step(self) -> None:
        self.inner.step()
        keep = self._keep
        for b in self._dynamic:
            b.v[:] = [keep * c for c in b.v]
            b.w[:] = [keep * c for c in b.w]


class ReferenceBatch(Simulation):
    """A batch of n reference worlds of one scene, stepped in turn, reporting world `k`'s
    bodies (the "worlds" mode: Settings.world = (k, n)). The reference has no batch of its
    own: what the batch tests is that its worlds share nothing (no scratch of the compiled
    loops, no module state), as the worlds of a GPU batch must not."""

    def __init__(self, worlds: list[Simulation], k: int):
        self._worlds, self._k = worlds, k
        self._shown = worlds[k]
        self.iterations = self._shown.iterations
        self.effects = self._shown.effects

    @property
    def knobs(self) -> dict:
        return {**self._shown.knobs, "batch": {"world": self._k, "worlds": len(self._worlds)}}

    def step(self) -> None:
        for world in self._worlds:
            world.step()

    def states(self):
        return self._shown.states()

    def body_order(self) -> list[str]:
        return self._shown.body_order()

    def write_state(self, out: np.ndarray) -> None:
        self._shown.write_state(out)

    def contact_forces(self):
        return self._shown.contact_forces()

    def contact_points(self):
        return self._shown.contact_points()

    def plant(self, change: str, size: float | None = None) -> Simulation:
        """A planted change in every world; "world seed" moves world k's (k > 0) dynamic
        bodies by `size` m times normal draws seeded by k, before the first step."""
        if change == "world seed":
            for k, world in enumerate(self._worlds[1:], start=1):
                rng = np.random.default_rng(k)
                for b in world._dynamic:
                    b.x = [c + size * rng.standard_normal() for c in b.x]
            return self
        self._worlds = [world.plant(change, size) for world in self._worlds]
        self._shown = self._worlds[self._k]
        return self


class _AfterStep(Passthrough):
    """The world with `change(bodies)` applied to its dynamic bodies after each step."""

    def __init__(self, sim: ReferenceSimulation, change):
        super().__init__(sim)
        self._change, self._dynamic = change, sim._dynamic

    def step(self) -> None:
        self.inner.step()
        self._change(self._dynamic)


def _float32_positions(bodies) -> None:
    """Every position rounded to single precision (the planted "float32 positions")."""
    for b in bodies:
        b.x = [float(np.float32(c)) for c in b.x]


def _turned_about_z(angle: float):
    """Every velocity turned `angle` rad counter-clockwise about z (the planted "handed drift")."""
    c, s = math.cos(angle), math.sin(angle)

    def turn(bodies) -> None:
        for b in bodies:
            vx, vy = b.v[0], b.v[1]
            b.v[0], b.v[1] = c * vx - s * vy, s * vx + c * vy
    return turn
