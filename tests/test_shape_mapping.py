"""The shapes the scene vocabulary added last (capsule, cylinder, hull, polygon, static
mesh) as the PyBullet, MuJoCo, MuJoCo Warp, DART and Drake adapters build them, in every
configuration the registry holds of them: the engine's own geometry read back (radii,
lengths, corners, the axis along the body's z), the bodies' start state, and one small
physical check each: a capsule and a cylinder on their side and on their end rest at the
height their size gives and carry their weight; a hull given as the corners of a box rests
as the box; a box, a hull and a ball rest on a ground given as a triangle mesh as on the
plane; a square given as a 2D polygon rests as the rect.

Each engine builds each scene once (`_run`, cached for the module): 0.5 s of simulated time.
"""
from __future__ import annotations

import functools
import itertools
import math

import numpy as np
import pytest

from adapters import registry
from adapters.base import Settings
from cases.scene import (Body, Box, Capsule, Cylinder, Hull, Material, Mesh, Polygon, Rect, Scene, Sphere, ground,
                         pair_key)
from tests.shape_helpers import DT, G, ON_ITS_SIDE
from tests.helpers import adapter_or_skip

STEPS = 500  # 0.5 s: every contact here has settled (the slowest, Drake's, lasts 16 steps)
SETTLED = 100  # steps over which the contact forces are averaged (pybullet's MLCP solvers let a
# resting box's contact force swing 2 % from step to step about its weight)
MODULES = ("adapters.pybullet_engine", "adapters.mujoco_engine", "adapters.mujoco_warp_engine",
           "adapters.dart_engine", "adapters.drake_engine")
CONFIGURATIONS = [name for name, (module, _, _) in registry.ENGINES.items() if module in MODULES]

# How far a resting body may sit from the height its shape gives: the softest mapped contact
# here sinks under its weight by g / w^2 = 0.25 mm (Drake's point contact, k = m w^2,
# w = pi / (16 dt)) and Drake's hydroelastic ball, capsule end and lying cylinder by up to
# 1.6 mm (moduli from a contact lasting 16 steps, module notes of adapters/drake_engine.py);
# a radius taken for a diameter, a half-length for a length or an axis across the body
# moves it by 50 mm or more (r = 50 mm, h = 100 mm here).
HEIGHT = 2e-3  # m
# A resting body carries its weight, over the last 0.1 s: what is left is the compliant
# contacts' decaying oscillation, 1e-4 of m g at most (Drake, measured); a contact missing at
# one end or a body in a wrong place moves it by tens of per cent.
WEIGHT = 1e-2  # of m g
# A hull given as a box's corners, and a body on a mesh ground, against the box and the
# plane on the same engine: the same contact law, so the same sag to a fraction of it.
TWIN = 2e-4  # m
# A body at rest after 0.5 s, its points' speed (|v| + |w| times its reach): the compliant
# contacts' decaying oscillation and Bullet's creep leave 0.3 mm/s (Drake; a lying cylinder
# on pybullet's box ground, measured); one that rocks, rolls off or sinks through moves
# 0.05 m/s or faster.
STILL = 1e-3  # m/s


def _speed(row: np.ndarray, shape) -> float:
    """The largest speed of a point of a body in state `row` (cases.trajectory layout)."""
    from cases.overlap import reach
    return float(np.linalg.norm(row[7:10]) + np.linalg.norm(row[10:13]) * reach(shape))


R, H = 0.05, 0.1  # capsule and cylinder radius and half-length, m
HALF = 0.1  # box and hull half-extent, m
BOX_CORNERS = tuple(itertools.product((-HALF, HALF), repeat=3))


def _resting(dimension: int = 3) -> dict[str, tuple]:
    """Body name -> (shape, height of its centre at rest on z = 0, orientation)."""
    if dimension == 2:
        return {"rect": (Rect((HALF, HALF)), HALF, (1.0, 0.0, 0.0, 0.0)),
                "polygon": (Polygon(((-HALF, -HALF), (HALF, -HALF), (HALF, HALF), (-HALF, HALF))), HALF,
                            (1.0, 0.0, 0.0, 0.0))}
    return {"capsule_side": (Capsule(R, H), R, ON_ITS_SIDE), "capsule_end": (Capsule(R, H), H + R, (1.0, 0.0, 0.0, 0.0)),
            "cylinder_side": (Cylinder(R, H), R, ON_ITS_SIDE), "cylinder_end": (Cylinder(R, H), H, (1.0, 0.0, 0.0, 0.0)),
            "box": (Box((HALF,) * 3), HALF, (1.0, 0.0, 0.0, 0.0)),
            "hull": (Hull(BOX_CORNERS), HALF, (1.0, 0.0, 0.0, 0.0)),
            "ball": (Sphere(HALF), HALF, (1.0, 0.0, 0.0, 0.0))}


# A ground mesh: a 4 m square in two triangles, with a 0.2 m step down at x > 1 (so a mesh
# that is not flat), turned 30 deg about z and lifted 0.5 m: its frame is the body's pose.
MESH_LIFT = 0.5
MESH_TURN = (math.cos(math.pi / 12), 0.0, 0.0, math.sin(math.pi / 12))
MESH = Mesh(((-2, -2, 0), (1, -2, 0), (1, 2, 0), (-2, 2, 0), (1, -2, -0.2), (2, -2, -0.2), (2, 2, -0.2), (1, 2, -0.2)),
            ((0, 1, 2), (0, 2, 3), (1, 4, 7), (1, 7, 2), (4, 5, 6), (4, 6, 7)))


def _scene(ground_kind: str, dimension: int = 3) -> Scene:
    bodies = []
    names = ("box", "hull", "ball") if ground_kind == "mesh" else tuple(_resting(dimension))
    lift = MESH_LIFT if ground_kind == "mesh" else 0.0
    for k, name in enumerate(names):
        shape, z, q = _resting(dimension)[name]
        if ground_kind == "mesh":  # on its upper flat, along its own x (turned 30 deg about z)
            x = -1.2 + 0.8 * k
            position = (math.cos(math.pi / 6) * x, math.sin(math.pi / 6) * x, z + lift)
        else:  # in a row along y (a 2D scene's bodies along x: it has no y)
            position = (float(k), 0.0, z) if dimension == 2 else (0.0, float(k), z)
        bodies.append(Body(name, shape, mass=1.0, position=position, orientation=q))
    floor = Body("ground", MESH, static=True, position=(0.0, 0.0, MESH_LIFT), orientation=MESH_TURN) \
        if ground_kind == "mesh" else ground()
    return Scene(bodies=(floor, *bodies), material=Material(mu_s=0.5), dimension=dimension)


@functools.cache
def _run(engine: str, ground_kind: str, dimension: int = 3):
    """(start states, states after STEPS, contact forces over the last SETTLED steps) of
    `_scene`, or the reason the engine cannot run it."""
    adapter = registry.get(engine)
    scene = _scene(ground_kind, dimension)
    why = adapter.capabilities.cannot_run(scene)
    if why:
        return why
    from adapters.base import Unsupported
    try:
        sim = adapter.build(scene, Settings(dt=DT))
    except Unsupported as exc:
        return str(exc)
    with sim:
        start = sim.states()
        for _ in range(STEPS - SETTLED):
            sim.step()
        forces: dict = {}
        for _ in range(SETTLED):
            sim.step()
            for key, f in sim.contact_forces().items():
                forces[key] = forces.get(key, 0.0) + f / SETTLED
        return start, sim.states(), forces


def _ran(engine: str, ground_kind: str, dimension: int = 3):
    adapter_or_skip(engine)
    out = _run(engine, ground_kind, dimension)
    if isinstance(out, str):
        pytest.skip(f"{engine}: {out}")
    return out


@pytest.mark.parametrize("engine", CONFIGURATIONS)
def test_bodies_start_where_the_scene_says(engine):
    """The state read back before the first step is the scene's, to the engine's float width
    (positions of metres: 1e-12 m in float64, 1e-6 m in float32)."""
    tol = 1e-12 if adapter_or_skip(engine).capabilities.float_bits == 64 else 1e-6
    for ground_kind, dimension in (("plane", 3), ("mesh", 3), ("plane", 2)):
        out = _run(engine, ground_kind, dimension)
        if isinstance(out, str):  # a configuration without 2D scenes
            continue
        start, _, _ = out
        for body in _scene(ground_kind, dimension).dynamic_bodies:
            row = start[body.name]
            assert row[0:3] == pytest.approx(body.position, abs=tol), (engine, body.name)
            assert abs(abs(float(np.dot(row[3:7], body.orientation))) - 1.0) < tol, (engine, body.name)
            assert np.abs(row[7:]).max() <= tol, (engine, body.name)


@pytest.mark.parametrize("engine", CONFIGURATIONS)
def test_capsules_and_cylinders_rest_at_their_size(engine):
    """On their side at their radius, on their end at their half-length (a capsule's plus its
    radius), each carrying its weight and at rest."""
    _, end, forces = _ran(engine, "plane")
    for name in ("capsule_side", "capsule_end", "cylinder_side", "cylinder_end"):
        _, z, q = _resting()[name]
        row = end[name]
        assert row[2] == pytest.approx(z, abs=HEIGHT), (engine, name, row[2] - z)
        assert abs(abs(float(np.dot(row[3:7], q))) - 1.0) < 1e-6, (engine, name, row[3:7])
        assert _speed(row, _resting()[name][0]) < STILL, (engine, name, row[7:])
        assert forces.get(pair_key("ground", name), 0.0) == pytest.approx(G, rel=WEIGHT), (engine, name)


def _point_contact(engine: str) -> bool:
    return getattr(adapter_or_skip(engine), "contact_model", None) == "point"


# Drake's point contact gives a pair one point, its deepest: a box on the half-space rests
# flat (the box routine), but a Convex on it, or a box on the triangle prisms of a mesh,
# stands on one corner at a time and rocks on them (measured: 3-9 mm deep, up to 0.1 rad/s,
# every approximation). A finding of the engine, not of the mapping (the geometry is checked
# below); its size belongs to the families that pose it.
ONE_POINT = "Drake's point contact: one point per pair, so a Convex (or a box on a mesh's prisms) rocks on its corners"


@pytest.mark.parametrize("engine", CONFIGURATIONS)
def test_a_hull_of_a_boxs_corners_rests_as_the_box(request, engine):
    if _point_contact(engine):
        request.applymarker(pytest.mark.xfail(strict=True, reason=ONE_POINT))
    _, end, forces = _ran(engine, "plane")
    box, hull = end["box"], end["hull"]
    assert hull[2] == pytest.approx(box[2], abs=TWIN), (engine, hull[2] - box[2])
    assert abs(abs(float(np.dot(hull[3:7], box[3:7]))) - 1.0) < 1e-6, (engine, hull[3:7])
    assert forces.get(pair_key("ground", "hull"), 0.0) == pytest.approx(G, rel=WEIGHT), engine


@pytest.mark.parametrize("engine", CONFIGURATIONS)
def test_a_mesh_ground_carries_bodies_as_the_plane(request, engine):
    """A box, a hull box and a ball on the upper flat of a stepped mesh ground (its frame
    lifted and turned) rest as on the plane: the same height above the surface, at rest,
    carrying their weight."""
    if _point_contact(engine):
        request.applymarker(pytest.mark.xfail(strict=True, reason=ONE_POINT))
    _, on_plane, _ = _ran(engine, "plane")
    _, on_mesh, forces = _ran(engine, "mesh")
    for name in ("box", "hull", "ball"):
        assert on_mesh[name][2] - MESH_LIFT == pytest.approx(on_plane[name][2], abs=TWIN), (engine, name)
        assert _speed(on_mesh[name], _resting()[name][0]) < STILL, (engine, name, on_mesh[name][7:])
        assert forces.get(pair_key("ground", name), 0.0) == pytest.approx(G, rel=WEIGHT), (engine, name)


@pytest.mark.parametrize("engine", CONFIGURATIONS)
def test_a_square_polygon_rests_as_the_rect(request, engine):
    if _point_contact(engine):
        request.applymarker(pytest.mark.xfail(strict=True, reason=ONE_POINT))
    _, end, forces = _ran(engine, "plane", 2)
    rect, polygon = end["rect"], end["polygon"]
    assert polygon[2] == pytest.approx(rect[2], abs=TWIN), (engine, polygon[2] - rect[2])
    assert abs(abs(float(np.dot(polygon[3:7], rect[3:7]))) - 1.0) < 1e-6, (engine, polygon[3:7])
    assert forces.get(pair_key("ground", "polygon"), 0.0) == pytest.approx(G, rel=WEIGHT), engine


# --- each engine's own geometry, read back -------------------------------------------------

# Points outside a body's surface along directions from its centre, and their exact distance
# to the surface (body frame): a capsule's and a cylinder's along their axis (z) and across
# it, a hull box's through a face and through a corner.
PROBES = {"capsule": (((0, 0, 1), H + R), ((1, 0, 0), R)), "cylinder": (((0, 0, -1), H), ((0, 1, 0), R)),
          "hull": (((1, 0, 0), HALF), ((1, 1, 1), HALF * math.sqrt(3)))}
REACH = 0.3  # m from the centre: outside every probed body
# The stepped mesh ground's surface height (its own frame) at points (x, y) of its own frame.
MESH_HEIGHTS = (((-1.5, 0.3), 0.0), ((0.5, -1.0), 0.0), ((1.5, 0.2), -0.2), ((1.9, 1.9), -0.2))


def _probes(scene: Scene):
    """(body name, world point outside the body, unit direction back to it, exact distance to
    its surface along that direction) for the probed bodies of `scene` and for points above
    a mesh ground (straight down in its frame)."""
    from cases.overlap import rotation_matrix
    out = []
    for body in scene.bodies:
        R_wb, p = rotation_matrix(body.orientation), np.asarray(body.position, float)
        if body.shape.kind in PROBES:
            for d, depth in PROBES[body.shape.kind]:
                u = R_wb @ (np.asarray(d, float) / np.linalg.norm(d))
                out.append((body.name, p + REACH * u, -u, REACH - depth))
        elif body.shape.kind == "mesh":
            for (x, y), z in MESH_HEIGHTS:
                out.append((body.name, p + R_wb @ np.array([x, y, z + REACH]), -R_wb[:, 2], REACH))
    return out


@pytest.mark.engine("pybullet*")
def test_pybullet_shapes_are_the_scenes():
    """GEOM_CAPSULE and GEOM_CYLINDER with (height, radius) = (2 h, r); the hull's corners
    its own (getMeshData); every surface, mesh ground included, where the scene has it, to
    rounding (distances from points outside by Bullet's GJK against a small probe ball: a
    margin left on a hull or a triangle would put it 1 mm out)."""
    adapter_or_skip("pybullet")
    from adapters.pybullet_engine import p
    for ground_kind in ("plane", "mesh"):
        scene = _scene(ground_kind)
        with registry.get("pybullet").build(scene, Settings(dt=DT)) as sim:
            c = sim._client
            uid = {name: u for (u, _), name in sim._ids.items()}
            for name in uid:
                kind = scene.body(name).shape.kind
                if kind in ("capsule", "cylinder"):
                    (_, _, geom, dims, *_), = p.getCollisionShapeData(uid[name], -1, physicsClientId=c)
                    assert geom == (p.GEOM_CAPSULE if kind == "capsule" else p.GEOM_CYLINDER)
                    assert dims[:2] == pytest.approx((2 * H, R), abs=1e-15)
                if kind == "hull":
                    _, corners = p.getMeshData(uid[name], -1, physicsClientId=c)
                    assert sorted(corners) == sorted(BOX_CORNERS)
                if kind in PROBES:  # the scene's mass properties, not Bullet's from the shape
                    mass, _, inertia, *_ = p.getDynamicsInfo(uid[name], -1, physicsClientId=c)
                    assert (mass, *inertia) == pytest.approx((1.0, *scene.body(name).principal_inertia), rel=1e-15)
            rho = 0.01
            ball = p.createCollisionShape(p.GEOM_SPHERE, radius=rho, physicsClientId=c)
            for name, q, _, distance in _probes(scene):
                points = p.getClosestPoints(uid[name], -1, 1.0, collisionShapeB=ball,
                                            collisionShapePositionB=list(q), physicsClientId=c)
                assert min(pt[8] for pt in points) + rho == pytest.approx(distance, abs=1e-9), (name, q)


@pytest.mark.engine("mujoco*")
def test_mujoco_geoms_are_the_scenes():
    """MuJoCo's capsule and cylinder with size (r, h); the hull a mesh geom of its corners
    (world vertices the scene's, to float32: MuJoCo stores mesh vertices so); every surface,
    the mesh ground's triangle prisms included, where the scene has it (mj_ray from points
    outside); a mesh ground one prism geom a triangle."""
    adapter_or_skip("mujoco")
    import mujoco
    from cases.overlap import rotation_matrix
    for ground_kind in ("plane", "mesh"):
        scene = _scene(ground_kind)
        with registry.get("mujoco").build(scene, Settings(dt=DT)) as sim:
            m, d = sim._model, sim._data
            geom = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g): g for g in range(m.ngeom)}
            for body in scene.bodies:
                kind = body.shape.kind
                if kind in ("capsule", "cylinder"):
                    g = geom[body.name]
                    assert m.geom_type[g] == getattr(mujoco.mjtGeom, f"mjGEOM_{kind.upper()}")
                    assert m.geom_size[g][:2] == pytest.approx((R, H), abs=1e-15)
                    # the geom's z axis is the body's
                    assert d.geom_xmat[g].reshape(3, 3)[:, 2] == pytest.approx(
                        rotation_matrix(body.orientation)[:, 2], abs=1e-12)
                if kind == "hull":
                    g = geom[body.name]
                    mesh = m.geom_dataid[g]
                    local = m.mesh_vert[m.mesh_vertadr[mesh]:m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
                    world = local @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g]
                    expect = np.asarray(BOX_CORNERS) + body.position
                    assert sorted(map(tuple, np.round(world, 6))) == sorted(map(tuple, np.round(expect, 6)))
                if kind == "mesh":
                    assert sum(name.startswith(f"{body.name}#") for name in geom) == len(MESH.triangles)
                if kind in PROBES:  # the scene's mass properties, not MuJoCo's from the geom
                    b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body.name)
                    assert (m.body_mass[b], *m.body_inertia[b]) == pytest.approx((1.0, *body.principal_inertia),
                                                                                 rel=1e-15)
                    assert m.body_ipos[b] == pytest.approx((0, 0, 0), abs=0) and m.body_iquat[b][0] == 1.0
            hit = np.zeros(1, np.int32)
            for name, q, u, distance in _probes(scene):
                # float32 vertices of metres: 1e-7 m; the others are doubles
                got = mujoco.mj_ray(m, d, q, u, None, 1, -1, hit)
                assert got == pytest.approx(distance, abs=1e-6), (name, q)
                assert sim._names[hit[0]] == name


@pytest.mark.engine("dart")
def test_dart_shapes_are_the_scenes():
    """DART's CapsuleShape and CylinderShape with (radius, height) = (r, 2 h), each shape
    node where the body is with its z axis the body's; the hull and the mesh ground
    MeshShapes spanning the scene's corners (DART reads back no vertices, only the bounds);
    the scene's detector (ODE's for these shapes, module notes)."""
    adapter_or_skip("dart")
    from dartpy import dynamics as D
    from cases.overlap import rotation_matrix
    for ground_kind in ("plane", "mesh"):
        scene = _scene(ground_kind)
        with registry.get("dart").build(scene, Settings(dt=DT)) as sim:
            assert sim.knobs["World.setCollisionDetector"] == "ode"
            for node, name in sim._frames.items():
                body, shape = scene.body(name), node.getShape()
                T = node.getWorldTransform()
                if body.shape.kind != "plane":
                    assert T.translation() == pytest.approx(body.position, abs=1e-12)
                    assert T.rotation() == pytest.approx(rotation_matrix(body.orientation), abs=1e-12)
                if body.shape.kind in ("capsule", "cylinder"):
                    assert isinstance(shape, D.CapsuleShape if body.shape.kind == "capsule" else D.CylinderShape)
                    assert (shape.getRadius(), shape.getHeight()) == pytest.approx((R, 2 * H), abs=1e-15)
                if body.shape.kind in PROBES:  # the scene's mass properties, not DART's from the shape
                    inertia = node.getBodyNodePtr().getInertia()
                    assert inertia.getMass() == 1.0 and np.array_equal(inertia.getLocalCOM(), np.zeros(3))
                    assert inertia.getMoment() == pytest.approx(np.diag(body.principal_inertia), rel=1e-15, abs=0)
                if body.shape.kind in ("hull", "mesh"):
                    assert isinstance(shape, D.MeshShape)
                    points = np.asarray(body.shape.vertices, float)
                    box = shape.getBoundingBox()  # float32 in assimp
                    assert box.getMin() == pytest.approx(points.min(axis=0), abs=1e-7)
                    assert box.getMax() == pytest.approx(points.max(axis=0), abs=1e-7)


@pytest.mark.engine("drake*")
@pytest.mark.parametrize("engine", ["drake-sap", "drake"])  # point and hydroelastic contact
def test_drake_geometry_is_the_scenes(engine):
    """Drake's Capsule and Cylinder with (radius, length) = (r, 2 h) (a capsule's length is
    its cylinder's), their surfaces where the scene has them (signed distances from points
    outside); the hull a Convex whose hull is the scene's corners; the mesh ground triangle
    prisms under point contact (each a Convex of the triangle and its copy behind it) and
    under hydroelastic contact a rigid Mesh of the scene's triangles, each where the body is."""
    adapter_or_skip(engine)
    from adapters.solids import triangle_prisms
    for ground_kind in ("plane", "mesh"):
        scene = _scene(ground_kind)
        with registry.get(engine).build(scene, Settings(dt=DT)) as sim:
            query = sim._plant.get_geometry_query_input_port().Eval(sim._context)
            inspector = query.inspector()
            ids = [g for g in inspector.GetAllGeometryIds() if g.get_value() in sim._geometry_name]
            for gid in ids:
                body = scene.body(sim._geometry_name[gid.get_value()])
                shape, X = inspector.GetShape(gid), query.GetPoseInWorld(gid)
                if body.shape.kind != "plane":
                    assert X.translation() == pytest.approx(body.position, abs=1e-12)
                kind = body.shape.kind
                if kind in ("capsule", "cylinder"):
                    assert type(shape).__name__ == kind.capitalize()
                    assert (shape.radius(), shape.length()) == pytest.approx((R, 2 * H), abs=1e-15)
                if kind in PROBES:  # the scene's mass properties, not Drake's from the shape
                    spatial = sim._plant.GetBodyByName(body.name).default_spatial_inertia()
                    assert spatial.get_mass() == 1.0 and np.array_equal(spatial.get_com(), np.zeros(3))
                    assert spatial.CalcRotationalInertia().CopyToFullMatrix3() == pytest.approx(
                        np.diag(body.principal_inertia), rel=1e-15, abs=0)
                if kind == "hull":
                    hull = shape.GetConvexHull()
                    corners = [tuple(np.round(hull.vertex(i), 12)) for i in range(hull.num_vertices())]
                    assert sorted(corners) == sorted(BOX_CORNERS)
                if kind == "mesh" and sim._hydro:
                    mesh = inspector.maybe_get_hydroelastic_mesh(gid)
                    assert np.asarray([mesh.vertex(i) for i in range(mesh.num_vertices())]) == pytest.approx(
                        np.asarray(MESH.vertices, float))
                    assert mesh.num_triangles() == len(MESH.triangles)
                elif kind == "mesh":
                    k = int(inspector.GetName(gid).rsplit("#", 1)[1])
                    expect = triangle_prisms(MESH.vertices, MESH.triangles)[0][k]
                    hull = shape.GetConvexHull()
                    got = sorted(tuple(np.round(hull.vertex(i), 9)) for i in range(hull.num_vertices()))
                    assert got == sorted(tuple(np.round(v, 9)) for v in expect)
            if ground_kind == "mesh" and not sim._hydro:
                assert len(ids) == len(MESH.triangles) + 3
            for name, q, _, distance in _probes(scene):
                if scene.body(name).shape.kind in ("capsule", "cylinder"):
                    near = [s for s in query.ComputeSignedDistanceToPoint(q, 1.0)
                            if sim._geometry_name.get(s.id_G.get_value()) == name]
                    assert near[0].distance == pytest.approx(distance, abs=1e-12), (name, q)


# --- the solids made for engines without the shape (adapters/solids.py) ---------------------

def test_triangle_prisms_fill_a_closed_convex_mesh_and_reach_behind_an_open_one():
    """A box given as a closed triangle mesh: every prism's corners lie in the box (a prism
    reaching out of the solid would be a phantom obstacle), each as deep as the box behind
    its face or PRISM_DEPTH, the less; an open ground: its prisms PRISM_DEPTH deep, their tops
    the triangles."""
    from adapters.solids import PRISM_DEPTH, triangle_prisms
    half = np.array([0.3, 0.2, 0.02])  # 4 cm thick: its top and bottom prisms are capped
    hull = Hull(tuple(map(tuple, np.asarray(BOX_CORNERS) / HALF * half)))
    prisms, depths = triangle_prisms(hull.vertices, hull.faces)
    for prism, depth in zip(prisms, depths):
        assert np.all(np.abs(prism) <= half + 1e-12)
        axis = int(np.argmax(np.abs(prism[3] - prism[0])))  # the face's normal
        assert depth == pytest.approx(min(PRISM_DEPTH, 2 * half[axis]), rel=1e-12)  # at most face to face
    prisms, depths = triangle_prisms(MESH.vertices, MESH.triangles)
    assert depths == [PRISM_DEPTH] * len(MESH.triangles)
    for prism, tri in zip(prisms, MESH.triangles):
        assert np.array_equal(prism[:3], np.asarray(MESH.vertices, float)[list(tri)])


def test_a_polygons_prism_is_closed_and_wound_outward():
    """Its volume by the divergence theorem over its faces is the polygon's area times its
    depth, which only a closed surface wound outward gives."""
    from adapters.solids import polygon_prism
    corners = Polygon(tuple((0.1 * math.cos(2 * math.pi * k / 7), 0.1 * math.sin(2 * math.pi * k / 7))
                            for k in range(7)))
    points, tri = polygon_prism(corners.corners, 0.05)
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
    assert volume == pytest.approx(corners.mass_properties[0] * 0.1, rel=1e-12)
    assert len(tri) == 4 * 7 - 4
