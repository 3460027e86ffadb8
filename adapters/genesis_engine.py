"""Genesis adapter: each scene body is an MJCF entity of Genesis' rigid solver, on the CPU.

Genesis (`genesis-world`) steps rigid bodies with MuJoCo's formulation rewritten as
Quadrants kernels (its fork of Taichi): soft contact rows with MuJoCo's solver parameters
(sol_params = solref + solimp, `genesis.utils.geom.default_solver_params`), a Newton
solver, a pyramidal or elliptic friction cone. The adapter runs it on the CPU backend in
float64 (`gs.init(backend=gs.cpu, precision="64")`, once a process).

Its contact-resolution choices are configurations (adapters/registry.py):
- `genesis`: the elliptic cone with the Newton solver, which Genesis resolves to the
  'signorini' resolution (friction bounded by the normal force the contact has developed;
  the default of 1.3.1, marked as having convergence issues in 1.4.2), impratio Genesis'
  default for that cone (100). The plain name is the more faithful of the two on 1.4.5
  (it misses no friction check of the battery and the core families);
- `genesis-defaults`: what Genesis resolves to by default (1.4.5): the pyramidal cone, and
  with it the 'convex' contact resolution (one convex program per step, MuJoCo's).

Mapping (each setting recorded in `knobs`):
- every dynamic body is an entity of its own, written as MJCF and parsed by Genesis
  (gs.morphs.MJCF): the scene's mass and principal inertia (<inertial>, never from the
  geoms), a free joint for a body that rotates, three world-axis slide joints for one that
  does not, no joint damping, armature or friction (the MuJoCo adapter's `_joints` and
  `_geom`). One entity a body, because Genesis skips collisions inside one entity between
  bodies that touch in its start pose (enable_neutral_collision) and between parent and
  child (the world and its bodies);
- a plane is Genesis' own (gs.morphs.Plane: an MJCF plane in the world body collides with
  nothing, measured), its friction and sol_params set once built; another static body an
  MJCF body without joints (welded to the world, a link of its own);
- restitution onto the contact spring-damper as the MuJoCo adapter maps it
  (`contact_spring_damper`: w = pi / (n dt), n = CONTACT_STEPS): MuJoCo's direct solref
  (-K, -B) written in the positive form Genesis reads, timeconst = 2 / B,
  dampratio = B / (2 sqrt K) (Genesis: b = 2 / (dmax timeconst), k = 1 / (dmax^2 timeconst^2
  dampratio^2), the same rows); solimp the MuJoCo adapter's. Genesis mixes two geoms'
  sol_params by their mean (collider/contact.py), so every geom carries the same values,
  and a scene whose pairs differ in e is unsupported;
- friction: Genesis takes the larger of the two geoms' coefficients, and at least 0.01
  (collider/contact.py: max(max(mu_a, mu_b), 1e-2)); per-body values come from
  adapters.combination under the max rule. A frictionless scene still gets friction rows
  with mu = 0.01: the effect manifest says "friction" (a finding, adapters/xfails/);
- gravity (0, 0, 0) where the scene asks for none; sleeping (use_hibernation) off, as is
  Genesis' default; contact pruning, the integrator and the solver's tolerance Genesis'
  defaults, stated.

Contact forces: Genesis reports each contact point's force (collider.get_contacts:
'force', on link a, the world frame) after the step; a pair's normal force is the sum of
its points' forces along the pair's normal (the points' 'normal', from b into a).

Cost (measured on this machine's CPU, 2 cores shared): importing genesis takes ~14 s of CPU
(its kernels' Python is parsed at import), a first scene ~70 s of CPU to compile with an
empty kernel cache (~/.cache/quadrants), ~9 s with a full one, and every build of a new
scene compiles its kernels again as far as the cache does not hold them.
"""
from __future__ import annotations

import math
import os
import tempfile
from importlib import metadata

import numpy as np

from adapters.base import Adapter, Capabilities, Settings, Simulation, Unsupported
from adapters.combination import per_body_values
from adapters.lazy import require
from adapters.mujoco_engine import CONTACT_STEPS, SOLIMP, _element, _geom, _joints, contact_spring_damper
from cases.scene import Body, Plane, Scene, pair_key

# genesis (~14 s of CPU to import: torch and its kernels' Python) is imported when a scene is
# first built (adapters/lazy.py)
require("genesis")
require("torch")

gs = None  # the genesis module, initialised once a process (_init)

# Genesis clamps every contact's friction coefficient to at least this (collider/contact.py)
FRICTION_FLOOR = 0.01
ITERATIONS = 25  # Genesis' default cap of the constraint solver's iterations (RigidOptions.iterations)
# The configurations (module notes): the friction cone, and what Genesis resolves the contact
# resolution to with it (RigidOptions.contact_resolution None: 'signorini' with the elliptic
# cone and the Newton solver, 'convex' otherwise)
CONFIGURATIONS = {"signorini": {"friction_cone": "elliptic", "contact_resolution": "signorini"},
                  "defaults": {"friction_cone": "pyramidal", "contact_resolution": "convex"}}


def _init():
    """Import genesis and initialise it on the CPU in float64, once a process."""
    global gs
    if gs is None:
        import genesis
        if not getattr(genesis, "_initialized", False):
            genesis.init(backend=genesis.cpu, precision="64", logging_level="warning", seed=0)
        gs = genesis
    return gs


# Genesis reads only the positive (timeconst, dampratio) form, in which b = 2 / (dmax timeconst):
# no row without damping. An elastic contact (e = 1, B = 0) gets this much instead, timeconst
# 1e6 s: dampratio B / (2 sqrt K) = 5e-9 at n = 16, dt = 1e-3, a rebound of 1 - pi 5e-9.
LEAST_DAMPING = 2e-6  # 1/s


def solver_params(e: float, n: float, dt: float) -> list[float]:
    """Genesis' sol_params (timeconst, dampratio, dmin, dmax, width, mid, power) of the contact
    spring-damper that the MuJoCo adapter's direct solref (-K, -B) gives for restitution e:
    timeconst = 2 / B, dampratio = B / (2 sqrt K) (module notes); B at least LEAST_DAMPING."""
    K, B = contact_spring_damper(e, n, dt)
    B = max(B, LEAST_DAMPING)
    return [2.0 / B, B / (2.0 * math.sqrt(K))] + list(SOLIMP)


class GenesisAdapter(Adapter):
    package = "genesis-world"
    # the release the conformance battery ran on; 1.x changes contact semantics every minor
    # release (issue 40), so the next minor is not promised
    supported = ">=1.4.5,<1.5"
    capabilities = Capabilities(
        dimensions=frozenset({3}),
        shapes=frozenset({"sphere", "box", "plane", "capsule", "cylinder"}),
        native_restitution=False,  # e mapped onto the contact spring-damper (sol_params), as MuJoCo
        static_kinetic=False,
        contact_forces=True,
        iterations=True,  # the constraint solver's iteration cap
        impact_model="compliant",
        float_bits=64,
        why_not=(("hull", "not mapped by this adapter (a Genesis mesh morph is convexified with its own tools)"),
                 ("mesh", "not mapped by this adapter"),
                 ("joint", "the adapter builds no scene joints"),
                 ("load", "the adapter applies no external forces")),
    )
    # A default run runs the core families and the conformance battery on it; named
    # (`--engines genesis`) every family. Every process pays Genesis' import (~14 s of CPU)
    # and every new scene its kernels' compile (~9 s of CPU with a full kernel cache).
    default_tags = frozenset({"core", "conformance"})

    def __init__(self, configuration: str = "signorini", name: str | None = None):
        if configuration not in CONFIGURATIONS:
            raise ValueError(f"configuration = {configuration!r}: must be one of {', '.join(CONFIGURATIONS)}")
        self.configuration = configuration
        self.name = name or ("genesis" if configuration == "signorini" else f"genesis-{configuration}")

    def version(self) -> str:
        return f"{metadata.version('genesis-world')} (cpu, float64)"

    def release_requirements(self, release: str) -> list[str]:
        """genesis-world imports torch without declaring it: a release's environment gets the
        torch the `genesis` extra names beside it."""
        return [f"genesis-world=={release}", "torch>=2.13.0"]

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene)
        if reason:
            raise Unsupported(reason)
        es = {scene.material_of(a.name, b.name).e for a, b in scene.contact_pairs()}
        if len(es) > 1:
            raise Unsupported(f"pairs with different e ({', '.join(map(str, sorted(es)))}): Genesis mixes two geoms' "
                              "solver parameters by their mean, so one body cannot meet two partners with two e")
        return GenesisSimulation(scene, settings, CONFIGURATIONS[self.configuration], es.pop() if es else 0.0)


def _mjcf(inner: str) -> str:
    return f'<mujoco><compiler angle="radian" inertiafromgeom="false"/><worldbody>{inner}</worldbody></mujoco>'


class GenesisSimulation(Simulation):
    def __init__(self, scene: Scene, settings: Settings, configuration: dict, e: float):
        g = _init()
        self._dt = settings.dt
        self.iterations = ITERATIONS if settings.iterations is None else settings.iterations
        effects = scene.effects
        gravity = tuple(scene.gravity) if "gravity" in effects else (0.0, 0.0, 0.0)
        contact = bool(scene.contact_pairs())
        frictional = "friction" in effects
        mu = per_body_values(scene, lambda m: m.mu_s, "max", "friction") if frictional else {}
        sol = solver_params(e if "restitution" in effects else 0.0, CONTACT_STEPS, self._dt)
        cone = getattr(g.friction_cone, configuration["friction_cone"])
        rigid = dict(enable_collision=contact, enable_self_collision=False, friction_cone=cone,
                     iterations=self.iterations, use_hibernation=False)
        self.knobs = {
            "gs.init": {"backend": "cpu", "precision": "64"},
            "SimOptions": {"dt": self._dt, "substeps": 1, "gravity": list(gravity)},
            "RigidOptions": {**{k: (v.name if hasattr(v, "name") else v) for k, v in rigid.items()},
                             # left None: what Genesis resolves it to with this cone and solver
                             "contact_resolution": configuration["contact_resolution"],
                             "constraint_solver": "Newton (default)", "tolerance": "None (1e-8 in float64, default)",
                             "integrator": "approximate_implicitfast (default)",
                             "contact_pruning_tolerance": "0.02 (default)",
                             "impratio": "None (default: 100 with the elliptic cone, else 1)"},
            "sol_params": {"values": sol, "e": e if "restitution" in effects else 0.0, "contact_steps": CONTACT_STEPS,
                           "least_damping_1_per_s": LEAST_DAMPING,
                           "mixing": "mean of the two geoms' (all alike)"},
            "friction": {"per_body": mu, "rule": "max of the two geoms'", "floor": FRICTION_FLOOR,
                         "frictionless_pairs_get": FRICTION_FLOOR},
            "geom": {}, "joint": {}, "inertial": {},
        }
        self._scene = g.Scene(sim_options=g.options.SimOptions(dt=self._dt, substeps=1, gravity=gravity),
                              rigid_options=g.options.RigidOptions(**rigid), show_viewer=False)
        self._order: list[str] = []
        self._entities = {}
        self._q0 = {}
        planes = []
        with tempfile.TemporaryDirectory(prefix="physval-genesis-") as folder:
            for body in scene.bodies:
                body_mu = max(mu.get(body.name, FRICTION_FLOOR), FRICTION_FLOOR)
                if isinstance(body.shape, Plane):  # Genesis' own plane (an MJCF plane in the world collides with nothing)
                    n = np.asarray(body.shape.normal, float)
                    morph = g.morphs.Plane(pos=tuple(body.shape.offset * n), normal=tuple(n))
                    self.knobs["geom"][body.name] = {"type": "gs.morphs.Plane", "pos": list(body.shape.offset * n),
                                                     "normal": list(n), "friction": body_mu, "solref": sol[:2],
                                                     "solimp": sol[2:]}
                    planes.append(body.name)
                else:
                    path = os.path.join(folder, f"{len(self._entities)}.xml")
                    with open(path, "w") as f:
                        f.write(_mjcf(self._body(body, body_mu, sol)))
                    morph = g.morphs.MJCF(file=path, convexify=False)
                self._entities[body.name] = self._scene.add_entity(
                    morph, material=g.materials.Rigid(friction=body_mu, needs_coup=False))
                if not body.static:
                    self._order.append(body.name)
            self._scene.build()
        for name in planes:  # the plane's solver parameters, as the MJCF geoms carry theirs
            for geom in self._entities[name].geoms:
                geom.set_sol_params(np.asarray(sol))
                geom.set_friction(self.knobs["geom"][name]["friction"])
        self._solver = self._scene.sim.rigid_solver
        self._links = [self._entities[n].get_link(n).idx for n in self._order]
        self._mass = np.array([b.mass for b in scene.dynamic_bodies])
        self._start(scene)
        self._link_body = {self._entities[n].get_link(n).idx: n for n in self._order}
        for body in scene.bodies:
            if body.static:
                for link in self._entities[body.name].links:
                    self._link_body[link.idx] = body.name
        self.effects = self._built_effects(scene, gravity, contact, e)

    def _body(self, body: Body, mu: float, sol: list[float]) -> str:
        """A scene body as MJCF: its geom (the MuJoCo adapter's `_geom`) with friction and
        sol_params, in a frame with its inertia and joints, or in the world if static."""
        geom = {"name": body.name, **_geom(body, list(body.orientation) if body.static else [1, 0, 0, 0]),
                "friction": [mu, 0, 0], "solref": None, "solimp": None, "condim": 3}
        tc, zeta, *imp = sol
        geom.update(solref=[tc, zeta], solimp=imp)
        if body.static:  # a body without joints: welded to the world, a link of its own
            self.knobs["geom"][body.name] = geom
            return _element("body", {"name": body.name, "pos": list(body.position)}, _element("geom", geom))
        joints = _joints(body, 3)
        if joints == "free":
            frame = {"name": body.name, "pos": list(body.position), "quat": list(body.orientation)}
            joint_xml = _element("freejoint", {"name": f"{body.name}:free"})
            inertial = {"pos": [0, 0, 0], "quat": [1, 0, 0, 0]}
            self.knobs["joint"][body.name] = "free"
        else:  # a world-aligned frame that slides; the geom and the inertia carry the orientation
            frame = {"name": body.name, "pos": list(body.position)}
            geom["quat"] = list(body.orientation)
            joint = [{"name": f"{body.name}:{t}{i}", "type": t, "axis": list(axis), "damping": 0, "stiffness": 0,
                      "armature": 0, "frictionloss": 0, "limited": "false"} for i, (t, axis) in enumerate(joints)]
            joint_xml = "".join(_element("joint", j) for j in joint)
            inertial = {"pos": [0, 0, 0], "quat": list(body.orientation)}
            self.knobs["joint"][body.name] = joint
        inertial.update(mass=body.mass, diaginertia=list(body.principal_inertia))
        self.knobs["geom"][body.name] = geom
        self.knobs["inertial"][body.name] = inertial
        return _element("body", frame, joint_xml + _element("inertial", inertial) + _element("geom", geom))

    def _start(self, scene: Scene) -> None:
        """The scene's start velocities: a free joint's dofs are (v, w), w in the world frame;
        slide joints' dofs v along x, y, z."""
        for body in scene.dynamic_bodies:
            entity = self._entities[body.name]
            v = list(body.velocity) + (list(body.angular_velocity) if body.rotates else [])
            if any(v):
                entity.set_dofs_velocity(np.asarray(v, float))
        self._forces_cache = None

    def _built_effects(self, scene: Scene, gravity, contact: bool, e: float) -> frozenset[str]:
        fx = set()
        if any(c != 0.0 for c in gravity):
            fx.add("gravity")
        if contact:
            fx.add("contact")
            fx.add("friction")  # every Genesis contact has friction rows, mu >= FRICTION_FLOOR
            if e > 0 and "restitution" in scene.effects:
                fx.add("restitution")
        if any(j == "free" for j in self.knobs["joint"].values()):
            fx.add("rotation")
        return frozenset(fx)

    def step(self) -> None:
        self._scene.step()
        self._forces_cache = None

    def _read(self) -> np.ndarray:
        s = self._solver
        pos = s.get_links_pos(self._links).numpy()
        quat = s.get_links_quat(self._links).numpy()
        vel = s.get_links_vel(self._links).numpy()
        ang = s.get_links_ang(self._links).numpy()
        return np.concatenate([pos, quat, vel, ang], axis=1)  # (bodies, 13): the trajectory layout

    def states(self) -> dict[str, np.ndarray]:
        rows = self._read()
        return {name: rows[i].astype(float) for i, name in enumerate(self._order)}

    def body_order(self) -> list[str]:
        return list(self._order)

    def write_state(self, out: np.ndarray) -> None:
        out[:] = self._read().ravel()

    def contact_forces(self) -> dict[tuple[str, str], float]:
        if self._forces_cache is not None:
            return dict(self._forces_cache)
        c = self._solver.collider.get_contacts(as_tensor=True, to_torch=False)
        out: dict[tuple[str, str], float] = {}
        if len(c.get("link_a", ())):
            for la, lb, force, normal in zip(c["link_a"], c["link_b"], c["force"], c["normal"]):
                a, b = self._link_body.get(int(la)), self._link_body.get(int(lb))
                if a is None or b is None:
                    continue
                key = pair_key(a, b)
                n = np.asarray(normal, float)
                f_n = abs(float(np.dot(np.asarray(force, float), n)))
                out[key] = out.get(key, 0.0) + f_n
        self._forces_cache = out
        return dict(out)

    def close(self) -> None:
        scene, self._scene = getattr(self, "_scene", None), None
        if scene is not None:
            try:
                scene.destroy()
            except Exception:  # noqa: BLE001 (an engine's own teardown; nothing to keep)
                pass
