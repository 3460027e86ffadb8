"""What the Box2D and Rapier adapters derive: per-shape materials that reproduce every pair
under the engine's own mixing rule, the contact geometry and force split of the Box2D
read-out, the Box2D angle convention, Rapier's planar locking, the options, and the shapes
of the vocabulary as the engines' own (Box2D's polygons; Rapier's capsules, cylinders,
convex polyhedra and triangle meshes).

Each test skips cleanly when its engine's package is missing."""
from __future__ import annotations

import math

import numpy as np
import pytest

from adapters.base import Settings, SettingsError
from cases.scene import (Body, Capsule, Cylinder, Hull, Material, Mesh, Polygon, Rect, Scene, ball, cube, ground,
                         principal_frame, quat_about_y)
from tests.shape_helpers import ON_ITS_SIDE, assert_rests, assert_same_points, landing, regular_polygon, settle

G = 9.81


def _two_bodies(dim: int, pairs=()) -> Scene:
    """A ground and two bodies (a ball, a box) with per-pair materials."""
    return Scene(bodies=(ground(), Body("a", ball(0.1, dim), mass=1.0, position=(0, 0, 0.1)),
                         Body("b", cube(0.1, dim), mass=2.0, position=(0.5, 0, 0.1))),
                 gravity=(0, 0, -G), material=Material(e=0.3, mu_s=0.4), pairs=pairs, dimension=dim)


SCENES = {
    "uniform": lambda dim: _two_bodies(dim),
    # each body its own value against the ground, the a-b pair what max(e) and
    # sqrt(mu mu) (Box2D) or the product of mu (Rapier) make of them
    "per-body": lambda dim: _two_bodies(dim, pairs=(("ground", "a", Material(e=0.5, mu_s=0.2)),
                                                    ("ground", "b", Material(e=0.1, mu_s=0.7)),
                                                    ("a", "b", Material(e=0.5, mu_s=0.14)))),
}


# --- Box2D ---------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def box2d():
    pytest.importorskip("pyb2d3")
    from adapters import box2d_engine
    return box2d_engine


@pytest.mark.engine("box2d")
@pytest.mark.parametrize("name", SCENES)
def test_box2d_shape_materials_reproduce_every_pair_under_its_mixing(box2d, name):
    """Box2D mixes sqrt(mu_a mu_b) and max(e_a, e_b) (b2DefaultWorldDef's callbacks)."""
    scene = SCENES[name](2)
    mu, e = box2d._materials(scene)
    for a, b in scene.contact_pairs():
        m = scene.material_of(a.name, b.name)
        assert math.sqrt(mu[a.name] * mu[b.name]) == pytest.approx(m.mu_s, rel=1e-12)
        assert max(e[a.name], e[b.name]) == pytest.approx(m.e, rel=1e-12)


@pytest.mark.engine("box2d")
def test_box2d_pairs_no_shape_values_reproduce_are_unsupported(box2d):
    """max(e_a, e_b) cannot give a-b 0.2 when the bodies take 0.5 and 0.1 from the ground."""
    from adapters.base import Unsupported
    scene = _two_bodies(2, pairs=(("ground", "a", Material(e=0.5)), ("ground", "b", Material(e=0.1)),
                                  ("a", "b", Material(e=0.2))))
    with pytest.raises(Unsupported, match="restitution"):
        box2d.Box2DAdapter().build(scene, Settings(dt=1e-3))


@pytest.mark.engine("box2d")
def test_box2d_materials_act_in_the_engine(box2d):
    """The mixed friction is the pair's: a square sliding at 1 m/s on the ground with the
    pair's mu = 0.7 (shape values 1 and 0.49) decelerates at mu g."""
    scene = Scene(bodies=(ground(), Body("box", cube(0.1, 2), mass=1.0, position=(0, 0, 0.1),
                                         velocity=(2.0, 0, 0), rotates=False)),
                  gravity=(0, 0, -G), material=Material(mu_s=0.7), dimension=2)
    sim = box2d.Box2DAdapter().build(scene, Settings(dt=1e-3))
    for _ in range(100):
        sim.step()
    v = sim.states()["box"][7]
    assert (2.0 - v) / 0.1 == pytest.approx(0.7 * G, rel=1e-4)  # float32 engine


@pytest.mark.engine("box2d")
def test_box2d_angle_round_trip(box2d):
    """A square turned by phi about scene +y reads back turned by phi (Box2D angle -phi),
    to float32 and without b2MakeRot's polynomial approximation (1e-3 rad)."""
    phi = 0.3
    scene = Scene(bodies=(Body("box", cube(0.1, 2), mass=1.0, orientation=quat_about_y(phi),
                               angular_velocity=(0, 2.0, 0)),), gravity=(0, 0, 0), dimension=2)
    sim = box2d.Box2DAdapter().build(scene, Settings(dt=1e-3))
    row = sim.states()["box"]
    assert np.allclose(row[3:7], quat_about_y(phi), atol=1e-7)
    assert row[11] == pytest.approx(2.0, rel=1e-7)
    assert sim.knobs["bodies"]["box"]["rotational_inertia"] == pytest.approx(2 * 0.1**2 / 3, rel=1e-7)


@pytest.mark.engine("box2d")
@pytest.mark.parametrize("dz, expected_gap", [(0.0, 0.0), (0.01, 0.01), (-0.002, -0.002)])
def test_box2d_gaps_and_normals(box2d, dz, expected_gap):
    """Signed distance and normal (from b into a) of circle/plane, square/plane,
    circle/square and square/square pairs, for touching, apart and overlapping poses."""
    r, h = 0.1, 0.1
    scene = Scene(bodies=(ground(), Body("c", ball(r, 2), mass=1.0, position=(0, 0, r + dz)),
                          Body("s", cube(h, 2), mass=1.0, position=(1.0, 0, h + dz)),
                          Body("t", cube(h, 2), mass=1.0, position=(1.0, 0, 3 * h + 2 * dz)),
                          Body("d", ball(r, 2), mass=1.0, position=(1.0 + h + r + dz, 0, h))),
                  gravity=(0, 0, 0), dimension=2, allowed_overlap=0.01)
    sim = box2d.Box2DAdapter().build(scene, Settings(dt=1e-3))
    for (a, b), normal in {("c", "ground"): (0, 1), ("ground", "c"): (0, -1), ("s", "ground"): (0, 1),
                           ("t", "s"): (0, 1), ("d", "s"): (1, 0), ("s", "d"): (-1, 0)}.items():
        gap, n = sim._gap(a, b)
        assert gap == pytest.approx(expected_gap, abs=1e-6)  # float32 poses
        assert np.allclose(n, normal, atol=1e-6)


@pytest.mark.engine("box2d")
def test_box2d_force_split_drops_speculative_cycle_closers(box2d):
    """Three millimetre squares stacked: the upper two also touch the ground speculatively
    (Box2D's contacts reach 2 cm); those pairs, 1 and 2 mm apart, close cycles and carry
    nothing, so the ground carries the whole weight and each interface the weight above."""
    half, mass = 0.5e-3, 1e-3
    boxes = tuple(Body(f"box{k}", cube(half, 2), mass=mass, position=(0, 0, half + 2 * half * k))
                  for k in range(3))
    scene = Scene(bodies=(ground(),) + boxes, gravity=(0, 0, -G), material=Material(mu_s=0.5), dimension=2)
    sim = box2d.Box2DAdapter().build(scene, Settings(dt=1e-3))
    pairs = [("box0", "ground"), ("box0", "box1"), ("box1", "box2"), ("box1", "ground"), ("box2", "ground")]
    f = np.zeros(len(pairs))
    for k in range(400):
        sim.step()
        if k >= 200:  # the mean over 0.2 s: a resting box's velocity jitters 2e-5 m/s step to step
            f += [sim.contact_forces().get(p, 0.0) / 200 for p in pairs]
    assert sim._touching >= set(pairs)  # the speculative pairs are Box2D contacts
    assert f[:3] == pytest.approx([3 * mass * G, 2 * mass * G, mass * G], rel=1e-3)
    assert f[3] == 0.0 and f[4] == 0.0


@pytest.mark.engine("box2d")
def test_box2d_stiffness_is_the_cap_and_options_are_checked(box2d):
    adapter = box2d.Box2DAdapter()
    scene = SCENES["uniform"](2)
    sim = adapter.build(scene, Settings(dt=1e-3, iterations=8))
    assert sim.knobs["contact_hertz"] == pytest.approx(0.125 * 8 / 1e-3)
    assert sim.knobs["sub_step_count"] == 8
    soft = adapter.build(scene, Settings(dt=1e-3, options={"contact_hertz": 30.0}))
    assert soft.knobs["contact_hertz"] == 30.0
    with pytest.raises(SettingsError, match="understands"):
        adapter.build(scene, Settings(dt=1e-3, options={"contact_stiffness": 1.0}))
    with pytest.raises(SettingsError, match="contact_push_speed"):
        adapter.build(scene, Settings(dt=1e-3, options={"contact_push_speed": -1.0}))


@pytest.mark.engine("box2d")
def test_box2d_polygon_is_its_corners_with_no_rounding(box2d):
    """A pentagon's Box2D polygon has the scene's corners in the body frame (float32), radius
    0, and the scene's mass and inertia; the contact geometry's outline is the same polygon."""
    corners = regular_polygon(5, 0.1)
    body = Body("p", Polygon(corners), mass=2.0, position=(0.0, 0.0, 0.5))
    scene = Scene(bodies=(ground(), body), gravity=(0, 0, 0), dimension=2)
    sim = box2d.Box2DAdapter().build(scene, Settings(dt=1e-3))
    shape = sim._bodies["p"].shapes[0]
    polygon = shape.polygon
    assert polygon.radius == 0.0
    built = np.asarray(polygon.vertices[:polygon.count], float)
    assert_same_points(built, body.shape.corners, 1e-7)  # float32 at 0.1 m: 7e-9
    assert sim._bodies["p"].mass == pytest.approx(2.0, rel=1e-7)
    assert sim._bodies["p"].rotational_inertia() == pytest.approx(body.principal_inertia[1], rel=1e-6)
    assert sim.knobs["bodies"]["p"]["polygon"]["radius"] == 0.0
    assert sim._outlines["p"][0] == tuple(map(tuple, body.shape.corners))


@pytest.mark.engine("box2d")
def test_box2d_pentagon_rests_on_a_face_at_its_apothem(box2d):
    """A regular pentagon (circumradius 0.1 m, 2 kg) placed on a face settles at the apothem
    R cos(pi/5) above the ground (its centroid, the body frame's origin) and the ground
    carries its weight. Tolerances: the rigid-limit push-out leaves g / (2 pi 1 kHz)^2 =
    0.25 um of overlap and float32 places 0.08 m to 7e-9 m: 1e-6 m; the momentum read-out
    is exact to float32 velocities: 1e-5 of the weight."""
    r = 0.1
    apothem = r * math.cos(math.pi / 5)
    body = Body("p", Polygon(regular_polygon(5, r)), mass=2.0, position=(0.0, 0.0, apothem))
    state, force = settle(box2d.Box2DAdapter(), body, 300, dimension=2)
    assert state[2] == pytest.approx(apothem, abs=1e-6)
    assert force == pytest.approx(2.0 * G, rel=1e-5)


@pytest.mark.engine("box2d")
def test_box2d_square_polygon_lands_as_the_rect(box2d):
    """A square given as a Polygon and as a Rect, dropped tilted and sliding: the same Box2D
    polygon (b2ComputeHull keeps b2MakeBox's corners and order), so the same trajectory to
    float32 round-off (measured: bit for bit)."""
    a = 0.1
    square = Polygon(((-a, -a), (a, -a), (a, a), (-a, a)))
    as_polygon, as_rect = (landing(box2d.Box2DAdapter(), shape, 2) for shape in (square, Rect((a, a))))
    assert np.abs(as_polygon - as_rect).max() < 1e-6


@pytest.mark.engine("box2d")
def test_box2d_polygons_it_cannot_hold_are_unsupported(box2d):
    """Nine corners (B2_MAX_POLYGON_VERTICES is 8) and a square with a corner cut 1 cm deep
    (two corners 1.4 cm apart: b2ComputeHull welds corners closer than 2 cm) are unsupported,
    said before any world is made."""
    from adapters.base import Unsupported
    nine = Polygon(regular_polygon(9, 0.1))
    a, cut = 0.1, 0.01
    points, _, _ = principal_frame([(-a, -a), (a, -a), (a, a - cut), (a - cut, a), (-a, a)])
    for shape, why in ((nine, "at most 8"), (Polygon(points), "keeps 4 of its 5 corners")):
        scene = Scene(bodies=(ground(), Body("p", shape, mass=1.0, position=(0, 0, 1.0))), dimension=2)
        with pytest.raises(Unsupported, match=why):
            box2d.Box2DAdapter().build(scene, Settings(dt=1e-3))


# --- Rapier --------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def rapier():
    pytest.importorskip("rapier3d")
    from adapters import rapier_engine
    return rapier_engine


@pytest.mark.engine("rapier")
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("name", SCENES)
def test_rapier_collider_materials_reproduce_every_pair_under_the_chosen_rule(rapier, name, dim):
    """One rule for every collider (the pair takes it), values that give each pair its own."""
    from adapters.combination import RULES
    scene = SCENES[name](dim)
    for value_of in (lambda m: m.mu_s, lambda m: m.e):
        rule, v = rapier.combine_rule(scene, value_of, "value")
        for a, b in scene.contact_pairs():
            assert RULES[rule](v[a.name], v[b.name]) == pytest.approx(value_of(scene.material_of(a.name, b.name)),
                                                                      rel=1e-12)


@pytest.mark.engine("rapier")
@pytest.mark.parametrize("dim", [2, 3])
def test_rapier_friction_acts_in_the_plane(rapier, dim):
    """A box sliding at 2 m/s with mu = 0.5 decelerates at mu g, in 3D and in a 2D scene
    (rotations about x and z locked; locking the y translation too makes Rapier drop
    friction altogether), and a 2D body stays in the x-z plane."""
    scene = Scene(bodies=(ground(), Body("box", cube(0.1, dim), mass=1.0, position=(0, 0, 0.1),
                                         velocity=(2.0, 0, 0))),
                  gravity=(0, 0, -G), material=Material(mu_s=0.5), dimension=dim)
    sim = rapier.RapierAdapter().build(scene, Settings(dt=1e-3))
    for _ in range(100):
        sim.step()
    row = sim.states()["box"]
    assert (2.0 - row[7]) / 0.1 == pytest.approx(0.5 * G, rel=1e-3)
    if dim == 2:
        assert abs(row[1]) < 1e-6 and abs(row[8]) < 1e-6


@pytest.mark.engine("rapier")
def test_rapier_resting_force_and_options(rapier):
    scene = Scene(bodies=(ground(), Body("box", cube(0.1, 3), mass=2.0, position=(0, 0, 0.1))),
                  gravity=(0, 0, -G), material=Material(mu_s=0.5), dimension=3)
    adapter = rapier.RapierAdapter()
    sim = adapter.build(scene, Settings(dt=1e-3))
    for _ in range(200):
        sim.step()
    assert sim.contact_forces()[("box", "ground")] == pytest.approx(2.0 * G, rel=1e-4)
    assert sim.knobs["contact_softness"]["natural_frequency"] == pytest.approx(0.125 * 4 / 1e-3)
    with pytest.raises(SettingsError, match="understands"):
        adapter.build(scene, Settings(dt=1e-3, options={"contact_hertz": 30.0}))


def _rapier_colliders(sim) -> dict:
    """The built colliders by body name."""
    return {sim._collider_of[h.index]: c for h, c in sim._world.colliders}


def _rapier_inertia(rigid_body) -> np.ndarray:
    """A body's inertia tensor in its own frame, from Rapier's principal moments and frame."""
    mp = rigid_body.mass_properties
    frame = np.asarray(mp.principal_inertia_local_frame.to_matrix(), float).reshape(3, 3)  # row-major
    return frame @ np.diag(mp.principal_inertia.to_tuple()) @ frame.T


@pytest.mark.engine("rapier")
def test_rapier_shapes_are_built_as_the_scene_gives_them(rapier):
    """The capsule's segment lies on body z; the cylinder's axis (Rapier's y) is turned onto
    body z; a hull is the convex polyhedron of the scene's corners; the mesh has the scene's
    vertices and triangles and ghost-edge fixing; each dynamic body has the scene's mass and
    inertia tensor in its body frame, the cylinder's unequal moments included (its collider
    is turned). float32: 1e-7 relative."""
    r, h = 0.05, 0.1
    corners = ((-0.1, -0.1, -0.1), (0.1, -0.1, -0.1), (-0.1, 0.1, -0.1), (0.1, 0.1, -0.1),
               (-0.1, -0.1, 0.1), (0.1, -0.1, 0.1), (-0.1, 0.1, 0.1), (0.1, 0.1, 0.1))
    mesh = Mesh(((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)), ((0, 1, 2), (0, 2, 3)))
    bodies = (Body("mesh", mesh, static=True),
              Body("capsule", Capsule(r, h), mass=2.0, position=(0, 0, 1)),
              Body("cylinder", Cylinder(r, h), mass=3.0, inertia=(0.01, 0.02, 0.03), position=(1, 0, 1)),
              Body("hull", Hull(corners), mass=4.0, position=(2, 0, 1)))
    sim = rapier.RapierAdapter().build(Scene(bodies=bodies, gravity=(0, 0, 0)), Settings(dt=1e-3))
    built = _rapier_colliders(sim)
    capsule = built["capsule"].shape.as_capsule()
    assert capsule.a.to_tuple() == pytest.approx((0, 0, -h), abs=1e-8)
    assert capsule.b.to_tuple() == pytest.approx((0, 0, h), abs=1e-8)
    assert capsule.radius == pytest.approx(r, rel=1e-7)
    cylinder = built["cylinder"]
    assert (cylinder.shape.as_cylinder().half_height, cylinder.shape.as_cylinder().radius) == \
        (pytest.approx(h, rel=1e-7), pytest.approx(r, rel=1e-7))
    axis = cylinder.rotation_wrt_parent.transform_vector((0.0, 1.0, 0.0)).to_tuple()
    assert axis == pytest.approx((0, 0, 1), abs=3e-7)  # a float32 quaternion turns it to a few 2^-23
    assert_same_points(built["hull"].shape.as_convex_polyhedron().points, corners, 1e-8)
    trimesh = built["mesh"].shape.as_trimesh()
    assert np.array_equal(trimesh.vertices, np.asarray(mesh.vertices, np.float32))
    assert np.array_equal(trimesh.indices, np.asarray(mesh.triangles))
    assert trimesh.flags.contains(rapier.r.TriMeshFlags.FIX_INTERNAL_EDGES)
    for body in bodies[1:]:
        rb = sim._world.rigid_bodies[sim._handles[body.name]]
        assert rb.mass == pytest.approx(body.mass, rel=1e-7)
        assert rb.local_center_of_mass.to_tuple() == (0.0, 0.0, 0.0)
        assert np.allclose(_rapier_inertia(rb), np.diag(body.principal_inertia), rtol=1e-6, atol=1e-9)


@pytest.mark.engine("rapier")
@pytest.mark.parametrize("shape, orientation, height", [
    (Capsule(0.05, 0.1), ON_ITS_SIDE, 0.05),
    (Cylinder(0.05, 0.1), ON_ITS_SIDE, 0.05),
    (Cylinder(0.05, 0.1), (1.0, 0.0, 0.0, 0.0), 0.1)], ids=["capsule on its side", "cylinder on its side",
                                                           "cylinder on an end"])
def test_rapier_capsule_and_cylinder_rest_at_their_height_with_their_weight(rapier, shape, orientation, height):
    """Placed on the ground, a capsule or cylinder on its side (axis along x) rests at its
    radius, a cylinder on an end at h, still, and the ground carries the weight (2 kg).
    Tolerances: the stiffest push-out Rapier is asked for (2 x 500 Hz against the ground)
    leaves g / (2 pi 1 kHz)^2 = 0.25 um of overlap, float32 places 0.1 m to 1e-8 m: 1e-6 m;
    the summed normal impulses balance gravity to float32: 1e-5 of the weight."""
    assert_rests(rapier.RapierAdapter(), shape, orientation, height)


@pytest.mark.engine("rapier")
def test_rapier_box_as_a_hull_and_square_as_a_polygon_land_as_the_primitives(rapier):
    """A cube given as a Hull (3D) and a square as a Polygon (2D, the hull of its prism along
    y), dropped tilted and sliding, follow the cuboid's trajectory to float32 (1e-6) through
    the corner impact, the bounce, the flat landing and the slide (measured: bit for bit;
    the cube's moments, equal but for the last bit, leave the gyroscopic term off as the
    Box's do: EQUAL_MOMENTS)."""
    a = 0.1
    for shape, twin, dim in ((Hull(tuple((x, y, z) for x in (-a, a) for y in (-a, a) for z in (-a, a))),
                              cube(a, 3), 3),
                             (Polygon(((-a, -a), (a, -a), (a, a), (-a, a))), Rect((a, a)), 2)):
        given, primitive = (landing(rapier.RapierAdapter(), s, dim) for s in (shape, twin))
        assert np.abs(given - primitive).max() < 1e-6


@pytest.mark.engine("rapier")
def test_rapier_mesh_ground_holds_like_the_plane(rapier):
    """A box resting on a mesh ground of two triangles (wound counterclockwise from above)
    rests at its half-extent with its weight on the mesh (the pair's total normal impulse:
    a trimesh's points read 0 in the bindings); one sliding at 3.2 m/s with mu = 0.2 across
    a 20 x 20 grid mesh (800 triangles, shared edges every 0.5 m) decelerates at mu g and
    stays on the surface (without FIX_INTERNAL_EDGES it lost 0.85 m/s more in 0.5 s on the
    edges; measured)."""
    a, size = 0.1, 5.0
    flat = Body("mesh", Mesh(((-size, -size, 0), (size, -size, 0), (size, size, 0), (-size, size, 0)),
                             ((0, 1, 2), (0, 2, 3))), static=True)
    state, force = settle(rapier.RapierAdapter(), Body("box", cube(a, 3), mass=1.0, position=(0.3, 0.2, a)), 200,
                          ground_body=flat)
    assert state[2] == pytest.approx(a, abs=1e-6)
    assert force == pytest.approx(G, rel=1e-5)
    n = 20
    xs = np.linspace(-size, size, n + 1)
    vertices = tuple((x, y, 0.0) for y in xs for x in xs)
    cells = [(j * (n + 1) + i) for j in range(n) for i in range(n)]
    triangles = tuple(t for k in cells for t in ((k, k + 1, k + n + 2), (k, k + n + 2, k + n + 1)))
    grid = Body("mesh", Mesh(vertices, triangles), static=True)
    sliding = Body("box", cube(a, 3), mass=1.0, position=(0.3, 0.2, a), velocity=(3.0, 1.0, 0.0), rotates=False)
    scene = Scene(bodies=(grid, sliding), gravity=(0, 0, -G), material=Material(mu_s=0.2))
    with rapier.RapierAdapter().build(scene, Settings(dt=1e-3)) as sim:
        heights = []
        for _ in range(500):
            sim.step()
            heights.append(sim.states()["box"][2])
        v = sim.states()["box"][7:9]
    assert np.hypot(*v) == pytest.approx(math.hypot(3.0, 1.0) - 0.2 * G * 0.5, rel=1e-4)  # float32
    assert np.ptp(heights) < 1e-6


@pytest.mark.engine("rapier")
def test_rapier_keeps_a_thin_hull(rapier):
    """A 1 m square plate 1e-5 m thick keeps its 8 corners (a convex mesh of the scene's
    faces; Rapier's own convex_hull flattens plates thinner than 8.5e-4 of their size in
    float32, measured) and rests on the ground at its half thickness."""
    t = 1e-5
    plate = Hull(tuple((x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-t / 2, t / 2)))
    state, force = settle(rapier.RapierAdapter(), Body("plate", plate, mass=1.0, position=(0, 0, t / 2)), 100)
    assert state[2] == pytest.approx(t / 2, abs=1e-6)
    assert force == pytest.approx(G, rel=1e-5)
