"""Box2D v3 (through the pyb2d3 bindings) behind the engine contract: 2D scenes only.

Frames. A 2D scene lies in the x-z plane; Box2D's plane is x-y. Scene (x, z) maps to
Box2D (x, y). A positive rotation phi about scene +y takes +z towards +x, while Box2D's
positive angle takes +x towards +y (= scene +z), so the Box2D angle is -phi and its
angular velocity is -omega_y (as for Pymunk). Box2D computes in float32: positions,
velocities, masses and material values are rounded to 2^-24 relative (6e-8), so a body
at 10 m is placed to 1e-6 m; checks tighter than that measure the float, not the physics.
Angles are set and read through the rotation's cosine and sine (Box2D's own angle
functions b2MakeRot / b2Rot_GetAngle are polynomial approximations, 1e-3 rad off).

Shapes. A Circle is a b2Circle, a Rect b2MakeBox, a Polygon b2MakeOffsetPolygon of the hull
of its corners (b2ComputeHull) at the body origin with radius 0 (no rounding), the body's
mass and inertia the scene's (b2Body_SetMassData). Box2D holds at most 8 corners and welds
or drops corners closer than 2 cm to each other or 1 cm to the line through their
neighbours (src/hull.c): such a polygon is `unsupported` (`_hull`), never quietly changed.
A Plane is a long static box whose top edge is the line.

What one `world.step(dt, n)` does (Box2D v3.1.1 src/solver.c, b2SolverStep): contacts are
found for the whole step, with speculative points up to 4 linear slops (2 cm) apart; then
n sub-steps of h = dt/n, each: velocities get gravity (v += g h), warm start, one
relaxed-Gauss-Seidel sweep of the soft contact constraint with a bias that pushes overlap
out, positions move (x += v h), one relax sweep without the bias (so the push-out leaves
no velocity behind: the "soft step" solver); after the sub-steps, restitution: each
contact point that took an impulse and approached faster than `restitution_threshold`
before the step gets v_n+ = -e v_n- with v_n- its normal velocity before the step, before
gravity (src/contact_solver.c, b2ApplyRestitution). There is no iteration count apart from
the sub-steps: `Settings.iterations` is n.

Impacts (`Capabilities.impact_model` "simultaneous"): all contacts of a step are solved
together, and restitution targets each contact's own approach speed before the step.
Measured at dt = 1e-3, e = 1: two touching discs dropped on the ground leave it together
(0.997 and 0.984 of the impact speed 5 steps later, as the reference's simultaneous model,
0.984 both); a striker at 1 m/s into three touching discs rebounds at -0.125 m/s and the
row leaves at 0.28, 0.28, 0.56 m/s (sequential impacts would stop the striker and send
the last disc on at 1 m/s). The one restitution sweep is not iterated to convergence, so
at e = 0.5 the dropped pair leaves at 0.19 and 0.34 of the impact speed, not both at 0.5.

Soft contact (b2MakeSoft): the push-out is a spring-damper of natural frequency
`contact_hertz` and damping ratio `contact_damping_ratio` (twice the frequency against
static bodies), capped at `contact_push_speed`, and Box2D clamps the frequency to 1/8 of
the sub-step rate. A rigid contact has no compliance, so the adapter asks for that cap:
a resting body then sits g / (2 pi f)^2 deep (1.6 um on the ground at dt = 1e-3, n = 4)
where Box2D's default 30 Hz lets a five-box stack sink 6.9 mm (measured).

Continuous collision ("box2d-bullet", `bullet=True`): continuous collision on
(`enableContinuous`) and each dynamic body that starts out moving further in a step than its
inscribed radius a bullet (`isBullet`, adapters.solids.starts_fast), which Box2D sweeps
against dynamic bodies too; the plain configuration has neither. Measured (a 2 cm disc at
100 m/s at a free 1 cm plate, cases/robustness/tunnelling.py): without them the disc is
stopped from 1.75 cm in front of the plate (a speculative contact) and passes from 5 cm;
with them it is stopped from both; with every dynamic body a bullet it passes from 5 cm
(Box2D sweeps no pair of two bullets). In a default run the configuration takes the
families tagged "swept" only (`default_tags`).

Pair materials. Box2D keeps friction and restitution per shape and mixes a pair as
sqrt(mu_a mu_b) and max(e_a, e_b); pyb2d3 0.11.1 exposes no mixing callback. Per-shape
values that reproduce every pair of the scene are found with adapters.combination
(friction: the product rule on mu^2); a scene that has none is `unsupported`.

Contact forces. pyb2d3 0.11.1 exposes no per-step contact data (b2Body_GetContactData is
not bound; its manifolds come only with the begin-touch events, before they are solved).
The forces are therefore read from what the contacts did: every velocity change of a
dynamic body in a step other than gravity is a contact impulse (damping is 0, no other
force acts), so body i took J_i = m_i (v_i' - v_i) - m_i g dt from its contacts, exactly
to float32 round-off. The pairs in contact are the engine's own (begin/end-touch events:
the contacts the solver had in the step). Each pair's impulse P_ab (on a, -P_ab on b)
solves sum_pairs(i) +-P = J_i, with P_ab along the pair's contact normal n (from b into a)
on a frictionless pair and n lambda + t tau on a frictional one (adapters.impulse_split).
Where the contact graph (all static bodies one node) is a forest, as in stacks, chains and
single contacts, that split is unique and is the engine's; where a cycle remains the
normals decide it (a disc in a V-groove of two frictionless lines: each takes
m g / (2 cos alpha), exactly). Box2D's contacts include speculative ones up to 2 cm apart;
one that would close a cycle and is more than ACTING_GAP (adapters.impulse_split) apart
after the step took nothing and is left out (a millimetre box's ground contact when it
rests on another box). Where friction acts around a cycle (a wedged disc, a box pressed
against a wall) momentum alone leaves the normal impulses open (friction can carry part
of the load or squeeze): the split with the least friction is returned and `knobs`
("pair_split") says so. The split is worked out when `contact_forces` is asked, from a
snapshot the step keeps, so the timed step holds only the engine's work and the snapshot.
The normal force of a pair is lambda / dt with n the pair's contact normal before the step
(the geometry Box2D found its contacts from): the plane's normal, the line of centres, or
the separating axis of least penetration over both polygons' edges (as b2CollidePolygons
chooses it).

Contact points. pyb2d3 0.11.1 gives a contact's manifold only with its begin-touch event:
recorded when Box2D found the contact at the start of the step in which it began, before
the solver acted (the impulses are zero). So `contact_points` gives the geometry of the
contacts that began touching in the last step, and no forces (`Capabilities.contact_geometry`;
`contact_points` False, so the per-point force readings leave Box2D out): f_n and f_t are
NaN. In a one-step scene (the narrow-phase and broad-phase families) that is every contact
of the step. A contact that persists from an earlier step has no manifold to read, and
`contact_points` raises ContactGeometryUnavailable rather than report a stale one or leave
the contact out. Each point is the manifold point's world `point` (midway between the
surfaces, measured: two overlapping discs), its `separation` the gap (positive: a
speculative point, up to 4 linear slops apart), and the manifold `normal` points from
shape A to shape B, so the point's a is B's body and b A's (n from b into a); Box2D's
(x, y) is the scene's (x, z).
"""
from __future__ import annotations

import math
from importlib import metadata

import numpy as np
import pyb2d3 as b2

from adapters.base import Adapter, Capabilities, Settings, Simulation, Tunable, Unsupported
from adapters.combination import per_body_values
from adapters.frames import planar_states, require_turn_about_y, state_row
from adapters.impulse_split import OPEN_SPLIT, acting_pairs, split_impulses
from adapters.solids import starts_fast
from cases.scene import Body, Circle, Plane, Rect, Scene, pair_key, quat_about_y
from cases.trajectory import ContactPoint

DEFAULT_SUBSTEPS = 4  # Box2D's recommended sub-step count (b2World_Step documentation)
# The fraction of the sub-step rate Box2D clamps contact_hertz to (src/world.c, b2World_Step:
# contactHertz = min(contactHertz, 0.125 inv_h)); the adapter asks for this cap.
HERTZ_CAP_PER_SUBSTEP_RATE = 0.125
# Box2D's default damping ratio (b2DefaultWorldDef): overdamped, so the push-out never
# rings; a ratio of 1 changed resting depths by < 1 % (measured, 5-box stack).
CONTACT_DAMPING_RATIO = 10.0
# Cap on the push-out speed, m/s (Box2D's default maxContactPushSpeed is 3). Overlap is a
# numerical error: what an impact leaves (v dt, 3 mm at 3 m/s and dt = 1e-3) goes within a
# few steps at 1 m/s, and a faster push-out only throws deeply overlapped bodies: a 1 kg
# box sunk 5 cm ends 0.46 J above rest at 3 m/s, 3.8 J at 10 m/s, < 0.02 J at 1 m/s
# (robustness_overlap; measured, nothing else in the battery changed between 0.3 and 3).
CONTACT_PUSH_SPEED = 1.0
# A speed cap that never acts (Box2D's default is 400 m/s, b2DefaultWorldDef; the harness
# calls anything faster than 100 m/s a blow-up).
MAXIMUM_LINEAR_SPEED = 1e4
# The static ground: a box whose top edge is the plane, PLANE_HALF_LENGTH either side of the
# point of the plane below the dynamic bodies' mean position, and PLANE_DEPTH deep. Box2D
# clips polygon contacts relative to a vertex of one polygon (b2CollidePolygons), so contact
# points on the ground are placed to the float32 spacing at PLANE_HALF_LENGTH from the
# bodies (7.6e-6 m): long enough for every motion of the scenes, short enough for that.
PLANE_HALF_LENGTH = 100.0  # m
PLANE_DEPTH = 1.0  # m: deeper than any overlap the scenes make
# What a Box2D polygon can hold (Box2D v3.1 include/box2d/collision.h and src/hull.c,
# b2ComputeHull): at most B2_MAX_POLYGON_VERTICES corners; corners closer than 4 linear slops
# are welded into one, and a corner within 2 linear slops of the line through its neighbours
# is dropped (B2_LINEAR_SLOP = 0.005 m at b2_lengthUnitsPerMeter = 1).
MAX_POLYGON_VERTICES = 8
LINEAR_SLOP = 0.005  # m


class ContactGeometryUnavailable(RuntimeError):
    """A contact whose manifold pyb2d3 does not give: it began touching before the last step."""


# How Box2D resolves an impact through bodies already touching (Capabilities.impact_model),
# measured (dt = 1e-3, no gravity, a 0.1 kg ball resting on a 1 kg one, both landing at 2 m/s,
# touching without overlap; tests/test_declared_models.py): neither model's closed form.
# Top and bottom ball leave at 3.497, 1.667 m/s (e = 1) and 1.302, 0.887 m/s (e = 0.5). The simultaneous model gives both 2 (e = 1) and 1 m/s (e = 0.5), the sequential one
# 5.273, 1.273 and 2.091, 0.591 (cases/column_impact.py): restitution targets each contact's
# approach before the step, so the touching pair takes part in the landing step without its
# bounce and gets it as an impact of its own later. So it declares no impact model, and the
# column family's model variants are unsupported on it (its model-free ones still run).
IMPACT_MODEL_MEASURED = None


class Box2DAdapter(Adapter):
    name = "box2d"
    package = "pyb2d3"
    # the release the conformance battery ran on; the next major (minor for 0.x) may change the API
    supported = ">=0.11.1,<0.12"
    capabilities = Capabilities(
        dimensions=frozenset({2}),
        shapes=frozenset({"circle", "rect", "polygon", "plane"}),  # a polygon: b2MakePolygon, radius 0 (`_hull`)
        native_restitution=True,
        static_kinetic=False,  # one friction coefficient per shape
        contact_forces=True,   # from the bodies' momenta, see the module notes
        contact_forces_beside_joints=False,  # the momenta hold the joints' impulses too
        iterations=True,       # the sub-step count
        contact_points=False,
        contact_geometry=True,  # the begin-touch manifolds of the last step (module notes)
        impact_model=IMPACT_MODEL_MEASURED,  # neither model: see the note above the class
        # rollingResistance per shape (`_rolling`); no torsional friction (a 2D engine has
        # no spin about a contact normal in its plane)
        contact_torques=frozenset({"rolling_resistance"}),
        restitution_law="two_phase",  # restitution in a pass of its own after the sub-steps, without friction
        float_bits=32,         # positions, velocities and masses in single precision (checked: 0.1 m/s reads back as float32(0.1))
        substeps=True,         # Settings.iterations is the sub-step count
        # Settings.threads: pyb2d3's ThreadPool of that many workers runs Box2D's task system
        # (b2WorldDef.workerCount and its enqueueTask); Box2D v3 promises the same result
        # whatever the worker count (its "cross-thread determinism")
        modes=frozenset({"threads"}),
        why_not=(("save_restore", "Box2D v3 has no snapshot: its contact cache (warm-start impulses) can be "
                                  "neither read nor written through pyb2d3"),
                 ("limit_restitution", "a joint's limit takes a range only (lower_angle and upper_angle, "
                                       "lower_translation and upper_translation): Box2D's limit rows have no "
                                       "restitution")),
        # Box2D's joints (_joint): soft constraint rows between the bodies' own coordinates,
        # solved in the sub-steps with the contacts
        joints=frozenset({"revolute", "prismatic", "fixed"}),
        joint_limits=True,
        joint_friction=True,
        coordinates="maximal",
        loads=True,  # apply_force_to_center and apply_torque before each step (Box2D clears them)
    )
    tunables = {
        "contact_hertz": Tunable(1.0, math.inf, math.inf,
                                 "push-out stiffness, Hz (default: Box2D's cap, 1/8 of the sub-step rate)"),
        "contact_damping_ratio": Tunable(0.0, 100.0, CONTACT_DAMPING_RATIO, "push-out damping ratio"),
        "contact_push_speed": Tunable(0.0, 100.0, CONTACT_PUSH_SPEED, "largest push-out speed, m/s"),
    }

    def __init__(self, name: str = "box2d", bullet: bool = False):
        """bullet: Box2D's continuous collision on, each fast dynamic body a bullet (isBullet;
        "box2d-bullet", module notes)."""
        self.name = name
        self.bullet = self.continuous_collision(bullet)

    def version(self) -> str:
        return f"pyb2d3 {metadata.version('pyb2d3')}"  # 0.11.1 bundles Box2D v3.1.1

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene)
        if reason:
            raise Unsupported(reason)
        for body in scene.bodies:  # a polygon Box2D cannot hold: said before a world is made
            if body.shape.kind == "polygon":
                _hull(body)
        return Box2DSimulation(scene, settings, self.options_in_force(settings), self.bullet)


def _rot(angle: float):
    """Box2D rotation of `angle` from the exact cosine and sine (b2MakeRot approximates)."""
    q = b2.Rot()
    q.c, q.s = math.cos(angle), math.sin(angle)
    return q


def _angle(body: Body) -> float:
    """Box2D angle of a 2D body: minus its rotation about scene +y (see module docstring)."""
    require_turn_about_y(body, "which a 2D engine cannot represent")
    w, _, y, _ = body.orientation
    return -2.0 * math.atan2(y, w)


def _angle_of(pb) -> float:
    """A Box2D body's angle from its rotation's cosine and sine."""
    q = pb.rotation
    return math.atan2(q.s, q.c)


def _materials(scene: Scene) -> tuple[dict[str, float], dict[str, float]]:
    """Per-shape friction and restitution that Box2D's mixing, sqrt(mu_a mu_b) and
    max(e_a, e_b), turns into each pair's values (Unsupported if none exist): the
    shapes' frictions multiply to the pair's mu^2."""
    mu = per_body_values(scene, lambda m: m.mu_s**2, "product", "friction")
    e = per_body_values(scene, lambda m: m.e, "max", "restitution")
    return mu, e


def _hull(body: Body):
    """The b2Hull of a scene Polygon, every corner kept (Unsupported where Box2D would weld
    or drop one: `MAX_POLYGON_VERTICES`)."""
    corners = np.ascontiguousarray(body.shape.corners, dtype=np.float32)
    n = len(corners)
    if n > MAX_POLYGON_VERTICES:
        raise Unsupported(f"polygon {body.name!r} has {n} corners: a Box2D polygon has at most "
                          f"{MAX_POLYGON_VERTICES} (B2_MAX_POLYGON_VERTICES)")
    hull = b2.compute_hull(corners)
    if hull.count != n:
        raise Unsupported(f"polygon {body.name!r}: Box2D's b2ComputeHull keeps {hull.count} of its {n} corners (it "
                          f"welds corners closer than {4 * LINEAR_SLOP:g} m and drops a corner within "
                          f"{2 * LINEAR_SLOP:g} m of the line through its neighbours)")
    return hull


def _shape_radius(body: Body) -> float:
    """b2GetShapeRadius: a circle's radius; 0 for the polygons the adapter makes (no rounding)."""
    return body.shape.radius if isinstance(body.shape, Circle) else 0.0


def _rolling(scene: Scene) -> dict[str, float]:
    """Per-shape rollingResistance: Box2D v3's is dimensionless (note 001's mu_r), a pair's
    lever arm is max(rr_a, rr_b) times the larger shape radius (src/contact.c, b2UpdateContact;
    the solver bounds the angular impulse by it times the normal impulse), so each pair asks
    for max(rr_a, rr_b) = d / max(r_a, r_b). Unsupported where no shape is round (a polygon's
    radius is 0: no rolling resistance) or no per-shape values fit."""
    names = [b.name for b in scene.bodies]
    if "rolling_resistance" not in scene.effects:
        return {n: 0.0 for n in names}

    def ratio(a: Body, b: Body) -> float:
        d = scene.material_of(a.name, b.name).rolling_resistance
        if d == 0.0:
            return 0.0
        r = max(_shape_radius(a), _shape_radius(b))
        if r == 0.0:
            raise Unsupported(f"rolling resistance = {d:g} m for {a.name}/{b.name}: Box2D scales it by the larger "
                              "shape radius, which is 0 for polygons")
        return d / r
    return per_body_values(scene, lambda m: m.rolling_resistance, "max", "rolling resistance", ratio)


# --- contact geometry: gap and normal of a pair from the bodies' poses ----------------------
# A pose is (x, y, c, s): centre and the cosine and sine of the rotation, in Box2D's plane.
# A polygon's outline is its corners and outward edge normals in the body frame, counter-
# clockwise in Box2D's plane (a scene polygon's corners are counterclockwise in (x, z), which
# is Box2D's (x, y)). Plain floats: these run for every touching pair and step.


def outline(shape) -> tuple[tuple, tuple]:
    """Body-frame corners and outward edge normals (corner i to i + 1) of a Rect or Polygon,
    counterclockwise."""
    if isinstance(shape, Rect):
        a, b = shape.half_extents
        corners = ((-a, -b), (a, -b), (a, b), (-a, b))
    else:
        corners = tuple((float(x), float(z)) for x, z in shape.corners)
    normals = []
    for (x0, y0), (x1, y1) in zip(corners, corners[1:] + corners[:1]):
        length = math.hypot(x1 - x0, y1 - y0)
        normals.append(((y1 - y0) / length, (x0 - x1) / length))  # the edge turned clockwise: outward
    return corners, tuple(normals)


def _placed(pose, shape_outline) -> tuple[list, list]:
    """World corners and outward normals of a polygon outline at `pose`."""
    x, y, c, s = pose
    corners, normals = shape_outline
    return ([(x + c * u - s * v, y + s * u + c * v) for u, v in corners],
            [(c * u - s * v, s * u + c * v) for u, v in normals])


def _max_separation(va, na, vb) -> tuple[float, tuple]:
    """The face of polygon a farthest from polygon b: its separation (negative: overlap)
    and outward normal (the separating axis test)."""
    best, normal = -math.inf, na[0]
    for (px, py), (nx, ny) in zip(va, na):
        sep = min((qx - px) * nx + (qy - py) * ny for qx, qy in vb)
        if sep > best:
            best, normal = sep, (nx, ny)
    return best, normal


def _polygon_point(va, na, point) -> tuple[float, tuple]:
    """Signed distance from a polygon to a point and the unit direction from it to the point."""
    qx, qy = point
    seps = [(qx - px) * nx + (qy - py) * ny for (px, py), (nx, ny) in zip(va, na)]
    k = max(range(len(seps)), key=seps.__getitem__)
    if seps[k] <= 0.0:
        return seps[k], na[k]  # inside: the face of least penetration
    best, direction = math.inf, na[k]
    for i, (ex, ey) in enumerate(va):  # outside: from the closest point of the boundary
        dx, dy = va[(i + 1) % len(va)][0] - ex, va[(i + 1) % len(va)][1] - ey
        t = min(max(((qx - ex) * dx + (qy - ey) * dy) / (dx * dx + dy * dy), 0.0), 1.0)
        rx, ry = qx - ex - t * dx, qy - ey - t * dy
        dist = math.hypot(rx, ry)
        if 0.0 < dist < best:
            best, direction = dist, (rx / dist, ry / dist)
    return best, direction


def contact_gap(A: Body, pose_a, B: Body, pose_b, outlines: dict | None = None) -> tuple[float, tuple]:
    """Signed distance of two bodies (negative: overlap) and the unit contact normal from
    B into A, in Box2D's plane: a plane's normal, the line of centres, or the axis of
    least penetration (as b2CollidePolygons chooses it). `outlines`: the polygon outlines
    by body name (worked out from the shapes where absent)."""
    if isinstance(A.shape, Plane):
        gap, (nx, ny) = contact_gap(B, pose_b, A, pose_a, outlines)
        return gap, (-nx, -ny)

    def placed(body: Body, pose):
        known = outlines.get(body.name) if outlines is not None else None
        return _placed(pose, known or outline(body.shape))
    if isinstance(B.shape, Plane):
        n = (B.shape.normal[0], B.shape.normal[2])
        if isinstance(A.shape, Circle):
            low = pose_a[0] * n[0] + pose_a[1] * n[1] - A.shape.radius
        else:
            low = min(x * n[0] + y * n[1] for x, y in placed(A, pose_a)[0])
        return low - B.shape.offset, n
    if isinstance(A.shape, Circle) and isinstance(B.shape, Circle):
        dx, dy = pose_a[0] - pose_b[0], pose_a[1] - pose_b[1]
        r = math.hypot(dx, dy)
        return r - A.shape.radius - B.shape.radius, (dx / r, dy / r)
    if isinstance(A.shape, Circle):
        gap, n = _polygon_point(*placed(B, pose_b), pose_a[:2])
        return gap - A.shape.radius, n
    va, na = placed(A, pose_a)
    if isinstance(B.shape, Circle):
        gap, (nx, ny) = _polygon_point(va, na, pose_b[:2])
        return gap - B.shape.radius, (-nx, -ny)
    vb, nb = placed(B, pose_b)
    s_a, (nx, ny) = _max_separation(va, na, vb)
    s_b, n_b = _max_separation(vb, nb, va)
    return (s_a, (-nx, -ny)) if s_a > s_b else (s_b, n_b)


# --- the simulation ------------------------------------------------------------------------

class Box2DSimulation(Simulation):
    def __init__(self, scene: Scene, settings: Settings, tuning: dict[str, float], bullet: bool = False):
        self._dt = settings.dt
        self._bullet = bullet
        self.iterations = DEFAULT_SUBSTEPS if settings.iterations is None else settings.iterations
        hertz_cap = HERTZ_CAP_PER_SUBSTEP_RATE * self.iterations / self._dt
        hertz = min(tuning["contact_hertz"], hertz_cap)
        gx, gz = float(scene.gravity[0]), float(scene.gravity[2])
        self._gravity = np.array([gx, gz])
        threads = settings.threads or 1
        world = b2.World(gravity=(gx, gz), restitution_threshold=0.0, maximum_linear_speed=MAXIMUM_LINEAR_SPEED,
                         thread_pool=b2.ThreadPool(threads) if threads > 1 else None)
        world.sleeping_enabled = False
        world.continuous_enabled = bullet
        world.set_contact_tuning(hertz, tuning["contact_damping_ratio"], tuning["contact_push_speed"])
        self._world = world
        self.knobs = {
            "sub_step_count": self.iterations,
            "worker_count": threads,          # ThreadPool(n) when above 1 (default: 1, no pool)
            "gravity": [gx, gz],
            "restitution_threshold": 0.0,     # default 1 m/s: slower impacts lose all bounce
            "maximum_linear_speed": MAXIMUM_LINEAR_SPEED,  # default 400 m/s
            "enable_sleep": False,            # default True
            "enable_continuous": bullet,      # default True: time-of-impact clamping of fast bodies
            "contact_hertz": hertz,           # default 30 Hz (clamped by Box2D to 0.125 inv_h)
            "contact_hertz_cap": hertz_cap,   # 0.125 * sub-steps / dt
            "static_contact_hertz": 2.0 * hertz,  # Box2D doubles it against static bodies
            "contact_damping_ratio": tuning["contact_damping_ratio"],  # default 10
            "contact_push_speed": tuning["contact_push_speed"],        # Box2D default 3 m/s
            "linear_slop": 0.005,             # B2_LINEAR_SLOP (b2_lengthUnitsPerMeter = 1), not settable per world
            "speculative_distance": 0.02,     # 4 linear slops: contacts found this far apart
            "warm_starting": True,            # Box2D's default; pyb2d3 does not expose the switch
            "contact_force": ("momentum: J_i = m (v' - v) - m g dt per body, split over the touching pairs "
                              "along their normals (adapters/impulse_split.py)"),
            "bodies": {},
        }

        friction, restitution = _materials(scene)
        self._rolling = _rolling(scene)
        self._pairs = {pair_key(a.name, b.name): scene.material_of(a.name, b.name)
                       for a, b in scene.contact_pairs()}
        self._bodies: dict[str, object] = {}   # dynamic bodies by name
        self._mass: dict[str, float] = {}      # their masses as Box2D holds them (float32)
        self._shape_of: dict[int, str] = {}    # shape id -> body name
        self._geometry: dict[str, Body] = {}
        self._outlines: dict[str, tuple] = {}  # polygon outlines by body name (contact_gap)
        self._centre = np.mean([(b.position[0], b.position[2]) for b in scene.dynamic_bodies], axis=0)
        self._every: dict[str, object] = {}   # every body (static ones too), for joints
        for body in scene.bodies:
            self._add(body, friction[body.name], restitution[body.name])
        self._joints = [self._joint(joint, j) for j, joint in enumerate(scene.joints)]
        # a torque about scene +y is minus Box2D's
        self._loads = [(self._bodies[load.body], (float(load.force[0]), float(load.force[2])), -float(load.torque[1]))
                       for load in scene.loads if load.acts]
        if self._loads:
            self.knobs["loads"] = "apply_force_to_center and apply_torque before each step (Box2D clears them)"
        self._static_pose = {}  # a plane's pose is its normal and offset (contact_gap)
        for body in scene.bodies:
            if body.static:
                angle = 0.0 if isinstance(body.shape, Plane) else _angle(body)
                self._static_pose[body.name] = (body.position[0], body.position[2], math.cos(angle), math.sin(angle))
        self._touching: set[tuple[str, str]] = set()
        self._began: list = []  # the last step's begin-touch events (contact_points)
        self._pending = None
        self._gaps_after: dict = {}  # pair -> (poses, contact_gap) after the last step read
        self._forces: dict[tuple[str, str], float] | None = {}
        self.knobs["pair_split"] = "unique"
        self.effects = self._built_effects(friction, restitution)

    def _add(self, body: Body, mu: float, e: float) -> None:
        shape_def = b2.shape_def(enable_contact_events=True, density=1.0)
        rolling = self._rolling[body.name]  # mu_r = d / r (`_rolling`)
        shape_def.material = b2.surface_material(friction=mu, restitution=e, rolling_resistance=rolling,
                                                 tangent_speed=0.0)
        record = {"friction": mu, "restitution": e, "rolling_resistance": rolling, "tangent_speed": 0.0}
        self._geometry[body.name] = body
        if body.shape.kind in ("rect", "polygon"):
            self._outlines[body.name] = outline(body.shape)
        if isinstance(body.shape, Plane):
            nx, ny, nz = body.shape.normal
            if ny != 0.0:
                raise Unsupported(f"plane normal {body.shape.normal}: not in the x-z plane of a 2D scene")
            # the box's top edge on the plane: the body at the plane's point below the
            # dynamic bodies' mean position, turned so that its +y is the normal
            n = np.array([nx, nz])
            origin = tuple(float(c) for c in self._centre - (self._centre @ n - body.shape.offset) * n)
            angle = math.atan2(-nx, nz)
            pb = self._world.create_static_body(position=origin, rotation=_rot(angle))
            shape = pb.create_polygon_shape(shape_def, b2.box(PLANE_HALF_LENGTH, PLANE_DEPTH / 2,
                                                               center=(0.0, -PLANE_DEPTH / 2)))
            record.update(static=True, polygon={"half_extents": [PLANE_HALF_LENGTH, PLANE_DEPTH / 2],
                                                "top_edge_through": list(origin), "angle": angle})
        else:
            angle = _angle(body)
            kw = dict(position=(body.position[0], body.position[2]), rotation=_rot(angle))
            if body.static:
                pb = self._world.create_static_body(**kw)
                record["static"] = True
            else:
                omega = -body.angular_velocity[1] if body.rotates else 0.0
                pb = self._world.create_dynamic_body(
                    **kw, linear_velocity=(body.velocity[0], body.velocity[2]), angular_velocity=omega,
                    linear_damping=0.0, angular_damping=0.0, enable_sleep=False,
                    fixed_rotation=not body.rotates, gravity_scale=1.0)
            if isinstance(body.shape, Circle):
                shape = pb.create_circle_shape(shape_def, b2.circle(radius=body.shape.radius))
                record["circle"] = {"radius": body.shape.radius}
            elif body.shape.kind == "polygon":
                # b2MakeOffsetPolygon of the corners' hull at the body origin: radius 0 (no rounding)
                shape = pb.create_polygon_shape(shape_def, b2.polygon(hull=_hull(body)))
                record["polygon"] = {"vertices": [[float(x), float(z)] for x, z in body.shape.corners], "radius": 0.0,
                                     "hull": "b2ComputeHull, every corner kept"}
            else:
                a, c = body.shape.half_extents
                shape = pb.create_polygon_shape(shape_def, b2.box(a, c))
                record["polygon"] = {"half_extents": [a, c], "radius": 0.0}
            if body.dynamic:
                # mass and inertia exactly as the scene states them; 0 inertia is Box2D's
                # lock on rotation (b2Body_SetMassData: invInertia = 0)
                mass = b2.MassData()
                mass.mass, mass.center = body.mass, (0.0, 0.0)
                mass.rotational_inertia = body.principal_inertia[1] if body.rotates else 0.0
                pb.mass_data = mass
                pb.bullet = bullet = self._bullet and starts_fast(body, self._dt)  # fast bodies only (module notes)
                self._bodies[body.name] = pb
                self._mass[body.name] = pb.mass
                record.update(mass=pb.mass, rotational_inertia=pb.mass_data.rotational_inertia,
                              fixed_rotation=not body.rotates, linear_damping=0.0, angular_damping=0.0,
                              enable_sleep=False, is_bullet=bullet)
        self._shape_of[shape.id] = body.name
        self._every[body.name] = pb
        self.knobs["bodies"][body.name] = record

    def _joint(self, joint, j: int):
        """A scene joint as a Box2D joint between the two bodies (the world: a static body at
        the origin, made once): revolute a revolute joint at the anchor, its limit in Box2D's
        angle (minus the scene's turn about +y); prismatic a prismatic joint along the axis
        (Box2D's holds the relative turn too); fixed a weld joint with rigid (0 Hz) linear
        and angular rows. No springs, no motors but a joint's dry friction (Box2D's own idiom: a
        motor at speed 0 with its force or torque bounded by the friction), collide_connected
        off (cases.scene.Joint).
        The joints' softness is Box2D's own (b2WorldDef jointHertz and jointDampingRatio,
        which pyb2d3 0.11.1 does not expose)."""
        if joint.parent is None and "world" not in self._every:
            self._every["world"] = self._world.create_static_body(position=(0.0, 0.0))
        a = self._every["world" if joint.parent is None else joint.parent]
        b = self._every[joint.body]
        anchor = (float(joint.anchor[0]), float(joint.anchor[2]))
        common = dict(body_a=a, body_b=b, local_anchor_a=a.local_point(anchor), local_anchor_b=b.local_point(anchor),
                      collide_connected=False)
        reference = _angle_of(b) - _angle_of(a)
        record = {"kind": joint.kind, "collide_connected": False, "reference_angle": reference,
                  "joint_softness": "Box2D's default (jointHertz, jointDampingRatio: not exposed by pyb2d3)"}
        if joint.kind == "revolute":
            made = b2.revolute_joint_def(**common, reference_angle=reference, enable_spring=False,
                                         enable_motor=joint.friction > 0, enable_limit=joint.limits is not None)
            if joint.friction > 0:  # dry friction: a motor held at speed 0 whose torque is bounded by it
                made.motor_speed, made.max_motor_torque = 0.0, joint.friction
                record.update(friction="motor at speed 0", max_motor_torque=joint.friction)
            if joint.limits is not None:  # the scene's turn about +y is minus Box2D's angle
                low, high = (-joint.limits[1], -joint.limits[0]) if joint.unit_axis[1] > 0 else joint.limits
                made.lower_angle, made.upper_angle = low, high
                record["limits"] = [low, high]
            self._world.create_revolute_joint(made)
        elif joint.kind == "prismatic":
            ux, _, uz = joint.unit_axis
            made = b2.prismatic_joint_def(**common, local_axis_a=a.local_vector((ux, uz)), reference_angle=reference,
                                          enable_spring=False, enable_motor=joint.friction > 0,
                                          enable_limit=joint.limits is not None)
            if joint.friction > 0:  # dry friction: a motor held at speed 0 whose force is bounded by it
                made.motor_speed, made.max_motor_force = 0.0, joint.friction
                record.update(friction="motor at speed 0", max_motor_force=joint.friction)
            if joint.limits is not None:
                made.lower_translation, made.upper_translation = joint.limits
                record["limits"] = list(joint.limits)
            self._world.create_prismatic_joint(made)
        else:  # fixed
            made = b2.weld_joint_def(**common, reference_angle=reference, linear_hertz=0.0, angular_hertz=0.0)
            record.update(linear_hertz=0.0, angular_hertz=0.0)
            self._world.create_weld_joint(made)
        self.knobs.setdefault("joints", {})[f"joints[{j}]"] = record
        return joint.kind

    def _built_effects(self, friction: dict, restitution: dict) -> frozenset[str]:
        fx = set()
        if np.any(self._gravity != 0.0):
            fx.add("gravity")
        if self._pairs:
            fx.add("contact")
            # Box2D's mixing of the values given to it, pair by pair
            if any(max(restitution[a], restitution[b]) > 0 for a, b in self._pairs):
                fx.add("restitution")
            if any(friction[a] * friction[b] > 0 for a, b in self._pairs):
                fx.add("friction")
            radius = {n: _shape_radius(b) for n, b in self._geometry.items()}
            if any(max(self._rolling[a], self._rolling[b]) * max(radius[a], radius[b]) > 0 for a, b in self._pairs):
                fx.add("rolling_resistance")
        if any(b.mass_data.rotational_inertia > 0 for b in self._bodies.values()):
            fx.add("rotation")
        if self._joints:
            fx.add("joint")
        if any("limits" in r for r in self.knobs.get("joints", {}).values()):
            fx.add("limit")
        if any("friction" in r for r in self.knobs.get("joints", {}).values()):
            fx.add("joint_friction")
        if self._loads:
            fx.add("load")
        return frozenset(fx)

    # --- stepping and the contact read-out --------------------------------------------

    def _snapshot(self) -> dict[str, tuple]:
        """Pose (x, y, c, s) and velocity (vx, vy) of every dynamic body, as Box2D holds them."""
        out = {}
        for name, pb in self._bodies.items():
            p, q, v = pb.position, pb.rotation, pb.linear_velocity  # attributes: unpacking costs 15 us
            out[name] = (p.x, p.y, q.c, q.s, v.x, v.y)
        return out

    def step(self) -> None:
        before = self._snapshot()
        for body, force, torque in self._loads:
            body.apply_force_to_center(force, False)
            body.apply_torque(torque, False)
        self._world.step(self._dt, self.iterations)
        events = self._world.get_contact_events()
        touching_before = frozenset(self._touching)
        # the begin-touch events of this step, whose manifolds contact_points reads (valid until the next step)
        self._began = list(events.begin_events()) if events.begin_count else []
        if self._began:
            self._touching.update(pair_key(self._shape_of[e.shape_a.id], self._shape_of[e.shape_b.id])
                                  for e in self._began)
        if events.end_count:
            self._touching.difference_update(pair_key(self._shape_of[e.shape_a.id], self._shape_of[e.shape_b.id])
                                             for e in events.end_events())
        # the forces are worked out when asked for (contact_forces), not inside the step
        self._pending = (before, self._snapshot(), touching_before)
        self._forces = None

    def _pose(self, name: str, snapshot: dict) -> tuple:
        return snapshot[name][:4] if name in snapshot else self._static_pose[name]

    def _gap(self, a: str, b: str, snapshot: dict | None = None) -> tuple[float, tuple]:
        return self._pair_gap((a, b), self._snapshot() if snapshot is None else snapshot)[1]

    def _pair_gap(self, key: tuple[str, str], snapshot: dict, known: tuple | None = None) -> tuple:
        """(poses, contact_gap) of a pair at `snapshot`; `known`, an earlier such result,
        is returned as it is when it was worked out at the same poses."""
        poses = (self._pose(key[0], snapshot), self._pose(key[1], snapshot))
        if known is not None and known[0] == poses:
            return known
        return poses, contact_gap(self._geometry[key[0]], poses[0], self._geometry[key[1]], poses[1], self._outlines)

    def _read_forces(self) -> dict[tuple[str, str], float]:
        """Normal force of each acting pair from the bodies' contact impulses (module notes).
        The normal is the pair's before the step (Box2D found its contacts from those
        poses), or after it for a pair that began touching in the step."""
        before, after, touching_before = self._pending
        # a pair's geometry before this step is its geometry after the last one (the same
        # poses): kept from the last read, it halves the pure-Python gap computations
        last, self._gaps_after = self._gaps_after, {}
        gaps, normals = {}, {}
        for key in self._touching:
            self._gaps_after[key] = self._pair_gap(key, after)
            gaps[key], normals[key] = self._gaps_after[key][1]
            if key in touching_before:
                normals[key] = self._pair_gap(key, before, last.get(key))[1][1]
        pairs = acting_pairs(gaps, self._bodies)
        if not pairs:
            return {}
        gx, gy = self._gravity * self._dt
        J = {n: (self._mass[n] * (after[n][4] - before[n][4] - gx), self._mass[n] * (after[n][5] - before[n][5] - gy))
             for n in self._bodies}
        P, open_ = split_impulses(J, pairs, normals, {key: self._pairs[key].mu_s > 0.0 for key in pairs})
        if open_:
            self.knobs["pair_split"] = OPEN_SPLIT
        return {key: (p[0] * normals[key][0] + p[1] * normals[key][1]) / self._dt for key, p in P.items()}

    # --- the contract -------------------------------------------------------------------

    def states(self):
        out = {}
        for name, pb in self._bodies.items():
            p, q, v = pb.position, pb.rotation, pb.linear_velocity
            phi = -math.atan2(q.s, q.c)
            out[name] = state_row((p.x, 0.0, p.y), quat_about_y(phi), (v.x, 0.0, v.y),
                                  (0.0, -pb.angular_velocity, 0.0))
        return out

    # Bulk reads (adapters.base): per body x, z (Box2D's y), the rotation's cosine and sine,
    # vx, vz and w in Box2D's plane, one tuple assignment a body; decoded as states() maps them.
    def body_order(self) -> list[str]:
        return list(self._bodies)

    def state_size(self) -> int:
        return 7 * len(self._bodies)

    def write_state(self, out: np.ndarray) -> None:
        i = 0
        for pb in self._bodies.values():
            p, q, v = pb.position, pb.rotation, pb.linear_velocity
            out[i:i + 7] = (p.x, p.y, q.c, q.s, v.x, v.y, pb.angular_velocity)
            i += 7

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        r = raw.reshape(len(raw), len(self._bodies), 7)
        x, z, c, s, vx, vz, w = np.moveaxis(r, 2, 0)
        return planar_states(x, z, -np.arctan2(s, c), vx, vz, -w)

    def contact_forces(self):
        if self._forces is None:
            self._forces = self._read_forces() if self._pending else {}
        return dict(self._forces)

    def contact_points(self) -> list[ContactPoint]:
        """The geometry of each contact that began touching in the last step, forces NaN
        (module notes); ContactGeometryUnavailable where a contact persists from before."""
        out, began = [], set()
        for e in self._began:
            a, b = self._shape_of[e.shape_b.id], self._shape_of[e.shape_a.id]  # the normal points from A to B
            if pair_key(a, b) not in self._touching:  # began and ended within the step
                continue
            began.add(pair_key(a, b))
            m = e.manifold
            n = (m.normal.x, 0.0, m.normal.y)
            for p in m.points():
                out.append(ContactPoint(a, b, np.array((p.point.x, 0.0, p.point.y)), np.array(n), math.nan,
                                        np.full(3, math.nan), float(p.separation)))
        stale = sorted(self._touching - began)
        if stale:
            raise ContactGeometryUnavailable(
                f"{len(stale)} contacts ({'/'.join(stale[0])} first) persist from an earlier step: pyb2d3 gives a "
                "contact's manifold only in the step it begins touching (b2Body_GetContactData is not bound)")
        return out

    def close(self) -> None:
        world, self._world = getattr(self, "_world", None), None
        if world is not None:
            world.destroy()
        self._bodies = {}
