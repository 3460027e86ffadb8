"""Planted faults: the suite tests its own power (mutation testing of the engines, not of
the code).

A fault wraps an engine's adapter (`FaultyAdapter(inner, fault)`) and changes ONE thing in
what the engine is given or reports: a material coefficient, gravity, the time step, an
inertia, the friction cone, a damping, the force read-out. It never touches the harness,
the cases or their closed forms: the wrapped engine carries the engine's own name, the
engine's recorded known-deviation bands judge it, and every check the fault moves out of
its tolerance (or out of its band) must come out `fail`. `tests/test_faults.py` asserts
that every fault is flagged in at least two families and the unmodified wrapper (`NONE`)
in none; `physval bench faults` writes the detection matrix (fault x family).

Sizes are those of bugs that ship: a coefficient a few per cent off, 9.80 for 9.81, a time
step 1 % off, an inertia tensor doubled, a square cone, the 0.04 damping PyBullet switches
on by default, a force 5 % off. A fault planted in an engine's internals is written per
engine: for the reference (its default formulation), MuJoCo and PyBullet (`ENGINES`);
wrapping another engine raises `NotPlantable`, but for a fault that changes only the
scene the engine is given (kinds "any"), which any engine can be handed.

`WRONG_ANSWERS` are the plain wrong answers (an effect off or doubled, another restitution
law, another combination rule, a radius written in, a contact offset) that the families
name in their `catches` (cases.family.Catch): each family declares which of them, and of
FAULTS, it must catch and on which variant, and tests/test_catches.py plants each there
and shows a check fail.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from adapters.base import Adapter, Settings, Simulation
from cases.overlap import rotation_matrix
from cases.scene import Box, Rect, Scene

ENGINES = ("reference", "mujoco", "pybullet")  # the engines faults are written for


class NotPlantable(Exception):
    """The fault has no meaning in (or no way into) this engine; the message says why."""


def engine_kind(adapter: Adapter, fault: "Fault | None" = None) -> str:
    """Which engine an adapter drives ("reference", "mujoco", "pybullet"), by its class;
    NotPlantable for any other (faults in engine internals are written per engine), unless
    `fault` changes only what any engine is given (kinds "any": then "any")."""
    kind = {"ReferenceAdapter": "reference", "MuJoCoAdapter": "mujoco",
            "PyBulletAdapter": "pybullet"}.get(type(adapter).__name__)
    if kind == "reference" and getattr(adapter, "formulation", "si") != "si":
        kind = None if fault is None or "any" not in fault.kinds else "any"
        if kind is None:
            raise NotPlantable("faults are written for the reference's default formulation (si) only")
    if kind is None:
        if fault is not None and "any" in fault.kinds:
            return "any"
        raise NotPlantable(f"no faults are written for {type(adapter).__name__}")
    return kind


# --- the fault contract ---------------------------------------------------------------------

class Fault:
    """What a fault changes; every hook defaults to "nothing". `kind` is the engine."""
    name = "none"
    kinds = ENGINES  # the engines the fault has a meaning in (the others are left out of its row)

    def scene(self, scene: Scene, kind: str) -> Scene:
        """The scene the engine is given instead of the case's."""
        return scene

    def settings(self, settings: Settings) -> Settings:
        """The settings the engine is built with instead of the harness's."""
        return settings

    def plant(self, sim: Simulation, scene: Scene, kind: str) -> Simulation:
        """Edits to the built engine (returns the simulation to run: it or a new one)."""
        return sim

    def after_step(self, kind: str):
        """A function (sim, dt) run after each of the engine's steps, or None (then the
        engine may step in bulk)."""
        return None

    read_out = 1.0  # factor on every contact force the engine reports

    @property
    def summary(self) -> str:
        return " ".join((self.__doc__ or "").split("\n\n")[0].split())


class NoFault(Fault):
    """Nothing changed: the wrapper alone, which must give exactly the engine's verdicts."""
    name = "none"


def _scale_materials(scene: Scene, change) -> Scene:
    """The scene with every material (the default and each pair's) replaced by change(m)."""
    return replace(scene, material=change(scene.material),
                   pairs=tuple((a, b, change(m)) for a, b, m in scene.pairs))


class Restitution(Fault):
    """Restitution e x 1.1 (at most 1) in every material.

    A combination rule or unit slip that hands the solver a slightly livelier material:
    e = 0.5 becomes 0.55. e = 0 and e = 1 stay as they are (1.1 is not a restitution)."""
    name = "restitution"
    factor = 1.1

    def scene(self, scene, kind):
        return _scale_materials(scene, lambda m: replace(m, e=min(1.0, m.e * self.factor)))


class _Friction(Fault):
    """Shared by the static and kinetic friction faults. The reference has both
    coefficients and takes the fault in the one named, through its own material table
    (the case's scene vocabulary forbids mu_k > mu_s, a real engine's table does not);
    MuJoCo and PyBullet have one coefficient, so there the fault scales it."""
    factor = 1.0
    which = ""  # "mu_s" or "mu_k"

    def scene(self, scene, kind):
        if kind == "reference":
            return scene
        f = self.factor
        return _scale_materials(scene, lambda m: replace(m, mu_s=m.mu_s * f,
                                                         mu_k=None if m.mu_k is None else m.mu_k * f))

    def plant(self, sim, scene, kind):
        if kind == "reference":
            _reference_materials(sim, **{self.which: self.factor})
        return sim


class StaticFriction(_Friction):
    """Static friction mu_s x 1.06 (MuJoCo, PyBullet: their one coefficient x 1.06).

    An engine that holds 6 % more than mu_s N before letting go: the break-away angle of
    a box on an incline moves from atan(0.5) = 26.6 deg to 27.9 deg."""
    name = "static friction"
    factor, which = 1.06, "mu_s"


class KineticFriction(_Friction):
    """Kinetic friction mu_k x 1.05 (MuJoCo, PyBullet: their one coefficient x 1.05).

    A sliding contact braked by 1.05 mu_k N: a box launched at 2 m/s with mu_k = 0.3 stops
    3.2 cm short of its 68 cm."""
    name = "kinetic friction"
    factor, which = 1.05, "mu_k"


@dataclass(frozen=True)
class _UncheckedMaterial:
    """The reference world's material record without its mu_k <= mu_s check (the world
    only reads these numbers)."""
    e: float
    mu_s: float
    mu_k: float
    rolling: float
    torsion: float

    @property
    def torques(self) -> bool:
        return self.rolling > 0.0 or self.torsion > 0.0


def _reference_materials(sim, mu_s: float = 1.0, mu_k: float = 1.0) -> None:
    """Scale the coefficients in the reference world's own material table."""
    world = sim._world

    def scaled(m):
        return _UncheckedMaterial(m.e, m.mu_s * mu_s, m.mu_k * mu_k, m.rolling, m.torsion)
    world.material = scaled(world.material)
    world.pair_materials = {k: scaled(m) for k, m in world.pair_materials.items()}


class Gravity(Fault):
    """Gravity of 9.80 m/s^2 where the scene asks for 9.81 (the same direction).

    A hard-coded g = 9.8: 0.1 % in every weight and every fall."""
    name = "gravity"
    g_used, g_asked = 9.80, 9.81

    def scene(self, scene, kind):
        return replace(scene, gravity=tuple(g * self.g_used / self.g_asked for g in scene.gravity))


class TimeStep(Fault):
    """The engine steps dt x 1.01 while the harness believes it steps dt.

    A time step passed in other units or rounded on the way (1e-3 s taken as 1.01e-3 s,
    e.g. a rate of 990 Hz): every simulated second lasts 1.01 s of the engine's physics."""
    name = "time step"
    factor = 1.01

    def settings(self, settings):
        return replace(settings, dt=settings.dt * self.factor)


class Inertia(Fault):
    """Principal inertia x 2 for every box (3D) and rect (2D); spheres and discs unchanged.

    An inertia tensor computed from full extents where half extents were meant, or given
    about the wrong point: lever-arm impacts then spin a box half as fast. A uniform factor
    leaves torque-free rotation (Euler's equations) as it was."""
    name = "inertia"
    factor = 2.0

    def scene(self, scene, kind):
        def body(b):
            if b.static or not isinstance(b.shape, (Box, Rect)):
                return b
            return replace(b, inertia=tuple(self.factor * i for i in b.principal_inertia))
        return replace(scene, bodies=tuple(body(b) for b in scene.bodies))


class FrictionCone(Fault):
    """A square friction cone in a fixed tangent frame instead of the circle: each of the
    two tangent directions bounded by mu f_n on its own, so friction reaches sqrt(2) mu f_n
    at 45 deg to the frame's axes and does not oppose a slip at 22.5 deg.

    MuJoCo: cone = "pyramidal" (MuJoCo's own default, which the adapter replaces by the
    elliptic cone). PyBullet: enableConeFriction = 0 (Bullet's default pair of independent
    friction rows). The reference: its sequential impulses clamp each tangent row to
    [-mu Pn, mu Pn] instead of the disc, with both rows along the fixed tangent basis
    (reference_impl.contact.tangent_basis) also while sliding."""
    name = "friction cone"

    def plant(self, sim, scene, kind):
        if kind == "mujoco":
            import mujoco
            return _mujoco_rebuilt(sim, scene, lambda m: setattr(m.opt, "cone", mujoco.mjtCone.mjCONE_PYRAMIDAL))
        if kind == "pybullet":
            from adapters.pybullet_engine import p
            p.setPhysicsEngineParameter(enableConeFriction=0, physicsClientId=sim._client)
            return sim
        sim._world.solver = _PyramidSolver(sim._world.solver)
        return sim


class _SolverWrapper:
    """The reference's solver module as it is, but for the `solve` a subclass plants."""

    def __init__(self, module):
        self._module = module

    def __getattr__(self, name):
        return getattr(self._module, name)


class _PyramidSolver(_SolverWrapper):
    """The reference's sequential impulses (reference_impl/sequential_impulses.py) with a
    per-row friction clamp in the fixed tangent basis: the rest of the module as it is."""

    def solve(self, contacts, bodies, dt, config):
        from reference_impl import contact as rc
        for c in contacts:
            if len(c.tangents) != 2:
                continue
            P = sum(np.asarray(row.d) * Pt for row, Pt in zip(c.tangents, c.Pt))  # warm start, world frame
            ra = tuple(c.point[i] - c.a.x[i] for i in range(3))
            rb = tuple(c.point[i] - c.b.x[i] for i in range(3))
            t1 = rc.tangent_basis(c.n)
            c.tangents = (rc.Row(c.a, c.b, ra, rb, t1), rc.Row(c.a, c.b, ra, rb, rc.cross(c.n, t1)))
            c.Pt = [float(P @ np.asarray(row.d)) for row in c.tangents]
        from dataclasses import replace  # sequential_impulses' own switch to the per-row clamp
        return self._module.solve(contacts, bodies, dt,
                                  replace(config, params={**config.params, "friction_set": "pyramid"}))


def _mujoco_rebuilt(sim, scene, edit):
    """A MuJoCo simulation of the same compiled model after edit(model): a fresh MjData,
    so every quantity the simulation derives from the model (e.g. how it decodes contact
    forces for the cone in force) is that of the edited model."""
    from adapters.mujoco_engine import MuJoCoSimulation
    model = sim._model
    edit(model)
    return MuJoCoSimulation(scene, model, sim.knobs, sim.iterations)


class Damping(Fault):
    """A velocity decay of c = 0.04 per second on every body's linear and angular velocity.

    PyBullet: linearDamping = angularDamping = 0.04, its default, which the adapter
    switches off (Bullet scales velocities by (1 - c)^dt each step). MuJoCo: joint damping
    on every degree of freedom, c times the dof's own mass or inertia (dof_M0), so each
    decays at the same rate (a damping left in a model's default class). The reference:
    v *= (1 - c dt) and w *= (1 - c dt) after each step."""
    name = "damping"
    c = 0.04  # 1/s

    def plant(self, sim, scene, kind):
        if kind == "mujoco":
            return _mujoco_rebuilt(sim, scene, lambda m: m.dof_damping.__setitem__(slice(None), self.c * m.dof_M0))
        if kind == "pybullet":
            from adapters.pybullet_engine import p
            for _, uid, _ in sim._dynamic:
                p.changeDynamics(uid, -1, linearDamping=self.c, angularDamping=self.c, physicsClientId=sim._client)
        return sim

    def after_step(self, kind):
        return self._decay if kind == "reference" else None

    def _decay(self, sim, dt):
        keep = 1.0 - self.c * dt
        for b in sim._dynamic:
            b.v[:] = [keep * c for c in b.v]
            b.w[:] = [keep * c for c in b.w]


class ForceReadout(Fault):
    """Every contact force the engine reports (contact_forces, and contact_points' normal
    and friction forces) x 1.05; the motion is untouched.

    An impulse divided by a time step other than the one it was solved over, or summed
    over one point too many: the dynamics are right and the reported forces are not."""
    name = "force read-out"
    read_out = 1.05


class PairMaterials(Fault):
    """Pair overrides ignored: every pair gets the scene's default material.

    An adapter that sets each body's coefficients from the scene's material and never
    reads the pair table (or an engine's combine rule left in force where a pair asked for
    its own value): a block meant to slide on ice brakes like the rest of the scene."""
    name = "pair materials"

    def scene(self, scene, kind):
        return replace(scene, pairs=())


class InertiaAxes(Fault):
    """Principal moments handed to the engine in the wrong body axes: x and z swapped on
    every box (a box with equal sides, a sphere, a disc or a 2D rect is unchanged).

    An inertia tensor written in another axis order than the engine reads it (z-up
    against y-up, or a diagonal given in the order of the shape's extents reversed): a
    flat box then tumbles and lands like a tall one."""
    name = "inertia axes"

    def scene(self, scene, kind):
        def body(b):
            if b.static or not isinstance(b.shape, Box):
                return b
            i = b.principal_inertia
            return replace(b, inertia=(i[2], i[1], i[0]))
        return replace(scene, bodies=tuple(body(b) for b in scene.bodies))


class AngularVelocityFrame(Fault):
    """Start angular velocity read in the body frame where the scene gives it in the
    world frame (the two agree for a body that starts unrotated).

    The most common slip of an adapter: MuJoCo's free joint and Bullet's base velocity
    take different frames; a tilted box launched spinning about the vertical instead
    spins about its own tilted axis, and lands with the wrong spin at the contact."""
    name = "angular velocity frame"

    def scene(self, scene, kind):
        def body(b):
            if b.static or not any(b.angular_velocity):
                return b
            w = rotation_matrix(b.orientation) @ np.asarray(b.angular_velocity, float)
            return replace(b, angular_velocity=tuple(float(c) for c in w))
        return replace(scene, bodies=tuple(body(b) for b in scene.bodies))


class RestitutionThreshold(Fault):
    """Restitution switched off below an approach speed of 0.2 m/s: a slow contact
    closes plastically (e = 0) whatever the pair's e.

    Bullet's default restitutionVelocityThreshold (0.2 m/s), which the adapter switches
    off; other engines ship the same with other numbers (Box2D's restitution threshold,
    1 m/s). PyBullet: the parameter set back. The reference: its solver targets
    v_n+ = 0 instead of -e v_n- on contacts approaching slower than the threshold. MuJoCo
    has no restitution coefficient (its bounce is the contact's spring-damper): no
    such threshold can be planted there."""
    name = "restitution threshold"
    speed = 0.2  # m/s
    kinds = ("reference", "pybullet")

    def plant(self, sim, scene, kind):
        if kind == "pybullet":
            from adapters.pybullet_engine import p
            p.setPhysicsEngineParameter(restitutionVelocityThreshold=self.speed, physicsClientId=sim._client)
        elif kind == "reference":
            sim._world.solver = _ThresholdSolver(sim._world.solver, self.speed)
        return sim


class _ThresholdSolver(_SolverWrapper):
    """The reference's solver with each slow approaching contact's restitution target
    (contact.normal_target: -e vn0) replaced by 0."""

    def __init__(self, module, speed: float):
        super().__init__(module)
        self._speed = speed

    def solve(self, contacts, bodies, dt, config):
        for c in contacts:
            if c.target is not None and -self._speed < c.vn0 < 0.0 and c.target > 0.0:
                c.target = 0.0
        return self._module.solve(contacts, bodies, dt, config)


class ContactTorques(Fault):
    """Contact torques nobody asked for on every frictional pair: a torsional friction of
    5 mm and a rolling resistance of 0.1 mm (lever arms of the normal force).

    MuJoCo's own defaults (geom friction "1 0.005 0.0001") brought in by condim 6 where
    the scene asked for sliding friction only: a ball rolling at 1 m/s loses 7 mm/s each
    second, a spinning one stops."""
    name = "contact torques"
    torsional, rolling = 5e-3, 1e-4  # m

    def scene(self, scene, kind):
        def torques(m):
            if not m.frictional or m.rolling_resistance or m.torsional_friction:
                return m
            return replace(m, torsional_friction=self.torsional, rolling_resistance=self.rolling)
        return _scale_materials(scene, torques)


# --- wrong answers: an effect off or doubled, another law, another rule -------------------
#
# The plain wrong answers a family names in its `catches` (cases.family.Catch): each changes
# what the engine is given (the scene), so it has a meaning in any engine ("any"), but for
# the restitution law, written for the reference's solver. tests/test_catches.py plants
# each on the variant its family names and shows a check fail.

class _Materials(Fault):
    """Every material (the default and each pair's) replaced by change(m): the base of the
    off and doubled faults below."""
    kinds = ("any",)

    def change(self, m):
        return m

    def scene(self, scene, kind):
        return _scale_materials(scene, self.change)


class RestitutionOff(_Materials):
    """Restitution off: e = 0 in every material.

    An adapter that sets the engine's restitution from a field it never fills (Bullet's and
    DART's default restitution is 0): every impact is plastic."""
    name = "restitution off"

    def change(self, m):
        return replace(m, e=0.0)


class RestitutionDoubled(_Materials):
    """Restitution doubled: e x 2 in every material (at most 1).

    A pair's e applied to each body of a rule that adds or multiplies them the other way
    (e = 0.3 on both bodies of a sum): e = 0.5 becomes 1."""
    name = "restitution doubled"

    def change(self, m):
        return replace(m, e=min(1.0, 2.0 * m.e))


class FrictionOff(_Materials):
    """Friction off: mu_s = mu_k = 0 in every material.

    An adapter that maps friction onto a field the engine ignores at this contact type (or
    one switched off by a flag it forgot): every contact is frictionless."""
    name = "friction off"

    def change(self, m):
        return replace(m, mu_s=0.0, mu_k=None)


class FrictionDoubled(_Materials):
    """Friction doubled: mu_s and mu_k x 2 in every material.

    A pair's mu set on both bodies of a rule that adds them (or mu_s given where the
    engine takes the friction angle's tangent of twice it): 0.3 becomes 0.6."""
    name = "friction doubled"

    def change(self, m):
        return replace(m, mu_s=2.0 * m.mu_s, mu_k=None if m.mu_k is None else 2.0 * m.mu_k)


class RollingOff(_Materials):
    """Rolling resistance off: d_r = 0 in every material."""
    name = "rolling resistance off"

    def change(self, m):
        return replace(m, rolling_resistance=0.0)


class RollingDoubled(_Materials):
    """Rolling resistance doubled: d_r x 2 in every material (a lever arm given where the
    engine wants a diameter)."""
    name = "rolling resistance doubled"

    def change(self, m):
        return replace(m, rolling_resistance=2.0 * m.rolling_resistance)


class TorsionOff(_Materials):
    """Torsional friction off: d_t = 0 in every material."""
    name = "torsional friction off"

    def change(self, m):
        return replace(m, torsional_friction=0.0)


class TorsionDoubled(_Materials):
    """Torsional friction doubled: d_t x 2 in every material."""
    name = "torsional friction doubled"

    def change(self, m):
        return replace(m, torsional_friction=2.0 * m.torsional_friction)


class RollingRadius(Fault):
    """Rolling resistance converted with a radius of its own: the engine is handed
    d_r R / 0.1 m for a ball of radius R, as an adapter that turns the lever arm into the
    dimensionless mu_r = d_r / R with R = 0.1 m written in (and the engine multiplies back
    by the ball's own radius). Right for a 0.1 m ball, half the torque for a 0.05 m one."""
    name = "rolling radius"
    kinds = ("any",)
    written_for = 0.1  # m

    def scene(self, scene, kind):
        radii = [b.shape.radius for b in scene.bodies if b.dynamic and hasattr(b.shape, "radius")]
        if not radii:
            return scene
        ratio = radii[0] / self.written_for
        return _scale_materials(scene, lambda m: replace(m, rolling_resistance=m.rolling_resistance * ratio))


class CombineRule(Fault):
    """Pair overrides computed for the product rule, combined by the max rule: each body
    gets the per-body values whose products give the scene's pairs
    (adapters.combination.per_body_values), and the engine combines two bodies' values by
    taking the larger, as Box2D's restitution and PhysX's friction and restitution do.

    An adapter that undoes another engine's rule than its own: a pair table of restitution
    0.5, 0.3, 0.5 reaches the engine as 0.91 for the first pair. (Where the product rule
    cannot express the table the scene is given unchanged: that adapter would have
    reported it unsupported.)"""
    name = "combine rule"
    kinds = ("any",)

    def scene(self, scene, kind):
        from adapters.base import Unsupported
        from adapters.combination import per_body_values
        pairs = scene.contact_pairs()
        if len(pairs) < 2:
            return scene
        try:
            e = per_body_values(scene, lambda m: m.e, "product", "restitution")
            mu = per_body_values(scene, lambda m: m.mu_s, "product", "friction")
        except Unsupported:
            return scene
        table = []
        for a, b in pairs:
            m = scene.material_of(a.name, b.name)
            table.append((a.name, b.name, replace(m, e=min(1.0, max(e[a.name], e[b.name])),
                                                  mu_s=max(mu[a.name], mu[b.name]), mu_k=None)))
        return replace(scene, pairs=tuple(table))


class RestitutionLaw(Fault):
    """The two-phase restitution law where the engine declares Newton's: friction acts on a
    plastic impact, then restitution is applied without friction (Box2D's, Box3D's and
    Rapier's relax pass after the solve).

    The reference: its solver targets v_n+ = 0 on each bouncing contact, then pushes each
    one's normal velocity up to its restitution target -e vn0 with normal impulses alone."""
    name = "restitution law"
    kinds = ("reference",)

    def plant(self, sim, scene, kind):
        sim._world.solver = _TwoPhaseSolver(sim._world.solver)
        return sim


class _TwoPhaseSolver(_SolverWrapper):
    """The reference's solver with restitution moved after it, frictionless (RestitutionLaw)."""

    def solve(self, contacts, bodies, dt, config):
        bounce = [(c, c.target) for c in contacts if c.target is not None and c.target > 0.0]
        for c, _ in bounce:
            c.target = 0.0
        stages = self._module.solve(contacts, bodies, dt, config)
        for _ in range(config.iterations):  # restitution, normal rows only, Gauss-Seidel
            largest = 0.0
            for c, goal in bounce:
                dv = goal - c.normal.velocity()
                if dv > 0.0:
                    P = c.normal.mass * dv
                    c.normal.apply(P)
                    c.Pn += P
                    largest = max(largest, dv)
            if largest <= config.tolerance:
                break
        for c, goal in bounce:
            c.target = goal
        return stages


class ContactOffset(Fault):
    """Contact 2 mm early: every dynamic body's collision shape 2 mm larger than the body
    (its mass and inertia kept), as an engine's contact offset or collision margin that an
    adapter leaves on. Bodies rest 2 mm above the surface, impacts happen 2 mm early, a
    rolling ball's contact point lies 2 mm further from its centre."""
    name = "contact offset"
    kinds = ("any",)
    offset = 2e-3  # m

    def scene(self, scene, kind):
        from cases.scene import Circle, Sphere

        def grown(s):
            if isinstance(s, (Sphere, Circle)):
                return replace(s, radius=s.radius + self.offset)
            if isinstance(s, (Box, Rect)):
                return replace(s, half_extents=tuple(h + self.offset for h in s.half_extents))
            return s

        def body(b):
            if b.static:
                return b
            return replace(b, shape=grown(b.shape), inertia=b.principal_inertia)
        return replace(scene, bodies=tuple(body(b) for b in scene.bodies),
                       allowed_overlap=scene.allowed_overlap + 2.0 * self.offset)


FAULTS: tuple[Fault, ...] = (Restitution(), StaticFriction(), KineticFriction(), Gravity(), TimeStep(), Inertia(),
                             FrictionCone(), Damping(), ForceReadout(), PairMaterials(), InertiaAxes(),
                             AngularVelocityFrame(), RestitutionThreshold(), ContactTorques())
# The plain wrong answers families name in their catches (beside FAULTS, the bug-sized
# faults the bench's detection matrix and tests/test_faults.py run on every family).
WRONG_ANSWERS: tuple[Fault, ...] = (RestitutionOff(), RestitutionDoubled(), FrictionOff(), FrictionDoubled(),
                                    RollingOff(), RollingDoubled(), TorsionOff(), TorsionDoubled(), RollingRadius(),
                                    CombineRule(), RestitutionLaw(), ContactOffset())
NONE = NoFault()


def by_name(name: str) -> Fault:
    for f in (NONE, *FAULTS, *WRONG_ANSWERS):
        if f.name == name:
            return f
    raise KeyError(f"no fault {name!r}: choose from {', '.join(f.name for f in (NONE, *FAULTS, *WRONG_ANSWERS))}")


# --- the wrapper ----------------------------------------------------------------------------

class FaultyAdapter(Adapter):
    """An engine's adapter with one planted fault. It carries the engine's name, its
    capabilities and its known-deviation file, so the harness judges it as that engine."""

    def __init__(self, inner: Adapter, fault: Fault = NONE):
        self.kind = engine_kind(inner, fault)
        self.inner, self.fault = inner, fault
        self.name = inner.name
        self.capabilities = inner.capabilities
        self.package = inner.package
        self.tunables = inner.tunables
        self.default_tags = inner.default_tags
        self.slow = inner.slow

    def version(self) -> str:
        return f"{self.inner.version()} (planted fault: {self.fault.name})"

    def deviations_file(self):
        return self.inner.deviations_file()

    def on_demand(self, scene):
        return self.inner.on_demand(scene)

    def options_in_force(self, settings):
        return self.inner.options_in_force(settings)

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        fault = self.fault
        given = fault.scene(scene, self.kind)
        sim = self.inner.build(given, fault.settings(settings))
        try:
            sim = fault.plant(sim, given, self.kind)
        except BaseException:
            sim.close()
            raise
        return FaultySimulation(sim, fault, settings.dt, fault.after_step(self.kind))


class FaultySimulation(Simulation):
    """The engine's simulation, passed through but for what the fault plants: a step
    after the engine's own (then stepped one step at a time) and the force read-out."""

    def __init__(self, inner: Simulation, fault: Fault, dt: float, after_step=None):
        self.inner, self.fault, self._dt, self._after = inner, fault, dt, after_step
        self.effects = inner.effects
        self.iterations = inner.iterations
        self.run = inner.run if after_step is None else None

    @property
    def knobs(self) -> dict:
        return {**self.inner.knobs, "planted_fault": self.fault.name}

    def step(self) -> None:
        self.inner.step()
        if self._after is not None:
            self._after(self.inner, self._dt)

    def states(self):
        return self.inner.states()

    def body_order(self):
        return self.inner.body_order()

    def state_size(self):
        return self.inner.state_size()

    def write_state(self, out):
        self.inner.write_state(out)

    def decode_states(self, raw):
        return self.inner.decode_states(raw)

    def contact_forces(self):
        k = self.fault.read_out
        return {pair: k * f for pair, f in self.inner.contact_forces().items()}

    def contact_points(self):
        k = self.fault.read_out
        return [replace(c, f_n=k * c.f_n, f_t=k * np.asarray(c.f_t)) for c in self.inner.contact_points()]

    def close(self) -> None:
        self.inner.close()



# --- running faulty engines -----------------------------------------------------------------

def plant_in(adapter: Adapter, name: str) -> FaultyAdapter:
    """`adapter` with the fault `name` planted (physval.core.context.Context.planted: how
    worker processes build the faulty engine); EngineError where it cannot be planted."""
    from adapters.registry import EngineError
    fault = by_name(name)
    try:
        kind = engine_kind(adapter, fault)
    except NotPlantable as exc:
        raise EngineError(f"fault {name!r} cannot be planted in {adapter.name}: {exc}") from None
    if kind not in fault.kinds and "any" not in fault.kinds:
        raise EngineError(f"fault {name!r} has no meaning in {adapter.name}")
    return FaultyAdapter(adapter, fault)


def jobs_of(families: dict[str, list], engine: str) -> list:
    """Jobs of the given variants (family name -> variants) on `engine`, at the family's
    dt and the adapter's default iterations (where known-deviation bands hold)."""
    from physval.core import Job
    return [Job(name, v, engine) for name, variants in families.items() for v in variants]


def verdicts(fault: Fault, jobs: list, execution=None, ctx=None) -> list[dict]:
    """The verdict rows of `jobs` run on their engines with `fault` planted, judged by the
    harness as the engine itself (its name, its bands): in worker processes through the
    core's loop given an `execution` (physval.core.session.Execution), else in this process
    (the tests' fast set, where a worker's start would cost more than the jobs)."""
    from physval.core import Context, execute, run_jobs
    from physval.core.context import Resolver
    ctx = replace(ctx or Context(), planted=fault.name)
    if execution is None:
        resolver = Resolver(ctx)
        return [row for job in jobs for row in execute(job, resolver).rows]
    res = run_jobs(jobs, ctx, execution.workers, execution.scheduler, execution.job_timeout, execution.start_method,
                   progress=execution.progress, label=f"faults: {fault.name}")
    if res.interrupted:
        raise KeyboardInterrupt(res.interrupted)
    return res.ordered(jobs)
