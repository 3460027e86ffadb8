"""What the PhysX adapter makes of the shapes of the vocabulary (adapters/physx_engine.py):
USD capsules and cylinders along body z (the cylinder PhysX's exact convex core), cooked
convex meshes for hulls and 2D polygons, a cooked single-sided triangle mesh for a static
mesh. PhysX gives no read-back of cooked geometry (ovphysx's population notes), so the
layer the adapter writes is checked, and PhysX's use of it by where bodies come to rest.

Each test skips cleanly when ovphysx is missing. ovphysx takes ~2 s to start a process and
~0.3 s a scene."""
from __future__ import annotations

import math

import numpy as np
import pytest

from adapters.base import Settings
from cases.scene import Body, Box, Capsule, Cylinder, Hull, Material, Mesh, Polygon, Rect, Scene, ground
from tests.shape_helpers import G, ON_ITS_SIDE, assert_rests, landing, regular_polygon, settle

pytestmark = pytest.mark.engine("physx*")


@pytest.fixture(scope="module")
def physx():
    pytest.importorskip("ovphysx")
    from adapters import physx_engine
    return physx_engine


def _layer(sim) -> str:
    with open(sim._file) as f:
        return f.read()


def test_physx_writes_each_shape_as_its_usd_collider(physx):
    """The layer holds a Capsule and a Cylinder along Z with USD's core height 2 h, the
    cylinder with margin 0 (an exact PhysX convex core, set process-wide); a hull as a Mesh
    cooked as a convex hull of its own corners (vertex limit their number, no minimum
    thickness); the static mesh as a single-sided Mesh cooked as triangles, unwelded."""
    r, h = 0.05, 0.1
    corners = tuple((x, y, z) for x in (-0.1, 0.1) for y in (-0.2, 0.2) for z in (-0.05, 0.05))
    mesh = Mesh(((-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)), ((0, 1, 2), (0, 2, 3)))
    bodies = (Body("mesh", mesh, static=True), Body("capsule", Capsule(r, h), mass=1.0, position=(0, 0, 1)),
              Body("cylinder", Cylinder(r, h), mass=1.0, position=(1, 0, 1)),
              Body("hull", Hull(corners), mass=1.0, position=(2, 0, 1)))
    with physx.PhysXAdapter().build(Scene(bodies=bodies, gravity=(0, 0, 0)), Settings(dt=1e-3)) as sim:
        layer = _layer(sim)
        knobs = sim.knobs
    for kind in ("Capsule", "Cylinder"):
        block = layer.split(f'def {kind} "Geom"')[1].split("}")[0]
        assert 'uniform token axis = "Z"' in block and f"double radius = {r!r}" in block
        assert f"double height = {2 * h!r}" in block
    assert "custom float physxConvexGeometry:margin = 0" in layer.split('def Cylinder "Geom"')[1].split("}")[0]
    assert knobs["collisionCylinderCustomGeometry"] is True
    hull = layer.split('def Mesh "Geom"')[2].split("}")[0]  # the mesh first, in scene order
    assert 'physics:approximation = "convexHull"' in hull and "hullVertexLimit = 8" in hull
    assert "minThickness = 0.0" in hull
    points = hull.split("point3f[] points = [")[1].split("]")[0]
    assert len(points.split("), (")) == 8
    triangles = layer.split('def Mesh "Geom"')[1].split("}")[0]
    assert 'physics:approximation = "none"' in triangles and "doubleSided = 0" in triangles
    assert "int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]" in triangles and "weldTolerance = 0.0" in triangles
    assert knobs["bodies"]["hull"]["convex_mesh"] == {"vertices": 8, "hullVertexLimit": 8, "minThickness": 0.0}


@pytest.mark.parametrize("shape, orientation, height", [
    (Capsule(0.05, 0.1), ON_ITS_SIDE, 0.05),
    (Capsule(0.05, 0.1), (1.0, 0.0, 0.0, 0.0), 0.15),
    (Cylinder(0.05, 0.1), ON_ITS_SIDE, 0.05),
    (Cylinder(0.05, 0.1), (1.0, 0.0, 0.0, 0.0), 0.1)], ids=["capsule on its side", "capsule upright",
                                                           "cylinder on its side", "cylinder on an end"])
def test_physx_capsule_and_cylinder_rest_at_their_height_with_their_weight(physx, shape, orientation, height):
    """Placed on the ground, a capsule or cylinder on its side (axis along x) rests at its
    radius, a capsule upright at h + r, a cylinder on an end at h, without turning, and the
    ground carries the weight (2 kg). Tolerances: PhysX's rigid contact leaves no overlap
    but float32 (0.15 m to 1e-8 m): 1e-6 m; the contact report's normal force is float32:
    1e-5 of the weight."""
    assert_rests(physx.PhysXAdapter(), shape, orientation, height)


def test_physx_pentagon_and_thin_plate_rest_on_a_face(physx):
    """A 2D regular pentagon (the convex mesh of its prism along y) rests on a face at its
    apothem, the body frame at its centroid; a 1 m plate 1e-4 m thick (a hull cooked with
    no minimum thickness: PhysX's default would make it 1 mm) rests at half its thickness.
    Tolerance 1e-6 m, float32 as above."""
    r = 0.1
    apothem = r * math.cos(math.pi / 5)
    state, force = settle(physx.PhysXAdapter(), Body("p", Polygon(regular_polygon(5, r)), mass=2.0,
                                                     position=(0.0, 0.0, apothem)), 200, dimension=2)
    assert state[2] == pytest.approx(apothem, abs=1e-6)
    assert force == pytest.approx(2.0 * G, rel=1e-5)
    t = 1e-4
    plate = Hull(tuple((x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-t / 2, t / 2)))
    state, _ = settle(physx.PhysXAdapter(), Body("plate", plate, mass=1.0, position=(0.0, 0.0, t / 2)), 100)
    assert state[2] == pytest.approx(t / 2, abs=1e-6)


def test_physx_box_as_a_hull_and_square_as_a_polygon_land_as_the_primitives(physx):
    """A cube given as a Hull (3D) and a square as a Polygon (2D), dropped tilted and sliding,
    follow the box's trajectory to float32 (1e-6) through the corner impact and the bounce
    (280 steps); at the second corner impact (step 283, 287 in 2D, measured) PhysX's contact
    generation for a convex mesh and for a box give different points (the spin after it
    differs by 0.13 %), and both come to rest flat on a face at the half-extent."""
    a = 0.1
    for shape, twin, dim in ((Hull(tuple((x, y, z) for x in (-a, a) for y in (-a, a) for z in (-a, a))),
                              Box((a, a, a)), 3),
                             (Polygon(((-a, -a), (a, -a), (a, a), (-a, a))), Rect((a, a)), 2)):
        given, primitive = (landing(physx.PhysXAdapter(), s, dim) for s in (shape, twin))
        assert np.abs(given[:280] - primitive[:280]).max() < 1e-6
        for rest in (given[-1], primitive[-1]):
            assert rest[2] == pytest.approx(a, abs=1e-6)


def test_physx_mesh_ground_holds_like_the_plane(physx):
    """A box on a mesh ground of two triangles (wound counterclockwise from above) rests at
    its half-extent with its weight on the mesh, and slides across the triangles' shared edge
    at 1 m/s with mu = 0.5 decelerating at mu g (PhysX applies mu_k while it slides; float32
    velocities: 1e-4)."""
    a, size = 0.1, 5.0
    mesh = Body("mesh", Mesh(((-size, -size, 0), (size, -size, 0), (size, size, 0), (-size, size, 0)),
                             ((0, 1, 2), (0, 2, 3))), static=True)
    state, force = settle(physx.PhysXAdapter(), Body("box", Box((a, a, a)), mass=1.0, position=(0.3, 0.2, a)), 200,
                          ground_body=mesh)
    assert state[2] == pytest.approx(a, abs=1e-6)
    assert force == pytest.approx(G, rel=1e-5)
    sliding = Body("box", Box((a, a, a)), mass=1.0, position=(0.3, 0.2, a), velocity=(1.0, 0.0, 0.0), rotates=False)
    scene = Scene(bodies=(mesh, sliding), gravity=(0, 0, -G), material=Material(mu_s=0.5))
    with physx.PhysXAdapter().build(scene, Settings(dt=1e-3)) as sim:
        for _ in range(100):
            sim.step()
        v = sim.states()["box"][7]
    assert (1.0 - v) / 0.1 == pytest.approx(0.5 * G, rel=1e-4)


def test_physx_hulls_it_cannot_hold_are_unsupported(physx):
    """A hull of 256 corners: a PhysX convex mesh holds at most 255."""
    from adapters.base import Unsupported
    from cases.scene import principal_frame
    i = np.arange(256) + 0.5
    phi, theta = np.arccos(1 - 2 * i / 256), np.pi * (1 + 5 ** 0.5) * i
    points, _, _ = principal_frame(np.c_[np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])
    scene = Scene(bodies=(ground(), Body("h", Hull(points), mass=1.0, position=(0, 0, 2.0))))
    with pytest.raises(Unsupported, match="at most 255"):
        physx.PhysXAdapter().build(scene, Settings(dt=1e-3))



def test_physx_contact_normals_point_into_the_sensor_whatever_pair_order_physx_keeps(physx):
    """PhysX's reported normal runs from the pair's second shape into its first, and which of
    two dynamic balls is second is PhysX's own order (measured on this 64-ball lattice of
    cases/broad_phase.py: 21 of its 32 dimers come with the raw normal into the ball read as
    b). The read-out gives each dimer once, its normal from b into a (the unit vector between
    their centres, along x) and its gap the dimers' overlap. Float32 coordinates of ~0.5 m:
    2e-6 is a few roundings (tests/test_contact_geometry.py)."""
    from cases import broad_phase
    variant = {"side": 4, "dim": 3}
    scene = broad_phase.scene(variant)
    centre = {b.name: np.asarray(b.position) for b in scene.bodies}
    with physx.PhysXAdapter().build(scene, Settings(dt=1e-3)) as sim:
        sim.step()
        points = sim.contact_points()
    assert {frozenset((p.a, p.b)) for p in points} == broad_phase.planned(variant)
    assert len(points) == len(broad_phase.planned(variant)), "a pair of two sensors is read once"
    for p in points:
        into_a = (centre[p.a] - centre[p.b]) / np.linalg.norm(centre[p.a] - centre[p.b])
        assert np.allclose(p.n, into_a, atol=2e-6), f"normal {p.n}, but should be {into_a} (from {p.b} into {p.a})"
        assert p.gap == pytest.approx(-broad_phase.DEPTH, abs=2e-6)


# --- joints (issue 39): the layer's joint frames and the jointed pairs' collision filter -------

def _quat(axis, angle: float) -> tuple[float, float, float, float]:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return (math.cos(angle / 2), *(math.sin(angle / 2) * a))


@pytest.mark.parametrize("kind, limits", [("revolute", (-0.2, 0.5)), ("prismatic", (-0.1, 0.3))])
@pytest.mark.parametrize("push", [1, -1])
def test_physx_joint_stops_at_its_limit_on_an_oblique_axis_between_turned_bodies(physx, kind, limits, push):
    """A hinge (slider) on an oblique axis between two turned boxes, the parent welded to the
    world, pushed by a load about (along) the axis one way or the other (no gravity): its
    coordinate, the body's turn (slide) relative to the start, comes to the limit on that
    side, and the body turns about no other axis. Checks the local frames (the anchor in each
    body, z on the axis), the sign of the coordinate and the degrees of a hinge's limits
    (measured: at each limit to 1e-4, off-axis turns below 2e-7 rad)."""
    from cases import rotations
    from cases.scene import Joint, Load
    axis = np.array([1.0, 1.0, 0.5]) / np.linalg.norm([1.0, 1.0, 0.5])
    base = Body("base", Box((0.1, 0.1, 0.1)), mass=1.0, position=(0.0, 0.0, 1.0), orientation=_quat((0.3, -1, 0.2), 0.7))
    arm = Body("arm", Box((0.2, 0.05, 0.05)), mass=1.0, position=(0.3, 0.1, 1.2), orientation=_quat((1, 0.4, -0.5), 1.1))
    joints = (Joint(kind, "arm", "base", anchor=(0.1, 0.05, 1.1), axis=tuple(axis), limits=limits),
              Joint("fixed", "base", None, anchor=(0.0, 0.0, 1.0)))
    load = Load("arm", force=tuple(push * 0.5 * axis) if kind == "prismatic" else (0.0, 0.0, 0.0),
                torque=tuple(push * 0.05 * axis) if kind == "revolute" else (0.0, 0.0, 0.0))
    scene = Scene(bodies=(base, arm), joints=joints, loads=(load,), gravity=(0.0, 0.0, 0.0))
    with physx.PhysXAdapter().build(scene, Settings(dt=1e-3)) as sim:
        for _ in range(2000):
            sim.step()
        s = sim.states()["arm"]
    turn = rotations.multiply(s[3:7], rotations.conjugate(arm.orientation))
    along = turn[1:] @ axis
    coordinate = 2 * math.atan2(along, turn[0]) if kind == "revolute" else (s[:3] - arm.position) @ axis
    assert coordinate == pytest.approx(limits[push > 0], abs=1e-4)
    assert np.linalg.norm(turn[1:] - along * axis) < 1e-5


@pytest.mark.parametrize("parent_static", [False, True])
def test_physx_jointed_bodies_pass_through_each_other(physx, parent_static):
    """A box on a slider to its parent, 1 cm from the parent's face and pushed into it by
    1 N (no gravity), slides through the parent; unjointed, the push stops it at the face.
    A dynamic parent: the joint's collisionEnabled 0; a static one, which is no actor of the
    joint: the body's PhysicsFilteredPairsAPI (measured: without it the box stops, 142 N)."""
    from cases.scene import Joint, Load
    for jointed in (True, False):
        parent = Body("a", Box((0.1, 0.1, 0.1)), mass=1.0, position=(0.0, 0.0, 1.0), static=parent_static)
        box = Body("b", Box((0.1, 0.1, 0.1)), mass=1.0, position=(0.21, 0.0, 1.0))
        joints = (Joint("prismatic", "b", "a", anchor=(0.21, 0.0, 1.0), axis=(1, 0, 0)),) if jointed else ()
        if not parent_static:
            joints += (Joint("fixed", "a", None, anchor=(0.0, 0.0, 1.0)),)
        scene = Scene(bodies=(parent, box), joints=joints, gravity=(0, 0, 0), loads=(Load("b", force=(-1.0, 0, 0)),))
        with physx.PhysXAdapter().build(scene, Settings(dt=1e-3)) as sim:
            for _ in range(1000):
                sim.step()
            x = sim.states()["b"][0]
        if jointed:
            assert x < -0.2, "the jointed box stopped at its parent"
        else:
            assert x == pytest.approx(0.2, abs=1e-3)
