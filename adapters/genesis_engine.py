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
  (gs.morphs.MJCF): its geom the MuJoCo adapter's (a hull a mesh geom of its corners, whose
  convex hull MuJoCo's compiler gives Genesis, not convexified again; a static triangle mesh
  the MuJoCo adapter's triangle prisms, each convex), the scene's mass and principal
  inertia (<inertial>, never from the geoms), a free joint for a body that rotates, three
  world-axis slide joints for one that does not (its orientation read as its start one: the
  link never turns), no joint damping, armature or friction (the MuJoCo adapter's `_joints` and
  `_geom`). One entity a body, because Genesis skips collisions inside one entity between
  bodies that touch in its start pose (enable_neutral_collision) and between parent and
  child (the world and its bodies);
- joints: the bodies a scene's joints connect are one entity a tree (with the bodies a loop's
  closing joint ties to it), written as the MuJoCo adapter writes its kinematic tree
  (reduced coordinates: each body's frame, inertia and joint, a loop's closing joint an
  <equality><connect>), then dressed for Genesis (`_tree`): every geom collides, a limit's
  and a joint's dry-friction rows get the spring-damper of the limit's restitution (Genesis
  gives both the joint's solreflimit). No rotor inertia: Genesis adds an armature of 0.1 to
  every revolute or prismatic joint a file leaves at 0 (MJCF_OPTIONS), which the slides of a
  body held from rotating had too before it was turned off. A load is an external wrench,
  which Genesis applies for one step: applied again before every step;
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

import xml.etree.ElementTree as ET

from adapters.base import Adapter, Capabilities, Settings, Simulation, Unsupported
from adapters.combination import per_body_values
from adapters.joints import joint_tree, start_rate
from adapters.lazy import require
from adapters.mujoco_engine import (CONTACT_STEPS, SOLIMP, _element, _geom, _import_mujoco, _joints, _loop_xml,
                                    _mesh_geoms, _tree_body_xml, contact_spring_damper)
from cases import rotations
from cases.scene import Body, Mesh, Plane, Scene, pair_key

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


# How an MJCF file becomes an entity: its geoms as written (no convexification), and no rotor
# inertia added to its joints: Genesis gives every revolute or prismatic joint whose armature
# the file leaves at 0 a default armature of 0.1 (kg m^2 or kg; morphs.MJCF.default_armature),
# which adds to the body's mass along a slide and to its moment about a hinge (measured: a
# pendulum of I_p = 0.251 kg m^2 swung 1.18x slower, sqrt(0.351 / 0.251))
MJCF_OPTIONS = {"convexify": False, "default_armature": None}


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
    # the releases the conformance battery passes on (physval versions, reports/versions/: 1.3.3,
    # 1.4.2, 1.4.5; on 1.3.0, which has no 'signorini' resolution, the elliptic cone fails it);
    # 1.x changes contact semantics every minor release (issue 40), so the next minor is not promised
    supported = ">=1.3.3,<1.5"
    capabilities = Capabilities(
        # 2D: the MuJoCo adapter's planar joints (slides along x and z, a hinge about y)
        dimensions=frozenset({2, 3}),
        shapes=frozenset({"sphere", "box", "plane", "capsule", "cylinder", "hull", "mesh", "circle", "rect",
                          "polygon"}),
        native_restitution=False,  # e mapped onto the contact spring-damper (sol_params), as MuJoCo
        static_kinetic=False,
        contact_forces=True,
        iterations=True,  # the constraint solver's iteration cap
        impact_model="compliant",
        float_bits=64,
        # joints as the MuJoCo adapter's kinematic tree in MJCF (one entity a tree), parsed by Genesis
        joints=frozenset({"revolute", "prismatic", "ball", "fixed"}),
        joint_limits=True,
        joint_friction=True,
        limit_restitution=True,  # e at a limit onto the limit row's spring-damper, as a contact's
        coordinates="reduced",
        loads=True,
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
        torch installed here, the same build (a CPU build stays one: PyPI's default torch
        brings CUDA, 5.3 GB more; pip must reach where it came from), else the one the
        `genesis` extra names."""
        try:
            torch = f"torch=={metadata.version('torch')}"
        except metadata.PackageNotFoundError:
            torch = "torch>=2.13.0"
        return [f"genesis-world=={release}", torch]

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        reason = self.capabilities.cannot_run(scene)
        if reason:
            raise Unsupported(reason)
        es = {scene.material_of(a.name, b.name).e for a, b in scene.contact_pairs()}
        if len(es) > 1:
            raise Unsupported(f"pairs with different e ({', '.join(map(str, sorted(es)))}): Genesis mixes two geoms' "
                              "solver parameters by their mean, so one body cannot meet two partners with two e")
        return GenesisSimulation(scene, settings, CONFIGURATIONS[self.configuration], es.pop() if es else 0.0)


def _mjcf(inner: str, outer: str = "", meshes: dict | None = None) -> str:
    """An MJCF file of a worldbody's content, what follows it, and the <mesh> assets its
    geoms name (the MuJoCo adapter's, vertices inline)."""
    assets = "<asset>" + "".join(_element("mesh", m) for m in meshes.values()) + "</asset>" if meshes else ""
    return (f'<mujoco><compiler angle="radian" inertiafromgeom="false"/>{assets}<worldbody>{inner}</worldbody>'
            f'{outer}</mujoco>')


def _text(value) -> str:
    """An MJCF attribute's text: a vector's numbers space-separated (each float's shortest repr)."""
    return " ".join(map(str, value)) if isinstance(value, (list, tuple)) else str(value)


def _children(scene: Scene, tree: dict) -> dict[str, list[Body]]:
    """Each tree parent's jointed children (adapters.joints.joint_tree), in scene order: the
    order _tree_body_xml writes them in, and so their dofs' order in the entity."""
    out: dict[str, list[Body]] = {}
    for body in scene.dynamic_bodies:
        if body.name in tree and tree[body.name].parent is not None:
            out.setdefault(tree[body.name].parent, []).append(body)
    return out


def _tree_groups(scene: Scene) -> list[list[str]]:
    """The dynamic bodies the scene's joints connect, in groups that share a joint (a tree,
    with the bodies a loop's closing joint ties to it): each group one Genesis entity, since
    an MJCF file's equality constraints hold its own bodies only. Scene order in each."""
    static = {b.name for b in scene.bodies if b.static}
    root = {}

    def find(name: str) -> str:
        while root.setdefault(name, name) != name:
            name = root[name]
        return name
    for joint in scene.joints:
        a = find(joint.body)
        if joint.parent is not None and joint.parent not in static:
            root[find(joint.parent)] = a
    groups: dict[str, list[str]] = {}
    for body in scene.dynamic_bodies:
        if body.name in root:
            groups.setdefault(find(body.name), []).append(body.name)
    return list(groups.values())


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
            "morphs.MJCF": dict(MJCF_OPTIONS),
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
            "geom": {}, "joint": {}, "inertial": {}, "left_out": {},
        }
        self._entities = {}
        # a body on slides (held from rotating, or in 2D): its orientation, which its geom and inertia
        # carry (its link's frame starts world-aligned and turns only about a 2D body's hinge)
        self._q0 = {}
        planes = []
        mus = {b.name: max(mu.get(b.name, FRICTION_FLOOR), FRICTION_FLOOR) for b in scene.bodies}
        groups = _tree_groups(scene) if scene.joints else []
        grouped = {name for group in groups for name in group}
        if any(a.name in group and b.name in group for a, b in scene.contact_pairs() for group in groups):
            rigid["enable_self_collision"] = True  # a pair inside one tree's entity (Genesis skips parent-child pairs)
            self.knobs["RigidOptions"]["enable_self_collision"] = True
        self._scene = g.Scene(sim_options=g.options.SimOptions(dt=self._dt, substeps=1, gravity=gravity),
                              rigid_options=g.options.RigidOptions(**rigid), show_viewer=False)
        with tempfile.TemporaryDirectory(prefix="physval-genesis-") as folder:
            for group in groups:  # each tree of jointed bodies one entity; its geoms carry their own friction
                path = os.path.join(folder, f"tree{len(self._entities)}.xml")
                with open(path, "w") as f:
                    f.write(self._tree(scene, group, mus, sol))
                entity = self._scene.add_entity(g.morphs.MJCF(file=path, **MJCF_OPTIONS),
                                                material=g.materials.Rigid(needs_coup=False))
                for name in group:
                    self._entities[name] = entity
            for body in scene.bodies:
                if body.name in grouped:
                    continue
                body_mu = mus[body.name]
                if isinstance(body.shape, Plane):  # Genesis' own (an MJCF plane in the world collides with nothing)
                    n = np.asarray(body.shape.normal, float)
                    morph = g.morphs.Plane(pos=tuple(body.shape.offset * n), normal=tuple(n))
                    self.knobs["geom"][body.name] = {"type": "gs.morphs.Plane", "pos": list(body.shape.offset * n),
                                                     "normal": list(n), "friction": body_mu, "solref": sol[:2],
                                                     "solimp": sol[2:]}
                    planes.append(body.name)
                else:
                    path = os.path.join(folder, f"{len(self._entities)}.xml")
                    with open(path, "w") as f:
                        meshes: dict[str, dict] = {}
                        f.write(_mjcf(self._body(body, body_mu, sol, meshes, scene.dimension), meshes=meshes))
                    morph = g.morphs.MJCF(file=path, **MJCF_OPTIONS)
                self._entities[body.name] = self._scene.add_entity(
                    morph, material=g.materials.Rigid(friction=body_mu, needs_coup=False))
            self._scene.build()
        self._order = [b.name for b in scene.dynamic_bodies]
        for name in planes:  # the plane's solver parameters, as the MJCF geoms carry theirs
            for geom in self._entities[name].geoms:
                geom.set_sol_params(np.asarray(sol))
                geom.set_friction(self.knobs["geom"][name]["friction"])
        self._solver = self._scene.sim.rigid_solver
        self._links = [self._entities[n].get_link(n).idx for n in self._order]
        self._slid = [(i, self._q0[n], scene.body(n).rotates) for i, n in enumerate(self._order) if n in self._q0]
        self._mass = np.array([b.mass for b in scene.dynamic_bodies])
        # loads: Genesis applies an external wrench over one step, so each step applies them again
        self._loads = [(self._entities[ld.body].get_link(ld.body).idx, np.asarray(ld.force, float),
                        np.asarray(ld.torque, float)) for ld in scene.loads]
        if self._loads:
            self.knobs["loads"] = {ld.body: {"force": list(ld.force), "torque": list(ld.torque),
                                             "applied": "apply_links_external_wrench before every step, at the "
                                                        "link origin (its centre of mass), world frame"}
                                   for ld in scene.loads}
        self._start(scene)
        self._link_body = {self._entities[n].get_link(n).idx: n for n in self._order}
        for body in scene.bodies:
            if body.static:
                for link in self._entities[body.name].links:
                    self._link_body[link.idx] = body.name
        self.effects = self._built_effects(scene, gravity, contact, e)

    def _body(self, body: Body, mu: float, sol: list[float], meshes: dict, dimension: int) -> str:
        """A scene body as MJCF: its geom (the MuJoCo adapter's `_geom`; a hull a mesh geom of
        its corners, whose convex hull MuJoCo's compiler gives Genesis) with friction and
        sol_params, in a frame with its inertia and joints, or in the world if static (a
        static triangle mesh as the MuJoCo adapter's triangle prisms, each convex)."""
        tc, zeta, *imp = sol
        contact = {"friction": [mu, 0, 0], "solref": [tc, zeta], "solimp": imp, "condim": 3}
        if isinstance(body.shape, Mesh):  # static (the scene allows no other): the prisms in world coordinates
            geoms, record = _mesh_geoms(body, meshes)
            self.knobs["geom"][body.name] = {**record, **contact}
            return _element("body", {"name": body.name}, "".join(_element("geom", {**g, **contact}) for g in geoms))
        geom = {"name": body.name, **_geom(body, list(body.orientation) if body.static else [1, 0, 0, 0],
                                           meshes=meshes), **contact}
        if body.static:  # a body without joints: welded to the world, a link of its own
            self.knobs["geom"][body.name] = geom
            return _element("body", {"name": body.name, "pos": list(body.position)}, _element("geom", geom))
        joints = _joints(body, dimension)
        if joints == "free":
            frame = {"name": body.name, "pos": list(body.position), "quat": list(body.orientation)}
            joint_xml = _element("freejoint", {"name": f"{body.name}:free"})
            inertial = {"pos": [0, 0, 0], "quat": [1, 0, 0, 0]}
            self.knobs["joint"][body.name] = "free"
        else:  # a world-aligned frame that slides (in 2D, turns about y); the geom and the inertia carry the orientation
            frame = {"name": body.name, "pos": list(body.position)}
            self._q0[body.name] = np.asarray(body.orientation, float)
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

    def _tree(self, scene: Scene, group: list[str], mus: dict, sol: list[float]) -> str:
        """A group of jointed bodies (_tree_groups) as MJCF: the MuJoCo adapter's kinematic
        tree (each body's frame, inertia and joint; a loop's closing joint an equality
        <connect>), dressed for Genesis, which collides geoms by contype/conaffinity and reads
        solver parameters in their positive (timeconst, dampratio) form only: every geom
        collides, with its body's friction and the contacts' sol_params; a joint's limit and
        dry-friction rows (Genesis gives both the joint's solreflimit) the spring-damper of
        the limit's restitution (e = 0 where it has none), as a contact's (solver_params)."""
        _import_mujoco()  # its quaternion product places a child in its parent's frame (Genesis needs mujoco too)
        tree, closing = joint_tree(scene)
        parents = {name: (tj.parent, tj.joint) for name, tj in tree.items()}
        children = _children(scene, tree)
        for name in group:
            if not scene.body(name).rotates:
                raise Unsupported(f"body {name!r} held from rotating (rotates=False) in a tree of joints: not mapped "
                                  "(its slides would need the tree's frames)")
        roots = [scene.body(n) for n in group if parents.get(n, (None,))[0] is None]
        meshes: dict[str, dict] = {}
        bodies = "".join(_tree_body_xml(scene, b, parents, children, self.knobs, meshes, CONTACT_STEPS, self._dt)
                         for b in roots)
        loops = [(j, joint) for j, joint in closing if joint.body in group]
        if loops:
            self.knobs.setdefault("loop", {})
        xml = ET.fromstring(_mjcf(bodies, _loop_xml(scene, loops, self.knobs, self._dt, frozenset()), meshes))
        for geom in xml.iter("geom"):
            name = geom.get("name")
            dressed = {"contype": 1, "conaffinity": 1, "condim": 3, "friction": [mus[name], 0, 0],
                       "solref": sol[:2], "solimp": sol[2:]}
            geom.attrib.update({k: _text(v) for k, v in dressed.items()})
            self.knobs["geom"][name].update(dressed)
        for joint in xml.iter("joint"):
            body = joint.get("name").rsplit(":", 1)[0]
            if body not in tree:  # a 2D root's planar joints: no scene joint, no limit
                continue
            spec, j = self.knobs["joint"][body], tree[body].joint
            if j.limits is not None or j.friction > 0:
                row = solver_params(j.limit_e if j.limits is not None else 0.0, CONTACT_STEPS, self._dt)
                limit = {"solreflimit": row[:2], "solimplimit": row[2:]}
                for k in ("solreffriction", "solimpfriction"):  # Genesis reads the limit's for friction rows
                    joint.attrib.pop(k, None)
                    spec.pop(k, None)
                joint.attrib.update({k: _text(v) for k, v in limit.items()})
                spec.update(limit)
        return ET.tostring(xml, encoding="unicode")

    def _start(self, scene: Scene) -> None:
        """The scene's start velocities: a free joint's dofs are (v, w), w in the world frame;
        slide and hinge joints' dofs v and w along their world axes (x, y, z; in 2D x, z, then
        the turn about y); a tree's dofs in its MJCF order (each body in the order written,
        depth first: a free root's (v, w), a joint's start rate)."""
        tree, _ = joint_tree(scene)
        written = {}  # entity -> its dofs' start velocities in order
        for body in self._written(scene, tree):
            entity = self._entities[body.name]
            tj = tree.get(body.name)
            if tj is not None:
                v = list(start_rate(scene, tj))
            elif self.knobs["joint"][body.name] == "free":
                v = list(body.velocity) + list(body.angular_velocity)
            else:  # slides and a 2D hinge along world axes, in the order the file has them
                v = [float(np.dot(body.velocity if kind == "slide" else body.angular_velocity, axis))
                     for kind, axis in _joints(body, scene.dimension)]
            written.setdefault(entity, []).extend(v)
        for entity, v in written.items():
            if any(v):
                entity.set_dofs_velocity(np.asarray(v, float))
        self._forces_cache = None

    def _written(self, scene: Scene, tree: dict) -> list[Body]:
        """The dynamic bodies in the order their entities' dofs come: a body alone, or a
        tree's bodies depth first from its roots (as _tree_body_xml writes them)."""
        out, children = [], _children(scene, tree)

        def visit(body: Body) -> None:
            out.append(body)
            for child in children.get(body.name, ()):
                visit(child)
        for body in scene.dynamic_bodies:
            if body.name not in tree or tree[body.name].parent is None:
                visit(body)
        return out

    def _built_effects(self, scene: Scene, gravity, contact: bool, e: float) -> frozenset[str]:
        fx = set()
        if any(c != 0.0 for c in gravity):
            fx.add("gravity")
        if contact:
            fx.add("contact")
            fx.add("friction")  # every Genesis contact has friction rows, mu >= FRICTION_FLOOR
            if e > 0 and "restitution" in scene.effects:
                fx.add("restitution")
        joints = [j for j in self.knobs["joint"].values() if isinstance(j, dict)]  # the trees' (a slide's: a list)
        slid = [j for spec in self.knobs["joint"].values() if isinstance(spec, list) for j in spec]
        if any(j == "free" for j in self.knobs["joint"].values()) or any(j.get("type") in ("hinge", "ball")
                                                                         for j in joints + slid):
            fx.add("rotation")
        if joints:
            fx.add("joint")
        if any(j.get("limited") == "true" for j in joints):
            fx.add("limit")
            # a limit row damped less than the plastic one (b = 1/dt) bounces
            if any(self._limit_restitution(j) for j in joints):
                fx.add("limit_restitution")
        if any(j.get("frictionloss", 0) > 0 for j in joints):
            fx.add("joint_friction")
        if self._loads:
            fx.add("load")
        return frozenset(fx)

    def _limit_restitution(self, joint: dict) -> bool:
        """Whether a tree joint's limit row bounces: damped less than the plastic row's
        b = 1/dt (Genesis: b = 2 / (dmax timeconst))."""
        if joint.get("limited") != "true":
            return False
        timeconst, dmax = joint["solreflimit"][0], joint["solimplimit"][1]
        return 2.0 / (dmax * timeconst) < (1.0 - 1e-9) / self._dt

    def step(self) -> None:
        for link, force, torque in self._loads:
            self._solver.apply_links_external_wrench(force, torque, [link])
        self._scene.step()
        self._forces_cache = None

    def _read(self) -> np.ndarray:
        s = self._solver
        pos = s.get_links_pos(self._links).numpy()
        quat = s.get_links_quat(self._links).numpy()
        vel = s.get_links_vel(self._links).numpy()
        ang = s.get_links_ang(self._links).numpy()
        for i, q0, turns in self._slid:  # the link's turn (a 2D body's, about y) after the one its geom carries
            quat[i] = rotations.multiply(quat[i], q0) if turns else q0
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
