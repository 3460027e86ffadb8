"""Pymunk (Chipmunk2D, via its Munk2D fork) behind the engine contract: 2D scenes only.

Frames. A 2D scene lies in the x-z plane; Pymunk's plane is x-y. Scene (x, z) maps to
Pymunk (x, y). A positive rotation phi about scene +y takes +z towards +x, while Pymunk's
positive angle takes +x towards +y (= scene +z), so the Pymunk angle is -phi and the
Pymunk angular velocity is -omega_y.

Shapes. A Circle is a pymunk.Circle, a Rect Poly.create_box and a Polygon a Poly of its
corners in the body frame, each with radius 0 (no rounding); the body's mass and moment are
the scene's (a Poly's own are never read). A Plane is a thick static segment.

What one `space.step(dt)` does (Munk2D src/cpSpaceStep.c, read for 7.3.1): positions move
with the *old* velocity (x += v dt), then contacts are found (overlapping shapes only; a
polygon also when exactly touching; no speculative contacts), pre_solve runs, restitution
targets -e v_n are taken from the relative normal velocity before gravity is added,
velocities get gravity (v += g dt), then `iterations` sweeps of sequential impulses with
accumulation, clamping and warm starting (001 notes, "Sequential Impulses"), and post_solve
runs. Overlap beyond `collision_slop` is pushed out through a separate bias velocity that
moves positions only (split impulse), at a rate set by `collision_bias`. The integrator
order is Pymunk's, recorded here, not corrected: free fall follows
z_n = z_0 - g dt^2 n(n-1)/2, above the continuous solution by g t dt / 2.

Contact read-out. Pymunk reports one impulse per arbiter (a touching pair of shapes), summed
over its points: `contact_points()` gives ONE point per touching pair, the pair's resultant,
at the mean of its points (each the midpoint of point_a and point_b), with the smallest
`distance` as its gap (the resultant form the contract allows, cases.trajectory.ContactPoint).
`contact_forces()` is the same read-out's f_n per pair.
"""
from __future__ import annotations

import math
import sys
from importlib import metadata

import numpy as np
import pymunk
# Chipmunk's C arbiter API, through the cffi binding Pymunk's own Arbiter properties call
# (pymunk/arbiter.py: total_impulse, contact_point_set and friction are these functions on
# `arbiter._arbiter`; the same names since Pymunk 5). Called directly in post_solve they cost
# 0.5 us per pair where the Python properties cost 4-10 us (building Vec2d and ContactPointSet
# objects), inside the timed step (measured on a five-box stack). Their struct results are
# copies owned by Python: valid after the callback. A Pymunk without that binding falls back
# on the public properties (same values, slower): _PointSet gives them the struct's names.
try:
    from pymunk._chipmunk_cffi import lib as _chipmunk
except ImportError:  # pragma: no cover - depends on the installed Pymunk
    _chipmunk = None

from adapters.base import Adapter, Capabilities, Settings, Simulation, Unsupported
from adapters.combination import per_body_values
from adapters.frames import planar_states, require_turn_about_y, state_row
from cases.scene import Body, Circle, Plane, Scene, pair_key, quat_about_y
from cases.trajectory import ContactPoint

DEFAULT_ITERATIONS = 10  # Pymunk's own default Space.iterations, stated here
# An unlimited prismatic joint is a groove this long each way from the start (m): Chipmunk's
# groove has two ends, and 1 km lies beyond any scene's travel.
GROOVE_HALF_LENGTH = 1e3
# Overlap the solver leaves alone (m). Pymunk's default 0.1 is pixel scale: bodies would rest
# up to 0.1 m deep. 0.1 mm is far below the scenes' sizes and above rounding; 1e-5 m with
# beta = 0.2 lets a five-box stack at dt = 5e-3 walk sideways 1.5 mm/s (measured). The cost
# shows at 60 Hz: a 5-box stack falls at 20 iterations (after 4.7 s), where slop 1e-3 holds
# it (resting 1 mm deep, the library's penetration bound); at 5-10 iterations both drop it
# within 0.3 s, at 50 both hold 5 and drop 10 (measured). The stability map of `physval
# stress` reports this trade-off, which is kept for accurate resting contact; the engine
# variant "pymunk-slop1mm" (adapters/registry.py) runs the other side of it.
COLLISION_SLOP = 1e-4
# Depenetration: v_bias = beta/dt (delta - delta_slop)_+ on pseudo-velocities (note 001,
# "Sequential Impulses": beta in [0.1, 0.3]); beta = 0.2 as in reference_impl, so the two
# differ by engine, not by knob. Pymunk takes it per second, as `collision_bias`, the
# fraction of overlap left after 1 s: beta = 1 - collision_bias**dt (its default, 0.9**60,
# is beta = 0.0063 at dt = 1e-3: an e = 0 impact's overlap would linger for 0.5 s).
BIAS_FACTOR = 0.2
COLLISION_PERSISTENCE = 3  # steps a separated pair's impulses are kept for warm starting (default)
# The static plane is a thick segment (a capsule) whose flat top lies exactly on the plane: a
# solid half-space this deep and twice this long, centred on the point of the plane nearest
# the origin. Rounding on its surface is about depth * 1e-16 m.
PLANE_HALF_LENGTH = 1e4  # m
PLANE_DEPTH = 1.0  # m: far more than any overlap v*dt at the scenes' speeds



class _PointSet:
    """Pymunk's public ContactPointSet under the C struct's field names (the fallback of
    the import above): normal, count, points[i].pointA / pointB / distance."""

    class _Point:
        __slots__ = ("pointA", "pointB", "distance")

        def __init__(self, p):
            self.pointA, self.pointB, self.distance = p.point_a, p.point_b, p.distance

    def __init__(self, cps):
        self.normal = cps.normal
        self.points = [self._Point(p) for p in cps.points]
        self.count = len(self.points)

class PymunkAdapter(Adapter):
    name = "pymunk"
    package = "pymunk"
    # 7.0.0 runs the battery as 7.3.1 does, bit for bit; Pymunk 6 has no Space.on_collision
    supported = ">=7.0.0,<8"
    capabilities = Capabilities(
        dimensions=frozenset({2}),
        shapes=frozenset({"circle", "rect", "polygon", "plane"}),  # a polygon: a Poly of radius 0
        native_restitution=True,
        static_kinetic=False,  # one friction coefficient per pair
        contact_forces=True,
        iterations=True,
        contact_points=True,
        # one sweep of sequential impulses over all the step's arbiters, converging to the
        # simultaneous solution, restitution from each contact's approach velocity at the
        # start of the step (cases/column_impact.py). Contacts exist only between shapes
        # that overlap (discs exactly touching have none), so a row of discs placed exactly
        # touching is struck one pair per step instead: the sequential outcome (measured:
        # a Newton's cradle of three, e = 1, ends at 0, 0, 1).
        impact_model="simultaneous",
        # Settings.threads: Space(threaded=True) with that many threads (Chipmunk's threaded
        # solver, Linux and macOS; it uses at most 2)
        modes=frozenset({"threads"}),
        why_not=(("save_restore", "a pickled Space restarts without Chipmunk's cached arbiters, whose "
                                  "accumulated impulses warm-start the next step: no whole state to save"),
                 ("limit_restitution", "a limit takes a range only (RotaryLimitJoint min and max, a GrooveJoint's "
                                       "ends): Chipmunk's limit rows have no restitution")),
        # Chipmunk's constraints (_joint): impulse rows between two bodies' own coordinates,
        # solved with the contacts, their drift corrected by error_bias
        joints=frozenset({"revolute", "prismatic", "fixed"}),
        joint_limits=True,
        coordinates="maximal",
        loads=True,  # Body.apply_force_at_world_point and .torque before each step (Chipmunk clears them)
    )

    def __init__(self, name: str = "pymunk", collision_slop: float = COLLISION_SLOP):
        """collision_slop: the overlap (m) the solver leaves alone (see COLLISION_SLOP);
        the "pymunk-slop1mm" variant takes 1e-3."""
        if not (math.isfinite(collision_slop) and collision_slop >= 0):
            raise ValueError(f"collision_slop = {collision_slop!r}: must be a finite length >= 0 (m)")
        self.name = name
        self.collision_slop = float(collision_slop)

    def version(self) -> str:
        # the distribution's version: pymunk 7.0.0's pymunk.version reads "2.0.0", its Munk2D's
        return f"{metadata.version('pymunk')} (Munk2D {pymunk.chipmunk_version})"

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene)
        if reason:
            raise Unsupported(reason)
        return PymunkSimulation(scene, settings, self.collision_slop)


def _angle(body: Body) -> float:
    """Pymunk angle of a 2D body: minus its rotation about scene +y (see module docstring)."""
    require_turn_about_y(body, "which a 2D engine cannot represent")
    w, _, y, _ = body.orientation
    return -2.0 * math.atan2(y, w)


def _json(value: float):
    """Infinity as the string 'inf' so knobs stay strict JSON."""
    return value if math.isfinite(value) else "inf"


class PymunkSimulation(Simulation):
    def __init__(self, scene: Scene, settings: Settings, collision_slop: float = COLLISION_SLOP):
        self._dt, self._scene = settings.dt, scene
        self.iterations = DEFAULT_ITERATIONS if settings.iterations is None else settings.iterations
        threads = settings.threads or 1
        space = pymunk.Space(threaded=threads > 1)
        if threads > 1:
            space.threads = threads
        space.iterations = self.iterations
        space.collision_slop = collision_slop
        # (1 - beta)**(1/dt) underflows below dt = 3e-4 s: floored at the smallest normal
        # float, where beta becomes 1 - exp(-708 dt) (recorded)
        collision_bias = max((1.0 - BIAS_FACTOR) ** (1.0 / self._dt), sys.float_info.min)
        space.collision_bias = collision_bias
        space.collision_persistence = COLLISION_PERSISTENCE
        space.damping = 1.0  # velocity kept per second: 1 is no damping
        space.sleep_time_threshold = math.inf  # sleeping off
        gx, gz = float(scene.gravity[0]), float(scene.gravity[2])
        space.gravity = (gx, gz)
        self.knobs = {
            "threads": threads,  # Space(threaded=True).threads when above 1 (default: unthreaded)
            "iterations": self.iterations,
            "collision_slop": collision_slop,
            "collision_bias": collision_bias,
            "bias_factor_per_step": 1.0 - collision_bias ** self._dt,  # beta in force
            "collision_persistence": COLLISION_PERSISTENCE,
            "damping": 1.0,
            "sleep_time_threshold": "inf",
            "gravity": [gx, gz],
            "ground": "segment",  # a scene Plane: a thick static segment (a capsule), its flat top on the plane
            "bodies": {},
        }

        self._space = space
        self._bodies: dict[str, pymunk.Body] = {}  # dynamic bodies, for states()
        shapes: dict[str, pymunk.Shape] = {}
        for kind, body in enumerate(scene.bodies, start=1):
            shapes[body.name] = self._add(body)
            shapes[body.name].collision_type = kind  # one per body: handlers are per pair
            if body.dynamic:
                self._bodies[body.name] = shapes[body.name].body
        self._c_bodies = [pb._body for pb in self._bodies.values()]  # Chipmunk's cpBody*, for write_state

        # Pair materials. Pymunk multiplies the two shapes' elasticity and friction. Where
        # per-body values reproduce every pair under that product, the shapes carry them and
        # no Python runs for materials inside the step. Otherwise each pair's pre_solve sets
        # the arbiter's restitution and friction: it runs after the product is taken and
        # before the restitution target is, so it is exact for any scene, at 2-4 us of Python
        # per touching pair and step (measured here).
        self._pairs = {pair_key(a.name, b.name): scene.material_of(a.name, b.name)
                       for a, b in scene.contact_pairs()}
        try:
            e = per_body_values(scene, lambda m: m.e, "product", "restitution")
            mu = per_body_values(scene, lambda m: m.mu_s, "product", "friction")
            pre_solve = None
        except Unsupported:
            e = mu = {name: 0.0 for name in shapes}  # overridden per pair
            pre_solve = self._pre_solve
        for name, shape in shapes.items():
            shape.elasticity, shape.friction = e[name], mu[name]
            self.knobs["bodies"][name].update(elasticity=e[name], friction=mu[name])
        self.knobs["pair_materials"] = "product of shape values" if pre_solve is None else "pre_solve"
        if pre_solve is not None:
            self.knobs["pre_solve"] = [{"pair": list(k), "restitution": m.e, "friction": m.mu_s}
                                       for k, m in self._pairs.items()]

        # Contacts: each pair's post_solve copies this step's impulse and points (_post_solve).
        # The handler for (a, b) makes the arbiter's shapes come in that order (Munk2D
        # cpArbiterUpdate sets `swapped` from the handler's typeA; checked with the pair's
        # collision types in both orders), so data=(a, b) names shapes[0] and shapes[1].
        self._solved: list[tuple] = []  # (pair key, total_impulse, contact_point_set, frictionless)
        for a, b in self._pairs:
            space.on_collision(shapes[a].collision_type, shapes[b].collision_type,
                               pre_solve=pre_solve, post_solve=self._post_solve, data=(a, b))
        self.knobs["contact_force"] = "post_solve: -total_impulse . normal / dt (the pair's resultant)"
        self.knobs["contact_points"] = "one per touching pair: mean of its points, smallest distance"
        space.reindex_static()

        every = {name: shape.body for name, shape in shapes.items()}
        self._constraints = [c for j, joint in enumerate(scene.joints) for c in self._joint(joint, j, every)]
        self._loads = [(self._bodies[load.body], (float(load.force[0]), float(load.force[2])), -float(load.torque[1]))
                       for load in scene.loads if load.acts]  # a torque about scene +y is -torque in Pymunk
        if self._loads:
            self.knobs["loads"] = "Body.force and Body.torque set before each step (Chipmunk clears them after it)"
        self.effects = self._built_effects()

    def _add(self, body: Body) -> pymunk.Shape:
        knobs = self.knobs["bodies"]
        if body.static:
            pb = pymunk.Body(body_type=pymunk.Body.STATIC)
            knobs[body.name] = {"static": True}
        else:
            moment = body.principal_inertia[1] if body.rotates else math.inf
            pb = pymunk.Body(body.mass, moment)
            knobs[body.name] = {"mass": body.mass, "moment": _json(moment)}
        if isinstance(body.shape, Plane):
            shape = self._plane(pb, body.shape, self._scene)
            knobs[body.name]["Segment"] = {"a": list(shape.a), "b": list(shape.b), "radius": shape.radius}
        else:
            pb.position = (body.position[0], body.position[2])
            pb.angle = _angle(body)
            if body.dynamic:
                pb.velocity = (body.velocity[0], body.velocity[2])
                # rotates=False holds the orientation fixed: no spin either
                pb.angular_velocity = -body.angular_velocity[1] if body.rotates else 0.0
            if isinstance(body.shape, Circle):
                shape = pymunk.Circle(pb, body.shape.radius)
            elif body.shape.kind == "polygon":
                # the corners in the body frame (the scene's (x, z) is Pymunk's (x, y)), no rounding
                corners = [(float(x), float(z)) for x, z in body.shape.corners]
                shape = pymunk.Poly(pb, corners, radius=0.0)
                knobs[body.name]["Poly"] = {"vertices": [list(v) for v in corners], "radius": 0.0}
            else:
                a, c = body.shape.half_extents
                shape = pymunk.Poly.create_box(pb, (2 * a, 2 * c), radius=0.0)
        self._space.add(pb, shape)
        return shape

    @staticmethod
    def _plane(pb: pymunk.Body, plane: Plane, scene: Scene) -> pymunk.Segment:
        """The half-space n . x <= offset as a capsule whose flat top is the line n . x = offset,
        centred below the line's point nearest the origin (moved under the bodies where they
        are far from it: Plane.centre_under)."""
        nx, ny, nz = plane.normal
        if ny != 0.0:
            raise Unsupported(f"plane normal {plane.normal}: not in the x-z plane of a 2D scene")
        axis = plane.offset - PLANE_DEPTH  # the capsule's axis, PLANE_DEPTH below the surface
        shift = plane.centre_under(scene, PLANE_HALF_LENGTH) - plane.offset * np.asarray(plane.normal, float)
        cx, cy = axis * nx + shift[0], axis * nz + shift[2]  # + 0 (the same bits) near the origin
        tx, ty = -nz * PLANE_HALF_LENGTH, nx * PLANE_HALF_LENGTH  # along the line
        return pymunk.Segment(pb, (cx - tx, cy - ty), (cx + tx, cy + ty), PLANE_DEPTH)

    def _joint(self, joint, j: int, every: dict) -> list:
        """A scene joint as Chipmunk constraints between the two bodies (the world: the
        space's static body): revolute a PivotJoint at the anchor; prismatic a GrooveJoint
        (the child's anchor on a groove of the parent along the axis, as long as the limits,
        else GROOVE_HALF_LENGTH each way) and a GearJoint (no relative turn); fixed a
        PivotJoint and a GearJoint; a revolute limit a RotaryLimitJoint. Every constraint at
        Chipmunk's defaults, stated (max_force, max_bias infinite; error_bias), and
        collide_bodies off: the two bodies do not collide (cases.scene.Joint)."""
        a = self._space.static_body if joint.parent is None else every[joint.parent]
        b = every[joint.body]
        anchor = (float(joint.anchor[0]), float(joint.anchor[2]))
        ux, _, uz = joint.unit_axis
        made, record = [], {"kind": joint.kind}
        if joint.kind in ("revolute", "fixed"):
            made.append(pymunk.PivotJoint(a, b, anchor))
        if joint.kind in ("prismatic", "fixed"):
            made.append(pymunk.GearJoint(a, b, b.angle - a.angle, 1.0))
        if joint.kind == "prismatic":
            low, high = joint.limits if joint.limits is not None else (-GROOVE_HALF_LENGTH, GROOVE_HALF_LENGTH)
            ends = [a.world_to_local((anchor[0] + s * ux, anchor[1] + s * uz)) for s in (low, high)]
            made.append(pymunk.GrooveJoint(a, b, ends[0], ends[1], b.world_to_local(anchor)))
            record["groove"] = [list(e) for e in ends]
        if joint.kind == "revolute" and joint.limits is not None:
            # the scene's turn q about +y is minus Pymunk's angle difference (module docstring)
            low, high = (-joint.limits[1], -joint.limits[0]) if joint.unit_axis[1] > 0 else joint.limits
            rest = b.angle - a.angle
            made.append(pymunk.RotaryLimitJoint(a, b, rest + low, rest + high))
            record["rotary_limit"] = [rest + low, rest + high]
        for c in made:
            c.collide_bodies = False
        self._space.add(*made)
        record.update(constraints=[type(c).__name__ for c in made], error_bias=made[0].error_bias,
                      max_bias=_json(made[0].max_bias), max_force=_json(made[0].max_force), collide_bodies=False)
        self.knobs.setdefault("joints", {})[f"joints[{j}]"] = record
        return made

    def _built_effects(self) -> frozenset[str]:
        fx = set()
        if any(g != 0.0 for g in self._space.gravity):
            fx.add("gravity")
        if self._pairs:
            fx.add("contact")
            if any(m.e > 0 for m in self._pairs.values()):
                fx.add("restitution")
            if any(m.mu_s > 0 for m in self._pairs.values()):
                fx.add("friction")
        if any(math.isfinite(b.moment) for b in self._bodies.values()):
            fx.add("rotation")
        if self._constraints:
            fx.add("joint")
        if any(isinstance(c, pymunk.RotaryLimitJoint) for c in self._constraints) or any(
                "groove" in r and j.limits is not None for r, j in zip(self.knobs.get("joints", {}).values(),
                                                                       self._scene.joints)):
            fx.add("limit")
        if self._loads:
            fx.add("load")
        return frozenset(fx)

    # --- callbacks, once per touching pair and step -----------------------------------

    def _pre_solve(self, arbiter: pymunk.Arbiter, space, key) -> None:
        m = self._pairs[key]
        arbiter.restitution, arbiter.friction = m.e, m.mu_s

    def _post_solve(self, arbiter: pymunk.Arbiter, space, key) -> None:
        # Every arbiter the solver iterated on this step gets its post_solve (Munk2D
        # cpSpaceStep: the loop over space->arbiters after the impulse sweeps), so these are
        # the pairs the solver acted on, as contact_forces always reported. The arbiter is
        # not valid after the callback: the C calls return copies (see the import).
        if _chipmunk is None:
            self._solved.append((key, arbiter.total_impulse, _PointSet(arbiter.contact_point_set),
                                 arbiter.friction == 0.0))
            return
        arb = arbiter._arbiter
        self._solved.append((key, _chipmunk.cpArbiterTotalImpulse(arb),
                             _chipmunk.cpArbiterGetContactPointSet(arb),
                             _chipmunk.cpArbiterGetFriction(arb) == 0.0))

    # --- the contract -------------------------------------------------------------------

    def step(self) -> None:
        self._solved = []
        for body, force, torque in self._loads:
            body.force, body.torque = force, torque  # at the centre of mass (the body's origin)
        self._space.step(self._dt)

    def states(self):
        out = {}
        for name, pb in self._bodies.items():
            x, z = pb.position
            vx, vz = pb.velocity
            out[name] = state_row((x, 0.0, z), quat_about_y(-pb.angle), (vx, 0.0, vz),
                                  (0.0, -pb.angular_velocity, 0.0))
        return out

    # Bulk reads (adapters.base): per body x, z, angle, vx, vz, w in Pymunk's plane (its y is
    # the scene's z), through Chipmunk's C getters (the calls Pymunk's properties make,
    # without building Vec2d objects); decoded as states() maps them.
    def body_order(self) -> list[str]:
        return list(self._bodies)

    def state_size(self) -> int:
        return 6 * len(self._bodies)

    def write_state(self, out: np.ndarray) -> None:
        if _chipmunk is None:
            i = 0
            for pb in self._bodies.values():
                out[i:i + 6] = (*pb.position, pb.angle, *pb.velocity, pb.angular_velocity)
                i += 6
            return
        get_p, get_v = _chipmunk.cpBodyGetPosition, _chipmunk.cpBodyGetVelocity
        get_a, get_w = _chipmunk.cpBodyGetAngle, _chipmunk.cpBodyGetAngularVelocity
        i = 0
        for cb in self._c_bodies:
            x, v = get_p(cb), get_v(cb)
            out[i:i + 6] = (x.x, x.y, get_a(cb), v.x, v.y, get_w(cb))
            i += 6

    def decode_states(self, raw: np.ndarray) -> np.ndarray:
        r = raw.reshape(len(raw), len(self._bodies), 6)
        x, z, angle, vx, vz, w = np.moveaxis(r, 2, 0)
        return planar_states(x, z, -angle, vx, vz, -w)

    def contact_forces(self):
        # the f_n of contact_points(), computed the same way (one resultant per pair)
        dt = self._dt
        out = {}
        for key, j, cps, _ in self._solved:
            n = cps.normal
            out[key] = -(j.x * n.x + j.y * n.y) / dt
        return out

    def contact_points(self):
        """One point per touching pair (Pymunk gives one impulse per arbiter, summed over its
        points): at the mean of the arbiter's points, gap its smallest `distance`.

        Conventions (Munk2D src/cpArbiter.c and chipmunk_private.h, read for 7.3.1, and
        checked on a sliding box with the pair's shapes in both orders): inside the solver the
        arbiter normal n points from its shape a to its shape b, apply_impulses pushes body b
        with +j and body a with -j, j = n jnAcc + perp(n) jtAcc per point. The Python view
        (`arbiter.normal`, `contact_point_set.normal`, `total_impulse`) undoes the solver's
        `swapped`, so in handler order: the normal points from shapes[0] to shapes[1] and
        total_impulse is the impulse ON shapes[0]. Here a = shapes[0] (the pair key's first
        name), b = shapes[1]: the contract normal (b into a) is -normal, and the force on a is
        total_impulse / dt, split along the normal and along perp(normal), the solver's one
        friction direction. `distance` is (point_b - point_a) . normal, negative in overlap:
        the contract's gap. A pair whose arbiter friction is 0 has friction exactly 0: the
        solver clamps jtAcc to [-friction jnAcc, friction jnAcc] (cpArbiterApplyImpulse).
        Pymunk's x-y plane is the scene's x-z plane: (x, y) -> (x, 0, y)."""
        dt = self._dt
        out = []
        for (a, b), j, cps, frictionless in self._solved:
            jx, jy = j.x, j.y
            nx, ny = cps.normal.x, cps.normal.y  # from a to b
            f_n = -(jx * nx + jy * ny) / dt  # along the contract normal -n
            if frictionless:
                f_t = np.zeros(3)
            else:
                tx, ty = -ny, nx  # perp(n): the solver's friction direction
                s = (jx * tx + jy * ty) / dt
                f_t = np.array([s * tx, 0.0, s * ty])
            count = cps.count
            px = py = 0.0
            gap = math.inf
            for p in cps.points[0:count]:
                pa, pb = p.pointA, p.pointB
                px += pa.x + pb.x
                py += pa.y + pb.y
                gap = min(gap, p.distance)
            out.append(ContactPoint(a, b, np.array([px / (2 * count), 0.0, py / (2 * count)]),
                                    np.array([-nx, 0.0, -ny]), f_n, f_t, gap))
        return out

    def close(self) -> None:
        space, self._space = getattr(self, "_space", None), None
        if space is not None:
            space.remove(*space.shapes, *space.bodies)
        self._bodies = {}
