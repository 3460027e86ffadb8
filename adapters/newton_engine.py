"""Newton (NVIDIA, Disney Research, Google DeepMind; built on Warp) behind the engine contract.

One `newton.Model` per built scene, stepped on the CPU by one of Newton's rigid-body
solvers, each its own engine configuration (adapters/registry.py):

- `newton-xpbd`: SolverXPBD, positions projected onto the contact constraints, velocities
  derived from them, then a restitution pass on the velocities (`enable_restitution`, off
  by default: switched on when a pair has e > 0). Torsional and rolling friction as lever
  arms (mu_torsional, mu_rolling clamp the torque impulses at that many metres times the
  normal impulse: the scene's d_t and d_r).
- `newton-semi-implicit` and `newton-featherstone`: penalty contact (spring ke, damper kd
  acting only while the bodies approach, viscous friction kf up to mu fn), integrated
  explicitly on the bodies (semi-implicit) or on the free joints' coordinates
  (Featherstone's articulated-body algorithm). No restitution coefficient: e is mapped onto
  the damper (below), the contact made to last `contact_steps` steps.
- `newton-vbd`: SolverVBD's rigid bodies (augmented-Lagrangian vertex block descent, the
  compliant-ALM contact path). No restitution of any kind (its contacts end plastic): a
  pair with e > 0 is unsupported.
- `newton-kamino`: SolverKamino (Disney Research's constrained multibody solver, beta in
  1.8.0): every hard frictional contact of a step in one nonlinear complementarity problem,
  with restitutive impacts, solved by its LOX backend (below). Maximal coordinates, as XPBD;
  a body held from rotating gets its inertia times HELD_INERTIA_SCALE (LOX refuses a
  singular one).
- `newton-mujoco`: SolverMuJoCo, which converts the Newton model into an MjModel (MjSpec:
  Newton bodies, joints and shapes become MuJoCo bodies, joints and geoms) and steps it with
  MuJoCo Warp (its default backend; `use_mujoco_cpu` would step MuJoCo C instead). The scene's
  contact is MuJoCo's own model of it, as adapters/mujoco_engine.py writes it: one explicit
  `<pair>` per body pair of the scene (`newton.solvers.mujoco.add_contact_pair`) with the
  MuJoCo adapter's solref (e mapped onto the contact spring-damper over `contact_steps`
  steps), solimp, solreffriction, friction and condim, and every geom in collision group 0
  (contype = conaffinity = 0), so it collides through its pairs alone and Newton's per-shape
  materials (mu, ke, kd, which SolverMuJoCo turns into geom friction and solref, combined by
  MuJoCo's max and solmix rules) are never read. The options are the MuJoCo adapter's:
  elliptic cone, impratio 100, Euler (Newton's default is implicitfast), Newton solver,
  100 iterations, tolerance 1e-8, 50 line-search iterations; sleeping off; no inactive weld
  per free body (`kinematic_switchable_roots=False`, a kinematic switch the scenes never use).
  A body held from rotating stands on three sliders (a D6 joint of three linear axes, as
  Featherstone). Contacts come from MuJoCo's collision detection; their forces from the
  CONTACT_F observable (exported into a `newton.Contacts` of SolverMuJoCo's capacity). The
  step is recorded as two Warp graphs and replayed (`_capture`). mujoco_warp is not a
  dependency of newton: Newton's `sim` extra pins mujoco-warp ~=3.17.0 with mujoco ~=3.17.0,
  which would replace this project's MuJoCo 4; SolverMuJoCo runs on mujoco-warp 4.0.0 and
  mujoco 4.0.0 (it warns of the mismatch), which this project's `newton` extra installs.

Kamino's backend. Measured on a ball dropped on the ground with e = 0.5 (its step recorded as
a Warp graph; 20 s to build and 20 s of compiling on first use): the default PADMM backend
(proximal ADMM, up to 200 iterations) costs 67 ms a step in free flight and 59 ms in contact
(the core families' 97 000 steps: 1.5-1.8 hours on one core); LOX costs 1.3 ms in flight and
5.1 ms in contact. LOX's implicit restitution is off by default, and without it the ball leaves
the ground at 0.10 m/s where e = 0.5 asks 1.4; with it (`contact_implicit_restitution`, switched
on where a pair has e > 0) at 0.49978 of the approach speed. So newton-kamino is LOX with
implicit restitution; its step and Newton's collision detection are recorded as two Warp graphs
and replayed (`_capture`): unrecorded, 9 ms a step in flight and 29 ms in contact.
SolverSteel, Style3D and ImplicitMPM are cloth, soft-body and granular solvers.

Shapes (SHAPES). Every solver but SolverMuJoCo collides through Newton's own pipeline, which
takes a capsule and a straight-sided cylinder along body z (Newton's axis: add_shape_capsule,
add_shape_cylinder with barrel_radius 0), a hull as a convex mesh of its corners and faces
(add_shape_convex_hull; maxhullvert their number, no hull recomputed), a static mesh as a
triangle mesh (add_shape_mesh, counterclockwise from outside, Newton's back-face culling),
every shape of density 0 and margin 0, the body's mass and inertia the scene's
(compute_inertia False on meshes). newton-mujoco keeps to spheres, boxes and planes: its
contact is the MuJoCo adapter's pairs, whose geoms for the other shapes (a triangle prism per
mesh triangle, a mesh geom per hull) Newton's conversion is not checked to reproduce
(NEWTON_MUJOCO_SHAPES). 2D scenes: each body on a D6 joint to the world (slides along x and
z, turns about y), a circle a sphere, a rect a box and a polygon a prism as deep along y as
they are wide (as the MuJoCo adapter makes them); not on SolverMuJoCo (its pairs would need
the MuJoCo adapter's planar model checked against Newton's conversion), Kamino (its model
takes no such joint) or VBD (its joint moves a free body off its path), nor with joints or
loads.

Float32. Warp stores positions, orientations and velocities in single precision.

Pair materials. XPBD, semi-implicit and Featherstone combine two shapes' mu, restitution,
mu_torsional, mu_rolling, ke, kd, kf by the arithmetic mean (kernels: "use average contact
material properties"); VBD combines mu by the geometric mean sqrt(mu_a mu_b) and ke, kd
by the arithmetic mean. adapters.combination finds per-shape values that give every pair
of the scene its value under that rule (unsupported if none do).

Penalty contact of the semi-implicit and Featherstone solvers (kernels_contact.py,
eval_body_contact): fn = ke d (d the penetration), plus kd vn while the bodies approach
(vn < 0) and nothing while they separate, so an impact is a damped quarter-oscillation in
then an undamped one out: with w = sqrt(ke / m) and zeta = kd / (2 sqrt(ke m)), the depth
reached is (v / w) exp(-zeta atan2(s, zeta) / s), s = sqrt(1 - zeta^2) (zeta < 1;
exp(-zeta atanh(q / zeta) / q) with q = sqrt(zeta^2 - 1) above 1), and the exit speed w
times it: e(zeta) = exp(-zeta atan2(s, zeta) / s), inverted by bisection. ke is one value
for every shape, m (pi / (n dt))^2 with m the smallest reduced mass of the scene's pairs
(the contact of that pair lasts n steps, the others longer); kd per pair 2 zeta(e) sqrt(ke
m_pair). e = 0 needs an infinite damper: kd is capped at m_pair / dt shared by the pair's contact
points (one for a sphere, four for a box's face: the explicit step's damping stays stable),
which leaves e = exp(-zeta ...) of that zeta. Friction: ft = kf vt up to mu fn, a viscous
creep below the Coulomb limit at speed F_t / kf; kf = m_pair / dt shared by the points the
same way (one step relaxes the slip), the largest the explicit step takes.

Contact forces: XPBD, VBD, Kamino and MuJoCo report each contact's force (SolverBase.ObservableKind.CONTACT_F,
requested every step); `contact_forces` sums the normal components per pair. The penalty
solvers report none (Capabilities.contact_forces False).
"""
from __future__ import annotations

import math
from importlib import metadata

import numpy as np

from adapters.base import Adapter, Capabilities, Settings, Simulation, Tunable, Unsupported
from adapters.combination import RULES as COMBINE, per_body_values
from adapters.joints import joint_tree, local_frame
from cases import rotations
from adapters.lazy import require
from adapters.warp_support import init_warp
from adapters.solids import polygon_prism, width_half_depth
from cases.scene import Body, Box, Circle, Plane, Polygon, Rect, Scene, Sphere, pair_key
from cases.trajectory import ContactPoint

require("newton")
require("warp")

SOLVERS = ("xpbd", "semi-implicit", "featherstone", "vbd", "mujoco", "kamino")
# The shapes Newton's own collision pipeline takes (every solver but SolverMuJoCo): a capsule and
# a cylinder along body z (Newton's own axis), a hull a convex mesh of its corners and faces, a
# static mesh a triangle mesh (counterclockwise from outside, Newton's winding).
SHAPES = frozenset({"sphere", "box", "plane", "capsule", "cylinder", "hull", "mesh"})
# newton-mujoco's contact is the MuJoCo adapter's pairs, matched to the geoms Newton's conversion
# makes of its own shapes: checked for spheres, boxes and planes only
_PAIRS_UNCHECKED = ("not mapped: newton-mujoco's contact pairs come from the mujoco adapter, and that "
                    "Newton's conversion makes this shape the geom those pairs name is not checked")
NEWTON_MUJOCO_SHAPES = (("capsule", _PAIRS_UNCHECKED), ("cylinder", _PAIRS_UNCHECKED), ("hull", _PAIRS_UNCHECKED),
                        ("mesh", "SolverMuJoCo makes a mesh a MuJoCo mesh geom, which MuJoCo collides as its convex "
                                 "hull (the mujoco adapter's triangle prisms have no counterpart in Newton's model)"))
# penalty solvers: the stiffest pair's contact lasts this many steps (as the MuJoCo mapping's
# 16). At 10 the explicit step's damping takes more than the model says: e = 0.5 maps to
# 0.395 between two balls (0.434 at 16 steps, 0.474 at 40)
CONTACT_STEPS = 16
# penalty solvers: the damper and the friction gain act at every contact point, and a box on
# a face has four: each point gets a quarter of the largest gain the explicit step takes
# (m / dt in all; a sphere's one point all of it). With m / dt at each of a box's points, a
# box below the friction threshold slid off at 0.3-12 m/s and slid 10-30x too fast above it
# (measured: the friction force rings)
BOX_CONTACT_POINTS = 4


def penalty_points(a: Body, b: Body) -> int:
    """The contact points the penalty gains are shared by: 1 where a sphere touches, 2 where a
    capsule does (its segment meets a face at one or two points), else 4."""
    kinds = (a.shape.kind, b.shape.kind)
    return 1 if "sphere" in kinds else 2 if "capsule" in kinds else BOX_CONTACT_POINTS

XPBD_ITERATIONS = 10  # Newton's default is 2; its own examples use 5-10
VBD_ITERATIONS = 10  # Newton's default (newton:maxSolverIterations absent)
# VBD solves for the bodies' poses from their inertia tensors, not the inverses: a body held
# from rotating gets its moments times this (1e9 left 2.5e-8 rad/s of spin from sliding friction; float32 holds 1e15 I)
HELD_INERTIA_SCALE = 1e15
VBD_FRICTION_EPSILON = 1e-2  # m/s, Newton's default friction smoothing speed
KAMINO_ITERATIONS = 16  # LOX's default max_iterations (it stops earlier at its 1e-5 tolerances)
# The rule each solver combines a pair's two shape values by, per quantity (module notes).
MU_RULE = {"xpbd": "mean", "semi-implicit": "mean", "featherstone": "mean", "vbd": "geometric", "kamino": "mean"}
# solvers with a restitution coefficient of their own, combined by the arithmetic mean (Kamino:
# its restitution_mix_mode set to "average", its default "min")
RESTITUTION = ("xpbd", "kamino")
# solvers stepping joint coordinates: a body held from rotating is a body on three sliders
GENERALIZED = ("featherstone", "mujoco")
# SolverMuJoCo's options by the names of the MJCF <option> the MuJoCo adapter writes (scene_mjcf)
MUJOCO_OPTIONS = ("integrator", "solver", "cone", "impratio", "iterations", "tolerance", "ls_iterations")


def restitution_of_damping(zeta: float) -> float:
    """e of the penalty contact damped only while approaching (module notes)."""
    if zeta == 0.0:
        return 1.0
    if zeta < 1.0:
        s = math.sqrt(1.0 - zeta * zeta)
        return math.exp(-zeta * math.atan2(s, zeta) / s)
    if zeta == 1.0:
        return math.exp(-1.0)
    q = math.sqrt(zeta * zeta - 1.0)
    return math.exp(-zeta * math.atanh(q / zeta) / q)


def damping_of_restitution(e: float) -> float:
    """The damping ratio zeta whose penalty impact gives e (bisection on the monotone
    restitution_of_damping); e = 0: infinity."""
    if e >= 1.0:
        return 0.0
    if e <= 0.0:
        return math.inf
    lo, hi = 0.0, 1.0
    while restitution_of_damping(hi) > e:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if restitution_of_damping(mid) > e else (lo, mid)
    return 0.5 * (lo + hi)


def per_shape(scene: Scene, value_of, rule: str, what: str, pair_value=None) -> dict[str, float]:
    """adapters.combination.per_body_values, and 0 on every shape of a scene without pairs."""
    if not scene.contact_pairs():
        return {b.name: 0.0 for b in scene.bodies}
    return per_body_values(scene, value_of, rule, what, pair_value=pair_value)


def reduced_mass(a: Body, b: Body) -> float:
    if a.static:
        return b.mass
    if b.static:
        return a.mass
    return a.mass * b.mass / (a.mass + b.mass)


# The scene's joints as Newton's own (add_joint_revolute and the like, NewtonSimulation._add_joints),
# each solver treating them its own way: XPBD, VBD and Kamino as constraints between maximal
# coordinates, Featherstone and SolverMuJoCo in the tree's joint coordinates (the semi-implicit
# solver's penalty joints are not built: SEMI_IMPLICIT_JOINTS); loads as State.body_f. Limits with Newton's own limit stiffness and
# damping (limit_ke, limit_kd: no coefficient of restitution at a limit); a joint's `friction`
# is not mapped (each solver reads it its own way: MuJoCo's frictionloss, another's damping).
NEWTON_JOINTS = dict(joints=frozenset({"revolute", "prismatic", "ball", "fixed"}), joint_limits=True, loads=True)
NEWTON_JOINTS_NOT = (("limit_restitution", "Newton's joint limits take a stiffness and a damping (limit_ke, limit_kd), "
                                           "no coefficient of restitution"),
                     ("joint_friction", "not mapped: Newton's joint `friction` means something else in each solver"))


# SolverSemiImplicit holds a joint by penalty springs of one global stiffness and damping
# (joint_attach_ke 1e4, joint_attach_kd 1e2), on the joint's rotation as on its point: on a 1 kg
# ball of radius 0.05 m (I = 1e-3 kg m^2) hinged 0.5 m from its pivot, at dt = 1e-3, that is a
# rotational spring-damper of kd dt / I = 100, which the explicit step cannot integrate: the
# pendulum is NaN within 0.5 s, limited or not (measured, Newton 1.8.0). No mapping of the two
# gains to a scene's masses is made: its joints are not built.
SEMI_IMPLICIT_JOINTS = (("joint", "SolverSemiImplicit's joints are penalty springs of one global stiffness and damping "
                                  "(joint_attach_ke, joint_attach_kd), which its explicit step cannot integrate on the "
                                  "scenes' small inertias (a 1 kg, 5 cm ball on a 0.5 m hinge at dt = 1e-3 turns NaN "
                                  "within 0.5 s, measured): not mapped"),)


def coordinates_of(solver: str) -> str:
    """How the solver represents a jointed body (adapters.base.COORDINATES)."""
    return "reduced" if solver in GENERALIZED else "maximal"


class NewtonAdapter(Adapter):
    package = "newton"
    # the release the conformance battery passes on. Newton is at 1.x and changes its API within
    # minor releases (`physval versions newton 1.7.0 1.8.0 --cases conformance`, measured): on 1.7.0
    # and 1.6.1 a body held from rotating turns on the semi-implicit and Featherstone solvers (a
    # locked box slides to a stop at 13.9 m/s^2 for mu g = 4.905), VBD's resting load reads 0.3 %
    # light and SolverMuJoCo is not yet `newton.solvers.mujoco`; on 1.4.0 and 1.0.0 the builder
    # fails. Warp is not pinned with it: Newton's releases ask only for a Warp at least as new.
    supported = ">=1.8.0,<1.9"
    packages = ("newton",)

    def __init__(self, solver: str = "xpbd"):
        if solver not in SOLVERS:
            raise ValueError(f"solver = {solver!r}: choose from {', '.join(SOLVERS)}")
        self.solver = solver
        self.name = f"newton-{solver}"
        penalty = solver in ("semi-implicit", "featherstone")
        if solver == "mujoco":
            self._init_mujoco()
            return
        self.capabilities = Capabilities(
            # a 2D body on a D6 joint to the world (NewtonSimulation._add); Kamino's model takes no
            # such joint: its conversion counts -1 joint coordinates for it and Warp refuses the
            # array (newton 1.8.0, measured). VBD's joint moves a free 2D body off its path (a 1 s
            # free fall from rest 0.10 m short of g t^2/2 = 4.9 m, a spin of 3 rad/s 3.6e-3 off,
            # measured): 3D scenes only there too
            dimensions=frozenset({3}) if solver in ("kamino", "vbd") else frozenset({2, 3}),
            shapes=SHAPES | {"circle", "rect", "polygon"},
            native_restitution=solver in RESTITUTION,
            static_kinetic=False,  # one mu per shape
            contact_forces=not penalty,
            contact_points=not penalty,  # points with the solver's CONTACT_F (NewtonSimulation.contact_points)
            iterations=solver in ("xpbd", "vbd", "kamino"),
            # penalty contacts and VBD's finite-stiffness ALM contacts act over several steps;
            # XPBD projects every contact of a step in one iterative solve (Gauss-Seidel within
            # a body pair, averaged across pairs): declared simultaneous. Measured once on
            # column_impact's strike, a ball striking a row of two keeps 1.0 of 2.0 kg m/s,
            # which neither model predicts: a deviation to record with Newton's entries
            # Kamino solves one complementarity problem of every hard contact of the step
            impact_model="simultaneous" if solver in ("xpbd", "kamino") else "compliant",
            contact_torques=frozenset({"rolling_resistance", "torsional_friction"}) if solver == "xpbd" else frozenset(),
            float_bits=32,
            why_not=(SEMI_IMPLICIT_JOINTS if solver == "semi-implicit" else ()) + NEWTON_JOINTS_NOT,
            **(dict(loads=True) if solver == "semi-implicit" else dict(coordinates=coordinates_of(solver), **NEWTON_JOINTS)),
        )
        self.tunables = {}
        if penalty:
            self.tunables["contact_steps"] = Tunable(
                2.0, 1000.0, float(CONTACT_STEPS),
                "contact duration in steps n of the stiffest pair: ke = m (pi / (n dt))^2")
        if solver == "vbd":
            self.tunables["friction_epsilon"] = Tunable(
                1e-6, 1.0, VBD_FRICTION_EPSILON, "friction smoothing speed, m/s (Newton's default 1e-2)")
            self.tunables["contact_steps"] = Tunable(
                0.5, 1000.0, 2.0, "contact stiffness as a duration in steps n: ke = m (pi / (n dt))^2")

    def _init_mujoco(self) -> None:
        require("mujoco_warp")  # SolverMuJoCo's default backend, not a dependency of newton itself
        from adapters.mujoco_engine import MuJoCoAdapter
        mj = MuJoCoAdapter.capabilities
        self.capabilities = Capabilities(
            dimensions=frozenset({3}),  # 2D scenes would need planar joints: not adapted
            shapes=frozenset({"sphere", "box", "plane"}),
            why_not=NEWTON_MUJOCO_SHAPES + NEWTON_JOINTS_NOT,
            coordinates=coordinates_of("mujoco"),
            **NEWTON_JOINTS,
            native_restitution=False,  # e mapped onto the pair's solref, as MuJoCo's adapter does
            static_kinetic=False,
            contact_forces=True,
            iterations=True,
            impact_model=mj.impact_model,
            contact_torques=mj.contact_torques,
            float_bits=32,
        )
        # the MuJoCo adapter's contact time scale n (its solref and solreffriction)
        self.tunables = dict(MuJoCoAdapter.tunables)

    # Warp launches a dozen kernels or more a step on the CPU: the median step over the default
    # run's core families (2 cores) is 1.85 ms with XPBD, 0.45 ms semi-implicit, 0.68 ms
    # Featherstone, 2.6 ms VBD, 0.56 ms Kamino and 23 us for SolverMuJoCo (Kamino's and its steps
    # replayed as Warp graphs; MuJoCo C 14 us on a 5-box stack), and each solver compiles 10-60 s on first use (kept in
    # the kernel cache, adapters/warp_support.py; SolverMuJoCo 84 s to build its first scene
    # with an empty cache, 9.5 s with a full one, 0.7 s each scene after). So every default run
    # takes Newton's conformance battery and core families (438 runs of the six
    # configurations, 487 s of stepping on 2 cores with a warm kernel cache), the others on
    # demand (--on-demand), and Newton is left out of the default sweep, stress battery,
    # benchmarks and readings (`slow`), which repeat each scene many times. The test suite runs
    # Newton with `pytest -m slow` (tests/conftest.py), so it stays within its 10 minutes on a
    # machine where Newton is installed.
    default_tags = frozenset({"core", "conformance"})
    slow = True

    def on_demand(self, scene: Scene) -> str | None:
        if self.solver == "mujoco":
            return ("Newton's SolverMuJoCo takes 10 s to start a process and about 80 s of compiling on first "
                    "use; beyond the core families its runs are on demand")
        return ("Newton takes 0.4-2.6 ms a step on the CPU (Warp kernel launches) and compiles each solver "
                "10-60 s on first use; beyond the core families its runs are on demand")

    def version(self) -> str:
        if self.solver == "mujoco":  # MuJoCo Warp steps the model: its release is part of the engine's
            return f"{metadata.version('newton')} (mujoco-warp {metadata.version('mujoco-warp')})"
        return metadata.version("newton")

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene)
        if reason:
            raise Unsupported(reason)
        if scene.dimension == 2 and (scene.joints or scene.loads):
            raise Unsupported("a 2D scene with joints or loads: its bodies stand on planar D6 joints to the world, "
                              "a tree's root would need one of its own (not mapped)")
        if self.solver == "mujoco":  # MuJoCo's own model of the scene: its pairs and options
            from adapters.mujoco_engine import MuJoCoAdapter
            tuning = self.options_in_force(settings)
            mj_model, mj_knobs, _ = MuJoCoAdapter(contact_steps=tuning["contact_steps"]).model(scene, settings)
            return NewtonSimulation(scene, settings, self.solver, tuning, mujoco=(mj_model, mj_knobs))
        if self.solver == "vbd":
            for a, b in scene.contact_pairs():
                e = scene.material_of(a.name, b.name).e
                if e > 0:
                    raise Unsupported(f"e = {e:g} for {a.name}/{b.name}: SolverVBD has no restitution "
                                      "(its rigid contacts end plastic)")
        return NewtonSimulation(scene, settings, self.solver, self.options_in_force(settings))


def _quat_xyzw(q):
    w, x, y, z = q
    return (x, y, z, w)


class NewtonSimulation(Simulation):
    def __init__(self, scene: Scene, settings: Settings, solver: str, tuning: dict[str, float], mujoco=None):
        wp = init_warp()
        import newton

        self._wp, self._dt, self._solver_name = wp, settings.dt, solver
        pairs = scene.contact_pairs()
        self._pairs = {pair_key(a.name, b.name): scene.material_of(a.name, b.name) for a, b in pairs}
        penalty = solver in ("semi-implicit", "featherstone")
        gravity = scene.gravity if solver != "mujoco" or "gravity" in scene.effects else (0.0, 0.0, 0.0)
        builder = newton.ModelBuilder(up_axis=newton.Axis.Z, gravity=tuple(float(g) for g in gravity))
        if solver == "mujoco":
            newton.solvers.SolverMuJoCo.register_custom_attributes(builder)
        self.knobs = {"solver": solver, "device": "cpu", "dt": settings.dt, "gravity": list(scene.gravity),
                      "up_axis": "Z", "rigid_gap": builder.rigid_gap, "bodies": {}}

        if solver == "mujoco":
            # the scene's materials are in MuJoCo's explicit pairs (added below); every geom
            # collides through those alone (collision group 0: contype = conaffinity = 0)
            shape = {b.name: {"collision_group": 0} for b in scene.bodies}
            self._mu = None
        else:
            # per-shape material values under the solver's combination rules (module notes)
            mu_rule = MU_RULE[solver]
            mu = per_shape(scene, lambda m: m.mu_s, mu_rule, "friction")
            shape = {b.name: {"mu": mu[b.name], "restitution": 0.0, "mu_torsional": 0.0, "mu_rolling": 0.0,
                              "ka": 0.0, "margin": 0.0} for b in scene.bodies}
            if solver in RESTITUTION:
                e = per_shape(scene, lambda m: m.e, "mean", "restitution")
                for b in scene.bodies:
                    shape[b.name]["restitution"] = e[b.name]
            if solver == "xpbd":
                dt_ = per_shape(scene, lambda m: m.torsional_friction, "mean", "torsional friction")
                dr = per_shape(scene, lambda m: m.rolling_resistance, "mean", "rolling resistance")
                for b in scene.bodies:
                    shape[b.name].update(mu_torsional=dt_[b.name], mu_rolling=dr[b.name])
            m_min = min((reduced_mass(a, b) for a, b in pairs), default=1.0)
            if penalty or solver == "vbd":
                n = tuning["contact_steps"]
                ke = m_min * (math.pi / (n * settings.dt)) ** 2
                self.knobs["contact_steps"] = n
            if penalty:
                def kd_of(a: Body, b: Body) -> float:
                    m = reduced_mass(a, b)
                    zeta = damping_of_restitution(scene.material_of(a.name, b.name).e)
                    return min(2.0 * zeta * math.sqrt(ke * m), m / (penalty_points(a, b) * settings.dt))

                def kf_of(a: Body, b: Body) -> float:
                    return reduced_mass(a, b) / (penalty_points(a, b) * settings.dt)
                kd = per_shape(scene, None, "mean", "damping", pair_value=kd_of)
                kf = per_shape(scene, None, "mean", "friction gain", pair_value=kf_of)
                for b in scene.bodies:
                    shape[b.name].update(ke=ke, kd=kd[b.name], kf=kf[b.name])
                self.knobs["penalty_mapping"] = ("ke = m_min (pi / (n dt))^2; kd = 2 zeta(e) sqrt(ke m_pair) capped at "
                                                 "m_pair / (k dt); kf = m_pair / (k dt); k = 1 contact point with a sphere, else 4")
            elif solver == "vbd":
                for b in scene.bodies:
                    shape[b.name].update(ke=ke, kd=0.0)
            self.knobs["combination"] = {"mu": mu_rule, "others": "mean"}
            self._mu = mu

        self._index: dict[str, int] = {}
        self._still: list[int] = []  # bodies held from rotating (maximal-coordinate solvers)
        self._shape_body: list[str] = []
        self._jointed = bool(scene.joints or scene.loads)
        self._planar = scene.dimension == 2
        for body in scene.bodies:
            self._add(newton, builder, body, shape[body.name], solver)
        if self._jointed:
            self._add_joints(newton, builder, scene, solver)
        if solver == "mujoco":
            self._add_pairs(builder, mujoco[1])
        if solver == "vbd":
            builder.color()
        model = builder.finalize(device="cpu")
        if self._still:  # held from rotating: no inverse inertia (VBD reads the inertia itself: made huge;
            inv = model.body_inv_inertia.numpy()  # Kamino's LOX refuses a singular one: both made extreme)
            inv[self._still] = inv[self._still] / HELD_INERTIA_SCALE if solver == "kamino" else 0.0
            model.body_inv_inertia.assign(inv)
            if solver in ("vbd", "kamino"):
                inertia = model.body_inertia.numpy()
                inertia[self._still] *= HELD_INERTIA_SCALE
                model.body_inertia.assign(inertia)
        self._model = model

        if solver == "xpbd":
            restitution = any(m.e > 0 for m in self._pairs.values())
            iterations = XPBD_ITERATIONS if settings.iterations is None else settings.iterations
            self._solver = newton.solvers.SolverXPBD(model, iterations=iterations, enable_restitution=restitution,
                                                     angular_damping=0.0)
            self.knobs.update(iterations=iterations, enable_restitution=restitution, angular_damping=0.0,
                              rigid_contact_relaxation=0.8, rigid_contact_restitution_iterations=2)
        elif solver == "semi-implicit":
            iterations = None
            self._solver = newton.solvers.SolverSemiImplicit(model, angular_damping=0.0)  # default 0.05
            self.knobs.update(angular_damping=0.0)
        elif solver == "featherstone":
            iterations = None
            self._solver = newton.solvers.SolverFeatherstone(model, angular_damping=0.0)  # default 0.05
            self.knobs.update(angular_damping=0.0, update_mass_matrix_interval=1)
        elif solver == "mujoco":
            iterations = self._mujoco_solver(newton, model, scene, *mujoco)
        elif solver == "kamino":
            iterations = KAMINO_ITERATIONS if settings.iterations is None else settings.iterations
            self._solver = self._kamino_solver(newton, model, iterations)
        else:
            iterations = VBD_ITERATIONS if settings.iterations is None else settings.iterations
            self._solver = newton.solvers.SolverVBD(model, iterations=iterations,
                                                    friction_epsilon=tuning["friction_epsilon"])
            self.knobs.update(iterations=iterations, friction_epsilon=tuning["friction_epsilon"],
                              rigid_compliant_alm=True)
        self.iterations = iterations

        self._s0, self._s1, self._control = model.state(), model.state(), model.control()
        q = self._s0.body_q.numpy()
        qd = np.zeros((model.body_count, 6), dtype=np.float32)
        for body in scene.bodies:
            if body.dynamic:
                i = self._index[body.name]
                q[i, :3] = body.position
                q[i, 3:] = _quat_xyzw(body.orientation)
                qd[i, :3] = body.velocity
                qd[i, 3:] = body.angular_velocity
        self._s0.body_q.assign(q)
        self._s0.body_qd.assign(qd)
        if solver in GENERALIZED or self._jointed or self._planar:  # the joints' start coordinates and rates
            newton.eval_ik(model, self._s0, self._s0.joint_q, self._s0.joint_qd)
        self._loads = None  # the scene's loads as body_f rows (world force at the centre of mass, torque)
        if scene.loads:
            f = np.zeros((model.body_count, 6), dtype=np.float32)
            for load in scene.loads:
                f[self._index[load.body]] += np.concatenate([load.force, load.torque])
            self._loads = wp.array(f, dtype=wp.spatial_vector, device="cpu")
            self.knobs["loads"] = "State.body_f (world force at the centre of mass, then torque), set after each clear"
        if solver == "mujoco":  # MuJoCo's collision detection: its contacts exported into these
            self._pipeline = None
            self._contacts = newton.Contacts(self._solver.get_max_contact_count(), 0, device="cpu")
        else:
            self._pipeline = newton.CollisionPipeline(model)
            self._contacts = self._pipeline.contacts()
        self._observables = None
        if not penalty:
            self._observables = self._solver.observables(
                kinds={self._solver.ObservableKind.CONTACT_F}, contacts=self._contacts)
        self._graphs = self._capture() if solver in ("mujoco", "kamino") else None
        self._order = [b.name for b in scene.bodies if b.dynamic]
        self._rows = [self._index[n] for n in self._order]
        if solver == "mujoco":
            from adapters.mujoco_engine import model_effects
            self.effects = model_effects(self._solver.mj_model, mujoco[1]) | self._joint_effects(scene)
        else:
            self.effects = self._built_effects(scene, shape, solver)

    def _kamino_solver(self, newton, model, iterations: int):
        """SolverKamino with its LOX backend (PADMM, the default, costs 59-67 ms a step for one
        ball: module notes), restitution by LOX's implicit restitution (off by default: without
        it a ball meant to leave at e = 0.5 leaves the ground at 0.10 m/s), the pair's mu and e
        by the arithmetic mean of the shapes' (restitution's default rule is the minimum)."""
        # Newton 1.8 exports SolverKamino, not the configurations it takes
        from newton._src.solvers.kamino.config import LOXSolverConfig, MaterialManagerConfig
        restitution = any(m.e > 0 for m in self._pairs.values())
        lox = LOXSolverConfig(max_iterations=iterations, contact_implicit_restitution=restitution)
        materials = MaterialManagerConfig(friction_mix_mode="average", restitution_mix_mode="average")
        config = newton.solvers.SolverKamino.Config(dynamics_solver="lox", lox=lox, materials=materials)
        self.knobs.update(dynamics_solver="lox", max_iterations=iterations, contact_implicit_restitution=restitution,
                          friction_mix_mode="average", restitution_mix_mode="average",
                          lox_defaults={k: getattr(lox, k) for k in ("position_tolerance", "velocity_tolerance",
                                                                      "contact_compliance", "fixed_iterations")},
                          integrator=config.integrator, angular_velocity_damping=config.angular_velocity_damping,
                          collision="Newton's CollisionPipeline (use_collision_detector False)")
        return newton.solvers.SolverKamino(model, config)

    def _add_pairs(self, builder, mj_knobs: dict) -> None:
        """MuJoCo's explicit pairs, each as the MuJoCo adapter writes it (adapters/mujoco_engine.py,
        scene_mjcf: solref from e, solimp, friction, condim, solreffriction), on the Newton shapes."""
        from newton.solvers import mujoco as newton_mujoco
        shape_of = {name: i for i, name in enumerate(self._shape_body)}
        for pair in mj_knobs["pair"].values():
            newton_mujoco.add_contact_pair(
                builder, shape_of[pair["geom1"]], shape_of[pair["geom2"]], condim=pair["condim"],
                solref=pair["solref"], solimp=pair["solimp"], friction=pair["friction"],
                # frictionless pairs (condim 1) have no friction rows: the value is never read
                solreffriction=pair.get("solreffriction", (0.0, 0.0)), margin=pair["margin"], gap=pair["gap"])

    def _mujoco_solver(self, newton, model, scene: Scene, mj_model, mj_knobs: dict) -> int:
        """SolverMuJoCo with the MuJoCo adapter's options; the knobs it sets. Returns the iteration cap."""
        option = mj_knobs["option"]
        options = {k: option[k] for k in MUJOCO_OPTIONS}
        options.update(integrator=options["integrator"].lower(), solver=options["solver"].lower())
        # kinematic_switchable_roots=False: no inactive weld per free body (a kinematic switch
        # the scenes never use); contacts from MuJoCo's own collision detection
        # the contact buffer MuJoCo Warp gets from the `mujoco-warp` adapter's sizing (Newton's
        # own default, 256, drops the contacts of a 55-box pyramid with a warning); a step that
        # needs more raises (ContactOverflow in `step`)
        from adapters.mujoco_warp_engine import contact_capacity
        nconmax, njmax = contact_capacity(mj_model, len(scene.dynamic_bodies))
        self._solver = newton.solvers.SolverMuJoCo(
            model, **options, disable_contacts="contact" not in scene.effects, use_mujoco_contacts=True,
            kinematic_switchable_roots=False, enable_sleeping=False, nconmax=nconmax, njmax=njmax)
        data = self._solver.mjw_data
        self._nacon, self._naconmax = data.nacon.numpy(), int(data.naconmax)
        m = self._solver.mj_model
        self.knobs.update(
            nconmax=nconmax, njmax=njmax,
            backend="mujoco_warp (SolverMuJoCo's default; use_mujoco_cpu False)", use_mujoco_contacts=True,
            kinematic_switchable_roots=False, enable_sleeping=False, mujoco_option=options,
            mujoco_pair=mj_knobs["pair"], restitution_map=mj_knobs["restitution_map"],
            friction_slip_steps=mj_knobs["friction_slip_steps"],
            geoms="contype = conaffinity = 0 (collision group 0): contacts from the pairs alone",
            compiled={"disableflags": int(m.opt.disableflags), "enableflags": int(m.opt.enableflags),
                      "npair": int(m.npair), "neq": int(m.neq), "njnt": int(m.njnt)})
        return option["iterations"]

    def _add(self, newton, builder, body: Body, values: dict, solver: str) -> None:
        wp = self._wp
        cfg = newton.ModelBuilder.ShapeConfig(density=0.0, **values)
        record = {"shape": dict(values), "density": 0.0}
        s = body.shape
        xform = wp.transform(wp.vec3(*body.position), wp.quat(*_quat_xyzw(body.orientation)))
        if body.static:
            where = -1
            record["type"] = "static shape"
        else:
            i1, i2, i3 = body.principal_inertia
            inertia = wp.mat33(i1, 0.0, 0.0, 0.0, i2, 0.0, 0.0, 0.0, i3)
            # a joint to the world of given axes: a 2D body's (slides along world x and z, turns
            # about world y), or, on Featherstone and MuJoCo, which move the joint coordinates, a
            # body held from rotating (three sliders); a scene's joints come with its tree (_add_joints)
            d6 = not self._jointed and (self._planar or (not body.rotates and solver in GENERALIZED))
            add = builder.add_link if self._jointed or d6 else builder.add_body
            where = add(xform=xform, mass=body.mass, inertia=inertia, lock_inertia=True, label=body.name)
            if d6:
                dof = newton.ModelBuilder.JointDofConfig
                linear = (newton.Axis.X, newton.Axis.Z) if self._planar else (newton.Axis.X, newton.Axis.Y, newton.Axis.Z)
                angular = [dof(axis=newton.Axis.Y)] if self._planar and body.rotates else []
                # the joint frame is the body's start pose: in 2D, turned about y only, its x and z span the plane
                joint = builder.add_joint_d6(-1, where, linear_axes=[dof(axis=a) for a in linear], angular_axes=angular,
                                             parent_xform=xform)
                builder.add_articulation([joint])
                record["joint"] = (("d6 to the world: linear x, z" + (", angular y" if body.rotates else ""))
                                   if self._planar else "d6, three linear axes")
            elif not self._jointed:
                record["joint"] = "free"
            if not self._jointed and not body.rotates and solver not in GENERALIZED:
                # held from rotating: a joint without an angular axis holds the body only as well
                # as the solver projects it (a held 2D body spun 7e-4 rad/s on XPBD, 4.3 on the
                # semi-implicit solver, measured): no inverse inertia
                self._still.append(where)
                record["inverse_inertia"] = 0.0
            self._index[body.name] = where
            record.update(type="dynamic", mass=body.mass, principal_inertia=[i1, i2, i3])
        if isinstance(s, Plane):
            builder.add_shape_plane(plane=(*s.normal, -s.offset), width=0.0, length=0.0, cfg=cfg, label=body.name)
            record["plane"] = {"normal": list(s.normal), "offset": s.offset}
        elif isinstance(s, (Sphere, Circle)):  # a circle: the sphere whose section in y = 0 it is
            builder.add_shape_sphere(where, xform=None if where >= 0 else xform, radius=s.radius, cfg=cfg,
                                     label=body.name)
            record["sphere"] = s.radius
        elif isinstance(s, Box):
            hx, hy, hz = s.half_extents
            builder.add_shape_box(where, xform=None if where >= 0 else xform, hx=hx, hy=hy, hz=hz, cfg=cfg,
                                  label=body.name)
            record["box"] = list(s.half_extents)
        elif isinstance(s, Rect):  # a rect: a box as deep along y as it is wide
            a, c = s.half_extents
            builder.add_shape_box(where, xform=None if where >= 0 else xform, hx=a, hy=a, hz=c, cfg=cfg,
                                  label=body.name)
            record["box"] = [a, a, c]
        elif s.kind in ("capsule", "cylinder"):  # along body z, Newton's own axis
            add = builder.add_shape_capsule if s.kind == "capsule" else builder.add_shape_cylinder
            add(where, xform=None if where >= 0 else xform, radius=s.radius, half_height=s.half_length, cfg=cfg,
                label=body.name)
            record[s.kind] = {"radius": s.radius, "half_height": s.half_length}
            if s.kind == "cylinder":  # straight-sided (barrel_radius 0, Newton's default)
                record["cylinder"]["barrel_radius"] = 0.0
        else:  # hull: a convex mesh of its corners and faces; mesh: a static triangle mesh; a
            # polygon: its prism, as deep along y as it is wide (adapters.solids)
            if isinstance(s, Polygon):
                vertices, triangles = polygon_prism(s.corners, width_half_depth(s.corners))
            else:
                vertices, triangles = (s.vertices, s.faces) if s.kind == "hull" else (s.vertices, s.triangles)
            mesh = newton.Mesh(np.asarray(vertices, np.float32), np.asarray(triangles, np.int32).ravel(),
                               compute_inertia=False, maxhullvert=len(vertices))  # the body's mass, not the mesh's
            convex = s.kind in ("hull", "polygon")
            add = builder.add_shape_convex_hull if convex else builder.add_shape_mesh
            add(where, xform=None if where >= 0 else xform, mesh=mesh, cfg=cfg, label=body.name)
            record["convex_mesh" if convex else "triangle_mesh"] = {
                "vertices": len(vertices), "triangles": len(triangles), "compute_inertia": False}
        self._shape_body.append(body.name)
        self.knobs["bodies"][body.name] = record

    def _add_joints(self, newton, builder, scene: Scene, solver: str) -> None:
        """The scene's joints on the links (_add): one articulation a tree (adapters.joints.
        joint_tree), its root's joint first (the scene's joint to the world or a static
        body, else a free joint) and its children after their parents, as Newton wants an
        articulation's joints (contiguous, parents first); the joints that close a loop after
        every articulation, in none (Newton's loop joints: constraints of the maximal-coordinate
        solvers, CONNECT or WELD equalities in SolverMuJoCo; Featherstone has none). The two
        bodies of every joint do not collide (the scene's rule), also with a static parent."""
        for body in scene.dynamic_bodies:
            if not body.rotates:
                raise Unsupported(f"body {body.name!r} held from rotating (rotates=False) in a scene with joints or "
                                  "loads: not mapped (its sliders would need the tree's frames)")
        tree, closing = joint_tree(scene)
        if closing and solver == "featherstone":
            j, joint = closing[0]
            raise Unsupported(f"joints[{j}] closes a loop: SolverFeatherstone steps tree coordinates and has no "
                              "loop constraints")
        self.knobs["joints"] = {}

        def root(name: str) -> str:
            while name in tree and tree[name].parent is not None:
                name = tree[name].parent
            return name
        for body in scene.dynamic_bodies:
            if body.name in tree and tree[body.name].parent is not None:
                continue  # hangs in another body's tree
            if body.name in tree:
                joints = [self._joint(newton, builder, scene, tree[body.name].index)]
            else:
                joints = [builder.add_joint_free(self._index[body.name], label=f"{body.name}:free")]
                self.knobs["joints"][body.name] = "free"
            joints += [self._joint(newton, builder, scene, tj.index) for name, tj in tree.items()
                       if tj.parent is not None and root(name) == body.name]
            builder.add_articulation(joints, label=body.name)
        for j, _ in closing:
            self._joint(newton, builder, scene, j)
        shape_of = {name: i for i, name in enumerate(self._shape_body)}
        for joint in scene.joints:
            if joint.parent is not None:
                builder.shape_collision_filter_pairs.append(tuple(sorted((shape_of[joint.body], shape_of[joint.parent]))))

    def _joint(self, newton, builder, scene: Scene, j: int) -> int:
        """Scene joint j as Newton's joint of its kind. Its frame is world-aligned at the
        anchor at the start, given in each body's frame (parent_xform, child_xform; the
        world's or a static parent's: the world frame), so the joint's coordinate is 0 at the
        start, as the scene's limits count it, and its axis is the scene's world axis."""
        wp, joint = self._wp, scene.joints[j]
        anchor = np.asarray(joint.anchor, float)

        def frame(name: str | None):
            body = None if name is None else scene.body(name)
            body = None if body is None or body.static else body  # the world, or a static body: world frame
            p, q = local_frame(body, anchor, (1.0, 0.0, 0.0, 0.0))
            return wp.transform(wp.vec3(*p), wp.quat(*_quat_xyzw(q))), -1 if body is None else self._index[name]
        parent_xform, parent = frame(joint.parent)
        child_xform, child = frame(joint.body)
        spec = dict(parent_xform=parent_xform, child_xform=child_xform, label=f"joints[{j}]")
        record = {"kind": joint.kind, "parent": joint.parent or "world", "anchor": anchor.tolist()}
        if joint.kind in ("revolute", "prismatic"):
            spec["axis"] = wp.vec3(*joint.unit_axis)
            record["axis"] = list(joint.unit_axis)
            if joint.limits is not None:  # Newton's limit stiffness and damping left at its defaults
                spec.update(limit_lower=float(joint.limits[0]), limit_upper=float(joint.limits[1]))
                record["limits"] = list(joint.limits)
            add = builder.add_joint_revolute if joint.kind == "revolute" else builder.add_joint_prismatic
        else:
            add = builder.add_joint_ball if joint.kind == "ball" else builder.add_joint_fixed
        self.knobs["joints"][f"joints[{j}]"] = record
        return add(parent, child, **spec)

    def _built_effects(self, scene: Scene, shape: dict, solver: str) -> frozenset[str]:
        """What the built model simulates, from the values given to Newton and its rules."""
        fx = set()
        if any(g != 0.0 for g in scene.gravity):
            fx.add("gravity")
        if self._pairs:
            fx.add("contact")
        mean = COMBINE["mean"]
        for a, b in self._pairs:
            if COMBINE[MU_RULE[solver]](shape[a]["mu"], shape[b]["mu"]) > 0:
                fx.add("friction")
            if solver in RESTITUTION and mean(shape[a]["restitution"], shape[b]["restitution"]) > 0:
                fx.add("restitution")
            if solver == "xpbd":
                if mean(shape[a]["mu_torsional"], shape[b]["mu_torsional"]) > 0:
                    fx.add("torsional_friction")
                if mean(shape[a]["mu_rolling"], shape[b]["mu_rolling"]) > 0:
                    fx.add("rolling_resistance")
            elif solver not in ("vbd", "kamino") and self._pairs[(a, b)].e > 0:
                fx.add("restitution")  # mapped onto the damper
        if any(b.dynamic and b.rotates for b in scene.bodies):
            fx.add("rotation")
        return frozenset(fx) | self._joint_effects(scene)

    def _joint_effects(self, scene: Scene) -> frozenset[str]:
        """The joints, limits and loads the model was given (_add_joints, the start state)."""
        fx = {"joint"} if scene.joints else set()
        if any(j.limits is not None for j in scene.joints):
            fx.add("limit")
        if self._loads is not None:
            fx.add("load")
        return frozenset(fx)

    # --- the contract -------------------------------------------------------------------

    def _capture(self) -> list:
        """SolverMuJoCo's step (SolverKamino's, with Newton's collision detection) recorded as
        two Warp graphs (on the CPU an operation stream Warp replays in C++, as
        adapters/mujoco_warp_engine.py does for mujoco_warp.step): state 0 into state 1 and
        back. Recording runs nothing (the state stays the start state); a replay is bit for bit
        the step (tests/test_newton_mujoco_mapping.py), at 0.40-0.47 ms instead of 19 ms a step
        for a 5-box stack, 53 us for a ball."""
        wp, graphs = self._wp, []
        for a, b in ((self._s0, self._s1), (self._s1, self._s0)):
            wp.capture_begin("cpu")
            try:
                if self._pipeline is not None:  # Kamino: Newton's collision detection, recorded with the step
                    a.clear_forces()
                    self._pipeline.collide(a, self._contacts)
                self._load(a)
                self._solver.step(a, b, self._control, self._contacts, self._dt, observables=self._observables)
            finally:
                graphs.append(wp.capture_end("cpu"))
        return graphs

    def step(self) -> None:
        if self._observables is not None:  # the poses the step's contacts are found at (contact_points):
            self._q_start = self._s0.body_q.numpy().copy()  # XPBD and VBD overwrite the input state
        if self._graphs is not None:
            self._wp.capture_launch(self._graphs[0])
            self._graphs.reverse()
            self._s0, self._s1 = self._s1, self._s0
            if self._solver_name == "mujoco" and self._nacon[0] > self._naconmax:  # SolverMuJoCo's own buffer
                from adapters.mujoco_warp_engine import ContactOverflow
                raise ContactOverflow(f"{int(self._nacon[0])} contacts in one step, more than the "
                                      f"{self._naconmax} allotted (CONTACTS_PER_BODY)")
            return
        s0 = self._s0
        s0.clear_forces()
        self._load(s0)
        if self._pipeline is not None:
            self._pipeline.collide(s0, self._contacts)
        if self._observables is not None:
            self._solver.step(s0, self._s1, self._control, self._contacts, self._dt, observables=self._observables)
        else:
            self._solver.step(s0, self._s1, self._control, self._contacts, self._dt)
        self._s0, self._s1 = self._s1, s0

    def _load(self, state) -> None:
        """The scene's loads into the state's body_f (cleared before each step)."""
        if self._loads is not None:
            self._wp.copy(state.body_f, self._loads)

    def body_order(self) -> list[str]:
        return list(self._order)

    def write_state(self, out: np.ndarray) -> None:
        q = self._s0.body_q.numpy()[self._rows]
        qd = self._s0.body_qd.numpy()[self._rows]
        rows = out.reshape(-1, 13)
        rows[:, 0:3] = q[:, 0:3]
        rows[:, 3] = q[:, 6]
        rows[:, 4:7] = q[:, 3:6]
        rows[:, 7:13] = qd
        
    def states(self):
        out = np.zeros(13 * len(self._order))
        self.write_state(out)
        rows = out.reshape(-1, 13)
        return {name: rows[i].copy() for i, name in enumerate(self._order)}

    def contact_forces(self):
        if self._observables is None:
            raise NotImplementedError(f"newton-{self._solver_name} reports no contact forces")
        c = self._contacts
        n = int(c.rigid_contact_count.numpy()[0])
        forces: dict[tuple[str, str], float] = {}
        if n == 0:
            return forces
        f = self._observables.contact_f.numpy()[:n, :3]
        normal = c.rigid_contact_normal.numpy()[:n]
        s0, s1 = c.rigid_contact_shape0.numpy()[:n], c.rigid_contact_shape1.numpy()[:n]
        for k in range(n):
            fn = float(np.dot(f[k], normal[k]))
            if fn == 0.0:
                continue
            key = pair_key(self._shape_body[s0[k]], self._shape_body[s1[k]])
            forces[key] = forces.get(key, 0.0) + fn
        return {k: abs(v) for k, v in forces.items()}

    def contact_points(self) -> list[ContactPoint]:
        """The last step's contacts as Newton's collision pipeline found them, with the force
        the solver reports for each (CONTACT_F, the force on shape 0, measured: a box resting on
        the ground reads -m g / 4 along the normal at each corner; the point's force on shape 1
        is its opposite):
        a = shape 1's body, b = shape 0's (Newton's normal points from shape 0 to shape 1),
        x = midway between the two surface points, gap = their distance along the normal.
        A contact's points are body-frame points on each shape's core (a sphere's centre, a
        capsule's segment) with the shape's thickness (margin0, margin1: radius plus margin)
        along the normal, placed by the bodies' poses at the start of the step, where the
        pipeline found them (kept before each step: XPBD and VBD write their solve into the
        step's input state, measured: a 5 cm overlap read back 2e-14 m deep). Contacts the solver left without force at a positive gap
        (found within rigid_gap ahead of touching) are not points it acted on: left out."""
        if self._observables is None:
            raise NotImplementedError(f"newton-{self._solver_name} reports no contact forces")
        c = self._contacts
        n = int(c.rigid_contact_count.numpy()[0])
        if n == 0:
            return []
        shape0, shape1 = c.rigid_contact_shape0.numpy()[:n], c.rigid_contact_shape1.numpy()[:n]
        normal = c.rigid_contact_normal.numpy()[:n].astype(float)
        f = -self._observables.contact_f.numpy()[:n, :3].astype(float)  # on shape 1
        body_q = self._q_start.astype(float)
        shape_body = self._model.shape_body.numpy()

        def world(shapes, points):
            out = points.astype(float).copy()
            body = shape_body[shapes]
            moving = body >= 0  # a static shape's points are in the world frame already
            q = body_q[body[moving]]
            out[moving] = q[:, :3] + rotations.rotate(q[:, [6, 3, 4, 5]], out[moving])  # Warp's x-y-z-w to w-x-y-z
            return out

        p0 = world(shape0, c.rigid_contact_point0.numpy()[:n]) + c.rigid_contact_margin0.numpy()[:n, None] * normal
        p1 = world(shape1, c.rigid_contact_point1.numpy()[:n]) - c.rigid_contact_margin1.numpy()[:n, None] * normal
        gap = np.einsum("ij,ij->i", p1 - p0, normal)
        f_n = np.einsum("ij,ij->i", f, normal)
        keep = np.flatnonzero((gap <= 0.0) | np.any(f != 0.0, axis=1))
        names = self._shape_body
        return [ContactPoint(names[shape1[k]], names[shape0[k]], 0.5 * (p0[k] + p1[k]), normal[k], float(f_n[k]),
                             f[k] - f_n[k] * normal[k], float(gap[k])) for k in keep]

    def close(self) -> None:
        self._solver = self._model = self._pipeline = self._contacts = self._observables = self._graphs = None
