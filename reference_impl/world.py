"""The world: bodies, pair materials, gravity, and the time step (see __init__.py)."""
from __future__ import annotations

import gc
import importlib
from dataclasses import dataclass

from reference_impl.broadphase import candidate_pairs
from reference_impl.config import Config
from reference_impl.contact import Contact, prepare
from reference_impl.geometry import collide
from reference_impl.rigid_body import RigidBody

ALIASES = {"si": "sequential_impulses"}


def formulation(name: str):
    """The module that implements formulation `name` (it defines `solve`)."""
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
    |tau_n| <= torsion N about the normal (contact.Contact.prepare)."""
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
        self.contacts: list[Contact] = []
        self.stages: tuple[str, ...] = ()
        self.normal_impulses: dict[tuple[str, str], float] = {}
        self._previous: dict = {}  # (a index, b index, feature) -> (Pn, tangential impulse vector)

    # --- building --------------------------------------------------------------------------

    def add(self, body: RigidBody) -> RigidBody:
        body.index = len(self.bodies)
        self.bodies.append(body)
        return body

    def set_material(self, a: RigidBody, b: RigidBody, material: Material) -> None:
        self.pair_materials[(min(a.index, b.index), max(a.index, b.index))] = material

    def material_of(self, a: RigidBody, b: RigidBody) -> Material:
        return self.pair_materials.get((min(a.index, b.index), max(a.index, b.index)), self.material)

    def unsupported(self) -> str | None:
        """Why the configured formulation cannot run this world faithfully, or None."""
        if not getattr(self.solver, "CONTACT_TORQUES", False) and any(
                m.torques for m in (self.material, *self.pair_materials.values())):
            return ("rolling resistance or torsional friction asked: this formulation has no torque "
                    "rows (the sequential impulses, 'si', have them)")
        check = getattr(self.solver, "unsupported", None)
        return check(self) if check is not None else None

    # --- stepping --------------------------------------------------------------------------

    def step(self, dt: float) -> None:
        """One step (see _step), with Python's cyclic garbage collector paused. A step
        makes ~10^4 short-lived objects on a 55-box pyramid (contacts, rows, their
        tuples); every 700 of them started a collection walking the young objects, every
        tenth of those a larger one, and those walks over the host process's heap were a
        third of a pyramid step (measured: 37 ms to 25 ms). A step's objects hold no
        reference cycles, so reference counting frees them as before; the collector
        resumes after the step. Results are unchanged: collecting frees memory, it
        computes nothing."""
        paused = gc.isenabled()
        if paused:
            gc.disable()
        try:
            self._step(dt)
        finally:
            if paused:
                gc.enable()

    def _step(self, dt: float) -> None:
        stages = ["collide"]
        dynamic = [b for b in self.bodies if not b.static]
        for body in dynamic:  # velocities before external forces
            body.v0[:] = body.v
            body.w0[:] = body.w

        # collide: broad phase, narrow phase, rows, warm-start impulses
        self.contacts = self.collide(dt)

        # integrate forces: gravity into the velocities
        gx, gy, gz = self.gravity
        if gx != 0.0 or gy != 0.0 or gz != 0.0:
            stages.append("gravity")
            for body in dynamic:
                v = body.v
                v[0] += gx * dt
                v[1] += gy * dt
                v[2] += gz * dt

        # solve the contacts with the configured formulation
        if self.contacts:
            stages += [f"{self.config.formulation}:{s}" for s in
                       self.solver.solve(self.contacts, self.bodies, dt, self.config)]

        # integrate positions (and orientations of the bodies that rotate)
        stages.append("positions")
        if any(b.can_rotate for b in dynamic):
            stages.append("rotations")
        for body in dynamic:
            body.integrate_position(dt)
            body.clear_pseudo()

        self._remember()
        self.stages = tuple(stages)

    def collide(self, dt: float) -> list[Contact]:
        """Contacts up to config.margin apart, plus the step each body may travel (so a
        contact this step will make is seen now: Contact.normal_target)."""
        margin = self.config.margin
        reach = [0.0 if b.static else dt * b.speed_bound() for b in self.bodies]
        found = []
        for i, j in candidate_pairs(self.bodies, margin, reach):
            a, b, points = collide(self.bodies[i], self.bodies[j], margin + reach[i] + reach[j])
            if not points:
                continue
            mat = self.material_of(a, b)
            planar = a.planar or b.planar
            for point, n, depth, feature in points:
                found.append(Contact(a, b, point, n, depth, feature, mat.e, mat.mu_s, mat.mu_k, planar,
                                     mat.rolling, mat.torsion))
        prepare(found, dt, self.config)  # rows, vn0, targets of all contacts at once
        contacts = []
        previous = self._previous if self.config.warm_start else {}
        keep_late = getattr(self.solver, "KEEP_LATE_CONTACTS", False)
        for c in found:
            if c.target is None and not keep_late:
                continue  # touches late in the step: the next step's contact (impulse formulations)
            old = previous.get((c.a.index, c.b.index, c.feature))
            if old is not None:
                c.warm = True
                c.Pn = old[0]
                c.Pt = [sum(P * d for P, d in zip(old[1], row.d)) for row in c.tangents]
                c.Pq = [sum(P * d for P, d in zip(old[2], row.rb_d)) for row in c.torques]
            contacts.append(c)
        return contacts

    def _remember(self) -> None:
        """Keep this step's impulses for warm starting and report them per body pair."""
        self._previous = {}
        impulses = {}
        for c in self.contacts:
            Pt, Pq = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
            for row, P in zip(c.tangents, c.Pt):
                for k in range(3):
                    Pt[k] += P * row.d[k]
            for row, P in zip(c.torques, c.Pq):  # an angular row's axis is its rb_d
                for k in range(3):
                    Pq[k] += P * row.rb_d[k]
            self._previous[(c.a.index, c.b.index, c.feature)] = (c.Pn, Pt, Pq)
            key = (c.a.name, c.b.name) if c.a.name <= c.b.name else (c.b.name, c.a.name)
            impulses[key] = impulses.get(key, 0.0) + c.Pn
        self.normal_impulses = impulses
