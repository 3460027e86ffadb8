"""The world: bodies, pair materials, gravity, and the time step (see __init__.py).

`World` is the Python front: it collects bodies and materials, then keeps everything a
step reads and writes in one `State` (bodies and contacts as arrays), and each
`World.step(dt)` is two compiled calls (compiled.py), with nothing per body or per
contact in Python: `begin` (broad and narrow phase, rows, warm start, gravity) and `end`
(the formulation's solve, then the integration). `begin` takes no formulation's type, so
a process compiles it once for every formulation; `end` is compiled per formulation (the
type of its `Stepper`'s settings picks the solve); a world with joints calls `end_joints`
in its place (joints.py), compiled only where a world has joints. numba optimises a function together
with everything it calls, so a single compiled step per formulation compiled the world's
collision phase again for each formulation.
"""
from __future__ import annotations

import importlib
import sys
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from reference_impl.broadphase import pairs as candidate_pairs
from reference_impl.compiled import cached, int_dict, njit, overload, structure
from reference_impl.config import Config
from reference_impl.contact import (MASS, RB_D, Contact, ContactArrays, Contacts, apply, compact, contact_arrays,
                                    new_contacts, prepare, velocity)
from reference_impl.geometry import MAX_PAIR_POINTS, Plane, Sphere, narrow_phase, new_points
from reference_impl.joints import (KINDS as JOINT_KINDS, STATIC, Joints, new_joints, perpendicular,
                                   prepare as prepare_joints)
from reference_impl.rigid_body import (Bodies, BodyArrays, RigidBody, integrate_position, new_bodies, speed_bound,
                                       stack)
from reference_impl.vectors import copy

ALIASES = {"si": "sequential_impulses"}


def formulation(name: str):
    """The module that implements formulation `name` (it defines `Settings`, `settings`,
    `STAGES` and `solve`: see reference_impl/__init__.py)."""
    module = ALIASES.get(name, name)
    try:
        found = importlib.import_module(f"reference_impl.{module}")
    except ModuleNotFoundError as exc:
        if exc.name != f"reference_impl.{module}":
            raise  # the module exists but needs something missing: say that, not "unknown"
        found = None
    if found is None or not callable(getattr(found, "solve", None)):
        raise ValueError(f"formulation {name!r}: no module reference_impl.{module} with a solve() "
                         "(see the interface in reference_impl/__init__.py)")
    return found


@dataclass(frozen=True)
class Material:
    """What a pair does on contact: restitution e, static mu_s and kinetic mu_k friction
    (mu_k None: the same as mu_s), and the lever arms (m) of the contact torques: rolling
    resistance |tau_r| <= rolling N about the tangent axes, torsional friction
    |tau_n| <= torsion N about the normal (contact._torque_rows)."""
    e: float = 0.0
    mu_s: float = 0.0
    mu_k: float | None = None
    rolling: float = 0.0   # m
    torsion: float = 0.0   # m

    def __post_init__(self):
        if self.mu_k is None:
            object.__setattr__(self, "mu_k", self.mu_s)
        if not (0.0 <= self.e <= 1.0 and 0.0 <= self.mu_k <= self.mu_s and self.rolling >= 0.0
                and self.torsion >= 0.0):
            raise ValueError(f"{self}: needs 0 <= e <= 1, 0 <= mu_k <= mu_s, rolling >= 0 and torsion >= 0")

    @property
    def torques(self) -> bool:
        """True when the pair has a contact torque (rolling resistance or torsional friction)."""
        return self.rolling > 0.0 or self.torsion > 0.0


class Phases(NamedTuple):
    """The settings of the world's own phases (from config.Config)."""
    margin: float
    slop: float
    beta: float
    stick_speed: float
    warm_start: bool
    keep_late: bool  # keep the contacts that touch late in the step (force laws need them)
    # three departures from the notes that physval plants as faults (physval/faults.py),
    # off unless config.params names them: "tangents": "fixed" keeps the tangent rows along
    # contact.tangent_basis also while sliding; "restitution_threshold" (m/s) closes a
    # contact approaching slower than it plastically (target 0 instead of -e vn0);
    # "restitution_law": "two-phase" solves every contact plastically, then pushes each
    # bouncing one up to -e vn0 with normal impulses alone (_restitution_after), sweeping
    # at most config.iterations times until no velocity changes by more than config.tolerance
    fixed_tangents: bool
    restitution_threshold: float
    two_phase: bool
    iterations: int
    tolerance: float


@structure
class State:
    """Everything a step reads and writes."""
    bodies: Bodies
    gravity: np.ndarray      # (3,)
    materials: np.ndarray    # (M, 5): e, mu_s, mu_k, rolling, torsion; row 0 the world's own
    material_of: np.ndarray  # (N, N) int: the row of materials of each pair of bodies
    phases: Phases
    features: dict           # clip-node ids of the narrow phase (geometry._clip_feature)
    contacts: Contacts       # the last step's (their impulses warm-start the next)
    pairs: np.ndarray        # (P, 2) body pairs in contact in the last step
    impulses: np.ndarray     # (P,) their normal impulse, N s
    joints: Joints           # joints.py: the joints' rows (their impulses warm-start the next step)
    joined: np.ndarray       # (N, N) bool: a joint connects the pair, which then never collides
    loads: np.ndarray        # (N, 6) constant external force (N) and torque (N m) on each body, world frame


@structure
class Stepper:
    """A world's State and its formulation's Settings: what `end` takes (one type per
    formulation, so that `end` compiles once per formulation and `begin` once)."""
    state: State
    settings: tuple


class Saved(NamedTuple):
    """A world's state between steps (World.save), as plain copies: every body's row and the
    warm start, i.e. the last step's contacts (their impulses), the narrow phase's feature
    ids they are matched by, and the pairs' normal impulses."""
    bodies: BodyArrays
    features: dict           # geometry._clip_feature's ids: (4 ints) -> int
    contacts: ContactArrays
    pairs: np.ndarray
    impulses: np.ndarray
    joint_impulses: np.ndarray | None = None  # the joints' last impulses (joints.Joints.P)


@dataclass(frozen=True)
class Joint:
    """A joint of the world (World.join), its anchor and axis in each body's frame
    (for the world as parent: world frame)."""
    kind: str
    body: int
    parent: int            # joints.STATIC: the world
    p_a: tuple
    p_b: tuple
    n_a: tuple
    n_b: tuple
    u_a: tuple = (1.0, 0.0, 0.0)  # a reference axis perpendicular to n (a hinge's angle 0)
    u_b: tuple = (1.0, 0.0, 0.0)
    limits: tuple = (-np.inf, np.inf)  # the coordinate's (lower, upper), rad or m
    limit_e: float = 0.0   # restitution at a limit
    friction: float = 0.0  # dry friction force (N, slider) or torque (N m, hinge)


class World:
    """Bodies (`add`), pair materials (`set_material`; others get `material`), gravity and
    a `Config`. After each `step(dt)`: `contacts` of the step, `stages` that ran and
    `normal_impulses` per body-name pair (sorted names), N s over the step."""

    def __init__(self, gravity=(0.0, 0.0, -9.81), material: Material = Material(),
                 config: Config = Config()):
        self.gravity = tuple(float(g) for g in gravity)
        self.material = material
        self.config = config
        self.solver = formulation(config.formulation)
        self.bodies: list[RigidBody] = []
        self.pair_materials: dict[tuple[int, int], Material] = {}
        self.joints: list[Joint] = []
        self.loads: dict[int, tuple] = {}  # body index -> (force, torque), world frame (`load`)
        self.stages: tuple[str, ...] = ()
        self.settings = None   # the formulation's Settings, made with the State
        self._state = None     # built at the first step, again after the world changes
        self._stepper = None   # the State with the formulation's settings (built with the State)
        self._end = end        # end, end_joints for a world with joints, or _end_two_phase when the Phases ask for it
        self._contacts = None  # the last step's contacts as contact.Contact, made when asked for
        self._stage_names: dict[int, tuple[str, ...]] = {}

    # --- building --------------------------------------------------------------------------

    def add(self, body: RigidBody) -> RigidBody:
        body.index = len(self.bodies)
        self.bodies.append(body)
        self._state = None
        return body

    def set_material(self, a: RigidBody, b: RigidBody, material: Material) -> None:
        self.pair_materials[(min(a.index, b.index), max(a.index, b.index))] = material
        self._state = None

    def configure(self, material: Material | None = None, config: Config | None = None, **params) -> None:
        """Change the default material, the whole `config`, or add formulation settings
        (Config.params: the friction set, or a hook of the step's Phases: "tangents",
        "restitution_threshold", "restitution_law") after bodies were added: the compiled
        state is built again at the next step (the warm start kept)."""
        if material is not None:
            self.material = material
        if config is not None:
            self.config = config
        if params:
            self.config = replace(self.config, params={**self.config.params, **params})
        self._state = None

    def join(self, kind: str, body: RigidBody, parent: RigidBody | None = None, anchor=(0.0, 0.0, 0.0),
             axis=(0.0, 1.0, 0.0), limits=None, limit_e: float = 0.0, friction: float = 0.0) -> Joint:
        """A joint of `kind` (joints.KINDS) holding `body` to `parent` (None: the world) at
        the world point `anchor`, a hinge about (a slider along) the world direction `axis`,
        both taken as the bodies stand now, where its coordinate is 0; `limits` (lower,
        upper) of that coordinate (rad or m, None: none) with the restitution `limit_e`,
        and its dry `friction` (N or N m). Joined bodies do not collide with each other."""
        if kind not in JOINT_KINDS:
            raise ValueError(f"joint kind {kind!r}: must be one of {', '.join(JOINT_KINDS)}")
        anchor = np.asarray(anchor, dtype=float)
        n = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
        u = perpendicular(n)  # the angle's zero

        def local(b, vector, point):  # world vector (and point) into b's body frame
            R = b.R
            return tuple(R.T @ (vector - b.x if point else vector))
        if parent is None:
            p_b, n_b, u_b, index = tuple(anchor), tuple(n), tuple(u), STATIC
        else:
            p_b, n_b, u_b, index = local(parent, anchor, True), local(parent, n, False), local(parent, u, False), \
                parent.index
        joint = Joint(kind, body.index, index, local(body, anchor, True), p_b, local(body, n, False), n_b,
                      local(body, u, False), u_b, (-np.inf, np.inf) if limits is None else tuple(map(float, limits)),
                      float(limit_e), float(friction))
        self.joints.append(joint)
        self._state = None
        return joint

    def load(self, body: RigidBody, force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0)) -> None:
        """A constant external `force` (N, at the centre of mass) and `torque` (N m) on
        `body`, world frame, for every step (added to what it had)."""
        f, t = self.loads.get(body.index, ((0.0,) * 3, (0.0,) * 3))
        self.loads[body.index] = (tuple(float(a) + float(b) for a, b in zip(f, force)),
                                  tuple(float(a) + float(b) for a, b in zip(t, torque)))
        self._state = None

    def material_of(self, a: RigidBody, b: RigidBody) -> Material:
        return self.pair_materials.get((min(a.index, b.index), max(a.index, b.index)), self.material)

    def unsupported(self) -> str | None:
        """Why the configured formulation cannot run this world faithfully, or None."""
        kinds = sorted({j.kind for j in self.joints} - getattr(self.solver, "JOINT_KINDS", frozenset()))
        if kinds:
            return (f"{', '.join(kinds)} joint asked: this formulation solves "
                    f"{', '.join(sorted(getattr(self.solver, 'JOINT_KINDS', ()))) or 'no'} joint rows")
        solver, limited = self.solver, [j for j in self.joints if np.isfinite(j.limits).any()]
        for asked, flag, what in ((limited, "JOINT_LIMITS", "joint limits"),
                                  ([j for j in limited if j.limit_e > 0.0], "LIMIT_RESTITUTION",
                                   "a restitution at a joint limit"),
                                  ([j for j in self.joints if j.friction > 0.0], "JOINT_FRICTION", "joint friction")):
            if asked and not getattr(solver, flag, False):
                return f"{what} asked: this formulation has no such rows"
        if not getattr(self.solver, "CONTACT_TORQUES", False) and any(
                m.torques for m in (self.material, *self.pair_materials.values())):
            return ("rolling resistance or torsional friction asked: this formulation has no torque "
                    "rows (the sequential impulses, 'si', have them)")
        check = getattr(self.solver, "unsupported", None)
        return check(self) if check is not None else None

    def save(self) -> Saved:
        """Everything the next step reads that the bodies and materials do not give, copied:
        with `restore`, a world built the same way continues exactly as this one would."""
        if self._state is None:
            self._state = self._build()
        pairs, impulses = _impulses(self._state)
        return Saved(stack(self.bodies), dict(_features(self._state).items()),
                     ContactArrays(*(a.copy() for a in contact_arrays(_contacts(self._state)))),
                     pairs.copy(), impulses.copy(), _joints(self._state).P.copy())

    def restore(self, saved: Saved) -> None:
        """Continue from `saved` (`save` of a world with the same bodies, materials and
        config): the bodies take its rows, the next step its warm start."""
        arrays = BodyArrays(*(a.copy() for a in saved.bodies))
        bodies = new_bodies(arrays)
        for i, body in enumerate(self.bodies):
            body.attach(arrays, bodies, i)
        features = int_dict(4)
        for key, value in saved.features.items():
            features[key] = value
        self._state = self._build((features, Contacts(*(a.copy() for a in saved.contacts)), saved.pairs.copy(),
                                   saved.impulses.copy()))
        if saved.joint_impulses is not None:
            _joints(self._state).P[:] = saved.joint_impulses
        self._contacts = None

    def _build(self, warm: tuple | None = None) -> State:
        """The State of this world: the bodies' rows gathered into one Bodies (each body
        then shows its row), the last step's contacts kept (or `warm`: features, contacts,
        pairs, impulses)."""
        arrays = stack(self.bodies)
        bodies = new_bodies(arrays)
        for i, body in enumerate(self.bodies):
            body.attach(arrays, bodies, i)
        N, table = len(self.bodies), [self.material, *self.pair_materials.values()]
        materials = np.array([(m.e, m.mu_s, m.mu_k, m.rolling, m.torsion) for m in table], dtype=float)
        material_of = np.zeros((N, N), np.int64)
        for row, (i, j) in enumerate(self.pair_materials, start=1):
            material_of[i, j] = material_of[j, i] = row
        c = self.config
        phases = Phases(float(c.margin), float(c.slop), float(c.beta), float(c.stick_speed), bool(c.warm_start),
                        bool(getattr(self.solver, "KEEP_LATE_CONTACTS", False)),
                        c.params.get("tangents", "slip") == "fixed", float(c.params.get("restitution_threshold", 0.0)),
                        c.params.get("restitution_law", "newton") == "two-phase", int(c.iterations), float(c.tolerance))
        if warm is not None:
            features, contacts, pairs, impulses = warm
        elif self._state is None:
            features, contacts, pairs, impulses = int_dict(4), new_contacts(0), np.zeros((0, 2), np.int64), np.zeros(0)
        else:  # the last step's, for the warm start
            features, contacts, (pairs, impulses) = _features(self._state), _contacts(self._state), \
                _impulses(self._state)
        js = self.joints
        joints = new_joints([j.body for j in js], [j.parent for j in js], [JOINT_KINDS[j.kind] for j in js],
                            [j.p_a for j in js], [j.p_b for j in js], [j.n_a for j in js], [j.n_b for j in js],
                            [j.u_a for j in js], [j.u_b for j in js], [j.limits[0] for j in js],
                            [j.limits[1] for j in js], [j.limit_e for j in js], [j.friction for j in js])
        if self._state is not None and warm is None:  # the joints' last impulses, for the warm start
            joints.P[:] = _joints(self._state).P
        joined = np.zeros((N, N), np.bool_)
        for j in js:
            if j.parent != STATIC:
                joined[j.body, j.parent] = joined[j.parent, j.body] = True
        loads = np.zeros((N, 6))
        for i, (force, torque) in self.loads.items():
            loads[i, :3], loads[i, 3:] = force, torque
        self.settings = self.solver.settings(c)  # the formulation's (compiled code shares its arrays)
        state = new_state(bodies, np.array(self.gravity, dtype=float), materials, material_of, phases,
                          features, contacts, pairs, impulses, joints, joined, loads)
        self._stepper = new_stepper(state, self.settings)
        self._end = _end_two_phase if phases.two_phase else (end_joints if self.joints else end)
        return state

    # --- stepping --------------------------------------------------------------------------

    def step(self, dt: float) -> None:
        """One step (note 001, "simulation loop"): `begin` and `end` below, compiled."""
        if self._state is None:
            self._state = self._build()
        dt = float(dt)
        ran = begin(self._state, dt) | self._end(self._stepper, dt)
        self._contacts = None
        names = self._stage_names.get(ran)
        if names is None:
            names = self._stage_names[ran] = self._names(ran)
        self.stages = names

    # A step seen in its two halves (`step` runs both): between them the contacts found are the
    # problem the formulation is about to solve, e.g. for an independent solver to solve too.
    def begin_step(self, dt: float) -> None:
        """A step's first half (note 001, "simulation loop"): collision detection and the free motion."""
        if self._state is None:
            self._state = self._build()
        begin(self._state, float(dt))
        self._contacts = None

    def end_step(self, dt: float) -> None:
        """A step's second half: the formulation's solve and the integration of positions."""
        self._end(self._stepper, float(dt))
        self._contacts = None

    def contact_problem(self):
        """(contacts, bodies) the solve reads: the compiled contact arrays and bodies of this step."""
        return _contacts(self._state), _bodies(self._state)

    def _names(self, ran: int) -> tuple[str, ...]:
        """The stages a step's bit mask says ran, in order (world's, then the formulation's)."""
        name = self.config.formulation
        every = [*WORLD_STAGES[:3], *(f"{name}:{s}" for s in self.solver.STAGES), *WORLD_STAGES[3:]]
        bits = [COLLIDE, GRAVITY, LOADS, *(1 << (SOLVER_SHIFT + k) for k in range(len(self.solver.STAGES))),
                POSITIONS, ROTATIONS]
        return tuple(s for s, bit in zip(every, bits) if ran & bit)

    @property
    def contacts(self) -> list[Contact]:
        """The contacts of the last step (contact.Contact: copies, read from its arrays)."""
        if self._contacts is None:
            found = contact_arrays(_contacts(self._state)) if self._state is not None else None
            self._contacts = [] if found is None else [Contact(found, j, self.bodies) for j in range(len(found.a))]
        return self._contacts

    @property
    def normal_impulses(self) -> dict[tuple[str, str], float]:
        """The last step's normal impulse per body pair in contact (sorted names), N s."""
        if self._state is None:
            return {}
        out = {}
        pairs, impulses = _impulses(self._state)
        for (i, j), P in zip(pairs.tolist(), impulses.tolist()):
            a, b = self.bodies[i].name, self.bodies[j].name
            out[(a, b) if a <= b else (b, a)] = P
        return out


# --- compiling ahead -----------------------------------------------------------------------
# A world's first step compiles `begin`, then its formulation's `end` (or `end_joints`), one
# after the other: on a fresh install about 75 s of numba, then 9-48 s a formulation, all
# in one process while any other that needs them waits for its cache (compiled.py). Named
# apart, the halves compile in separate processes at once, each into numba's cache.

def _sample_world(config: Config, joints: bool) -> World:
    """A ball on the ground (with `joints`, hinged to the world): the smallest world whose
    step calls what the worlds of `config` call; its arrays have their types."""
    world = World(config=config)
    world.add(RigidBody("ground", Plane(), static=True))
    ball = world.add(RigidBody("ball", Sphere(0.1), 1.0, (0.004, 0.004, 0.004), x=(0.0, 0.0, 0.1)))
    if joints:
        world.join("revolute", ball, anchor=(0.0, 0.0, 0.3))
    return world


def _half(config: Config, half: str) -> tuple:
    """(compiled function, *its arguments) of one half of a sample world's step."""
    world = _sample_world(config, half == "end_joints")
    state = world._build()
    return (begin, state, 1e-3) if half == "begin" else (world._end, world._stepper, 1e-3)


def uncompiled_halves(config: Config) -> list[str]:
    """The halves of a step under `config` that numba's cache does not hold yet, of
    "begin" (every formulation's), "end" and, for a formulation with joint rows,
    "end_joints" (compile_half compiles one)."""
    halves = ["begin", "end"] + (["end_joints"] if getattr(formulation(config.formulation), "JOINT_KINDS", None)
                                 else [])
    return [h for h in halves if not cached(*_half(config, h))]


def compile_half(config: Config, half: str) -> None:
    """Compile one half of the step under `config` (uncompiled_halves) into numba's cache:
    call it once on a sample world."""
    function, *args = _half(config, half)
    function(*args)


@njit
def new_state(bodies, gravity, materials, material_of, phases, features, contacts, pairs, impulses, joints, joined,
              loads):
    return State(bodies, gravity, materials, material_of, phases, features, contacts, pairs, impulses, joints,
                 joined, loads)


@njit
def new_stepper(state, settings):
    return Stepper(state, settings)


# Python reads a State's fields through compiled getters
@njit
def _contacts(state):
    return state.contacts


@njit
def _bodies(state):
    return state.bodies


@njit
def _impulses(state):
    return state.pairs, state.impulses


@njit
def _features(state):
    return state.features


@njit
def _joints(state):
    return state.joints


# the stages of a step, bits of World.step's mask: the world's, and from SOLVER_SHIFT on the
# formulation's (bit SOLVER_SHIFT + k: its STAGES[k])
WORLD_STAGES = ("collide", "gravity", "loads", "positions", "rotations")
COLLIDE, GRAVITY, POSITIONS, ROTATIONS, LOADS = 1, 2, 4, 8, 16
SOLVER_SHIFT = 5


def solve(contacts, bodies, dt, settings):
    """The formulation's solve: that of the module whose `Settings` `settings` is."""
    return sys.modules[type(settings).__module__].solve(contacts, bodies, dt, settings)


@overload(solve, inline=True)
def _solve_of(contacts, bodies, dt, settings):
    """Compiled, the same choice made once, when the caller compiles for a formulation."""
    chosen = sys.modules[settings.instance_class.__module__].solve
    return lambda contacts, bodies, dt, settings: chosen(contacts, bodies, dt, settings)


def solve_joints(contacts, joints, bodies, dt, settings):
    """The formulation's solve of contacts and joints (its `solve_joints`; joints.py)."""
    return sys.modules[type(settings).__module__].solve_joints(contacts, joints, bodies, dt, settings)


@overload(solve_joints, inline=True)
def _solve_joints_of(contacts, joints, bodies, dt, settings):
    """Compiled: the formulation's solve_joints, or for one without joint rows nothing
    (World.unsupported refuses a world with joints for it, so this never runs)."""
    chosen = getattr(sys.modules[settings.instance_class.__module__], "solve_joints", None)
    if chosen is None:
        return lambda contacts, joints, bodies, dt, settings: 0
    return lambda contacts, joints, bodies, dt, settings: chosen(contacts, joints, bodies, dt, settings)


@njit
def begin(state, dt) -> int:
    """The world's part of a step before the formulation's (note 001, "simulation loop"),
    the same for every formulation:

    1. collide: broad phase, narrow phase (shapes up to config.margin apart, plus the step
       each body can travel), each contact's rows, approach velocity, target and bias
       (contact.prepare), and last step's impulses of the same contacts (warm start);
       they are state.contacts from now on;
    2. gravity: v += g dt (skipped when gravity is zero), then the constant loads
       (v += F/m dt, w += I^-1 tau dt).

    Returns the stages that ran (bits, above)."""
    bodies = state.bodies
    N = len(bodies.x)
    for i in range(N):  # velocities before external forces
        if not bodies.static[i]:
            for k in range(3):
                bodies.v0[i, k], bodies.w0[i, k] = bodies.v[i, k], bodies.w[i, k]
    ran = COLLIDE
    state.contacts = collide(bodies, state.contacts, state.features, state.materials, state.material_of, dt,
                             state.phases, state.joined)

    g = state.gravity  # integrate forces: gravity into the velocities
    if g[0] != 0.0 or g[1] != 0.0 or g[2] != 0.0:
        ran |= GRAVITY
        for i in range(N):
            if not bodies.static[i]:
                for k in range(3):
                    bodies.v[i, k] += g[k] * dt
    return ran | _apply_loads(bodies, state.loads, dt)


@njit
def _apply_loads(bodies, loads, dt) -> int:
    """Integrate the constant loads: v += F/m dt, w += I^-1 tau dt (the world inverse
    inertia at the step's start, as gravity's step: symplectic Euler). LOADS if any acts."""
    ran = 0
    for i in range(len(loads)):
        acts = False
        for k in range(6):
            acts = acts or loads[i, k] != 0.0
        if acts and not bodies.static[i]:
            ran = LOADS
            for k in range(3):
                bodies.v[i, k] += bodies.inv_mass[i] * loads[i, k] * dt
                bodies.w[i, k] += (bodies.inv_I[i, k, 0] * loads[i, 3] + bodies.inv_I[i, k, 1] * loads[i, 4]
                                   + bodies.inv_I[i, k, 2] * loads[i, 5]) * dt
    return ran


@njit
def end(stepper, dt) -> int:
    """The rest of a step: 3. solve: the formulation of `stepper.settings` changes the body
    velocities (when there are contacts); 4. integrate (`finish`). Returns the stages
    that ran (bits, above)."""
    state = stepper.state
    ran = 0
    if len(state.contacts.a):
        ran = solve(state.contacts, state.bodies, dt, stepper.settings) << SOLVER_SHIFT
    return ran | finish(state, dt)


@njit
def end_joints(stepper, dt) -> int:
    """`end` of a world with joints: their rows and position errors at the step's start
    (the bodies have not moved since `begin`; joints.prepare), then the formulation's
    solve_joints of contacts and joints together. A separate function that World.step
    calls only for a world with joints, so that a world without them compiles and runs
    `end` alone, as before joints existed."""
    state = stepper.state
    prepare_joints(state.joints, state.bodies, dt, state.phases.slop)
    ran = solve_joints(state.contacts, state.joints, state.bodies, dt, stepper.settings) << SOLVER_SHIFT
    return ran | finish(state, dt)


@njit
def _end_two_phase(stepper, dt) -> int:
    """`end` with the two-phase law of Phases (a planted fault) in place of the solve."""
    state = stepper.state
    ran = 0
    if len(state.contacts.a):
        ran = _two_phase(state.contacts, state.bodies, dt, stepper.settings, state.phases) << SOLVER_SHIFT
    return ran | finish(state, dt)


@njit
def finish(state, dt) -> int:
    """4. integrate positions and orientations from v + vp, w + wp, then clear vp, wp;
    and each body pair's normal impulse of the step. Returns the stages that ran."""
    bodies = state.bodies
    ran = POSITIONS  # integrate positions (and orientations of the bodies that rotate)
    for i in range(len(bodies.x)):
        if not bodies.static[i]:
            if bodies.can_rotate[i]:
                ran |= ROTATIONS
            integrate_position(bodies, i, dt)
            for k in range(3):
                bodies.vp[i, k], bodies.wp[i, k] = 0.0, 0.0
    state.pairs, state.impulses = _pair_impulses(state.contacts)
    return ran


@njit(inline=True)
def _two_phase(contacts, bodies, dt, settings, phases) -> int:
    """The two-phase law of Phases: the formulation solves with every bouncing contact's
    target (> 0) set to 0; then each of them is pushed up to its target by normal impulses
    alone, Gauss-Seidel in contact order, and its target set back."""
    goals = contacts.target.copy()
    for j in range(len(goals)):
        if goals[j] > 0.0:
            contacts.target[j] = 0.0
    ran = solve(contacts, bodies, dt, settings)
    for _ in range(phases.iterations):
        largest = 0.0
        for j in range(len(goals)):
            if goals[j] > 0.0:
                a, b, row = contacts.a[j], contacts.b[j], contacts.normal[j]
                dv = goals[j] - velocity(row, bodies.v[a], bodies.w[a], bodies.v[b], bodies.w[b])
                if dv > 0.0:
                    P = row[MASS] * dv
                    apply(row, P, bodies.v[a], bodies.w[a], bodies.v[b], bodies.w[b])
                    contacts.Pn[j] += P
                    largest = max(largest, dv)
        if largest <= phases.tolerance:
            break
    for j in range(len(goals)):
        if goals[j] > 0.0:
            contacts.target[j] = goals[j]
    return ran


@njit(inline=True)
def collide(bodies, previous, features, materials, material_of, dt, phases, joined):
    """Contacts up to phases.margin apart, plus the step each body may travel (so a
    contact this step will make is seen now: contact.normal_target), with their rows, and
    warm-started from `previous` (the last step's contacts). Pairs `joined` (by a
    joint) have none."""
    N = len(bodies.x)
    reach = np.zeros(N)
    for i in range(N):
        if not bodies.static[i]:
            reach[i] = dt * speed_bound(bodies, i)
    pairs = candidate_pairs(bodies, phases.margin, reach)
    found = new_points(MAX_PAIR_POINTS * len(pairs))
    first, second = np.empty(len(found.depth), np.int64), np.empty(len(found.depth), np.int64)
    count = 0
    for p in range(len(pairs)):
        i, j = pairs[p, 0], pairs[p, 1]
        if joined[i, j]:
            continue
        a, b, m = narrow_phase(bodies, i, j, phases.margin + reach[i] + reach[j], features, found, count)
        for t in range(count, count + m):
            first[t], second[t] = a, b
        count += m
    contacts = new_contacts(count)
    for k in range(count):
        a, b = first[k], second[k]
        material = materials[material_of[a, b]]
        contacts.a[k], contacts.b[k], contacts.depth[k], contacts.feature[k] = a, b, found.depth[k], found.feature[k]
        copy(contacts.point[k], found.point[k])
        copy(contacts.n[k], found.n[k])
        contacts.e[k], contacts.mu_s[k], contacts.mu_k[k] = material[0], material[1], material[2]
        contacts.rolling[k], contacts.torsion[k] = material[3], material[4]
        contacts.planar[k] = bodies.planar[a] or bodies.planar[b]
    prepare(contacts, bodies, dt, phases.beta, phases.slop, phases.stick_speed,  # rows, vn0, targets
            phases.fixed_tangents, phases.restitution_threshold)
    if not phases.keep_late:  # touches late in the step: the next step's contact (impulse formulations)
        contacts = compact(contacts, ~np.isnan(contacts.target))
    if phases.warm_start:
        _warm_start(contacts, previous)
    return contacts


@njit
def _warm_start(contacts, previous) -> None:
    """Each contact that `previous` has too (same bodies, same feature: the last of them)
    starts from its impulses (note 001, "inter-timestep persistence"): Pn as it was, the
    tangential and torque impulses as world vectors projected on this step's rows. Both
    lists are in body-pair order, so one pass over `previous` finds them."""
    c, p, m = contacts, previous, 0
    M = len(previous.a)
    for j in range(len(c.a)):
        pair = (min(c.a[j], c.b[j]), max(c.a[j], c.b[j]))
        while m < M and (min(p.a[m], p.b[m]), max(p.a[m], p.b[m])) < pair:
            m += 1
        old = -1
        for t in range(m, M):
            if (min(p.a[t], p.b[t]), max(p.a[t], p.b[t])) != pair:
                break
            if p.a[t] == c.a[j] and p.b[t] == c.b[j] and p.feature[t] == c.feature[j]:
                old = t
        if old < 0:
            continue
        c.warm[j] = True
        c.Pn[j] = p.Pn[old]
        Pt = _world_vector(p.tangents[old], p.Pt[old], p.n_tangents[old], 0)
        Pq = _world_vector(p.torques[old], p.Pq[old], p.n_rolling[old] + p.n_torsion[old], RB_D)
        for k in range(c.n_tangents[j]):
            c.Pt[j, k] = _project(Pt, c.tangents[j, k], 0)
        for k in range(c.n_rolling[j] + c.n_torsion[j]):
            c.Pq[j, k] = _project(Pq, c.torques[j, k], RB_D)


@njit
def _world_vector(rows, P, count, axis):
    """sum_k P[k] times the direction of rows[k] (its d at `axis` 0, or its r_b x d: a
    torque row's axis)."""
    out = np.zeros(3)
    for k in range(count):
        for e in range(3):
            out[e] += P[k] * rows[k, axis + e]
    return out


@njit
def _project(vector, row, axis) -> float:
    """vector . the row's direction, summed from 0."""
    total = 0.0
    for e in range(3):
        total += vector[e] * row[axis + e]
    return total


@njit
def _pair_impulses(contacts):
    """The body pairs in contact (in the contacts' order) and the sum of their normal impulses."""
    C = len(contacts.a)
    pairs, impulses, P = np.empty((C, 2), np.int64), np.empty(C), 0
    for j in range(C):
        a, b = min(contacts.a[j], contacts.b[j]), max(contacts.a[j], contacts.b[j])
        if P == 0 or pairs[P - 1, 0] != a or pairs[P - 1, 1] != b:
            pairs[P, 0], pairs[P, 1], impulses[P] = a, b, 0.0
            P += 1
        impulses[P - 1] += contacts.Pn[j]
    return pairs[:P].copy(), impulses[:P].copy()
