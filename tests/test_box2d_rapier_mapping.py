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
from tests.shape_helpers import ON_ITS_SIDE, assert_same_points, landing, regular_polygon, settle

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
