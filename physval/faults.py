"""Planted faults: the suite tests its own power (mutation testing of the engines, not of
the code).

Each fault of the catalogue changes ONE thing in what an engine is given or reports: a
material coefficient, gravity, the time step, an inertia, the friction cone, a damping, the
force read-out. It is planted at the adapter layer, through the documented hook of
adapters/planting.py (`Planted(adapter, fault)`: the scene, the settings, an engine-internal
change the adapter itself makes, or a wrapper of the built simulation), and never touches
the harness, the cases or their closed forms: the planted engine carries the engine's own
name, the engine's recorded known-deviation bands judge it, and every check the fault moves
out of its tolerance (or out of its band) must come out `fail`. `tests/test_faults.py`
asserts that every fault is flagged in at least two families and the unmodified wrapper
(`NONE`) in none; `physval bench faults` writes the detection matrix (fault x family).

Sizes are those of bugs that ship: a coefficient a few per cent off, 9.80 for 9.81, a time
step 1 % off, an inertia tensor doubled, a square cone, the 0.04 damping PyBullet switches
on by default, a force 5 % off. A fault that changes what any engine is given is planted in
any engine; one that needs a change inside the engine (a square friction cone, a damping, a
restitution threshold or law, a kinetic friction above the static one) is planted where the
engine's adapter makes that change (`Adapter.plantable`: the reference's default
formulation, MuJoCo and PyBullet make them today), and elsewhere cannot be (`why_not`).

`WRONG_ANSWERS` are the plain wrong answers (an effect off or doubled, another restitution
law, another combination rule, a radius written in, a contact offset) that the families
name in their `catches` (cases.family.Catch): each family declares which of them, and of
FAULTS, it must catch and on which variant, and tests/test_catches.py plants each there
and shows a check fail.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from adapters.planting import Fault, NotPlantable, Passthrough, why_not  # noqa: F401 (the contract, re-exported)
from cases.overlap import rotation_matrix
from cases.scene import Box, Capsule, Cylinder, Hull, Mesh, Polygon, Rect, Scene

# The engines `physval bench faults` plants in by default: the plain configuration of each
# engine whose adapter makes the engine-internal changes (Adapter.plantable).
ENGINES = ("reference", "mujoco", "pybullet")


# --- the catalogue ---------------------------------------------------------------------------

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

    def scene(self, scene, capabilities):
        return _scale_materials(scene, lambda m: replace(m, e=min(1.0, m.e * self.factor)))


def _both_scaled(m, f: float):
    """The material with mu_s and mu_k (where given) x f."""
    return replace(m, mu_s=m.mu_s * f, mu_k=None if m.mu_k is None else m.mu_k * f)


class StaticFriction(Fault):
    """Static friction mu_s x 1.06 (an engine with one coefficient: it x 1.06).

    An engine that holds 6 % more than mu_s N before letting go: the break-away angle of
    a box on an incline moves from atan(0.5) = 26.6 deg to 27.9 deg. An engine with
    separate coefficients keeps mu_k as the case gave it."""
    name = "static friction"
    factor = 1.06

    def scene(self, scene, capabilities):
        f = self.factor
        if capabilities.static_kinetic:
            return _scale_materials(scene, lambda m: replace(m, mu_s=m.mu_s * f, mu_k=m.mu_k_))
        return _scale_materials(scene, lambda m: _both_scaled(m, f))


class KineticFriction(Fault):
    """Kinetic friction mu_k x 1.05 (an engine with one coefficient: it x 1.05).

    A sliding contact braked by 1.05 mu_k N: a box launched at 2 m/s with mu_k = 0.3 stops
    3.2 cm short of its 68 cm. An engine with separate coefficients takes it in its own
    material table (the engine-internal change "kinetic friction"): the case's scene
    vocabulary forbids mu_k > mu_s, a real engine's table does not."""
    name = "kinetic friction"
    factor = 1.05

    def scene(self, scene, capabilities):
        if capabilities.static_kinetic:
            return scene
        return _scale_materials(scene, lambda m: _both_scaled(m, self.factor))

    def change(self, capabilities):
        return ("kinetic friction", self.factor) if capabilities.static_kinetic else None


class Gravity(Fault):
    """Gravity of 9.80 m/s^2 where the scene asks for 9.81 (the same direction).

    A hard-coded g = 9.8: 0.1 % in every weight and every fall."""
    name = "gravity"
    g_used, g_asked = 9.80, 9.81

    def scene(self, scene, capabilities):
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
    """Principal inertia x 2 for every box (3D), rect (2D), capsule and cylinder; spheres
    and discs unchanged.

    An inertia tensor computed from full extents where half extents were meant, or given
    about the wrong point: lever-arm impacts then spin a box half as fast, and a cylinder
    rolls down an incline with g sin / 2 instead of 2/3 g sin. A uniform factor leaves
    torque-free rotation (Euler's equations) as it was."""
    name = "inertia"
    factor = 2.0

    def scene(self, scene, capabilities):
        def body(b):
            if b.static or not isinstance(b.shape, (Box, Rect, Capsule, Cylinder)):
                return b
            return replace(b, inertia=tuple(self.factor * i for i in b.principal_inertia))
        return replace(scene, bodies=tuple(body(b) for b in scene.bodies))


class FrictionCone(Fault):
    """A square friction cone in a fixed tangent frame instead of the circle: each of the
    two tangent directions bounded by mu f_n on its own, so friction reaches sqrt(2) mu f_n
    at 45 deg to the frame's axes and does not oppose a slip at 22.5 deg.

    An engine-internal change, each engine's own (its Simulation.plant): MuJoCo: cone =
    "pyramidal" (MuJoCo's own default, which the adapter replaces by the elliptic cone).
    PyBullet: enableConeFriction = 0 (Bullet's default pair of independent friction rows).
    The reference: its sequential impulses clamp each tangent row to [-mu Pn, mu Pn]
    instead of the disc, with both rows along the fixed tangent basis
    (reference_impl.contact.tangent_basis) also while sliding."""
    name = "friction cone"

    def change(self, capabilities):
        return ("square friction cone", None)


class Damping(Fault):
    """A velocity decay of c = 0.04 per second on every body's linear and angular velocity.

    An engine-internal change, each engine's own (its Simulation.plant): PyBullet:
    linearDamping = angularDamping = 0.04, its default, which the adapter switches off (Bullet scales velocities by (1 - c)^dt each step). MuJoCo: joint damping
    on every degree of freedom, c times the dof's own mass or inertia (dof_M0), so each
    decays at the same rate (a damping left in a model's default class). The reference:
    v *= (1 - c dt) and w *= (1 - c dt) after each step."""
    name = "damping"
    c = 0.04  # 1/s

    def change(self, capabilities):
        return ("velocity damping", self.c)


class ForceReadout(Fault):
    """Every contact force the engine reports (contact_forces, and contact_points' normal
    and friction forces) x 1.05; the motion is untouched.

    An impulse divided by a time step other than the one it was solved over, or summed
    over one point too many: the dynamics are right and the reported forces are not."""
    name = "force read-out"
    factor = 1.05

    def simulation(self, sim):
        return _ScaledForces(sim, self.factor)


class _ScaledForces(Passthrough):
    """The simulation with every contact force it reports x `factor`."""

    def __init__(self, inner, factor: float):
        super().__init__(inner)
        self.factor = factor

    def contact_forces(self):
        k = self.factor
        return {pair: k * f for pair, f in self.inner.contact_forces().items()}

    def contact_points(self):
        k = self.factor
        return [replace(c, f_n=k * c.f_n, f_t=k * np.asarray(c.f_t)) for c in self.inner.contact_points()]


class PairMaterials(Fault):
    """Pair overrides ignored: every pair gets the scene's default material.

    An adapter that sets each body's coefficients from the scene's material and never
    reads the pair table (or an engine's combine rule left in force where a pair asked for
    its own value): a block meant to slide on ice brakes like the rest of the scene."""
    name = "pair materials"

    def scene(self, scene, capabilities):
        return replace(scene, pairs=())


class InertiaAxes(Fault):
    """Principal moments handed to the engine in the wrong body axes: x and z swapped on
    every box (a box with equal sides, a sphere, a disc or a 2D rect is unchanged).

    An inertia tensor written in another axis order than the engine reads it (z-up
    against y-up, or a diagonal given in the order of the shape's extents reversed): a
    flat box then tumbles and lands like a tall one."""
    name = "inertia axes"

    def scene(self, scene, capabilities):
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

    def scene(self, scene, capabilities):
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
    1 m/s). An engine-internal change: PyBullet: the parameter set back. The reference:
    its solver targets v_n+ = 0 instead of -e v_n- on contacts approaching slower than the
    threshold. MuJoCo has no restitution coefficient (its bounce is the contact's
    spring-damper): its adapter makes no such change."""
    name = "restitution threshold"
    speed = 0.2  # m/s

    def change(self, capabilities):
        return ("restitution threshold", self.speed)


class ContactTorques(Fault):
    """Contact torques nobody asked for on every frictional pair: a torsional friction of
    5 mm and a rolling resistance of 0.1 mm (lever arms of the normal force).

    MuJoCo's own defaults (geom friction "1 0.005 0.0001") brought in by condim 6 where
    the scene asked for sliding friction only: a ball rolling at 1 m/s loses 7 mm/s each
    second, a spinning one stops."""
    name = "contact torques"
    torsional, rolling = 5e-3, 1e-4  # m

    def scene(self, scene, capabilities):
        def torques(m):
            if not m.frictional or m.rolling_resistance or m.torsional_friction:
                return m
            return replace(m, torsional_friction=self.torsional, rolling_resistance=self.rolling)
        return _scale_materials(scene, torques)


# --- wrong answers: an effect off or doubled, another law, another rule -------------------
#
# The plain wrong answers a family names in its `catches` (cases.family.Catch): each changes
# what the engine is given (the scene), so it can be planted in any engine, but for the
# restitution law, an engine-internal change (the reference's solver makes it).
# tests/test_catches.py plants each on the variant its family names and shows a check fail.

class _Materials(Fault):
    """Every material (the default and each pair's) replaced by material(m), and every joint
    by joint(j): the base of the off and doubled faults below. A joint carries the same
    effects as a contact's material where it has them (a restitution at its limits, a dry
    friction along its coordinate), and an effect off or doubled is off or doubled there
    too: else a family of joints (limit_impact, rail_slide) could not show it sees them."""

    def material(self, m):
        return m

    def joint(self, j):
        return j

    def scene(self, scene, capabilities):
        scene = _scale_materials(scene, self.material)
        return replace(scene, joints=tuple(self.joint(j) for j in scene.joints))


class RestitutionOff(_Materials):
    """Restitution off: e = 0 in every material and at every joint limit.

    An adapter that sets the engine's restitution from a field it never fills (Bullet's and
    DART's default restitution is 0): every impact is plastic."""
    name = "restitution off"

    def material(self, m):
        return replace(m, e=0.0)

    def joint(self, j):
        return replace(j, limit_e=0.0)


class RestitutionDoubled(_Materials):
    """Restitution doubled: e x 2 in every material and at every joint limit (at most 1).

    A pair's e applied to each body of a rule that adds or multiplies them the other way
    (e = 0.3 on both bodies of a sum): e = 0.5 becomes 1."""
    name = "restitution doubled"

    def material(self, m):
        return replace(m, e=min(1.0, 2.0 * m.e))

    def joint(self, j):
        return replace(j, limit_e=min(1.0, 2.0 * j.limit_e))


class FrictionOff(_Materials):
    """Friction off: mu_s = mu_k = 0 in every material, no friction in any joint.

    An adapter that maps friction onto a field the engine ignores at this contact type (or
    one switched off by a flag it forgot): every contact is frictionless."""
    name = "friction off"

    def material(self, m):
        return replace(m, mu_s=0.0, mu_k=None)

    def joint(self, j):
        return replace(j, friction=0.0)


class FrictionDoubled(_Materials):
    """Friction doubled: mu_s and mu_k x 2 in every material, each joint's friction x 2.

    A pair's mu set on both bodies of a rule that adds them (or mu_s given where the
    engine takes the friction angle's tangent of twice it): 0.3 becomes 0.6."""
    name = "friction doubled"

    def material(self, m):
        return replace(m, mu_s=2.0 * m.mu_s, mu_k=None if m.mu_k is None else 2.0 * m.mu_k)

    def joint(self, j):
        return replace(j, friction=2.0 * j.friction)


class RollingOff(_Materials):
    """Rolling resistance off: d_r = 0 in every material."""
    name = "rolling resistance off"

    def material(self, m):
        return replace(m, rolling_resistance=0.0)


class RollingDoubled(_Materials):
    """Rolling resistance doubled: d_r x 2 in every material (a lever arm given where the
    engine wants a diameter)."""
    name = "rolling resistance doubled"

    def material(self, m):
        return replace(m, rolling_resistance=2.0 * m.rolling_resistance)


class TorsionOff(_Materials):
    """Torsional friction off: d_t = 0 in every material."""
    name = "torsional friction off"

    def material(self, m):
        return replace(m, torsional_friction=0.0)


class TorsionDoubled(_Materials):
    """Torsional friction doubled: d_t x 2 in every material."""
    name = "torsional friction doubled"

    def material(self, m):
        return replace(m, torsional_friction=2.0 * m.torsional_friction)


class RollingRadius(Fault):
    """Rolling resistance converted with a radius of its own: the engine is handed
    d_r R / 0.1 m for a ball of radius R, as an adapter that turns the lever arm into the
    dimensionless mu_r = d_r / R with R = 0.1 m written in (and the engine multiplies back
    by the ball's own radius). Right for a 0.1 m ball, half the torque for a 0.05 m one."""
    name = "rolling radius"
    written_for = 0.1  # m

    def scene(self, scene, capabilities):
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

    def scene(self, scene, capabilities):
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

    def change(self, capabilities):
        return ("two-phase restitution", None)


class ContactOffset(Fault):
    """Contact 2 mm early: every dynamic body's collision shape 2 mm larger than the body
    (its mass and inertia kept), as an engine's contact offset or collision margin that an
    adapter leaves on. Bodies rest 2 mm above the surface, impacts happen 2 mm early, a
    rolling ball's contact point lies 2 mm further from its centre."""
    name = "contact offset"
    offset = 2e-3  # m

    def scene(self, scene, capabilities):
        from cases.scene import Circle, Sphere

        def grown(s):
            if isinstance(s, (Sphere, Circle, Capsule)):
                return replace(s, radius=s.radius + self.offset)
            if isinstance(s, Cylinder):
                return replace(s, radius=s.radius + self.offset, half_length=s.half_length + self.offset)
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



# --- faults that break an invariance (cases.relations), each flagged by its relation --------------

class PositionRoundoff(Fault):
    """Positions kept in single precision: every body's position rounded to float32 after
    each step, while the engine declares float64.

    An engine that stores positions in float32 (or computes contact geometry in absolute
    float32 coordinates) behind a double interface: its rounding is 6e-8 of the distance
    from the origin, 6 mm at 100 km, where the scene is the same physics. An engine-internal
    change ("float32 positions": the reference makes it)."""
    name = "position round-off"

    def change(self, capabilities):
        return ("float32 positions", None)


class UnconvergedSweep(Fault):
    """One Gauss-Seidel sweep a step from zero impulses (no warm start, no least-squares
    cold start): the contacts' impulses then depend on the order they are visited in, the
    order the bodies were created in.

    A solver left at one iteration (or an iteration count too small for a stack) and
    started cold: each contact sees the impulses of those before it in the sweep, so a
    stack built top-down stands otherwise than one built bottom-up. An engine-internal
    change ("cold sweeps": the reference makes it)."""
    name = "unconverged sweep"
    sweeps = 1

    def change(self, capabilities):
        return ("cold sweeps", self.sweeps)


class WorldSeed(Fault):
    """A batch whose world k starts perturbed by a seed drawn from k (1e-9 m per position
    component), the world alone (or world 0) exact.

    A batched engine that seeds its per-world noise (contact jitter, a randomised solver
    order) with the world's index: world 3 of 4 is not the scene alone. An engine-internal
    change ("world seed": the reference's batch makes it)."""
    name = "world seed"
    size = 1e-9  # m

    def change(self, capabilities):
        return ("world seed", self.size)


class ColdRestore(Fault):
    """A restored state without its warm-start cache: the contacts of the step after a
    restore start from zero impulses.

    A snapshot of body poses and velocities taken for the whole state: the solver's
    accumulated impulses, which it carries from step to step, are lost, so a resting stack
    restored midway settles again. An engine-internal change ("cold restore": the reference
    makes it)."""
    name = "cold restore"

    def change(self, capabilities):
        return ("cold restore", None)


class ThreadOrder(Fault):
    """With a thread pool, a sum taken in another order: planted as one rounding of the time
    step (dt (1 + 2^-52)) whenever MuJoCo steps with a pool.

    A parallel reduction that adds the threads' partial sums in the order they finish: the
    result differs by roundings between a run on one thread and one on many. An
    engine-internal change ("thread order": MuJoCo makes it)."""
    name = "thread order"

    def change(self, capabilities):
        return ("thread order", None)


class HandedDrift(Fault):
    """A handed error: every body's velocity turned 1e-3 rad counter-clockwise about the
    vertical (z, seen from above) after each step, in a scene and in its mirror image alike.

    Physics turns a mirrored motion the other way; a term that turns motion one way in
    every frame (a sign slip in a cross product that builds a direction, a spin term
    with a fixed sense) does not. A turn about the vertical commutes with it, so the
    scene turned about z keeps the invariance and only the mirror (and the tilted turn,
    whose vertical is another axis) part the runs. An engine-internal change ("handed
    drift": the reference makes it)."""
    name = "handed drift"
    angle = 1e-3  # rad a step

    def change(self, capabilities):
        return ("handed drift", self.angle)


class ShapeMargin(Fault):
    """A margin of 1 mm inside the shapes given by points: every hull and polygon shrunk by
    1 mm along each of its axes (a box's hull: every face 1 mm in), every mesh lowered 1 mm
    along its normals; boxes, spheres and planes as given, every body's inertia kept.

    An engine that keeps a collision margin inside the convex and triangle-mesh shapes it
    is given (Bullet shrinks a convex shape by its margin, 0.04 m by default, and rounds it
    back out; one that forgets the rounding leaves a solid smaller than the points) where
    the primitives it has closed forms for have none: a box given as the hull of its
    corners then stands 1 mm lower than the box. (Grown rather than shrunk, the solid would
    start inside the ground, which the scene refuses.) A change of the scene, planted in
    any engine that takes these shapes."""
    name = "shape margin"
    margin = -1e-3  # m: inward

    def scene(self, scene, capabilities):
        m = self.margin

        def grown(vertices):
            extent = np.max(np.abs(np.asarray(vertices, float)), axis=0)
            return tuple(tuple(float(c * (1.0 + m / e)) for c, e in zip(v, extent)) for v in vertices)

        def raised(mesh):
            v, normals = np.asarray(mesh.vertices, float), np.zeros((len(mesh.vertices), 3))
            for a, b, c in mesh.triangles:
                n = np.cross(v[b] - v[a], v[c] - v[a])
                normals[[a, b, c]] += n / np.linalg.norm(n)
            normals /= np.linalg.norm(normals, axis=1, keepdims=True)
            return replace(mesh, vertices=tuple(tuple(float(x) for x in p) for p in v + m * normals))

        def body(b):
            s = b.shape
            if isinstance(s, (Hull, Polygon)):
                return replace(b, shape=replace(s, vertices=grown(s.vertices)),
                               inertia=None if b.static else tuple(b.principal_inertia))
            if isinstance(s, Mesh):
                return replace(b, shape=raised(s))
            return b
        return replace(scene, bodies=tuple(body(b) for b in scene.bodies))


# Each relation of cases.relations that a planted fault proves, and the fault: the fault must
# make its relation's verdict `fail` on the relation's default scene, the plain wrapper not
# (tests/test_invariance.py); "friction cone" is the catalogue's square cone in a fixed
# tangent frame: a friction that depends on the direction of sliding; "damping" is the
# catalogue's 0.04 per second, a rate in absolute units (PyBullet's default), which Froude's
# scaling (times x sqrt(k)) does not carry: what an engine adds in absolute units breaks scale.
INVARIANCE_FAULTS: tuple[Fault, ...] = (PositionRoundoff(), UnconvergedSweep(), WorldSeed(), ColdRestore(),
                                        ThreadOrder(), HandedDrift(), ShapeMargin())
PROVES = {"rotate_vertical": "friction cone", "rotate_tilted": "handed drift",
          "translate_10m": "position round-off", "translate_1000m": "position round-off",
          "translate_100000m": "position round-off", "mirror": "handed drift",
          "scale_4": "damping", "scale_quarter": "damping", "body_order": "unconverged sweep",
          "worlds": "world seed", "save_restore": "cold restore", "threads": "thread order",
          "as_hull": "shape margin", "as_mesh": "shape margin"}
# Relations no planted fault can prove yet, and why (none today: tests/test_invariance.py
# asks a proof of a representation relation as soon as an engine takes its shape).
UNPROVEN: dict[str, str] = {}


def by_name(name: str) -> Fault:
    every = (NONE, *FAULTS, *WRONG_ANSWERS, *INVARIANCE_FAULTS)
    for f in every:
        if f.name == name:
            return f
    raise KeyError(f"no fault {name!r}: choose from {', '.join(f.name for f in every)}")


# --- running planted engines -----------------------------------------------------------------

def plantable_in(engine: str, fault: Fault) -> str | None:
    """Why `fault` cannot be planted in the engine named `engine`, or None."""
    from adapters.registry import get
    return why_not(get(engine), fault)


def jobs_of(families: dict[str, list], engine: str) -> list:
    """Jobs of the given variants (family name -> variants) on `engine`, at the family's
    dt and the adapter's default iterations (where known-deviation bands hold)."""
    from physval.core import Job
    return [Job(name, v, engine) for name, variants in families.items() for v in variants]


def verdicts(fault: Fault, jobs: list, execution=None, ctx=None) -> list[dict]:
    """The verdict rows of `jobs` run on their engines with `fault` planted (the run's
    Context carries it to every process, whose Resolver wraps each engine in
    adapters.planting.Planted), judged by the harness as the engine itself (its name, its
    bands): in worker processes through the core's loop given an `execution`
    (physval.core.session.Execution), else in this process (the tests' fast set, where a
    worker's start would cost more than the jobs)."""
    from physval.core import Context, execute, run_jobs
    from physval.core.context import Resolver
    ctx = replace(ctx or Context(), planted=fault)
    if execution is None:
        resolver = Resolver(ctx)
        return [row for job in jobs for row in execute(job, resolver).rows]
    res = run_jobs(jobs, ctx, execution.workers, execution.scheduler, execution.job_timeout, execution.start_method,
                   progress=execution.progress, label=f"faults: {fault.name}")
    if res.interrupted:
        raise KeyboardInterrupt(res.interrupted)
    return res.ordered(jobs)
