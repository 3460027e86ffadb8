"""The engine-neutral scene vocabulary: shapes, bodies, pair materials, gravity, effects.

This module is the one thing `cases/` and `adapters/` share. A scene is immutable and is
validated when it is made: a bad field raises `SceneError` naming the field and the range
it must lie in, so no engine ever sees it.

Conventions (SI units throughout):
- positions in metres, world frame, z up;
- orientation as a unit quaternion (w, x, y, z), body to world;
- angular velocity in the world frame, rad/s;
- a 2D scene (`dimension=2`) lies in the x-z plane: y and the rotations about x and z
  stay zero, and its shapes are `Circle` and `Rect`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from cases.overlap import penetration

# The physics a scene can call for (Scene.effects, derived from the scene; an adapter
# simulates these and nothing more, and reports what it simulated in Simulation.effects):
# "gravity" (non-zero gravity), "contact" (a pair that may touch), "restitution" (a pair
# with e > 0), "friction" (a pair with mu_s > 0), "rotation" (a dynamic body that rotates),
# "rolling_resistance" / "torsional_friction" (a pair with Material.rolling_resistance /
# Material.torsional_friction > 0: the contact torques of CONTACT_TORQUES).
EFFECTS = ("gravity", "contact", "restitution", "friction", "rotation", "rolling_resistance",
           "torsional_friction")
# The effects that are torques a contact exerts (about the rolling axes, about the normal);
# an engine declares the ones it models in Capabilities.contact_torques.
CONTACT_TORQUES = ("rolling_resistance", "torsional_friction")

# How an engine resolves impacts at several contacts within one step (an adapter declares
# its model in Capabilities.impact_model):
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
# variant unsupported (adapters.base.Capabilities.cannot_run).
IMPACT_MODEL_NEED = "impact_model:"

# The restitution law an engine applies at a contact with friction (an adapter declares it
# in Capabilities.restitution_law; the closed forms differ where a frictional contact has
# e > 0 and its impulse turns a body, so normal and tangential velocities couple):
# "newton": Newton's velocity restitution with Coulomb friction acting throughout the
#   impact (the Newton-Coulomb impulse of note 004: u_n+ = -e u_n-, friction on the whole
#   normal impulse);
# "two_phase": a plastic impact with Coulomb friction (the Newton-Coulomb impulse at e = 0),
#   then a normal impulse alone up to Newton's u_n+ = -e u_n-, without friction (Box2D and
#   Rapier apply restitution in a pass of its own after the solve);
# "poisson": Poisson's hypothesis, the restitution impulse e times the compression impulse,
#   with Coulomb friction in both phases (no built-in engine declares it; a plug-in may).
# The closed forms of all three: cases/impact_laws.py.
RESTITUTION_LAWS = ("newton", "two_phase", "poisson")
RESTITUTION_LAW_NEED = "restitution_law:"

# Bodies may start this far inside each other: contact geometry built by hand is exact to
# rounding (1e-12 m), and 1 um is far below any depth an engine resolves at dt = 1e-3.
DEFAULT_ALLOWED_OVERLAP = 1e-6


class SceneError(ValueError):
    """A scene field outside its allowed range; the message names the field."""


def _finite(value, where: str, shape: tuple[int, ...] | None = None) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        what = "a number" if shape is None else f"{shape[0]} numbers"
        raise SceneError(f"{where} = {value!r}: must be {what}") from None
    if shape is not None and array.shape != shape:
        raise SceneError(f"{where} = {value!r}: must have {shape[0]} components")
    if not np.all(np.isfinite(array)):
        raise SceneError(f"{where} = {value!r}: must be finite (no NaN or infinity)")
    return array


def _positive(value: float, where: str) -> float:
    _finite(value, where)
    if not value > 0:
        raise SceneError(f"{where} = {value!r}: must be > 0")
    return float(value)


# --- shapes -------------------------------------------------------------------------------

@dataclass(frozen=True)
class Sphere:
    """A ball of `radius` m, centred on its body's position (3D scenes). Default inertia
    of a solid ball: 2/5 m r^2 about every axis."""
    radius: float
    kind = "sphere"
    dimension = 3

    def inertia(self, m: float) -> tuple[float, float, float]:
        i = 2.0 / 5.0 * m * self.radius**2
        return (i, i, i)

    def validate(self, where: str) -> None:
        _positive(self.radius, f"{where}.radius")


@dataclass(frozen=True)
class Box:
    """A cuboid with `half_extents` (a, b, c) m along its body's x, y, z axes, centred on
    the body's position (3D scenes). Default inertia of a solid box:
    m (b^2 + c^2) / 3, m (a^2 + c^2) / 3, m (a^2 + b^2) / 3 (principal, body frame)."""
    half_extents: tuple[float, float, float]
    kind = "box"
    dimension = 3

    def inertia(self, m: float) -> tuple[float, float, float]:
        a, b, c = self.half_extents
        return (m * (b * b + c * c) / 3.0, m * (a * a + c * c) / 3.0, m * (a * a + b * b) / 3.0)

    def validate(self, where: str) -> None:
        _finite(self.half_extents, f"{where}.half_extents", (3,))
        for axis, h in zip("xyz", self.half_extents):
            _positive(h, f"{where}.half_extents.{axis}")


@dataclass(frozen=True)
class Plane:
    """The static half-space below the plane n . x = offset (solid on the side opposite n):
    `normal` a unit vector (default +z), `offset` in m. Only a static body may have it; in a
    2D scene it is a line of the x-z plane (engines cannot represent a normal with a
    y component there and report `unsupported`)."""
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    offset: float = 0.0
    kind = "plane"
    dimension = None  # a line in 2D scenes, a plane in 3D ones

    def inertia(self, m: float):
        raise SceneError("a plane is static: it has no inertia")

    def validate(self, where: str) -> None:
        n = _finite(self.normal, f"{where}.normal", (3,))
        _finite(self.offset, f"{where}.offset")
        if abs(np.linalg.norm(n) - 1.0) > 1e-9:
            raise SceneError(f"{where}.normal = {self.normal!r}: must be a unit vector")


@dataclass(frozen=True)
class Circle:
    """A disc of `radius` m in a 2D scene (x-z plane); 3D engines embed it as a cylinder
    along y. Default inertia of a solid disc about y: m r^2 / 2."""
    radius: float
    kind = "circle"
    dimension = 2

    def inertia(self, m: float) -> tuple[float, float, float]:
        i = 0.5 * m * self.radius**2  # about y, the only axis a 2D body turns about
        return (i, i, i)

    def validate(self, where: str) -> None:
        _positive(self.radius, f"{where}.radius")


@dataclass(frozen=True)
class Rect:
    """A rectangle in a 2D scene (x-z plane): `half_extents` (a, c) m along the body's x
    and z axes; 3D engines embed it as a box along y. Default inertia about y, the only
    axis a 2D body turns about: m (a^2 + c^2) / 3."""
    half_extents: tuple[float, float]
    kind = "rect"
    dimension = 2

    def inertia(self, m: float) -> tuple[float, float, float]:
        a, c = self.half_extents
        i = m * (a * a + c * c) / 3.0
        return (i, i, i)

    def validate(self, where: str) -> None:
        _finite(self.half_extents, f"{where}.half_extents", (2,))
        for axis, h in zip("xz", self.half_extents):
            _positive(h, f"{where}.half_extents.{axis}")


Shape = Sphere | Box | Plane | Circle | Rect


# --- materials and bodies -----------------------------------------------------------------

@dataclass(frozen=True)
class Compliance:
    """A compliant contact law for a pair (note 001, "Elastic Impact Details", "Hertz
    Constant", "Analyzing Newton's Cradle"): the bodies overlap by xi and push apart with
    - "hertz": F = H xi^1.5, H from Young's modulus E (Pa) and Poisson's ratio nu of the
      material both bodies are made of, and the radii of curvature at the contact;
    - "hooke": F = k xi with the contact stiffness k (N/m).
    Without it (Material.compliance = None) contact is rigid."""
    law: str
    E: float | None = None
    nu: float | None = None
    k: float | None = None

    def validate(self, where: str) -> None:
        if self.law == "hertz":
            if self.E is None or self.nu is None or self.k is not None:
                raise SceneError(f"{where}: a Hertz contact takes E and nu (and no k)")
            _positive(self.E, f"{where}.E")
            _finite(self.nu, f"{where}.nu")
            if not 0.0 <= self.nu < 0.5:
                raise SceneError(f"{where}.nu = {self.nu!r}: Poisson's ratio must lie in [0, 0.5)")
        elif self.law == "hooke":
            if self.k is None or self.E is not None or self.nu is not None:
                raise SceneError(f"{where}: a Hooke contact takes k (and no E, nu)")
            _positive(self.k, f"{where}.k")
        else:
            raise SceneError(f"{where}.law = {self.law!r}: must be 'hertz' or 'hooke'")


@dataclass(frozen=True)
class Material:
    """What a pair of bodies does on contact (a scene's default, or one pair's in Scene.pairs).

    - `e`: Newton's coefficient of restitution in [0, 1], the ratio of the normal
      velocities after and before an impact (0: plastic, 1: elastic);
    - `mu_s`: Coulomb's static friction coefficient (>= 0; 0: frictionless);
    - `mu_k`: the kinetic coefficient, <= mu_s (None: equal to mu_s). Engines with one
      coefficient report a pair with mu_k != mu_s `unsupported`;
    - `compliance`: a compliant contact law (`Compliance`), or None for rigid contact;
    - `rolling_resistance`: d_r in m (>= 0; 0: none), the lever arm of the normal force N
      against rolling: the contact exerts a torque about the rolling axes (tangent to the
      contact plane) opposing the relative rolling, |tau_r| <= d_r N (isotropic: a disc
      in the tangent plane), as static friction holds up to mu_s N. Note 001 ("dry
      friction") writes rolling friction as a force F_r = mu_r F_n, mu_r << mu_k: for a
      body of radius r that is the same law with mu_r = d_r / r (the torque d_r N at the
      contact equals F_r r). A length, not mu_r, because it does not depend on the shape:
      MuJoCo's rolling coefficient (friction[3:5], condim 6) and Bullet's rollingFriction
      (the combined value times the normal impulse) are this length; Box2D v3's
      rollingResistance is mu_r (it multiplies by the larger radius of the pair), so its
      adapter divides;
    - `torsional_friction`: d_t in m (>= 0; 0: none), the same law about the contact
      normal: a torque opposing the relative spin about n, |tau_n| <= d_t N (a contact
      patch of radius a with uniform pressure and Coulomb friction mu gives
      d_t = 2/3 mu a). MuJoCo's torsional coefficient (friction[2], condim 4 or 6) and
      Bullet's spinningFriction are this length.
    Engines that model neither report a pair asking for them `unsupported`
    (Capabilities.contact_torques).
    """
    e: float = 0.0
    mu_s: float = 0.0
    mu_k: float | None = None  # None: equal to mu_s
    compliance: Compliance | None = None
    rolling_resistance: float = 0.0  # m: |tau_r| <= d_r N about the rolling axes
    torsional_friction: float = 0.0  # m: |tau_n| <= d_t N about the contact normal

    @property
    def mu_k_(self) -> float:
        """The kinetic coefficient in force (mu_s when mu_k is None)."""
        return self.mu_s if self.mu_k is None else self.mu_k

    def validate(self, where: str) -> None:
        _finite(self.e, f"{where}.e")
        if not 0.0 <= self.e <= 1.0:
            raise SceneError(f"{where}.e = {self.e!r}: coefficient of restitution must lie in [0, 1]")
        _finite(self.mu_s, f"{where}.mu_s")
        if self.mu_s < 0:
            raise SceneError(f"{where}.mu_s = {self.mu_s!r}: friction coefficient must be >= 0")
        if self.mu_k is not None:
            _finite(self.mu_k, f"{where}.mu_k")
            if self.mu_k < 0:
                raise SceneError(f"{where}.mu_k = {self.mu_k!r}: friction coefficient must be >= 0")
            if self.mu_k > self.mu_s:
                raise SceneError(f"{where}.mu_k = {self.mu_k!r}: must be <= mu_s = {self.mu_s!r}")
        for name in CONTACT_TORQUES:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise SceneError(f"{where}.{name} = {value!r}: must be a number (a lever arm in m, >= 0)")
            _finite(value, f"{where}.{name}")
            if value < 0:
                raise SceneError(f"{where}.{name} = {value!r}: a lever arm in m, must be >= 0")
        if self.compliance is not None:
            self.compliance.validate(f"{where}.compliance")

    def torque(self, effect: str) -> float:
        """The lever arm (m) of a contact torque of CONTACT_TORQUES: d_r or d_t."""
        if effect not in CONTACT_TORQUES:
            raise KeyError(f"{effect!r}: not a contact torque ({', '.join(CONTACT_TORQUES)})")
        return float(getattr(self, effect))

    @property
    def frictional(self) -> bool:
        """True when the pair has friction (mu_s > 0)."""
        return self.mu_s > 0


@dataclass(frozen=True)
class Body:
    """A rigid body of the scene, in its start state.

    - `name`: unique in the scene; trajectories, contact forces and pairs use it;
    - `shape`: Sphere, Box, Plane (static only) in 3D; Circle, Rect, Plane in 2D;
    - `mass`: kg, > 0 for a dynamic body, None for a static one;
    - `inertia`: principal moments (kg m^2) in the body frame; None: the shape's solid
      default (see each shape);
    - `position` (m), `orientation` (unit quaternion w, x, y, z, body to world),
      `velocity` (m/s), `angular_velocity` (rad/s, world frame): the start state;
    - `static`: fixed in place, infinite mass (the ground, walls);
    - `rotates`: False holds the orientation fixed (a sphere in a frictionless central
      impact, a block that must only slide), so no engine spins it up from round-off.
    """
    name: str
    shape: Shape
    mass: float | None = None  # None for a static body
    inertia: tuple[float, float, float] | None = None  # principal, body frame; None: from shape
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    static: bool = False
    rotates: bool = True  # False: the orientation is held fixed (e.g. a sphere in a frictionless impact)

    @property
    def dynamic(self) -> bool:
        """True for a body that moves (not static)."""
        return not self.static

    @property
    def principal_inertia(self) -> tuple[float, float, float]:
        """The principal moments in force: `inertia`, else the shape's default for `mass`."""
        if self.inertia is not None:
            return tuple(float(i) for i in self.inertia)
        return self.shape.inertia(self.mass)

    def validate(self, where: str) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise SceneError(f"{where}.name = {self.name!r}: must be a non-empty string")
        if not isinstance(self.shape, (Sphere, Box, Plane, Circle, Rect)):
            raise SceneError(f"{where}.shape = {self.shape!r}: must be a shape of cases.scene "
                             "(Sphere, Box, Plane, Circle, Rect)")
        self.shape.validate(f"{where}.shape")
        _finite(self.position, f"{where}.position", (3,))
        q = _finite(self.orientation, f"{where}.orientation", (4,))
        if abs(np.linalg.norm(q) - 1.0) > 1e-9:
            raise SceneError(f"{where}.orientation = {self.orientation!r}: must be a unit quaternion (w, x, y, z)")
        _finite(self.velocity, f"{where}.velocity", (3,))
        _finite(self.angular_velocity, f"{where}.angular_velocity", (3,))
        if self.shape.kind == "plane" and not self.static:
            raise SceneError(f"{where}.static = False: a plane must be static")
        if not isinstance(self.static, bool) or not isinstance(self.rotates, bool):
            raise SceneError(f"{where}: static and rotates must be True or False")
        if not self.rotates and any(w != 0.0 for w in self.angular_velocity):
            raise SceneError(f"{where}.angular_velocity = {self.angular_velocity!r}: a body held from rotating "
                             "(rotates=False) cannot spin")
        if self.static:
            return
        if self.mass is None:
            raise SceneError(f"{where}.mass = None: a dynamic body needs a mass > 0")
        _positive(self.mass, f"{where}.mass")
        if self.inertia is not None:
            _finite(self.inertia, f"{where}.inertia", (3,))
            for axis, i in zip("xyz", self.inertia):
                _positive(i, f"{where}.inertia.{axis}")


def pair_key(a: str, b: str) -> tuple[str, str]:
    """Pairs are unordered: one key for (a, b) and (b, a)."""
    return (a, b) if a <= b else (b, a)


# --- the scene ----------------------------------------------------------------------------

@dataclass(frozen=True)
class Scene:
    """An engine-neutral scene, validated when made (SceneError names the bad field).

    - `bodies`: at least one dynamic body; names unique;
    - `gravity`: m/s^2, world frame (an incline tilts gravity: `tilted_gravity`);
    - `material`: the Material of every pair not named in `pairs`;
    - `pairs`: per-pair overrides (body a, body b, Material), unordered; an engine whose
      per-body combination rule cannot express the pair table reports `unsupported`;
    - `dimension`: 3, or 2 for a scene in the x-z plane (Circle, Rect, Plane; y, and
      rotations about x and z, stay zero), which the 2D engines run too;
    - `allowed_overlap`: m the bodies may start inside each other (default 1 um: contact
      built by hand is exact to rounding); a scene that starts deeper on purpose says so;
    - `effects`: derived, not given: the physics the scene calls for (EFFECTS).
    """
    bodies: tuple[Body, ...]
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    material: Material = Material()  # every pair not named in `pairs`
    pairs: tuple[tuple[str, str, Material], ...] = ()  # per-pair overrides (a, b, material)
    dimension: int = 3
    allowed_overlap: float = DEFAULT_ALLOWED_OVERLAP
    effects: frozenset[str] = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "bodies", tuple(self.bodies))
        object.__setattr__(self, "pairs", tuple(self.pairs))
        self._validate()
        object.__setattr__(self, "effects", self._derive_effects())

    # lookups
    def body(self, name: str) -> Body:
        """The body called `name` (KeyError if none)."""
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    def material_of(self, a: str, b: str) -> Material:
        """The Material of the pair (a, b): its entry in `pairs`, else `material`."""
        key = pair_key(a, b)
        for x, y, mat in self.pairs:
            if pair_key(x, y) == key:
                return mat
        return self.material

    @property
    def contact_laws(self) -> frozenset[str]:
        """The compliant contact laws the touching pairs ask for (empty: all rigid)."""
        mats = [self.material_of(a.name, b.name) for a, b in self.contact_pairs()]
        return frozenset(m.compliance.law for m in mats if m.compliance is not None)

    @property
    def dynamic_bodies(self) -> tuple[Body, ...]:
        """The bodies that move, in scene order."""
        return tuple(b for b in self.bodies if b.dynamic)

    def contact_pairs(self) -> list[tuple[Body, Body]]:
        """Every pair that may touch: all pairs with at least one dynamic body."""
        out = []
        for i, a in enumerate(self.bodies):
            for b in self.bodies[i + 1:]:
                if a.dynamic or b.dynamic:
                    out.append((a, b))
        return out

    def _derive_effects(self) -> frozenset[str]:
        """The physics the scene calls for; adapters simulate these and nothing more."""
        fx = set()
        if any(g != 0.0 for g in self.gravity):
            fx.add("gravity")
        pairs = self.contact_pairs()
        if pairs:
            fx.add("contact")
            mats = [self.material_of(a.name, b.name) for a, b in pairs]
            if any(m.e > 0 for m in mats):
                fx.add("restitution")
            if any(m.frictional for m in mats):
                fx.add("friction")
            fx.update(effect for effect in CONTACT_TORQUES if any(m.torque(effect) > 0 for m in mats))
        if any(b.rotates for b in self.dynamic_bodies):
            fx.add("rotation")
        return frozenset(fx)

    def _validate(self) -> None:
        if self.dimension not in (2, 3):
            raise SceneError(f"dimension = {self.dimension!r}: must be 2 or 3")
        if not self.bodies:
            raise SceneError("bodies = (): a scene needs at least one body")
        if not self.dynamic_bodies:
            raise SceneError("bodies: a scene needs at least one dynamic body")
        _finite(self.gravity, "gravity", (3,))
        _finite(self.allowed_overlap, "allowed_overlap")
        if self.allowed_overlap < 0:
            raise SceneError(f"allowed_overlap = {self.allowed_overlap!r}: must be >= 0")
        names = set()
        for i, body in enumerate(self.bodies):
            where = f"bodies[{i}]"
            if not isinstance(body, Body):
                raise SceneError(f"{where} = {body!r}: must be a Body")
            body.validate(f"{where}({body.name})")
            if body.name in names:
                raise SceneError(f"{where}.name = {body.name!r}: body names must be unique")
            names.add(body.name)
            dim = body.shape.dimension
            if dim is not None and dim != self.dimension:
                raise SceneError(f"{where}({body.name}).shape = {body.shape.kind}: a {dim}D shape "
                                 f"in a {self.dimension}D scene (2D: circle, rect, plane; 3D: sphere, box, plane)")
        self.material.validate("material")
        for j, (a, b, mat) in enumerate(self.pairs):
            for n in (a, b):
                if n not in names:
                    raise SceneError(f"pairs[{j}] names body {n!r}: not in the scene ({', '.join(sorted(names))})")
            mat.validate(f"pairs[{j}]({a},{b})")
        if self.dimension == 2:
            self._validate_planar()
        for a, b in self.contact_pairs():
            depth = penetration(a, b)
            if depth > self.allowed_overlap:
                raise SceneError(f"bodies {a.name!r} and {b.name!r} start {depth:.3g} m inside each other: "
                                 f"allowed_overlap is {self.allowed_overlap:.3g} m")

    def _validate_planar(self) -> None:
        for i, body in enumerate(self.bodies):
            where = f"bodies[{i}]({body.name})"
            if body.position[1] != 0 or body.velocity[1] != 0:
                raise SceneError(f"{where}: a 2D scene lies in the x-z plane: position.y and velocity.y must be 0")
            w = body.angular_velocity
            if w[0] != 0 or w[2] != 0:
                raise SceneError(f"{where}.angular_velocity = {w!r}: a 2D body turns about y only")
            if isinstance(body.shape, Plane):
                if body.shape.normal[1] != 0:
                    raise SceneError(f"{where}.shape.normal = {body.shape.normal!r}: a 2D scene's plane is a line "
                                     "in the x-z plane: normal.y must be 0")
            elif body.orientation[1] != 0 or body.orientation[3] != 0:
                raise SceneError(f"{where}.orientation = {body.orientation!r}: a 2D body turns about y only "
                                 "(quaternion x and z must be 0)")
        if self.gravity[1] != 0:
            raise SceneError(f"gravity = {self.gravity!r}: a 2D scene lies in the x-z plane: gravity.y must be 0")


# --- small helpers cases use to build scenes ----------------------------------------------

def ball(radius: float, dimension: int = 3) -> Sphere | Circle:
    """A sphere in a 3D scene, a disc in a 2D one."""
    return Sphere(radius) if dimension == 3 else Circle(radius)


def cube(half: float, dimension: int = 3) -> Box | Rect:
    """A cube of half-extent `half` in a 3D scene, a square in a 2D one."""
    return Box((half, half, half)) if dimension == 3 else Rect((half, half))


def quat_about_y(angle: float) -> tuple[float, float, float, float]:
    """Rotation by `angle` (rad) about +y as a (w, x, y, z) quaternion."""
    return (math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0)


def ground(name: str = "ground") -> Body:
    """The static half-space z <= 0."""
    return Body(name, Plane(), static=True)


def tilted_gravity(theta: float, g: float = 9.81) -> tuple[float, float, float]:
    """Gravity of an incline at angle theta (rad), with the incline as the plane z = 0:
    the downhill direction is +x."""
    return (g * math.sin(theta), 0.0, -g * math.cos(theta))
