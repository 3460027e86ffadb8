"""MuJoCo adapter: a scene becomes one MJCF string; contact is MuJoCo's soft constraint.

MuJoCo has no coefficient of restitution. Every contact row is a unilateral
spring-damper in constraint space, and e is mapped onto it: k = w^2, b = 2 zeta w with
w = pi / (n dt) for a contact lasting about n steps, zeta from the spring-damper that lets
go when its force reaches zero (`restitution_of_damping_ratio`). n trades rebound accuracy
(error ~ 1/n) for penetration (~ v n dt / pi): the adapter's accuracy knob, in `knobs`.

Every pair of the scene that may touch is an explicit `<pair>`, and geoms collide with
nothing else (contype = conaffinity = 0). A `<pair>` states its own friction, condim and
solref, so any pair table of the scene is reproduced exactly; MuJoCo's geom combination
(friction max, solref averaged by solmix, condim max) cannot give two pairs that share a
body different e at all. `adapters.combination` is therefore not needed here.

Shapes (`_geom`): capsules and cylinders are MuJoCo's own, along the body's z; a hull (and
a 2D polygon's prism) a mesh geom of its corners, which MuJoCo collides as their convex hull,
the shape itself (vertices kept in float32); a static mesh one convex prism a triangle
(`_mesh_geoms`: MuJoCo would take a whole mesh's convex hull, which fills every hollow).
Bodies carry the scene's mass and principal inertia (<inertial>, inertiafromgeom false),
never MuJoCo's from the geoms. General convex pairs run on MuJoCo's native GJK/EPA with
several contacts a pair (the flags nativeccd, multiccd: MuJoCo 4's defaults, stated).

Speculative contacts ("mujoco-speculative", `speculative=True`): MuJoCo 4.0.0's flag
speculative, off in the other configurations. A fast geom's broad phase is grown by its
motion over the step, the time of impact found by conservative advancement, and the contact
given a distance that makes the solver arrest the approach by the step's end. MuJoCo has
no swept CCD of its own (`nativeccd` and `multiccd` name its convex collision routines).
Measured (cases/robustness/tunnelling.py): the 2 cm ball at 50-100 m/s is stopped from 1.75
and 5 cm in front of the free plate, momentum kept to 2e-14 and no energy gained; without
the flag it passes at both gaps. In a default run the configuration takes the families
tagged "swept" only (`default_tags`).

Compliant contact: a pair whose material has the Hooke law (cases.scene.Compliance,
F = k xi per contact point, elastic, no damping) is the same soft constraint with no
damping and the impedance at MuJoCo's floor, see `hooke_row`: each contact row then
pushes with k xi, exactly for a contact alone on its bodies and to O(1e-4) of the force
where contacts share a body (9e-5 of the peak force in a touching cradle) or an
external force acts (1e-4 of that force: a body resting under gravity is pushed with
k xi + 1e-4 m g). The Hertz law (F ~ xi^1.5) has no counterpart: the reference acceleration is linear in the overlap,
and a position-dependent impedance d(r) only multiplies a lone contact's force by
(d(r)/dmax)^2, with d(r) - dmin ~ r^p, p >= 1 (solimp[4] is clamped to >= 1) over a
finite width: xi^1.5 would need d ~ xi^0.25.
"""
from __future__ import annotations

import functools
import math
import re
from dataclasses import replace
from importlib import metadata
from types import SimpleNamespace
from xml.sax.saxutils import quoteattr

import numpy as np

from adapters.base import Adapter, Capabilities, Settings, Simulation, Tunable, Unsupported
from adapters.lazy import require
from adapters.joints import closing_ball_points, joint_tree
from adapters.frames import about_y_many
from adapters.solids import polygon_prism, triangle_prisms, width_half_depth
from cases import rotations
from cases.scene import (Body, Box, Capsule, Circle, Cylinder, Hull, Joint, Mesh, Plane, Polygon, Rect, Scene, Sphere,
                         pair_key)
from cases.trajectory import ContactPoint

# mujoco (~0.15 s to import) is imported when a scene is first built (adapters/lazy.py)
require("mujoco")  # not installed: ImportError now, so the registry reports it
mujoco = None      # the module, bound by _import_mujoco()


def _import_mujoco() -> None:
    global mujoco
    if mujoco is None:
        import mujoco as module
        mujoco = module

_ROWS = np.arange(3)  # an elliptic contact's efc rows: normal, tangent 1, tangent 2

# Contact lasts about n = 16 steps: worst |rebound ratio - e| 0.03 (e = 0.5), peak
# penetration ~ v n dt / pi (23 mm at 4.4 m/s, dt = 1e-3). Error falls as 1/n and depth
# grows as n: this is the speed/accuracy axis (measured, see the adapter's report).
CONTACT_STEPS = 16

# MuJoCo's own default cap; the Newton solver stops at `tolerance` long before it (a
# five-box stack converges in 1 iteration, measured).
ITERATIONS = 100
TOLERANCE = 1e-8  # MuJoCo's default, stated

# Constant impedance d = dmin = dmax = 0.99. With the direct (negative) solref form MuJoCo
# divides k by dmax^2 and b by dmax and multiplies back by d, so a contact row obeys
# a = -b v - k r + (1 - d) a_free exactly: 1 % of the unconstrained acceleration leaks
# through (a body resting under gravity sits 0.01 g / k deep, 2.5 um at n = 16).
SOLIMP = (0.99, 0.99, 0.001, 0.5, 2.0)

# Friction: elliptic cone, friction rows 100x less regularised than normal rows
# (impratio): a box 1 deg below the incline threshold creeps < 0.003 mm/s (pyramidal cone,
# impratio 1: ~0.26 mm/s).
CONE = "elliptic"
IMPRATIO = 100.0

# The "mujoco-defaults" variant (MuJoCoAdapter(defaults="all"), adapters/registry.py): what a
# user gets who writes the scene's physics into MJCF and tunes nothing. Reverted to MuJoCo's
# own defaults (checked against MjModel of an empty <pair>, mujoco 4.0.0): the cone
# (pyramidal), impratio (1), every rigid pair's solimp (0.9 0.95 0.001 0.5 2) and its
# solreffriction (0 0: the friction rows share the normal row's solref), and the solref of a
# pair with e = 0 ((0.02, 1): critically damped over 20 ms), where the scene asks for no
# bounce and a user leaves the contact alone. Kept, because the scene asks for them: a pair
# with e > 0 gets the solref of the e mapping (MuJoCo has no coefficient and no default that
# bounces, so a user must set solref; the mapping is how), Hooke pairs their own row
# (hooke_row: the law is the scene's), friction coefficients and condim 1 for frictionless
# pairs, and the effect switches (gravity, contact), which are what the scene simulates,
# not tuning. Solver, iterations, tolerance, line search, noslip, integrator, warm start and
# sleeping are MuJoCo's defaults in both configurations; autoreset stays off in both (a
# blown-up state must stay visible to the harness).
# Each knob can revert on its own (MuJoCoAdapter(defaults=...)), which is how the causes of
# the variant's deviations were measured (adapters/xfails/mujoco-defaults.txt).
DEFAULTABLE = ("cone", "impratio", "solimp", "solreffriction", "solref")
DEFAULT_CONE = "pyramidal"
DEFAULT_IMPRATIO = 1.0
DEFAULT_SOLREF = (0.02, 1.0)
DEFAULT_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)

# Friction rows remove slip over the contact's own time scale, n dt (solreffriction
# b = 1/(n dt), no stiffness): one time scale for the whole contact, as MuJoCo's default
# (solreffriction = solref) intends. A finding, recorded as a deviation: MuJoCo's convex
# model lifts a sliding contact, projecting the slip it cannot remove inside the cone
# partly onto the normal (~ mu v_t / (m (1 + mu^2)) per step when slip is removed over m
# steps), so boxes chatter while sliding: at m = 1 (the rigid limit) a ball sliding at
# 2 m/s hops 33 mm; at m = n = 16 the incline grid's worst sliding-acceleration error is
# 0.065 m/s^2 (0.083 at m = 1, 0.044 at m = 10: no m reaches the 0.01 tolerance, and m is
# not tuned to the cases).


# --- e onto the contact spring-damper ---------------------------------------------------

def restitution_of_damping_ratio(zeta: float) -> float:
    """Rebound ratio e of a mass hitting a spring-damper that cannot pull.

    In time units of 1/w (tau = w t) the penetration x obeys x'' + 2 zeta x' + x = 0 with
    x(0) = 0, x'(0) = v. The contact force, proportional to x + 2 zeta x', falls to zero
    while x > 0; there the body lets go with x' < 0, so e = -x'(tau*) / v.
    Underdamped (s = sqrt(1 - zeta^2)): x = v/s e^(-zeta tau) sin(s tau), and
    x + 2 zeta x' = 0 gives tan(s tau*) = -2 zeta s / (1 - 2 zeta^2), i.e.
    th = s tau* = pi - atan2(2 zeta s, 1 - 2 zeta^2), e = -exp(-zeta th/s) (cos th - zeta/s sin th).
    Overdamped (r1,2 = -zeta +- sqrt(zeta^2 - 1), so 1 + 2 zeta r = -r^2): release at
    r1^2 e^(r1 tau) = r2^2 e^(r2 tau), tau* = 2 ln(r2/r1) / (r1 - r2).
    Both branches give e^-2 at zeta = 1. The textbook log-decrement zeta (release at x = 0)
    is another model: it overestimates e by ~0.05 at e = 0.5 (measured).
    """
    if zeta < 1.0:
        s = math.sqrt(1.0 - zeta * zeta)
        th = math.pi - math.atan2(2.0 * zeta * s, 1.0 - 2.0 * zeta * zeta)
        return -math.exp(-zeta * th / s) * (math.cos(th) - zeta / s * math.sin(th))
    if zeta == 1.0:
        return math.exp(-2.0)
    q = math.sqrt(zeta * zeta - 1.0)
    r2 = -zeta - q
    r1 = 1.0 / r2  # = -zeta + q, without the cancellation at large zeta
    tau = 2.0 * math.log(r2 / r1) / (r1 - r2)
    return -(r1 * math.exp(r1 * tau) - r2 * math.exp(r2 * tau)) / (r1 - r2)


def damping_ratio_of_restitution(e: float) -> float:
    """Inverse of `restitution_of_damping_ratio` by bisection (e falls as zeta grows).
    e = 0 needs infinite damping: math.inf."""
    if e <= 0.0:
        return math.inf
    if e >= 1.0:
        return 0.0
    lo, hi = 0.0, 1.0
    while restitution_of_damping_ratio(hi) > e:
        lo, hi = hi, 2.0 * hi
    while hi - lo > 1e-14 * hi:
        mid = 0.5 * (lo + hi)
        if restitution_of_damping_ratio(mid) > e:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def contact_spring_damper(e: float, n: float, dt: float) -> tuple[float, float]:
    """(k, b) of a contact row: k = w^2, b = 2 zeta w, w = pi / (n dt). b is capped at 1/dt,
    which removes the whole normal velocity in one explicit step (more would reverse it):
    the value for e = 0 and the limit for very small e."""
    w = math.pi / (n * dt)
    return w * w, min(2.0 * damping_ratio_of_restitution(e) * w, 1.0 / dt)


# --- Hooke's law onto the contact row -------------------------------------------------------
# MuJoCo's soft contact (src/engine/engine_core_constraint.c, mj_makeImpedance and the
# aref of mj_referenceConstraint; the Newton solver's optimality condition): a frictionless
# contact row with direct solref (-K, -B) and constant impedance d = dmin = dmax takes the
# force f solving, over all active rows at once,
#     (A + R) f = aref - J a0,   R = (1 - d)/d D,   aref = -(K/d) r - (B/d) v,
# with A = J M^-1 J^T, D its approximation from body_invweight0 (mj_diagApprox: the two
# bodies' translational inverse weights), r = dist (< 0 in overlap), a0 the acceleration
# without contact. Multiplied by d:  (D + d (A - D)) f = -K r - B v - d J a0.
# With B = 0 and K = k D the row pushes with f = k xi (xi = -r), up to d (A - D) f and
# d J a0: for a lone contact whose D is its A (spheres on slide or free joints) exactly,
# at any d; where contacts share a body (A has off-diagonal terms) or A has lever arms
# D ignores, and where external forces act (a0), by O(d). So d sits at MuJoCo's floor,
# mjMINIMP = 1e-4 (getsolparam clamps solimp to it): the residual cannot go lower.
# Larger d makes the rows prescribe accelerations instead of forces (d -> 1: A f = aref),
# which couples touching contacts: d = 0.99 puts the cradle's balls 0.48 m/s off.
HOOKE_IMPEDANCE = 1e-4  # = mjMINIMP
HOOKE_SOLIMP = (HOOKE_IMPEDANCE, HOOKE_IMPEDANCE, 0.001, 0.5, 2.0)  # flat: width unused


def hooke_row(k: float, invweight: float) -> dict:
    """MJCF attributes of a frictionless contact row pushing with F = k xi: solref
    (-k D, 0) (direct form, no damping), D = invweight the sum of the two bodies'
    translational body_invweight0 (MuJoCo's D of the row), impedance at its floor."""
    return {"solref": [-k * invweight, 0.0], "solimp": list(HOOKE_SOLIMP), "condim": 1,
            "friction": [0, 0, 0, 0, 0]}


# Contact torques (cases.scene.Material.rolling_resistance, torsional_friction): MuJoCo's
# torsional coefficient friction[2] (condim 4 and 6) and rolling coefficients friction[3:5]
# (condim 6) are lengths, the scene's lever arms, taken as they are. In the elliptic cone
# they share one cone with sliding friction: f_n >= |(f_t1 / mu, f_t2 / mu, tau_n / d_t,
# tau_r1 / d_r, tau_r2 / d_r)|, so a rolling ball that also needs a friction force gets
# slightly less than d_r N (by (F / mu N)^2 / 2: 2.6e-3 of it in cases/rolling_resistance.py).
# MuJoCo clamps every coefficient to at least mjMINMU = 1e-5 (engine_collision_driver.c):
# condim 6 for rolling resistance alone realises a torsional friction of 1e-5 m nobody
# asked for (reported in Simulation.effects), and a torque on a frictionless pair would
# realise sliding friction 1e-5 (turned away: `_torques_unrepresentable`).
MJMINMU = 1e-5


def _condim(mat) -> int:
    """3 (sliding friction), 4 (and torsional), 6 (and rolling) for a frictional pair."""
    return 6 if mat.rolling_resistance > 0 else 4 if mat.torsional_friction > 0 else 3


def _torques_unrepresentable(scene: Scene) -> str | None:
    for a, b in scene.contact_pairs():
        mat = scene.material_of(a.name, b.name)
        if not mat.frictional and (mat.rolling_resistance > 0 or mat.torsional_friction > 0):
            return (f"{a.name}/{b.name}: a contact torque on a frictionless pair: MuJoCo's torque rows come with "
                    f"condim 4/6, whose sliding friction it clamps to at least mjMINMU = {MJMINMU:g}")
    return None


def _hooke_unrepresentable(scene: Scene) -> str | None:
    for a, b in scene.contact_pairs():
        mat = scene.material_of(a.name, b.name)
        c = mat.compliance
        if c is None or c.law != "hooke":
            continue
        if mat.e != 1.0:
            return (f"{a.name}/{b.name}: Hooke contact with e = {mat.e:g}: F = k xi is elastic (e = 1); "
                    "a damped compliant contact is another law")
        if mat.frictional:
            return (f"{a.name}/{b.name}: Hooke contact with friction: MuJoCo's friction rows share the "
                    "normal row's cone, and a sliding contact's normal force is then not k xi")
    return None


# --- what this MuJoCo release's MJCF knows ------------------------------------------------------
# The adapter writes one MJCF for every supported release (MuJoCoAdapter.supported) and asks the
# release itself what its parser accepts, instead of keeping a table of version numbers: the
# schema MuJoCo prints (mj_printSchema) names every element and its attributes.

_SCHEMA_ELEMENT = re.compile(r"^( *)(\S+) \(.\)(.*)$")  # "   option (*)   timestep ...": 3 spaces a level


@functools.cache
def mjcf_schema() -> dict[str, frozenset[str]]:
    """Every element of this release's MJCF by its path below <mujoco> ("option/flag",
    "contact/pair", "(world)body/freejoint"), with the attributes its parser accepts. Read
    once a process."""
    _import_mujoco()
    out: dict[str, set[str]] = {}
    path: list[str] = []
    for line in mujoco.mj_printSchema(False, False).splitlines():
        element = _SCHEMA_ELEMENT.match(line)
        if element:  # an element and the first of its attributes; continuation lines hold more
            path = path[:len(element.group(1)) // 3] + [element.group(2)]
            line = element.group(3)
        out.setdefault("/".join(path[1:]), set()).update(line.split())
    return {k: frozenset(v) for k, v in out.items()}


# Attributes written only where the release knows them. Leaving one out asks for the same
# physics, because a release without the attribute lacks what it switches off (MuJoCo's
# changelog). Every other attribute the adapter writes is in every supported release; one that
# is not makes the compiler reject the scene (Unsupported, naming it).
ABSENT_MEANS = {
    "option/flag/sleep": "no sleeping before MuJoCo 3.4.0",
    "option/flag/speculative": "no speculative contacts before MuJoCo 4.0.0",
    "compiler/alignfree": "no free-joint alignment before MuJoCo 3.2.3",
    "(world)body/freejoint/align": "no free-joint alignment before MuJoCo 3.2.3",
    "contact/pair/adhesion": "no contact adhesion before MuJoCo 3.11.0",
}


def _known(path: str, attrs: dict, left_out: dict) -> dict:
    """`attrs` of the element at `path` less the ABSENT_MEANS attributes this release does not
    know, each noted in `left_out` (the knob of that name) with why that changes nothing."""
    known = mjcf_schema().get(path, frozenset())
    drop = [a for a in attrs if a not in known and f"{path}/{a}" in ABSENT_MEANS]
    for a in drop:
        left_out[f"{path}/{a}"] = ABSENT_MEANS[f"{path}/{a}"]
    return {k: v for k, v in attrs.items() if k not in drop} if drop else attrs


# --- MJCF ----------------------------------------------------------------------------------

def _num(x: float) -> str:
    return format(float(x), ".17g")


def _vec(xs) -> str:
    return quoteattr(" ".join(_num(x) for x in xs))


def _rotate(quat, v) -> tuple[float, float, float]:
    """v turned by the unit quaternion (w, x, y, z): v + w t + u x t with t = 2 u x v."""
    w, x, y, z = quat
    vx, vy, vz = v
    tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
    return (vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx)


# ground="box": a scene Plane becomes a static box this large, its top face on the plane
GROUND_HALF_WIDTH = 100.0     # m: wider than any scene travels
GROUND_HALF_THICKNESS = 1.0   # m: thicker than any body moves in one step
GROUNDS = ("plane", "box")


def _geom(body: Body, quat, ground: str = "plane", meshes: dict | None = None) -> dict:
    """MJCF attributes of a body's collision geom (one geom per body but a Mesh's: `_geoms`).
    2D shapes become solids in the plane y = 0: a circle a sphere (every contact a planar
    scene makes lies in y = 0, where the sphere's section is the disc, and sphere collisions
    are analytic; MuJoCo's cylinder pairs go through general convex collision, whose normals
    are ~0.1 deg off), a rect a box and a polygon a prism, as deep along y as they are wide.
    A capsule and a cylinder are MuJoCo's own, whose axis is the geom's z, as the scene's
    (size: radius, half-length). A hull and a polygon's prism are mesh geoms of their corners
    (`_mesh_asset`, into `meshes`), which MuJoCo collides as their convex hull, the shape
    itself."""
    s = body.shape
    if isinstance(s, Plane):
        # MuJoCo's plane is z = 0 of its frame, solid below it: put that frame on the
        # scene's plane n . x = offset (a plane is its normal and offset, as in cases.overlap)
        n = np.asarray(s.normal, float)
        if ground == "box":  # its frame GROUND_HALF_THICKNESS below the plane, z along n
            return {"type": "box", "size": [GROUND_HALF_WIDTH, GROUND_HALF_WIDTH, GROUND_HALF_THICKNESS],
                    "pos": list((s.offset - GROUND_HALF_THICKNESS) * n), "zaxis": list(n)}
        return {"type": "plane", "size": [0, 0, 1], "pos": list(s.offset * n), "zaxis": list(n)}
    if isinstance(s, (Sphere, Circle)):
        return {"type": "sphere", "size": [s.radius]}
    if isinstance(s, Box):
        return {"type": "box", "size": list(s.half_extents), "quat": list(quat)}
    if isinstance(s, Rect):
        a, c = s.half_extents
        return {"type": "box", "size": [a, a, c], "quat": list(quat)}
    if isinstance(s, (Capsule, Cylinder)):
        return {"type": s.kind, "size": [s.radius, s.half_length], "quat": list(quat)}
    if isinstance(s, Hull):
        return {"type": "mesh", "mesh": _mesh_asset(meshes, body.name, s.vertices), "quat": list(quat)}
    if isinstance(s, Polygon):
        half_depth = width_half_depth(s.corners)
        return {"type": "mesh", "mesh": _mesh_asset(meshes, body.name, polygon_prism(s.corners, half_depth)[0]),
                "quat": list(quat)}
    raise Unsupported(f"shape {s.kind} has no MuJoCo geom in this adapter")


# A mesh asset's convex hull keeps every vertex (MuJoCo's default, stated: no vertex limit).
MAXHULLVERT = -1


def _mesh_asset(meshes: dict, name: str, vertices) -> str:
    """Add a <mesh> of `vertices` (in its geom's frame) to `meshes` under `name`; its name.
    MuJoCo keeps a mesh's vertices in float32 (mjModel.mesh_vert: 6e-8 of their size), and
    its compiler moves a mesh into its own centroid and principal axes and offsets the geom
    by as much, so the solid stays where the vertices put it."""
    meshes[name] = {"name": name, "vertex": [float(c) for v in vertices for c in v], "scale": [1.0, 1.0, 1.0],
                    "maxhullvert": MAXHULLVERT}
    return name


def _geom_names(body: Body) -> list[str]:
    """The names of a body's geoms: its own, or one per triangle of a Mesh (name#k)."""
    if isinstance(body.shape, Mesh):
        return [f"{body.name}#{k}" for k in range(len(body.shape.triangles))]
    return [body.name]


def _mesh_geoms(body: Body, meshes: dict) -> tuple[list[dict], dict]:
    """A static Mesh as geoms MuJoCo can collide with. MuJoCo collides a mesh geom as its
    convex hull, which fills every hollow of a mesh that is not convex (a ground of any relief
    becomes the solid under its highest points; a flat one, no solid at all), so each triangle
    is a mesh geom of its own: its prism, the triangle extruded into the solid
    (adapters.solids.triangle_prisms: up to PRISM_DEPTH deep, less where the solid behind is
    thinner). Their union has the mesh's surface on the side the bodies are on; a body
    crossing a seam between triangles meets the prisms' side faces only while it overlaps
    the top less than it crosses the seam. Returns the geoms and the record."""
    prisms, depths = triangle_prisms(body.shape.vertices, body.shape.triangles)
    geoms = [{"name": name, "type": "mesh", "mesh": _mesh_asset(meshes, name, prism),
              "pos": list(body.position), "quat": list(body.orientation)}
             for name, prism in zip(_geom_names(body), prisms)]
    record = {"mesh geoms": f"{len(geoms)} triangle prisms {body.name}#0..{body.name}#{len(geoms) - 1}",
              "prism depth, m": {"largest": max(depths), "least": min(depths)},
              "pos": list(body.position), "quat": list(body.orientation)}
    return geoms, record


def _element(tag: str, attrs: dict, inner: str = "") -> str:
    text = " ".join(f"{k}={_vec(v) if isinstance(v, (list, tuple)) else quoteattr(str(v))}"
                    for k, v in attrs.items())
    return f"<{tag} {text}>{inner}</{tag}>"


# Joints of a dynamic body held in the x-z plane or from rotating: (type, world axis).
_SLIDES_3D = (("slide", (1, 0, 0)), ("slide", (0, 1, 0)), ("slide", (0, 0, 1)))
_SLIDES_2D = (("slide", (1, 0, 0)), ("slide", (0, 0, 1)))
_HINGE_Y = (("hinge", (0, 1, 0)),)


def _joints(body: Body, dimension: int):
    """'free' for a 3D body that rotates, else its (type, world axis) joints."""
    if dimension == 3:
        return "free" if body.rotates else _SLIDES_3D
    return _SLIDES_2D + (_HINGE_Y if body.rotates else ())


def _body_xml(body: Body, dimension: int, knobs: dict, ground: str = "plane", meshes: dict | None = None) -> str:
    q0 = list(body.orientation)
    no_collide = {"contype": 0, "conaffinity": 0}  # collisions come from <pair> only
    if isinstance(body.shape, Mesh):  # static only (cases.scene)
        geoms, knobs["geom"][body.name] = _mesh_geoms(body, meshes)
        return "".join(_element("geom", {**g, **no_collide}) for g in geoms)
    if body.static:
        geom = _geom(body, q0, ground, meshes)
        if not isinstance(body.shape, Plane):
            geom["pos"] = list(body.position)
        geom = {"name": body.name, **geom, **no_collide}
        knobs["geom"][body.name] = geom
        return _element("geom", geom)
    joints = _joints(body, dimension)
    if joints == "free":
        # the body frame is the scene body's frame and carries the inertia, so the free
        # joint's qpos and qvel describe the body itself (align="false" keeps it so)
        frame = {"name": body.name, "pos": list(body.position), "quat": q0}
        geom = {"name": body.name, **_geom(body, [1, 0, 0, 0], meshes=meshes), **no_collide}
        joint_xml = _element("freejoint", _known("(world)body/freejoint", {"align": "false"}, knobs["left_out"]))
        inertial = {"pos": [0, 0, 0], "quat": [1, 0, 0, 0]}
        knobs["joint"][body.name] = "free"
    else:
        # a world-aligned frame at the start position: joints slide / turn along world
        # axes, and the geom and inertia carry the body's orientation
        frame = {"name": body.name, "pos": list(body.position)}
        geom = {"name": body.name, **_geom(body, q0, meshes=meshes), **no_collide}
        joint = [{"name": f"{body.name}:{t}{i}", "type": t, "axis": list(axis), "damping": 0,
                  "stiffness": 0, "armature": 0, "frictionloss": 0, "limited": "false"}
                 for i, (t, axis) in enumerate(joints)]
        joint_xml = "".join(_element("joint", j) for j in joint)
        inertial = {"pos": [0, 0, 0], "quat": q0}
        knobs["joint"][body.name] = joint
    inertial.update(mass=body.mass, diaginertia=list(body.principal_inertia))
    knobs["geom"][body.name] = geom
    knobs["inertial"][body.name] = inertial
    return _element("body", frame, joint_xml + _element("inertial", inertial) + _element("geom", geom))


# --- joints (cases.scene.Joint): MuJoCo's kinematic tree --------------------------------------
# MuJoCo is a reduced-coordinate engine: a jointed body is a child <body> of the body it hangs
# on, with the joint's own coordinates as its qpos (a hinge one angle), so a joint holds
# exactly. A fixed joint is a child body with no joint at all (welded). The tree cannot close a
# loop: the joint that would (a body's second joint, or one whose parent hangs on its body) is
# an equality constraint instead, <equality><connect> (_loop_xml).
_JOINT_TYPES = {"revolute": "hinge", "prismatic": "slide", "ball": "ball"}  # "fixed": welded, no joint


def _tree(scene: Scene) -> tuple[dict[str, tuple[str | None, Joint]], list[tuple[int, Joint]]]:
    """Each jointed dynamic body's parent in the tree (None: the world, or a static body)
    and its scene joint, and the joints (index, joint) that close a loop: those the tree
    cannot hold (adapters.joints.joint_tree, which the other reduced-coordinate adapters share)."""
    tree, closing = joint_tree(scene)
    return {name: (tj.parent, tj.joint) for name, tj in tree.items()}, closing


# A loop's closing joint is MuJoCo's <connect>: it holds the joint's point on both bodies
# together (three rows, a ball joint). That is a revolute joint too where the loop is planar
# (every joint a hinge about the same axis, or welded): the tree's hinges already keep the two
# bodies from turning about any other axis, and connect's row along the axis is redundant.
# Other closing joints (prismatic, fixed, a non-planar revolute) are not mapped.
# An equality is a soft constraint: its solref makes the gap a spring-damper, which each
# step's second-order drift (cases/four_bar.py, loop_gap) loads, so the loop stays open by
# about that drift over k dt^2. Measured on four_bar (dt 1e-3, the largest gap over 1 s and the
# rocker's miss of Freudenstein's equation): MuJoCo's default solref (0.02 1): 0.81 mm, 2.0e-3
# rad; the plastic contact's row over 16 steps (-38553 -1000): 0.59 mm, 1.9e-3 rad; solref
# (2 dt, 1), the stiffest time constant MuJoCo's documentation calls stable: 0.11 mm, 3.7e-4
# rad. solimp does not matter here (0.9-0.95 or 0.9999: the same gap to 1 %): the impedance
# scales the force the gap needs, which its d of 0.9 or more leaves near the rigid one.
# The loop gets solref (2 dt, 1) and the adapter's SOLIMP; "mujoco-defaults" MuJoCo's own.
LOOP_TIME_STEPS = 2.0  # solref's time constant, in steps: MuJoCo's stable minimum


def _loop_xml(scene: Scene, closing: list[tuple[int, Joint]], knobs: dict, dt: float, defaults: frozenset) -> str:
    """The <equality> of the joints that close a loop (_tree), one <connect> each, recorded
    in knobs["loop"]; Unsupported for a closing joint connect does not hold."""
    if not closing:
        return ""
    row = {"solref": list(DEFAULT_SOLREF) if "solref" in defaults else [LOOP_TIME_STEPS * dt, 1.0],
           "solimp": list(DEFAULT_SOLIMP if "solimp" in defaults else SOLIMP)}
    out = []
    closing_ball_points(scene, closing, "MuJoCo's connect")  # Unsupported for a loop connect does not close
    for j, joint in closing:
        body = scene.body(joint.body)
        anchor, _ = _relative(body, joint.anchor)
        spec = {"name": f"loop{j}", "body1": joint.body, "anchor": anchor, **row}
        up = None if joint.parent is None or scene.body(joint.parent).static else joint.parent
        if up is not None:
            spec["body2"] = up
        out.append(_element("connect", spec))
        knobs["loop"][f"joints[{j}]"] = {**spec, "kind": joint.kind, "mjcf": "equality/connect"}
    return _element("equality", {}, "".join(out))


def _relative(frame: Body | None, point, quat=None) -> tuple[list, list | None]:
    """A world point (and orientation) in the frame of `frame`'s start pose (None: world)."""
    if frame is None:
        return list(point), (None if quat is None else list(quat))
    inverse = rotations.conjugate(frame.orientation)
    local = _rotate(inverse.tolist(), (np.asarray(point, float) - frame.position).tolist())
    if quat is None:
        return list(local), None
    q = np.zeros(4)
    mujoco.mju_mulQuat(q, inverse, np.asarray(quat, float))
    return list(local), q.tolist()


def _limit_row(e: float, n: float, dt: float) -> dict:
    """A joint limit is a contact-like constraint row: the spring-damper over n steps that
    gives a contact restitution e (contact_spring_damper; e = 0: plastic, b = 1/dt), here the
    joint's restitution at its limit (Joint.limit_e), and the contact's impedance."""
    k, b = contact_spring_damper(e, n, dt)
    return {"solreflimit": [-k, -b], "solimplimit": list(SOLIMP)}


def _tree_body_xml(scene: Scene, body: Body, tree: dict, children: dict, knobs: dict, meshes: dict,
                   n: float, dt: float) -> str:
    """The <body> of a dynamic body and, nested in it, those hanging on it: its frame the
    scene body's frame (relative to its parent's start pose), so xpos and xquat are its
    position and orientation; its joint from the scene joint, or free (3D) or planar (2D)."""
    up, joint = tree.get(body.name, (None, None))
    above = None if up is None else scene.body(up)
    pos, quat = _relative(above, body.position, body.orientation)
    frame = {"name": body.name, "pos": pos, "quat": quat}
    inverse = rotations.conjugate(body.orientation).tolist()
    off = {"damping": 0, "stiffness": 0, "armature": 0, "frictionloss": 0}
    if joint is None and scene.dimension == 3:
        joints = [_element("freejoint", _known("(world)body/freejoint", {"align": "false"}, knobs["left_out"]))]
        knobs["joint"][body.name] = "free"
    elif joint is None:  # a free 2D body: slides along world x and z, a hinge about world y
        spec = [{"name": f"{body.name}:{t}{i}", "type": t, "axis": list(_rotate(inverse, axis)), **off,
                 "limited": "false"} for i, (t, axis) in enumerate(_SLIDES_2D + _HINGE_Y)]
        joints = [_element("joint", j) for j in spec]
        knobs["joint"][body.name] = spec
    elif joint.kind == "fixed":
        joints = []
        knobs["joint"][body.name] = {"kind": "fixed", "on": up or "world", "mjcf": "child body without a joint"}
    else:
        spec = {"name": f"{body.name}:{joint.kind}", "type": _JOINT_TYPES[joint.kind],
                "pos": list(_rotate(inverse, (np.asarray(joint.anchor) - body.position).tolist())), **off}
        if joint.kind != "ball":
            spec["axis"] = list(_rotate(inverse, joint.unit_axis))
        if joint.limits is not None:
            spec.update(limited="true", range=list(joint.limits), **_limit_row(joint.limit_e, n, dt))
        else:
            spec["limited"] = "false"
        if joint.friction > 0:  # dry friction: a frictionloss row, slip removed over n dt as the pairs' friction rows
            spec.update(frictionloss=joint.friction, solreffriction=[0, -1.0 / (n * dt)], solimpfriction=list(SOLIMP))
        joints = [_element("joint", spec)]
        knobs["joint"][body.name] = {**spec, "on": up or "world"}
    geom = {"name": body.name, **_geom(body, [1, 0, 0, 0], meshes=meshes), "contype": 0, "conaffinity": 0}
    inertial = {"pos": [0, 0, 0], "quat": [1, 0, 0, 0], "mass": body.mass, "diaginertia": list(body.principal_inertia)}
    knobs["geom"][body.name] = geom
    knobs["inertial"][body.name] = inertial
    inner = "".join(_tree_body_xml(scene, c, tree, children, knobs, meshes, n, dt) for c in children.get(body.name, ()))
    return _element("body", frame, "".join(joints) + _element("inertial", inertial) + _element("geom", geom) + inner)


def _tree_xml(scene: Scene, knobs: dict, ground: str, meshes: dict, n: float, dt: float) -> tuple[str, list]:
    """The worldbody's content of a scene with joints or loads: static bodies as _body_xml
    writes them, dynamic bodies as a kinematic tree (_tree_body_xml); and the joints that
    close a loop (_tree), for _loop_xml."""
    for body in scene.dynamic_bodies:
        if not body.rotates:
            raise Unsupported(f"body {body.name!r} held from rotating (rotates=False) in a scene with joints or "
                              "loads: not mapped (its slides would need the tree's frames)")
    tree, closing = _tree(scene)
    children: dict[str, list[Body]] = {}
    for body in scene.dynamic_bodies:
        if tree.get(body.name, (None,))[0] is not None:
            children.setdefault(tree[body.name][0], []).append(body)
    static = "".join(_body_xml(b, scene.dimension, knobs, ground, meshes) for b in scene.bodies if b.static)
    roots = [b for b in scene.dynamic_bodies if tree.get(b.name, (None,))[0] is None]
    return static + "".join(_tree_body_xml(scene, b, tree, children, knobs, meshes, n, dt) for b in roots), closing


def _pair_xml(scene: Scene, n: float, dt: float, knobs: dict, invweight: dict | None,
              defaults: frozenset = frozenset()) -> str:
    out = []
    for a, b in scene.contact_pairs():
        mat = scene.material_of(a.name, b.name)
        # one <pair> per two geoms (a Mesh has one a triangle), all alike
        geoms = [(g1, g2) for g1 in _geom_names(a) for g2 in _geom_names(b)]
        named = {} if len(geoms) == 1 else {"geom1": _named(a), "geom2": _named(b)}
        if mat.compliance is not None:  # Hooke (capabilities turn the others away)
            # invweight None: the first compile, which only reads body_invweight0
            w = 1.0 if invweight is None else invweight[a.name] + invweight[b.name]
            pair = _known("contact/pair", {"geom1": a.name, "geom2": b.name, **hooke_row(mat.compliance.k, w),
                                           "margin": 0, "gap": 0, "adhesion": 0}, knobs["left_out"])
            knobs["pair"]["|".join(pair_key(a.name, b.name))] = {
                **pair, **named, "e": mat.e, "law": "hooke", "k": mat.compliance.k, "invweight": w}
            out.extend(_element("pair", {**pair, "geom1": g1, "geom2": g2}) for g1, g2 in geoms)
            continue
        k, damping = contact_spring_damper(mat.e, n, dt)
        solref = [-k, -damping] if "solref" not in defaults or mat.e > 0 else list(DEFAULT_SOLREF)
        pair = _known("contact/pair", {"geom1": a.name, "geom2": b.name, "solref": solref,
                                       "solimp": list(DEFAULT_SOLIMP if "solimp" in defaults else SOLIMP),
                                       "margin": 0, "gap": 0, "adhesion": 0}, knobs["left_out"])
        if mat.frictional:  # one coefficient: capabilities turn away mu_k != mu_s
            pair.update(condim=_condim(mat), friction=[mat.mu_s, mat.mu_s, mat.torsional_friction,
                                                       mat.rolling_resistance, mat.rolling_resistance],
                        solreffriction=[0, 0] if "solreffriction" in defaults else [0, -1.0 / (n * dt)])
        else:  # no friction rows at all
            pair.update(condim=1, friction=[0, 0, 0, 0, 0])
        zeta = damping_ratio_of_restitution(mat.e)
        knobs["pair"]["|".join(pair_key(a.name, b.name))] = {
            **pair, **named, "e": mat.e, "zeta": zeta if math.isfinite(zeta) else None,
            "damping_capped_at_1_over_dt": math.isclose(damping * dt, 1.0) and solref[0] < 0}
        out.extend(_element("pair", {**pair, "geom1": g1, "geom2": g2}) for g1, g2 in geoms)
    return "".join(out)


def _named(body: Body) -> str:
    """A body's geoms as the pair record names them."""
    names = _geom_names(body)
    return names[0] if len(names) == 1 else f"{names[0]}..{names[-1]} (one pair each)"


def scene_mjcf(scene: Scene, settings: Settings, iterations: int, n: float,
               invweight: dict | None = None, ground: str = "plane",
               defaults: frozenset = frozenset(), speculative: bool = False) -> tuple[str, dict]:
    """The MJCF of `scene` and the knobs it sets, by MJCF element and attribute name.
    `invweight`: each body's translational body_invweight0 (0 for static ones), which
    Hooke pairs need (`hooke_row`); None where no pair is Hooke (or to compile once and
    read it). `ground`: a scene Plane as a MuJoCo plane or a large box (`GROUNDS`).
    `defaults`: the knobs of DEFAULTABLE left at MuJoCo's defaults (the module notes, "mujoco-defaults").
    `speculative`: MuJoCo's speculative contacts on (flag speculative, "mujoco-speculative"; Unsupported
    on a release without them)."""
    option = {"timestep": settings.dt, "gravity": list(scene.gravity), "integrator": "Euler",
              "solver": "Newton", "iterations": iterations, "tolerance": TOLERANCE,
              "ls_iterations": 50, "noslip_iterations": 0, "cone": DEFAULT_CONE if "cone" in defaults else CONE,
              "impratio": DEFAULT_IMPRATIO if "impratio" in defaults else IMPRATIO,
              "density": 0, "viscosity": 0, "wind": [0, 0, 0]}
    left_out = {}  # the ABSENT_MEANS attributes this release does not know
    flag = _known("option/flag", {"gravity": "enable" if "gravity" in scene.effects else "disable",
                                  "contact": "enable" if "contact" in scene.effects else "disable",
                                  "sleep": "disable", "speculative": "enable" if speculative else "disable",
                                  "override": "disable",
                                  "autoreset": "disable",  # a blown-up state stays visible instead of resetting
                                  "warmstart": "enable",
                                  # general convex pairs (capsules, cylinders and meshes against
                                  # most shapes): MuJoCo's own GJK/EPA and several contacts a
                                  # pair (MuJoCo 4's defaults, stated; without multiccd a box on
                                  # a hull has one contact a step); no sphere, box or plane pair
                                  # goes through them
                                  "nativeccd": "enable", "multiccd": "enable"}, left_out)
    if speculative and "option/flag/speculative" in left_out:
        raise Unsupported(f"MuJoCo {metadata.version('mujoco')} has {left_out['option/flag/speculative']}: the "
                          "speculative configuration needs 4.0.0 or later")
    compiler = _known("compiler", {"inertiafromgeom": "false", "alignfree": "false", "angle": "radian"}, left_out)
    knobs = {"compiler": compiler, "option": option, "flag": flag,
             "restitution_map": {"contact_steps_n": n, "w": math.pi / (n * settings.dt),
                                 "k": "w^2", "b": "2 zeta w, at most 1/dt"},
             "friction_slip_steps": "solref (MuJoCo's default: solreffriction 0 0)" if "solreffriction" in defaults else n,
             "mujoco_defaults": sorted(defaults),  # the contact knobs left at MuJoCo's defaults
             **({"hooke_map": {"impedance": HOOKE_IMPEDANCE, "solref": "(-k D, 0): no damping",
                               "D": "sum of the two bodies' body_invweight0 (translational)",
                               "force": "k xi per contact row (condim 1)"}}
                if "hooke" in scene.contact_laws else {}),
             "ground": ground, "joint": {}, "inertial": {}, "geom": {}, "pair": {}, "left_out": left_out}
    meshes: dict[str, dict] = {}  # <mesh> assets by name
    loops = ""
    if scene.joints or scene.loads:
        bodies, closing = _tree_xml(scene, knobs, ground, meshes, n, settings.dt)
        if closing:
            knobs["loop"] = {}
            loops = _loop_xml(scene, closing, knobs, settings.dt, defaults)
    else:
        bodies = "".join(_body_xml(b, scene.dimension, knobs, ground, meshes) for b in scene.bodies)
    pairs = _pair_xml(scene, n, settings.dt, knobs, invweight, defaults)
    if meshes:
        knobs["mesh"] = {"maxhullvert": MAXHULLVERT, "scale": [1.0, 1.0, 1.0],
                         "vertex": "the scene's points in the geom frame", "count": len(meshes)}
    assets = "<asset>" + "".join(_element("mesh", m) for m in meshes.values()) + "</asset>" if meshes else ""
    xml = ('<mujoco model="physval">' + _element("compiler", compiler)
           + _element("option", option, _element("flag", flag)) + assets
           + f"<worldbody>{bodies}</worldbody><contact>{pairs}</contact>{loops}</mujoco>")
    return xml, knobs


# --- the simulation -------------------------------------------------------------------------

def geom_bodies(scene: Scene) -> dict[str, str]:
    """The scene body each geom of `scene_mjcf`'s model belongs to, by geom name."""
    return {g: b.name for b in scene.bodies for g in _geom_names(b)}


def model_effects(m, knobs: dict) -> frozenset[str]:
    """What a compiled MjModel simulates (its flags, pairs and joints), `knobs` the pair
    knobs scene_mjcf wrote: for every implementation that steps such a model (MuJoCo C here,
    Newton's SolverMuJoCo in adapters/newton_engine.py)."""
    _import_mujoco()
    fx = set()
    if not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY and np.any(m.opt.gravity != 0):
        fx.add("gravity")
    if m.npair and not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT:
        fx.add("contact")
        if any(p["e"] > 0 for p in knobs["pair"].values()):
            fx.add("restitution")
        if np.any(m.pair_dim > 1):
            fx.add("friction")
        if np.any(m.pair_dim >= 4):  # realised at >= mjMINMU even where the scene says 0
            fx.add("torsional_friction")
        if np.any(m.pair_dim == 6):
            fx.add("rolling_resistance")
    if np.any(np.isin(m.jnt_type, (mujoco.mjtJoint.mjJNT_FREE, mujoco.mjtJoint.mjJNT_HINGE,
                                   mujoco.mjtJoint.mjJNT_BALL))):
        fx.add("rotation")
    if any(j != "free" and isinstance(j, dict) for j in knobs.get("joint", {}).values()):
        fx.add("joint")  # a scene joint (the tree's records are dicts; a free body's "free", a planar one's list)
    if np.any(m.jnt_limited):
        fx.add("limit")
    # a limit row damped less than the plastic one's b = 1/dt (direct solref: -b) bounces
    if np.any(m.jnt_limited.astype(bool) & (-m.jnt_solref[:, 1] < (1.0 - 1e-9) / m.opt.timestep)):
        fx.add("limit_restitution")
    if np.any(m.dof_frictionloss > 0):
        fx.add("joint_friction")
    return frozenset(fx)


class MuJoCoSimulation(Simulation):
    def __init__(self, scene: Scene, model: mujoco.MjModel, knobs: dict, iterations: int):
        self.knobs = knobs
        self.iterations = iterations
        self._scene = scene  # to build again after a planted change (plant)
        self._model = model
        self._data = d = mujoco.MjData(model)
        self._bodies = self._start(scene, model, d)
        body_of = geom_bodies(scene)
        names = [body_of[mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)] for g in range(model.ngeom)]
        self._names = names  # geom id -> the scene body's name
        self._planar = scene.dimension == 2
        # MuJoCo may report a contact's geoms in either order (it orders some type pairs,
        # e.g. sphere-box, its own way): key both
        # each geom pair's body pair, as an index into _pair_keys (contact_forces sums by it)
        index: dict[tuple[str, str], int] = {}
        self._pair_index = np.full((model.ngeom, model.ngeom), -1)
        for g1, g2 in zip(model.pair_geom1.tolist(), model.pair_geom2.tolist()):
            i = index.setdefault(pair_key(names[g1], names[g2]), len(index))
            self._pair_index[g1, g2] = self._pair_index[g2, g1] = i
        self._pair_keys = list(index)
        self._f6 = np.zeros(6)  # mj_contactForce's output (pyramidal cones only)
        self._elliptic = model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
        # mjContact.adhesion, which mj_contactForce subtracts, exists from MuJoCo 3.11.0 on
        # (before it a contact has no adhesion)
        self._adhesion = hasattr(d.contact, "adhesion")
        # contacts come from <pair>s only: which carry friction rows (condim 3)
        rubs = model.pair_dim > 1
        self._rubs = "all" if rubs.all() else "some" if rubs.any() else "none"
        self._nq, self._qpos, self._qvel = model.nq, d.qpos, d.qvel  # views into MjData, for write_state
        self._state = self._buffer = self._warm = None  # run()'s buffers
        mujoco.mj_forward(model, d)  # start-state quantities, so build cost stays out of step()
        self.effects = self._built_effects(knobs)

    def _start(self, scene: Scene, model, d) -> list:
        """Set the start velocities; per dynamic body: name, qpos address, dof address, and
        for bodies on joints other than a free joint: start position, start quat, slide axes
        (rows), has a hinge."""
        bodies = []
        for body in scene.dynamic_bodies:
            jnt = model.body_jntadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body.name)]
            qa, va = model.jnt_qposadr[jnt], model.jnt_dofadr[jnt]
            joints = _joints(body, scene.dimension)
            q0 = np.asarray(body.orientation, float)
            v, w = np.asarray(body.velocity, float), np.asarray(body.angular_velocity, float)
            if joints == "free":
                d.qvel[va:va + 3] = v                                    # world frame
                d.qvel[va + 3:va + 6] = _rotate(rotations.conjugate(q0).tolist(), w.tolist())  # body frame
                bodies.append((body.name, qa, va, None))
                continue
            for i, (kind, axis) in enumerate(joints):
                d.qvel[va + i] = (w if kind == "hinge" else v) @ np.asarray(axis, float)
            slides = np.array([axis for kind, axis in joints if kind == "slide"], float)
            hinge = joints[-1][0] == "hinge"
            bodies.append((body.name, qa, va, (np.asarray(body.position, float), q0, slides, hinge)))
        return bodies

    def _built_effects(self, knobs: dict) -> frozenset[str]:
        return model_effects(self._model, knobs)

    def step(self) -> None:
        mujoco.mj_step(self._model, self._data)

    def states(self) -> dict[str, np.ndarray]:
        # from qpos/qvel: after mj_step, xpos/xquat still describe the start of the step
        qpos, qvel = self._qpos, self._qvel
        out = {}
        for name, qa, va, held in self._bodies:
            if held is None:  # free joint: qpos = pos, quat; qvel = world vel, BODY-frame omega
                pose, vel = qpos[qa:qa + 7].tolist(), qvel[va:va + 6].tolist()
                out[name] = np.array(pose + vel[:3] + list(_rotate(pose[3:], vel[3:])))
            else:
                row = np.zeros(13)  # cases.trajectory: pos, quat w-x-y-z, vel, world angular vel
                p0, q0, slides, hinge = held
                ns = len(slides)
                row[0:3] = p0 + qpos[qa:qa + ns] @ slides
                row[7:10] = qvel[va:va + ns] @ slides
                if hinge:  # turns the start orientation about world y
                    th = qpos[qa + ns]
                    mujoco.mju_mulQuat(row[3:7], np.array([math.cos(th / 2), 0.0, math.sin(th / 2), 0.0]), q0)
                    row[11] = qvel[va + ns]
                else:
                    row[3:7] = q0
                out[name] = row
        return out

    # Bulk reads (adapters.base): the raw state is qpos then qvel, two copies a step.
    def body_order(self) -> list[str]:
        return [b[0] for b in self._bodies]

    def state_size(self) -> int:
        return self._model.nq + self._model.nv

    def write_state(self, out: np.ndarray) -> None:
        out[:self._nq] = self._qpos
        out[self._nq:] = self._qvel

    def run(self, steps: int, out: np.ndarray) -> None:
        """`steps` mj_steps in one call of MuJoCo's rollout (its C loop, which records each
        step's state), continued from the current state and warm start: bit for bit the
        same as mj_step in turn (tests/test_bulk_reads.py)."""
        from mujoco import rollout as _rollout
        m, d = self._model, self._data
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        if self._state is None or self._buffer.shape[1] < steps:
            self._state = np.empty((1, mujoco.mj_stateSize(m, spec)))
            self._buffer = np.empty((1, steps, self._state.shape[1]))
            self._warm = np.empty((1, m.nv))
        mujoco.mj_getState(m, d, self._state[0], spec)
        self._warm[0] = d.qacc_warmstart
        full = self._buffer[:, :steps]
        if not full.flags.c_contiguous:
            full = np.empty((1, steps, self._state.shape[1]))
        # one model in a list and one MjData as such: the call every release from 3.2.6 takes
        # (3.2.6 takes no list of MjData, 3.2.0-3.2.5 no list of models)
        _rollout.rollout([m], d, self._state, nstep=steps, initial_warmstart=self._warm, state=full,
                         skip_checks=True)
        full = full[0]
        out[:, :self._nq] = full[:, 1:1 + self._nq]
        out[:, self._nq:] = full[:, 1 + self._nq:1 + self._nq + m.nv]
        warm = d.qacc_warmstart.copy()
        mujoco.mj_setState(m, d, full[-1], spec)  # continue from the last step, as mj_step leaves it
        d.qacc_warmstart[:] = warm

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        nq = self._nq
        qpos, qvel = raw[:, :nq], raw[:, nq:]
        out = np.zeros((len(raw), len(self._bodies), 13))
        for i, (name, qa, va, held) in enumerate(self._bodies):
            row = out[:, i]
            if held is None:  # free joint: world position, quat, world velocity, BODY-frame omega
                row[:, 0:7] = qpos[:, qa:qa + 7]
                row[:, 7:10] = qvel[:, va:va + 3]
                row[:, 10:13] = rotations.rotate(row[:, 3:7], qvel[:, va + 3:va + 6])
                continue
            p0, q0, slides, hinge = held
            ns = len(slides)
            row[:, 0:3] = p0 + qpos[:, qa:qa + ns] @ slides
            row[:, 7:10] = qvel[:, va:va + ns] @ slides
            if hinge:  # turns the start orientation about world y
                row[:, 3:7] = rotations.multiply(about_y_many(qpos[:, qa + ns]), q0)
                row[:, 11] = qvel[:, va + ns]
            else:
                row[:, 3:7] = q0
        return out

    # MuJoCo's contact conventions, read in its source (google-deepmind/mujoco,
    # include/mujoco/mjdata.h, mjContact: "frame ... normal is in [0-2], points from
    # geom[0] to geom[1]"; dist "neg: penetration"; pos the midpoint between the geoms) and
    # src/engine/engine_core_util.c mj_contactForce: the force in the contact frame (rows
    # normal, tangent1, tangent2) is efc_force at the contact's efc_address, copied as is
    # for an elliptic cone (decoded for a pyramidal one), minus the contact's adhesion.
    # Which body it acts on: src/engine/engine_core_smooth.c mj_rnePostConstraint maps
    # frame^T f to the world and ADDS it to geom[1]'s body, subtracts it from geom[0]'s
    # (the contact Jacobian is jac(geom2) - jac(geom1), engine_core_constraint.c). So
    # frame^T f is the force geom1 exerts on geom2, and the contract's a is geom2, b is
    # geom1, n = frame[0:3]. Checked here (mujoco 4.0.0): a box resting on the ground
    # (geom1 = ground, the plane sorts first) gets f_n n summing to +m g z, and a box
    # sliding along +x gets friction mu f_n along -x.

    def _solved(self):
        """The contacts the solver acted on in the last step (one rule for the pair forces
        and the points: a constraint row, not excluded): a selector into d.contact's
        arrays (a slice when all are, so the caller copies what it keeps) and (k, 3)
        forces in each contact's frame (normal, tangent1, tangent2), as geom1 exerts them
        on geom2. d.contact and efc_force belong to the step just taken: mj_step solves,
        then integrates."""
        d = self._contacts()
        con = d.contact
        addr = con.efc_address
        # no constraint row (e.g. exactly touching, dist = 0) or excluded: no force
        if addr.min() >= 0 and not con.exclude.any():  # the usual case, in two reductions
            sel = slice(None)
        else:
            sel = np.flatnonzero((addr >= 0) & (con.exclude == 0))
        a = addr[sel]
        if not len(a):
            return sel, np.zeros((0, 3))
        if self._elliptic and self._rubs == "all":  # condim 3 everywhere: three rows a contact
            f = d.efc_force[a[:, None] + _ROWS]
            if self._adhesion:
                f[:, 0] -= con.adhesion[sel]
            return sel, f
        f = np.zeros((len(a), 3))
        if self._elliptic:  # mj_contactForce's elliptic branch, all contacts at once
            efc = d.efc_force
            f[:, 0] = efc[a] - con.adhesion[sel] if self._adhesion else efc[a]
            if self._rubs == "some":  # condim 1 pairs have no friction rows: zeros
                rub = con.dim[sel] > 1
                f[rub, 1] = efc[a[rub] + 1]
                f[rub, 2] = efc[a[rub] + 2]
        else:  # pyramidal: the engine decodes its edge forces
            for j, i in enumerate(np.arange(d.ncon)[sel].tolist()):
                mujoco.mj_contactForce(self._model, d, i, self._f6)
                f[j] = self._f6[:3]
        return sel, f

    def _contacts(self):
        """What the contact read-out reads: the MjData (its ncon, contact and efc_force)."""
        return self._data

    def contact_forces(self) -> dict[tuple[str, str], float]:
        d = self._contacts()
        if d.ncon == 0:
            return {}
        sel, f = self._solved()
        geom = d.contact.geom[sel]
        ids = self._pair_index[geom[:, 0], geom[:, 1]]
        n = len(self._pair_keys)
        total = np.bincount(ids, weights=f[:, 0], minlength=n).tolist()  # summed in contact order
        keys = self._pair_keys
        return {keys[i]: total[i] for i in np.flatnonzero(np.bincount(ids, minlength=n)).tolist()}

    def contact_points(self) -> list[ContactPoint]:
        """One point per MuJoCo contact the solver acted on (see the conventions above):
        a = geom2's body, b = geom1's, n = the frame's normal, f_t = the solved forces
        along the frame's two tangents (exactly zero for frictionless, condim 1, pairs),
        x = the contact's pos, gap = its dist.
        2D scenes: a rect is a box as deep along y as it is wide, so MuJoCo reports its
        contacts in pairs at y = +-depth; they are reported as they are, projected onto
        the plane y = 0 (two points at the same x-z place that share the load)."""
        d = self._contacts()
        if d.ncon == 0:
            return []
        sel, f = self._solved()
        con = d.contact
        frame = con.frame[sel]
        n = frame[:, 0:3].copy()  # a copy: d.contact is overwritten by the next step
        x = con.pos[sel].copy()
        if self._rubs == "none":
            f_t = np.zeros_like(n)
        else:
            f_t = f[:, 1:2] * frame[:, 3:6] + f[:, 2:3] * frame[:, 6:9]
        if self._planar:  # no y dof: the y components act on nothing
            x[:, 1] = 0.0
            n[:, 1] = 0.0
            n /= np.linalg.norm(n, axis=1)[:, None]
            f_t[:, 1] = 0.0
        names = self._names
        geoms = con.geom[sel].tolist()
        return list(map(ContactPoint, [names[g[1]] for g in geoms], [names[g[0]] for g in geoms],
                        x, n, f[:, 0].tolist(), f_t, con.dist[sel].tolist()))

    def close(self) -> None:
        self._model = self._data = None

    # the "save_restore" and "threads" modes (Capabilities.modes)
    STATE = "mjSTATE_INTEGRATION"  # qpos, qvel, act, the warm start qacc_warmstart, time, controls, ...

    def save_state(self) -> np.ndarray:
        """MuJoCo's integration state (mj_getState): everything mj_step reads that it does not
        compute, the solver's warm start included."""
        spec = getattr(mujoco.mjtState, self.STATE)
        state = np.empty(mujoco.mj_stateSize(self._model, spec))
        mujoco.mj_getState(self._model, self._data, state, spec)
        return state

    def restore_state(self, state) -> None:
        mujoco.mj_setState(self._model, self._data, np.asarray(state, float), getattr(mujoco.mjtState, self.STATE))

    def use_threads(self, n: int) -> None:
        """Bind a pool of `n` worker threads to the simulation's MjData (mju_threadpool).
        It then steps by mj_step alone: rollout (`run`) refuses an MjData with a pool."""
        mujoco.mju_threadpool(self._data, n)
        self.run = None
        self.knobs = {**self.knobs, "mju_threadpool": n}

    # --- planted faults (adapters/planting.py) ------------------------------------------

    def plant(self, change: str, size: float | None = None) -> Simulation:
        """MuJoCo's planted changes (MuJoCoAdapter.plantable), each an edit of the compiled
        model and a simulation of it built anew (a fresh MjData, so every quantity derived
        from the model, e.g. how contact forces are decoded for the cone in force, is the
        edited model's): "square friction cone" is cone = "pyramidal" (MuJoCo's own
        default, which the adapter replaces by the elliptic cone); "velocity damping" is
        joint damping on every degree of freedom, `size` times the dof's own mass or
        inertia (dof_M0), so each decays at the same rate (a damping left in a model's
        default class); "thread order" (an invariance fault) lengthens the time step by
        one rounding in place where a thread pool is bound (use_threads), and nowhere else."""
        model = self._model
        if change == "square friction cone":
            model.opt.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
        elif change == "velocity damping":
            model.dof_damping[:] = size * model.dof_M0
        elif change == "thread order":  # only where a pool is bound: the step on one thread unchanged
            if self.knobs.get("mju_threadpool"):
                model.opt.timestep *= 1.0 + 2.0**-52
            return self
        else:
            return super().plant(change, size)
        return type(self)(self._scene, model, self.knobs, self.iterations)


class MuJoCoTreeSimulation(MuJoCoSimulation):
    """A scene with joints or loads (_tree_xml): each body's state is read from MuJoCo's own
    kinematics of qpos and qvel (a child's pose and velocity follow from its ancestors'
    joints), its start velocities are the joint velocities that give them, and loads are
    MuJoCo's applied forces (xfrc_applied: world force at the centre of mass and torque,
    held from step to step). No rollout: each step's state is read through mj_kinematics."""

    run = None  # the bulk run's rollout does not carry xfrc_applied; step() does

    def _start(self, scene: Scene, model, d) -> list:
        ids = {b.name: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b.name) for b in scene.dynamic_bodies}
        for load in scene.loads:
            d.xfrc_applied[ids[load.body]] = list(load.force) + list(load.torque)
        # the joint velocities qdot that give every body its start velocity: J qdot = (v, w),
        # exact where the start velocities respect the joints, else unsupported
        mujoco.mj_forward(model, d)
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        rows, target = [], []
        for body in scene.dynamic_bodies:
            mujoco.mj_jacBody(model, d, jacp, jacr, ids[body.name])
            rows += [jacp.copy(), jacr.copy()]
            target += [body.velocity, body.angular_velocity]
        J, y = np.vstack(rows), np.concatenate(target)
        qvel = np.linalg.lstsq(J, y, rcond=None)[0] if model.nv else np.zeros(0)
        miss = float(np.max(np.abs(J @ qvel - y))) if len(y) else 0.0
        if miss > 1e-9 * max(1.0, float(np.max(np.abs(y)))):
            raise Unsupported(f"the start velocities break the joints (the nearest joint velocities miss them by "
                              f"{miss:.3g}): a jointed body's start velocity must be one its joints allow")
        d.qvel[:] = qvel
        self._ids = np.array([ids[b.name] for b in scene.dynamic_bodies])
        self._roots = model.body_rootid[self._ids]
        return [(b.name, None, None, None) for b in scene.dynamic_bodies]

    def _built_effects(self, knobs: dict) -> frozenset[str]:
        loaded = np.any(self._data.xfrc_applied != 0)
        return model_effects(self._model, knobs) | ({"load"} if loaded else set())

    # Bulk reads: a raw row is each body's xpos, xquat, cvel and its subtree's centre of mass,
    # from MuJoCo's own kinematics of the state after the step (mj_kinematics, mj_comPos,
    # mj_comVel on the live data: mj_step recomputes all of them from qpos and qvel at its
    # start, so this changes nothing it steps), decoded with numpy.
    _ROW = 16  # xpos 3, xquat 4, cvel 6 (rotation, translation), subtree_com 3

    def states(self) -> dict[str, np.ndarray]:
        raw = np.empty((1, self.state_size()))
        self.write_state(raw[0])
        return dict(zip(self.body_order(), self.decode_states(raw)[0]))

    def state_size(self) -> int:
        return self._ROW * len(self._ids)

    def write_state(self, out: np.ndarray) -> None:
        m, d, ids = self._model, self._data, self._ids
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_comVel(m, d)
        n = len(ids)
        out[0:3 * n] = d.xpos[ids].ravel()
        out[3 * n:7 * n] = d.xquat[ids].ravel()
        out[7 * n:13 * n] = d.cvel[ids].ravel()
        out[13 * n:16 * n] = d.subtree_com[self._roots].ravel()

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        n = len(self._ids)
        xpos = raw[:, 0:3 * n].reshape(-1, n, 3)
        cvel = raw[:, 7 * n:13 * n].reshape(-1, n, 6)
        com = raw[:, 13 * n:16 * n].reshape(-1, n, 3)
        out = np.empty((len(raw), n, 13))
        out[:, :, 0:3] = xpos
        out[:, :, 3:7] = raw[:, 3 * n:7 * n].reshape(-1, n, 4)
        # cvel is (w, v) at the subtree's centre of mass, world axes: the body origin's
        # velocity is v + w x (xpos - subtree_com) (MuJoCo's mj_objectVelocity)
        out[:, :, 7:10] = cvel[:, :, 3:6] + np.cross(cvel[:, :, 0:3], xpos - com)
        out[:, :, 10:13] = cvel[:, :, 0:3]
        return out


class MuJoCoPortTreeSimulation(MuJoCoTreeSimulation):
    """MuJoCoTreeSimulation for a port of MuJoCo's pipeline (MuJoCo Warp, MJX) that steps
    the MjData's copy in its own arrays: the start state and the loads go to the port with
    the MjData (xfrc_applied is part of it), and each read first copies the port's qpos and
    qvel (self._qpos, self._qvel, which the port binds) back into the MjData that MuJoCo C's
    kinematics reads."""

    run = None

    def write_state(self, out: np.ndarray) -> None:
        self._data.qpos[:] = self._qpos
        self._data.qvel[:] = self._qvel
        super().write_state(out)


class MuJoCoAdapter(Adapter):
    name = "mujoco"
    package = "mujoco"
    # 3.2.6 (Dec 2024) to 4.x: every release of the last two years runs the conformance battery
    # (the MJCF written is the release's own, mjcf_schema); 3.2.0-3.2.5 lack rollout([m], d) and
    # before 3.2.1 the autoreset flag. Resting stacks of boxes topple before 3.12.0 (README).
    supported = ">=3.2.6,<5"
    capabilities = Capabilities(
        dimensions=frozenset({2, 3}),
        # every kind (_geom); a static mesh as one convex prism a triangle (_mesh_geoms)
        shapes=frozenset({"sphere", "box", "plane", "circle", "rect", "capsule", "cylinder", "hull", "polygon",
                          "mesh"}),
        native_restitution=False,  # e is mapped onto the contact spring-damper
        static_kinetic=False,
        contact_forces=True,
        iterations=True,
        contact_points=True,
        contact_laws=frozenset({"hooke"}),  # F = k xi per contact (hooke_row)
        # every contact a spring-damper lasting ~CONTACT_STEPS steps: an impulse through
        # touching bodies spreads over them (cases/column_impact.py: a struck row of two
        # leaves at 0.66 and 0.68 m/s where rigid simultaneous contact gives 2/3 each)
        impact_model="compliant",
        contact_torques=frozenset({"rolling_resistance", "torsional_friction"}),  # condim 6 / 4, lengths
        # Settings.threads: a thread pool bound to the MjData (mju_threadpool); a whole state
        # through mj_getState / mj_setState (mjSTATE_INTEGRATION, the warm start included)
        modes=frozenset({"threads", "save_restore"}),
        # joints as MuJoCo's kinematic tree (_tree_xml): reduced coordinates; loads as xfrc_applied
        joints=frozenset({"revolute", "prismatic", "ball", "fixed"}),
        joint_limits=True,
        joint_friction=True,
        limit_restitution=True,  # the limit row's spring-damper from Joint.limit_e, as a contact's from e
        coordinates="reduced",
        loads=True,
    )
    # Settings.options: the contact time scale n (the module notes), which with e sets the
    # contact row's solref (k, b) and the friction rows' slip time n dt. From 2 steps (stiff:
    # the rebound error ~ 1/n is large) to 50 (soft: depth ~ v n dt / pi, 15 mm at 1 m/s).
    tunables = {"contact_steps": Tunable(2.0, 50.0, float(CONTACT_STEPS),
                                         "contact duration in time steps (solref time scale n dt)")}
    plantable = frozenset({"square friction cone", "velocity damping", "thread order"})  # MuJoCoSimulation.plant

    def __init__(self, contact_steps: float = CONTACT_STEPS, ground: str = "plane", name: str | None = None,
                 defaults=(), speculative: bool = False):
        """contact_steps: n, the contact's duration in steps (the accuracy knob); ground:
        a scene Plane as a MuJoCo plane (the default; its box collisions give every
        corner at once) or a large box (`GROUNDS`); defaults: the contact knobs of DEFAULTABLE
        left at MuJoCo's own defaults, "all" for every one (the module notes, "mujoco-defaults");
        speculative: MuJoCo's speculative contacts (flag speculative, "mujoco-speculative")."""
        if ground not in GROUNDS:
            raise ValueError(f"ground = {ground!r}: must be one of {', '.join(GROUNDS)}")
        if name is not None:  # a variant's name (a subclass keeps its own class attribute)
            self.name = name
        self.contact_steps = contact_steps
        self.ground = ground
        defaults = DEFAULTABLE if defaults == "all" else tuple(defaults)
        unknown = sorted(set(defaults) - set(DEFAULTABLE))
        if unknown:
            raise ValueError(f"defaults = {unknown}: must be among {', '.join(DEFAULTABLE)} (or 'all')")
        self.defaults = frozenset(defaults)
        self.speculative = self.continuous_collision(speculative)

    def version(self) -> str:
        return metadata.version("mujoco")

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        kind = MuJoCoTreeSimulation if scene.joints or scene.loads else MuJoCoSimulation
        sim = kind(scene, *self.model(scene, settings))
        if (settings.threads or 1) > 1:
            sim.use_threads(settings.threads)
        return sim

    def model(self, scene: Scene, settings: Settings) -> tuple[mujoco.MjModel, dict, int]:
        """The compiled MjModel of `scene`, the knobs its MJCF sets and the iteration cap:
        what every MuJoCo implementation (MuJoCo C here, MuJoCo Warp in
        adapters/mujoco_warp_engine.py) steps. Unsupported for what MuJoCo cannot represent."""
        # (a body held from rotating does not spin, and a 2D scene lies in the x-z plane:
        # cases.scene validates both)
        reason = self.capabilities.cannot_run(scene) or _hooke_unrepresentable(scene) or _torques_unrepresentable(scene)
        if reason:
            raise Unsupported(reason)
        iterations = ITERATIONS if settings.iterations is None else settings.iterations
        self.options_in_force(settings)  # an unknown option or one out of its range: SettingsError
        _import_mujoco()
        n = float(settings.options.get("contact_steps", self.contact_steps))
        xml, knobs = scene_mjcf(scene, settings, iterations, n, ground=self.ground, defaults=self.defaults,
                                speculative=self.speculative)
        model = self._compile(xml)
        if "hooke" in scene.contact_laws:
            # a Hooke row's stiffness is k times MuJoCo's D of the row, from the bodies'
            # body_invweight0, which the compiler computes (masses and joints, not solref)
            body_of = geom_bodies(scene)
            invweight = {body_of[mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)]:
                         float(model.body_invweight0[model.geom_bodyid[g], 0]) for g in range(model.ngeom)}
            xml, knobs = scene_mjcf(scene, settings, iterations, n, invweight, self.ground, self.defaults,
                                    self.speculative)
            model = self._compile(xml)
        return model, knobs, iterations

    @staticmethod
    def _compile(xml: str) -> mujoco.MjModel:
        try:
            return mujoco.MjModel.from_xml_string(xml)
        except ValueError as exc:
            raise Unsupported(f"MuJoCo rejects the scene: {exc}") from None


def float32_capabilities(why_not: tuple[tuple[str, str], ...] = ()) -> Capabilities:
    """The capabilities of a single-precision port of MuJoCo's pipeline (MuJoCo Warp, MJX),
    which builds MuJoCo C's model (MuJoCoAdapter.model) and reads forces, contact points and
    a joint tree's states as MuJoCo C does (MuJoCoPortTreeSimulation): MuJoCo C's, with
    32-bit floats, Settings.iterations capping the Newton solver's iterations (no
    sub-steps), and no threads or saved states; `why_not` says why for what a port lacks."""
    return replace(MuJoCoAdapter.capabilities, float_bits=32, substeps=False, modes=frozenset(), why_not=why_not)


def port_contacts(rows: np.ndarray, dim: np.ndarray, force: np.ndarray, geom: np.ndarray, frame: np.ndarray,
                  pos: np.ndarray, dist: np.ndarray, adhesion: np.ndarray) -> SimpleNamespace:
    """A port's solved contacts (MuJoCo Warp, MJX) in the layout the base class reads from an
    MjData (ncon, contact.*, efc_force): each contact's rows contiguous from its efc_address
    and padded with zeros to the widest contact. `rows[i, j]`: the index in the port's
    `force` of contact i's row j (row 0 < 0: the contact has no rows); `frame` (n, 9)."""
    n = len(dim)
    width = max(int(dim.max()), 1) if n else 1
    solved = rows[:, 0] >= 0
    efc = np.where(np.arange(width) < dim[:, None], force[np.maximum(rows[:, :width], 0)], 0.0)
    return SimpleNamespace(
        ncon=n, efc_force=efc.ravel(),
        contact=SimpleNamespace(efc_address=np.where(solved, np.arange(n) * width, -1), exclude=np.zeros(n, int),
                                adhesion=adhesion, dim=dim, geom=geom, frame=frame.astype(float),
                                pos=pos.astype(float), dist=dist.astype(float)))
