"""What the Box3D adapter derives (adapters/box3d_engine.py): every pair's own materials
through Box3D's mixing callbacks, the stated inertia from the first step on, contact forces
from the bodies' momenta, the 2D scenes on motion locks, and the shapes of the vocabulary
as Box3D's own (capsules; hulls for hulls, cylinders and polygons; static meshes).

Each test skips cleanly when robox3d is missing."""
from __future__ import annotations

import numpy as np
import pytest

from adapters.base import Settings
from cases.scene import Body, Box, Capsule, Cylinder, Hull, Material, Mesh, Polygon, Rect, Scene, ball, cube, ground
from tests.shape_helpers import ON_ITS_SIDE, assert_rests, assert_same_points, landing, settle

G = 9.81


@pytest.fixture(scope="module")
def box3d():
    pytest.importorskip("robox3d")
    from adapters import box3d_engine
    return box3d_engine


def _run(sim, steps: int):
    for _ in range(steps):
        sim.step()
    return sim.states()


@pytest.mark.engine("box3d")
@pytest.mark.parametrize("dim", (3, 2))
def test_box3d_every_pair_bounces_with_its_own_e(box3d, dim):
    """Two balls dropped side by side with e = 0.5 and 0.9 against the ground and 0 between
    them (no per-body rule reproduces that table; the callbacks return each pair's value):
    each leaves the ground at exactly e times its approach (float32 velocities)."""
    a = Body("a", ball(0.1, dim), mass=1.0, position=(0, 0, 0.2))
    b = Body("b", ball(0.1, dim), mass=2.0, position=(1.0, 0, 0.2))
    scene = Scene(bodies=(ground(), a, b), gravity=(0, 0, -G), dimension=dim,
                  pairs=(("ground", "a", Material(e=0.5)), ("ground", "b", Material(e=0.9)),
                         ("a", "b", Material(e=0.0))))
    sim = box3d.Box3DAdapter().build(scene, Settings(dt=1e-3))
    vz = {"a": [], "b": []}
    for _ in range(300):
        sim.step()
        s = sim.states()
        for n in vz:
            vz[n].append(s[n][9])
    for name, e in (("a", 0.5), ("b", 0.9)):
        v = np.array(vz[name])
        k = int(np.argmax(v > 0))  # the step of the bounce
        assert -v[k] / v[k - 1] == pytest.approx(e, abs=1e-6)


@pytest.mark.engine("box3d")
def test_box3d_stated_inertia_acts_from_the_first_step(box3d):
    """A 1 kg ball (I = 2/5 m r^2) created sliding at 2 m/s on the ground with mu = 0.2
    spins up at mu g m r / I in its first step too (b3Body_SetMassData alone leaves the
    shapes' density inertia for that step: 8.8 rad/s instead of 0.049)."""
    r, mu = 0.1, 0.2
    scene = Scene(bodies=(ground(), Body("ball", ball(r, 3), mass=1.0, position=(0, 0, r), velocity=(2.0, 0, 0))),
                  gravity=(0, 0, -G), material=Material(mu_s=mu))
    sim = box3d.Box3DAdapter().build(scene, Settings(dt=1e-3))
    w = _run(sim, 1)["ball"][11]
    assert w == pytest.approx(mu * G * r / (0.4 * r * r) * 1e-3, rel=1e-3)


@pytest.mark.engine("box3d")
def test_box3d_stack_forces_are_the_weights_above(box3d):
    """A resting stack of three boxes: each interface carries the weight above it, to
    float32 round-off, step by step once settled (the momentum read-out; the contact
    points' last sub-step impulses read 1-2 % heavy)."""
    boxes = tuple(Body(f"box{k}", cube(0.1, 3), mass=1.0, position=(0, 0, 0.1 + 0.2 * k)) for k in range(3))
    scene = Scene(bodies=(ground(),) + boxes, gravity=(0, 0, -G), material=Material(mu_s=0.5))
    sim = box3d.Box3DAdapter().build(scene, Settings(dt=1e-3))
    _run(sim, 500)
    below = {("box0", "ground"): 3, ("box0", "box1"): 2, ("box1", "box2"): 1}
    forces = {k: [] for k in below}
    for _ in range(200):
        sim.step()
        f = sim.contact_forces()
        for k in below:
            forces[k].append(f[k])
    for k, n in below.items():
        assert np.mean(forces[k]) == pytest.approx(n * G, rel=1e-4)


@pytest.mark.engine("box3d")
def test_box3d_a_pressing_load_is_in_the_contact_force_not_the_read_out(box3d):
    """A resting box pressed down by a constant load of 5 N (applied before each step,
    Box3D clears it after): the ground carries m g + 5 N, to float32 round-off; the
    momentum read-out takes the load's velocity change out with gravity's."""
    from cases.scene import Load
    box = Body("box", cube(0.1, 3), mass=1.0, position=(0, 0, 0.1))
    scene = Scene(bodies=(ground(), box), gravity=(0, 0, -G), material=Material(mu_s=0.5),
                  loads=(Load("box", force=(0.0, 0.0, -5.0)),))
    sim = box3d.Box3DAdapter().build(scene, Settings(dt=1e-3))
    assert "load" in sim.effects
    _run(sim, 300)
    forces = []
    for _ in range(100):
        sim.step()
        forces.append(sim.contact_forces()[("box", "ground")])
    assert np.mean(forces) == pytest.approx(G + 5.0, rel=1e-4)


@pytest.mark.engine("box3d")
@pytest.mark.parametrize("axis", [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (1.0, 0.0, 0.0)])
def test_box3d_a_slider_moves_along_its_axis(box3d, axis):
    """A block on a prismatic joint to the world under gravity slides along the scene's axis
    at g a_z (Box3D slides along its frames' x: the adapter puts x on the axis): after 200
    steps of 1 ms it is s = g a_z t^2 / 2 (+ the semi-implicit sub-steps' g a_z t h / 2, h =
    dt / sub-steps) along it, to 1e-4 m: Box3D's soft joint sags 6.8e-5 m across a horizontal
    axis under the block's weight (measured); the wrong axis misses by centimetres."""
    from cases.scene import Joint
    a = np.asarray(axis) / np.linalg.norm(axis)
    block = Body("block", cube(0.05, 3), mass=0.5, position=(0.0, 0.0, 1.0))
    scene = Scene(bodies=(block,), gravity=(0, 0, -G),
                  joints=(Joint("prismatic", "block", None, anchor=(0.0, 0.0, 1.0), axis=axis),))
    sim = box3d.Box3DAdapter().build(scene, Settings(dt=1e-3))
    x = _run(sim, 200)["block"][:3] - [0.0, 0.0, 1.0]
    t, h = 0.2, 1e-3 / sim.iterations
    s = -G * a[2] * (t * t / 2 + t * h / 2)
    np.testing.assert_allclose(x, s * a, rtol=0, atol=1e-4)


@pytest.mark.engine("box3d")
def test_box3d_2d_bodies_stay_in_their_plane(box3d):
    """A tilted square landing and sliding in a 2D scene (motion locks) moves only in x-z and turns only about y."""
    import math
    half = math.radians(10) / 2
    sq = Body("sq", cube(0.1, 2), mass=1.0, position=(0, 0, 0.3), velocity=(0.5, 0, 0),
              orientation=(math.cos(half), 0.0, math.sin(half), 0.0))
    scene = Scene(bodies=(ground(), sq), gravity=(0, 0, -G), material=Material(mu_s=0.5, e=0.3), dimension=2)
    s = _run(box3d.Box3DAdapter().build(scene, Settings(dt=1e-3)), 400)["sq"]
    assert s[1] == 0.0 and s[8] == 0.0  # y, vy
    assert s[4] == 0.0 and s[6] == 0.0  # the quaternion turns about y only
    assert s[10] == 0.0 and s[12] == 0.0  # no spin about x or z


@pytest.mark.engine("box3d")
@pytest.mark.parametrize("e", (1.0, 0.5))
def test_box3d_touching_balls_land_one_impact_at_a_time(box3d, e):
    """The declared impact model, as measured (IMPACT_MODEL_MEASURED): a 0.1 kg ball resting
    on a 1 kg one (touching, no overlap), both landing at 2 m/s, gravity off. The landing
    step bounces the bottom ball alone; the next resolves the pair as an impact of its own:
    the sequential model's closed form (cases/column_impact.py), not the simultaneous
    one's (both at e V)."""
    from cases.column_impact import sequential_velocities
    assert box3d.Box3DAdapter.capabilities.impact_model == "sequential"
    v = 2.0
    bottom = Body("bottom", ball(0.1, 3), mass=1.0, position=(0, 0, 0.1), velocity=(0, 0, -v))
    top = Body("top", ball(0.1, 3), mass=0.1, position=(0, 0, 0.3), velocity=(0, 0, -v))
    scene = Scene(bodies=(ground(), bottom, top), gravity=(0, 0, 0), material=Material(e=e))
    s = _run(box3d.Box3DAdapter().build(scene, Settings(dt=1e-3)), 5)
    (v_top, v_bottom, _), _ = sequential_velocities([0.1, 1.0, float("inf")], [v, v, 0.0], e)
    # float32 velocities of a few m/s, three impacts: 1e-5 m/s
    assert s["top"][9] == pytest.approx(-v_top, abs=1e-5)
    assert s["bottom"][9] == pytest.approx(-v_bottom, abs=1e-5)


# --- the shapes of the vocabulary ------------------------------------------------------------

def _hull_points(box3d, sim, name: str) -> np.ndarray:
    """The corners of a body's Box3D hull, in its body frame (b3HullData keeps them at
    pointOffset bytes from its start)."""
    ffi, lib = box3d.ffi, box3d.lib
    hull = lib.b3Shape_GetHull(sim._shape_ids[name])
    points = ffi.cast("b3Vec3*", ffi.cast("char*", hull) + hull.pointOffset)
    return np.array([(points[i].x, points[i].y, points[i].z) for i in range(hull.vertexCount)])


def _corners(a: float, b: float, c: float):
    return tuple((x, y, z) for x in (-a, a) for y in (-b, b) for z in (-c, c))


@pytest.mark.engine("box3d")
def test_box3d_shapes_are_built_as_the_scene_gives_them(box3d):
    """The capsule's segment lies on body z with its radius; a hull keeps the scene's corners;
    a cylinder is the 42-sided prism inscribed in it (CYLINDER_SIDES, corners on its rim); a
    polygon the prism over its corners along y; the mesh has its triangles; every dynamic
    body the scene's mass and principal inertia (float32: 1e-7 relative)."""
    r, h = 0.05, 0.1
    wedge = Hull(((-0.1, -0.05, -0.05), (0.1, -0.05, -0.05), (-0.1, 0.05, -0.05), (0.1, 0.05, -0.05),
                  (-0.1, 0.0, 0.1), (0.1, 0.0, 0.1)))
    from cases.scene import principal_frame
    points, _, _ = principal_frame(wedge.vertices)
    wedge = Hull(points)
    mesh = Mesh(((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)), ((0, 1, 2), (0, 2, 3)))
    bodies = (Body("mesh", mesh, static=True),
              Body("capsule", Capsule(r, h), mass=2.0, position=(0, 0, 1)),
              Body("cylinder", Cylinder(r, h), mass=3.0, position=(1, 0, 1)),
              Body("wedge", wedge, mass=4.0, position=(2, 0, 1)))
    sim = box3d.Box3DAdapter().build(Scene(bodies=bodies, gravity=(0, 0, 0)), Settings(dt=1e-3))
    lib = box3d.lib
    capsule = lib.b3Shape_GetCapsule(sim._shape_ids["capsule"])
    assert (capsule.center1.x, capsule.center1.y, capsule.center1.z) == (0.0, 0.0, pytest.approx(-h, rel=1e-7))
    assert (capsule.center2.x, capsule.center2.y, capsule.center2.z) == (0.0, 0.0, pytest.approx(h, rel=1e-7))
    assert capsule.radius == pytest.approx(r, rel=1e-7)
    assert_same_points(_hull_points(box3d, sim, "wedge"), wedge.vertices, 1e-7)
    rim = _hull_points(box3d, sim, "cylinder")
    assert len(rim) == 2 * box3d.CYLINDER_SIDES
    assert np.allclose(np.hypot(rim[:, 0], rim[:, 1]), r, rtol=1e-6) and set(np.round(rim[:, 2], 7)) == {-h, h}
    assert lib.b3Shape_GetMesh(sim._shape_ids["mesh"]).data.triangleCount == 2
    for body in bodies[1:]:
        bid = sim._ids[sim._order.index(body.name)]
        inertia = lib.b3Body_GetLocalRotationalInertia(bid)
        diagonal = (inertia.cx.x, inertia.cy.y, inertia.cz.z)
        assert lib.b3Body_GetMass(bid) == pytest.approx(body.mass, rel=1e-7)
        assert diagonal == pytest.approx(body.principal_inertia, rel=1e-6)
        assert (inertia.cx.y, inertia.cx.z, inertia.cy.z) == (0.0, 0.0, 0.0)
    sim.close()
    square = Polygon(((-0.1, -0.1), (0.1, -0.1), (0.1, 0.1), (-0.1, 0.1)))
    sim = box3d.Box3DAdapter().build(Scene(bodies=(Body("p", square, mass=1.0),), gravity=(0, 0, 0), dimension=2),
                                     Settings(dt=1e-3))
    assert_same_points(_hull_points(box3d, sim, "p"), _corners(0.1, 0.1, 0.1), 1e-7)
    sim.close()


@pytest.mark.engine("box3d")
@pytest.mark.parametrize("shape, orientation, height", [
    (Capsule(0.05, 0.1), ON_ITS_SIDE, 0.05),
    (Capsule(0.05, 0.1), (1.0, 0.0, 0.0, 0.0), 0.15),
    (Cylinder(0.05, 0.1), (1.0, 0.0, 0.0, 0.0), 0.1)], ids=["capsule on its side", "capsule upright",
                                                           "cylinder on an end"])
def test_box3d_capsule_and_cylinder_rest_at_their_height_with_their_weight(box3d, shape, orientation, height):
    """Placed on the ground, a capsule on its side (axis along x) rests at its radius, upright
    at h + r, a cylinder on an end at h, still, and the ground carries the weight (2 kg).
    Tolerances: the rigid-limit push-out leaves g / (2 pi 1 kHz)^2 = 0.25 um of overlap and
    float32 places 0.15 m to 1e-8 m: 1e-6 m; the momentum read-out is exact to float32
    velocities: 1e-5 of the weight."""
    assert_rests(box3d.Box3DAdapter(), shape, orientation, height)


@pytest.mark.engine("box3d")
def test_box3d_box_as_a_hull_and_square_as_a_polygon_land_as_the_primitives(box3d):
    """A cube given as a Hull (3D) and a square as a Polygon (2D), dropped tilted and sliding,
    follow the primitive's trajectory to float32 (1e-6) through the corner impact, the bounce
    and the next corner impact; from the flat landing (step 376-379, measured), where four
    points take the impact together and Box3D's one relax sweep visits them in the order of
    the hull's corners (not b3MakeBoxHull's), they part, and both come to rest flat on the
    ground at the half-extent (0.25 um of push-out overlap, float32: 1e-6)."""
    a = 0.1
    for shape, twin, dim in ((Hull(_corners(a, a, a)), Box((a, a, a)), 3),
                             (Polygon(((-a, -a), (a, -a), (a, a), (-a, a))), Rect((a, a)), 2)):
        given, primitive = (landing(box3d.Box3DAdapter(), s, dim) for s in (shape, twin))
        assert np.abs(given[:350] - primitive[:350]).max() < 1e-6
        for rest in (given[-1], primitive[-1]):
            assert rest[2] == pytest.approx(a, abs=1e-6)
            assert abs(abs(rest[3]) - 1.0) < 1e-6  # lying flat, turned back to its start (|w| = 1)


@pytest.mark.engine("box3d")
def test_box3d_mesh_ground_holds_at_its_rest_offset_with_the_pair_friction(box3d):
    """A box on a mesh ground of two triangles (wound counterclockwise from above) rests
    B3_MESH_REST_OFFSET (5 mm, a compile-time constant of Box3D's mesh contact) above it
    and the mesh carries its weight; sliding across the triangles' shared edge at 1 m/s with
    the pair's mu = 0.5 (the callbacks reach the mesh) it decelerates at mu g."""
    a, size = 0.1, 5.0
    mesh = Body("mesh", Mesh(((-size, -size, 0), (size, -size, 0), (size, size, 0), (-size, size, 0)),
                             ((0, 1, 2), (0, 2, 3))), static=True)
    offset = box3d.MESH_REST_OFFSET
    resting = Body("box", Box((a, a, a)), mass=1.0, position=(0.3, 0.2, a + offset))
    state, force = settle(box3d.Box3DAdapter(), resting, 200, ground_body=mesh)
    assert state[2] == pytest.approx(a + offset, abs=1e-6)
    assert force == pytest.approx(G, rel=1e-5)
    sliding = Body("box", Box((a, a, a)), mass=1.0, position=(0.3, 0.2, a + offset), velocity=(1.0, 0, 0),
                   rotates=False)
    scene = Scene(bodies=(mesh, sliding), gravity=(0, 0, -G), material=Material(mu_s=0.5))
    s = _run(box3d.Box3DAdapter().build(scene, Settings(dt=1e-3)), 100)["box"]
    assert (1.0 - s[7]) / 0.1 == pytest.approx(0.5 * G, rel=1e-4)  # float32 velocities


@pytest.mark.engine("box3d")
def test_box3d_hulls_it_cannot_hold_are_unsupported(box3d):
    """A hull of 45 corners (more half-edges than Box3D's uint8 indices reach) and a 1 m plate
    1e-5 m thick (b3CreateHull loops without end on some plates that thin: refused before
    Box3D sees it) are unsupported, with the reason."""
    from adapters.base import Unsupported
    i = np.arange(45) + 0.5
    phi, theta = np.arccos(1 - 2 * i / 45), np.pi * (1 + 5 ** 0.5) * i
    ball_points = np.c_[np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)] * 0.1
    from cases.scene import principal_frame
    points, _, _ = principal_frame(ball_points)
    for shape, why in ((Hull(points), "keeps 0 of its 45 corners"), (Hull(_corners(0.5, 0.5, 5e-6)), "thinner than")):
        scene = Scene(bodies=(ground(), Body("h", shape, mass=1.0, position=(0, 0, 1.0))))
        with pytest.raises(Unsupported, match=why):
            box3d.Box3DAdapter().build(scene, Settings(dt=1e-3))
