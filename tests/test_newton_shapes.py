"""What adapters/newton_engine.py makes of the shapes of the vocabulary on Newton's own
collision pipeline (newton-xpbd here, the solver with Newton's rigid contact): a capsule and
a straight-sided cylinder along body z, a hull as a convex mesh of exactly its corners, a
static mesh as a triangle mesh; and that Newton uses them so: a capsule upright, a cylinder
on its end and on its side (a line contact) and a hull of a box's corners rest on a mesh ground at the heights their
sizes give, and the contact points it reports there (a body's points on the ground, pushing it up
with its weight). Slow: Newton and Warp start in ~10 s a process and a build costs ~15 s of CPU
with a full kernel cache (measured), so this is one build, stepped once for every check."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from adapters import registry
from adapters.base import Settings
from cases.scene import Body, Capsule, Cylinder, Hull, Material, Mesh, Scene
from tests.shape_helpers import DT, G, ON_ITS_SIDE

pytestmark = [pytest.mark.engine("newton-*"), pytest.mark.slow]

R, H, A = 0.05, 0.1, 0.1  # capsule and cylinder radius and half-length, hull half-side, m
CORNERS = tuple(itertools.product((-A, A), repeat=3))
GROUND = Mesh(((-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)), ((0, 1, 2), (0, 2, 3)))
UP = (1.0, 0.0, 0.0, 0.0)
# upright, a capsule and a cylinder rest at heights only their axis along body z gives
REST = {"capsule": (Capsule(R, H), UP, H + R), "cylinder": (Cylinder(R, H), UP, H),
        "cylinder_side": (Cylinder(R, H), ON_ITS_SIDE, R), "hull": (Hull(CORNERS), UP, A)}
STEPS = 300
# XPBD's contact leaves the bodies ~1e-6 m into the ground under their weight and float32 holds
# a position at 1 m to 6e-8 m (measured: 0.2-1.1 um); a radius taken for a diameter, a
# half-length for a length or the axis across the body misplaces a body by 50 mm or more.
HEIGHT = 1e-5  # m
# float32 read-out of velocities that XPBD has brought to rest (measured: 0 to 1e-5 m/s);
# a body rolling off, rocking on a corner or sinking moves at 1e-2 m/s or more.
STILL = 1e-4  # m/s or rad/s


@pytest.fixture(scope="module")
def built():
    """(the Newton model, the states after STEPS, the recorded knobs) of the scene: every
    shape at rest on the mesh ground."""
    try:
        adapter = registry.get("newton-xpbd")
    except registry.EngineError as exc:
        pytest.skip(str(exc))
    bodies = [Body("ground", GROUND, static=True)]
    bodies += [Body(name, shape, mass=2.0, position=(0.5 * k - 0.5, 0.0, z), orientation=q)
               for k, (name, (shape, q, z)) in enumerate(REST.items())]
    scene = Scene(bodies=tuple(bodies), gravity=(0.0, 0.0, -G), material=Material(mu_s=0.5))
    with adapter.build(scene, Settings(dt=DT)) as sim:
        model = sim._model
        built = (model.shape_type.numpy(), model.shape_scale.numpy(), list(model.shape_source))
        for _ in range(STEPS):
            sim.step()
        return built, sim.states(), sim.knobs, sim.contact_points()


def test_newton_builds_each_shape_as_its_own_kind(built):
    import newton
    (types, scale, sources), _, knobs, _ = built
    kinds = [newton.GeoType(int(t)).name for t in types]
    assert kinds == ["MESH", "CAPSULE", "CYLINDER", "CYLINDER", "CONVEX_MESH"], \
        f"{kinds}, but should be the scene's kinds in its order"
    # Newton's capsule and cylinder scale is (radius, half-height, 0) along its own z
    np.testing.assert_allclose(scale[1:4], [(R, H, 0.0)] * 3, rtol=1e-7)
    np.testing.assert_allclose(scale[[0, 4]], 1.0)  # the points are the scene's, unscaled
    ground, hull = sources[0], sources[4]
    np.testing.assert_allclose(ground.vertices, GROUND.vertices, atol=0)
    assert ground.indices.reshape(-1, 3).tolist() == [list(t) for t in GROUND.triangles]
    assert len(hull.vertices) == 8 and hull.maxhullvert == 8  # no corner dropped or added
    assert knobs["bodies"]["cylinder"]["cylinder"]["barrel_radius"] == 0.0


@pytest.mark.parametrize("name", list(REST))
def test_newton_rests_each_shape_at_its_height_on_a_mesh_ground(built, name):
    _, states, _, _ = built
    shape, q, z = REST[name]
    row = states[name]
    assert row[2] == pytest.approx(z, abs=HEIGHT), f"{name} at z = {row[2]}, but should rest at {z}"
    assert np.abs(row[3:7] - q).max() < 1e-5, f"{name} turned to {row[3:7]}, but should stay at {q}"
    assert np.abs(row[7:13]).max() < STILL, f"{name} moves at {row[7:13]}, but should be at rest"


# The points of a body at rest: on the ground's surface to XPBD's resting depth, pushed up along
# +z, carrying its weight. XPBD's reported force is its position correction over dt^2 (the
# solver's notes call it approximate): a box at rest on the plane reads 9.8065 for 9.81 N
# (3.6e-4 of m g, measured); a sign or frame error gives -m g, a point at the body's centre
# or a normal across the ground.
WEIGHT = 1e-3  # of m g


@pytest.mark.parametrize("name", list(REST))
def test_newton_reports_the_points_a_resting_shape_stands_on(built, name):
    _, states, _, points = built
    mine = [c for c in points if c.a == name]
    assert mine and all(c.b == "ground" for c in mine), f"{name}: points {mine}, but should stand on the ground"
    for c in mine:
        np.testing.assert_allclose(c.n, (0.0, 0.0, 1.0), atol=1e-6, err_msg=f"{name}: normal, but should be +z")
        assert abs(c.x[2]) < HEIGHT and abs(c.gap) < HEIGHT, f"{name}: point {c.x} gap {c.gap}, but should be on z = 0"
    weight = sum(c.f_n for c in mine)
    assert weight == pytest.approx(2.0 * G, rel=WEIGHT), f"{name} carried by {weight} N, but should be {2.0 * G} N"
