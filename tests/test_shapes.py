"""The shapes of the scene vocabulary (cases/scene.py): their mass properties against
independent values, their input checks (one line naming the body and the field), the start
overlap check on every pair of them (cases/overlap.py), and engines that do not declare a
shape reporting it unsupported."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import minimize, minimize_scalar
from scipy.spatial import ConvexHull

from adapters.base import Capabilities, Settings, Unsupported
from cases.overlap import exact, penetration, rotation_matrix
from cases.scene import (SHAPE_KINDS, Body, Box, Capsule, Circle, Cylinder, Hull, Mesh, Plane, Polygon, Rect, Scene,
                         SceneError, Sphere, ground, principal_frame, quat_about_y)

# Mass properties computed in float64 from a handful of terms agree with closed forms to a
# few units of round-off; 1e-12 relative leaves room for the sums over hundreds of faces.
ROUNDOFF = 1e-12


def box_corners(a, b, c):
    return list(itertools.product((-a, a), (-b, b), (-c, c)))


def prism(n: int, radius: float, half: float, phase: float = 0.0):
    """A regular n-gon prism of circumradius `radius` along z: corners of a hull."""
    t = phase + 2 * np.pi * np.arange(n) / n
    return [(radius * math.cos(a), radius * math.sin(a), z) for z in (-half, half) for a in t]


@pytest.fixture
def rng():
    """Each test its own draws, the same whichever tests run."""
    return np.random.default_rng(36)


def unit_quaternion(rng):
    q = rng.normal(size=4)
    return tuple(q / np.linalg.norm(q))


# --- mass properties -----------------------------------------------------------------------

def test_a_hull_of_a_box_has_the_box_inertia(rng):
    for _ in range(5):
        a, b, c = rng.uniform(0.01, 2.0, 3)
        hull = Hull(box_corners(a, b, c))
        hull.validate("hull")
        assert hull.mass_properties[0] == pytest.approx(8 * a * b * c, rel=ROUNDOFF)
        assert hull.inertia(2.5) == pytest.approx(Box((a, b, c)).inertia(2.5), rel=ROUNDOFF)


@pytest.mark.parametrize("n", [16, 64, 256])
def test_a_fine_hull_of_a_cylinder_is_within_its_facet_error(n):
    """An n-gon prism inscribed in a cylinder (circumradius r) has, per unit mass,
    I_z = r^2 (2 + cos a) / 6 and I_x = r^2 (2 + cos a) / 12 + h^2 / 3, a = 2 pi / n (a
    triangle (0, p, q) has polar moment A (|p|^2 + |q|^2 + p.q) / 6); the cylinder's
    r^2 / 2 and r^2 / 4 + h^2 / 3 exceed them by r^2 (1 - cos a) / 6 and / 12: the facet error,
    O(r^2 / n^2). The hull's integral must give the prism exactly and so miss the cylinder
    by exactly that much."""
    r, h, m = 0.3, 0.2, 1.7
    hull = Hull(prism(n, r, h))
    hull.validate("hull")
    alpha = 2 * np.pi / n
    ix, _, iz = hull.inertia(m)
    assert iz == pytest.approx(m * r * r * (2 + math.cos(alpha)) / 6, rel=ROUNDOFF)
    assert ix == pytest.approx(m * (r * r * (2 + math.cos(alpha)) / 12 + h * h / 3), rel=ROUNDOFF)
    cx, _, cz = Cylinder(r, h).inertia(m)
    facet = m * r * r * (1 - math.cos(alpha))
    assert cz - iz == pytest.approx(facet / 6, rel=1e-6)  # the difference of two close numbers: 1e-6
    assert cx - ix == pytest.approx(facet / 12, rel=1e-6)
    assert 0 < (cz - iz) / cz <= 2 * math.pi**2 / (3 * n * n)  # (1 - cos a) / 3 <= a^2 / 6


def _revolution_inertia(radius_at, z0: float, z1: float, m: float) -> tuple[float, float]:
    """(I_x, I_z) of a solid of revolution about z with radius R(z) on [z0, z1] and mass m,
    by quadrature of its discs: volume pi R^2 dz, I_z of a disc pi R^4 / 2 dz, I_x of a disc
    about the centre pi R^4 / 4 dz + pi R^2 z^2 dz."""
    opts = dict(epsabs=0.0, epsrel=1e-13, limit=200)
    volume = quad(lambda z: math.pi * radius_at(z)**2, z0, z1, **opts)[0]
    iz = quad(lambda z: math.pi * radius_at(z)**4 / 2, z0, z1, **opts)[0]
    ix = quad(lambda z: math.pi * radius_at(z)**4 / 4 + math.pi * radius_at(z)**2 * z * z, z0, z1, **opts)[0]
    return m * ix / volume, m * iz / volume


@pytest.mark.parametrize("r,h", [(0.1, 0.3), (0.25, 0.05), (0.2, 1e-3)])
def test_capsule_inertia_composes_a_cylinder_and_a_sphere(r, h):
    """Three routes: the cylinder's and the sphere's closed forms, the sphere cut at its
    equator and its halves moved apart by 2h (each half's centroid 3r/8 from its flat face:
    parallel-axis theorem through the centroid); quadrature of the solid of revolution; and
    the sphere's 2/5 m r^2 as the length goes to zero."""
    m = 3.0
    capsule = Capsule(r, h).inertia(m)
    v_cyl, v_sph = 2 * h * math.pi * r * r, 4 / 3 * math.pi * r**3
    m_cyl, m_sph = m * v_cyl / (v_cyl + v_sph), m * v_sph / (v_cyl + v_sph)
    cyl, sph = Cylinder(r, h).inertia(m_cyl), Sphere(r).inertia(m_sph)
    d = 3 * r / 8  # a hemisphere's centroid from its flat face
    half_about_face = sph[0] / 2  # each half of the sphere about a diameter in its face
    half_about_centre = half_about_face - m_sph / 2 * d * d + m_sph / 2 * (h + d)**2
    assert capsule[2] == pytest.approx(cyl[2] + sph[2], rel=ROUNDOFF)
    assert capsule[0] == pytest.approx(cyl[0] + 2 * half_about_centre, rel=ROUNDOFF)
    assert capsule[0] == capsule[1]

    def radius_at(z):
        return r if abs(z) <= h else math.sqrt(max(0.0, r * r - (abs(z) - h)**2))

    ix, iz = _revolution_inertia(radius_at, -h - r, h + r, m)
    assert capsule[0] == pytest.approx(ix, rel=1e-9) and capsule[2] == pytest.approx(iz, rel=1e-9)  # quadrature
    assert Capsule(r, 1e-12).inertia(m) == pytest.approx(Sphere(r).inertia(m), rel=1e-9)


def test_cylinder_inertia_is_the_solid_of_revolution():
    r, h, m = 0.15, 0.4, 2.0
    ix, iz = _revolution_inertia(lambda z: r, -h, h, m)
    assert Cylinder(r, h).inertia(m) == pytest.approx((ix, ix, iz), rel=1e-12)


def test_a_square_polygon_is_a_rect_and_a_regular_polygon_its_closed_form():
    a, c, m = 0.3, 0.1, 2.0
    square = Polygon([(a, c), (-a, c), (-a, -c), (a, -c)])
    square.validate("square")
    assert square.inertia(m) == pytest.approx(Rect((a, c)).inertia(m), rel=ROUNDOFF)
    assert square.mass_properties[0] == pytest.approx(4 * a * c, rel=ROUNDOFF)
    n, r = 7, 0.2  # per unit mass r^2 (2 + cos(2 pi / n)) / 6, as the prism's I_z above
    gon = Polygon([(r * math.cos(t), r * math.sin(t)) for t in 2 * np.pi * np.arange(n) / n][::-1])
    gon.validate("gon")
    assert gon.inertia(m)[0] == pytest.approx(m * r * r * (2 + math.cos(2 * math.pi / n)) / 6, rel=ROUNDOFF)


def test_principal_frame_moves_a_point_set_into_its_body_frame(rng):
    points = rng.normal(size=(40, 3)) * (0.3, 0.2, 0.1)
    points = points[ConvexHull(points).vertices] + (1.0, -2.0, 0.5)
    body_points, centre, q = principal_frame(points)
    hull = Hull(body_points)
    hull.validate("hull")  # centred and principal
    R = rotation_matrix(q)
    assert np.allclose(np.asarray(centre) + np.asarray(body_points) @ R.T, points, atol=1e-12)
    # the principal moments are the eigenvalues of the tensor in the points' own frame
    tensor_world = R @ np.diag(hull.inertia(1.0)) @ R.T
    ix, iy, iz = hull.inertia(1.0)
    assert ix <= iy <= iz and np.allclose(np.linalg.eigvalsh(tensor_world), (ix, iy, iz), rtol=1e-12)
    flat = rng.normal(size=(30, 2))
    flat = flat[ConvexHull(flat).vertices] + (3.0, -1.0)
    polygon_points, centre2, q2 = principal_frame(flat)
    Polygon(polygon_points).validate("polygon")
    assert q2 == (1.0, 0.0, 0.0, 0.0) and centre2[1] == 0.0
    assert np.allclose(np.asarray(polygon_points) + (centre2[0], centre2[2]), flat, atol=1e-12)


# --- input checks --------------------------------------------------------------------------

CUBE = box_corners(0.1, 0.1, 0.1)
SQUARE = [(0.1, 0.1), (-0.1, 0.1), (-0.1, -0.1), (0.1, -0.1)]
GROUND = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]  # two triangles, counterclockwise from +z
UP = dict(position=(0, 0, 1.0), mass=1.0)


@pytest.mark.parametrize("shape,field,rule", [
    (Capsule(0.0, 0.1), r"radius = 0.0", r"must be > 0"),
    (Capsule(0.1, -0.2), r"half_length = -0.2", r"must be > 0"),
    (Cylinder(-0.1, 0.1), r"radius = -0.1", r"must be > 0"),
    (Cylinder(0.1, 0.0), r"half_length = 0.0", r"must be > 0"),
    (Cylinder(0.1, math.nan), r"half_length = nan", r"must be finite"),
    (Hull(CUBE[:3]), r"vertices = .*", r"must be at least 4 points"),
    (Hull([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), (0.5, 0.2, 0)]), r"vertices = .*",
     r"must span a volume \(the points are coplanar\)"),
    (Hull(CUBE + [(0.0, 0.0, 0.0)]), r"vertices\[8\] = \(0.0, 0.0, 0.0\)", r"must be a corner of the convex hull"),
    (Hull(CUBE + [(0.1, 0.0, 0.0)]), r"vertices\[8\] = \(0.1, 0.0, 0.0\)", r"must be a corner"),  # on a face
    (Hull(CUBE + [CUBE[3]]), r"vertices\[8\] = .*", r"must differ from every other point \(it repeats vertices\[3\]\)"),
    (Hull([(x + 0.05, y, z) for x, y, z in CUBE]), r"vertices = .*", r"must have their centre of mass at the origin"),
    (Hull([tuple(rotation_matrix((0.9, 0.3, 0.1, 0.0) / np.linalg.norm((0.9, 0.3, 0.1))) @ p)
           for p in box_corners(0.3, 0.2, 0.1)]), r"vertices = .*", r"must be given in the principal axes"),
    (Hull(CUBE[:7] + [(0.1, 0.1, math.inf)]), r"vertices = .*", r"must be finite"),
    (Hull("cube"), r"vertices = 'cube'", r"must be a sequence of \(x, y, z\) points in m"),
    (Mesh(GROUND, [(0, 1, 2), (0, 2, 3)]), r"", r""),  # the dynamic mesh (below)
])
def test_a_bad_3d_shape_is_one_line_naming_the_body_and_the_field(shape, field, rule):
    if shape.kind == "mesh":  # a mesh is static only
        with pytest.raises(SceneError, match=r"^bodies\[1\]\(b\)\.static = False: must be True for a mesh"):
            Scene(bodies=(ground(), Body("b", shape, **UP)))
        return
    with pytest.raises(SceneError, match=rf"^bodies\[1\]\(b\)\.shape\.{field}: {rule}") as got:
        Scene(bodies=(ground(), Body("b", shape, **UP)))
    assert "\n" not in str(got.value)


@pytest.mark.parametrize("shape,field,rule", [
    (Polygon(SQUARE[:2]), r"vertices = .*", r"must be at least 3 points"),
    (Polygon([(0, 0), (0.1, 0.1), (0.2, 0.2)]), r"vertices = .*", r"must span an area \(the points are collinear\)"),
    (Polygon([(0.2, 0.0), (0.0, 0.05), (-0.2, 0.0), (0.0, 0.2)]), r"vertices\[1\] = \(0.0, 0.05\)",
     r"must be a corner .*a polygon must be convex"),  # an arrow head: not convex
    (Polygon([(x + 0.01, z) for x, z in SQUARE]), r"vertices = .*", r"must have their centroid at the origin"),
])
def test_a_bad_polygon_is_one_line_naming_the_body_and_the_field(shape, field, rule):
    with pytest.raises(SceneError, match=rf"^bodies\[1\]\(b\)\.shape\.{field}: {rule}"):
        Scene(bodies=(ground(), Body("b", shape, **UP)), dimension=2)


@pytest.mark.parametrize("mesh,field,rule", [
    (Mesh(GROUND, [(0, 1, 2), (0, 2, 4)]), r"triangles\[1\] = \(0, 2, 4\)", r"must index vertices 0..3"),
    (Mesh(GROUND, [(0, 1, 2), (0, 2, -1)]), r"triangles\[1\] = \(0, 2, -1\)", r"must index vertices 0..3"),
    (Mesh(GROUND, [(0, 1, 2), (0, 2, 2)]), r"triangles\[1\] = \(0, 2, 2\)", r"must have an area > 0"),
    (Mesh(GROUND + [(0.5, 0.5, 0.0)], [(0, 1, 2), (0, 2, 4)]), r"triangles\[1\] = \(0, 2, 4\)",
     r"must have an area > 0 \(its corners repeat or are collinear\)"),
    (Mesh(GROUND + [(0, 0, 1)], [(0, 1, 2), (0, 2, 3), (0, 2, 4)]), r"triangles\[2\] = \(0, 2, 4\)",
     r"must leave each edge in at most two triangles"),
    (Mesh(GROUND, [(0, 1, 2), (0, 3, 2)]), r"triangles\[1\] = \(0, 3, 2\)",
     r"must be wound as its neighbour triangles\[0\]"),
    (Mesh(GROUND, [(0, 1, 2.5)]), r"triangles = .*", r"must be one or more triples of vertex indices"),
    (Mesh(GROUND, []), r"triangles = \(\)", r"must be one or more triples of vertex indices"),
    (Mesh(GROUND[:2], [(0, 1, 1)]), r"vertices = .*", r"must be at least 3 points"),
])
def test_a_bad_mesh_is_one_line_naming_the_body_and_the_field(mesh, field, rule):
    with pytest.raises(SceneError, match=rf"^bodies\[0\]\(b\)\.shape\.{field}: {rule}"):
        Scene(bodies=(Body("b", mesh, static=True), Body("ball", Sphere(0.1), **UP)))


def test_the_new_shapes_keep_to_their_dimension():
    with pytest.raises(SceneError, match=r"shape = hull: a 3D shape in a 2D scene \(2D: .*polygon"):
        Scene(bodies=(ground(), Body("b", Hull(CUBE), **UP)), dimension=2)
    with pytest.raises(SceneError, match=r"shape = polygon: a 2D shape in a 3D scene"):
        Scene(bodies=(ground(), Body("b", Polygon(SQUARE), **UP)))


def test_good_shapes_make_a_scene():
    scene = Scene(bodies=(Body("floor", Mesh(GROUND, [(0, 1, 2), (0, 2, 3)]), static=True),
                          Body("hull", Hull(CUBE), mass=1.0, position=(0.5, 0.5, 0.1)),
                          Body("capsule", Capsule(0.05, 0.1), mass=1.0, position=(-0.5, 0.0, 0.05),
                               orientation=quat_about_y(math.pi / 2)),
                          Body("cylinder", Cylinder(0.05, 0.1), mass=1.0, position=(0.0, -0.5, 0.1))))
    assert scene.body("hull").principal_inertia == pytest.approx(Box((0.1, 0.1, 0.1)).inertia(1.0))
    assert hash(scene.body("floor").shape) == hash(Mesh(GROUND, ((0, 1, 2), (0, 2, 3))))  # lists became tuples
    Scene(bodies=(ground(), Body("p", Polygon(SQUARE), mass=1.0, position=(0, 0, 0.1))), dimension=2)


# --- the start overlap check ---------------------------------------------------------------

def _body(name, shape, position, orientation=(1.0, 0.0, 0.0, 0.0), static=False):
    return Body(name, shape, mass=None if static else 1.0, position=tuple(position), orientation=orientation,
                static=static)


def test_a_box_as_a_hull_overlaps_as_the_box(rng):
    for _ in range(40):
        h = rng.uniform(0.05, 0.3, 3)
        pose = dict(position=rng.normal(size=3) * 0.2, orientation=unit_quaternion(rng))
        box, hull = _body("a", Box(tuple(h)), **pose), _body("a", Hull(box_corners(*h)), **pose)
        other = rng.choice([Sphere(0.15), Box((0.1, 0.2, 0.15)), Plane((0.6, 0.0, 0.8), 0.05)])
        b = _body("b", other, rng.normal(size=3) * 0.2, unit_quaternion(rng), static=other.kind == "plane")
        assert penetration(hull, b) == pytest.approx(penetration(box, b), abs=1e-12)


def _segment_distance(p0, p1, q0, q1) -> float:
    """Distance between segments by minimising |p(s) - q(t)|^2 over [0, 1]^2 (a convex
    quadratic: L-BFGS-B reaches its minimum to 1e-14 m^2)."""
    f = lambda x: float(np.sum((p0 + x[0] * (p1 - p0) - q0 - x[1] * (q1 - q0))**2))  # noqa: E731
    best = minimize(f, [0.5, 0.5], bounds=[(0, 1), (0, 1)], method="L-BFGS-B", options=dict(ftol=1e-16, gtol=1e-12))
    return math.sqrt(max(best.fun, 0.0))


def test_capsules_and_spheres_overlap_by_their_radii_less_the_core_distance(rng):
    for _ in range(15):
        caps = [Capsule(rng.uniform(0.05, 0.2), rng.uniform(0.02, 0.3)) for _ in range(2)]
        bodies = [_body(n, c, rng.normal(size=3) * 0.15, unit_quaternion(rng)) for n, c in zip("ab", caps)]
        ends = [(np.asarray(b.position) - rotation_matrix(b.orientation)[:, 2] * b.shape.half_length,
                 np.asarray(b.position) + rotation_matrix(b.orientation)[:, 2] * b.shape.half_length) for b in bodies]
        expect = caps[0].radius + caps[1].radius - _segment_distance(*ends[0], *ends[1])
        # L-BFGS-B stops within ~1e-14 m^2 of the least squared distance: 1e-7 m at distances over 1e-7 m
        assert penetration(*bodies) == pytest.approx(max(0.0, expect), abs=1e-7)
        sphere = _body("s", Sphere(0.1), rng.normal(size=3) * 0.15)
        centre = np.asarray(sphere.position)
        expect = 0.1 + caps[0].radius - _segment_distance(*ends[0], centre, centre)
        assert penetration(bodies[0], sphere) == pytest.approx(max(0.0, expect), abs=1e-7)


def test_a_capsule_against_a_box_overlaps_by_its_radius_less_the_core_distance(rng):
    """The segment's distance to the box by minimising over (t, a point of the box): convex."""
    h = np.array([0.2, 0.1, 0.15])
    box = _body("box", Box(tuple(h)), (0, 0, 0), unit_quaternion(rng))
    R = rotation_matrix(box.orientation)
    for _ in range(15):
        cap = _body("c", Capsule(0.1, 0.15), rng.normal(size=3) * 0.25, unit_quaternion(rng))
        axis = rotation_matrix(cap.orientation)[:, 2] * 0.15
        p0, p1 = R.T @ (np.asarray(cap.position) - axis), R.T @ (np.asarray(cap.position) + axis)
        f = lambda x: float(np.sum((p0 + x[0] * (p1 - p0) - x[1:])**2))  # noqa: E731
        res = minimize(f, np.zeros(4), bounds=[(0, 1)] + [(-v, v) for v in h], method="L-BFGS-B",
                       options=dict(ftol=1e-16, gtol=1e-12))
        distance = math.sqrt(max(res.fun, 0.0))
        if distance < 1e-3:  # the core inside the box: measured by the separating axes, checked elsewhere
            continue
        assert penetration(cap, box) == pytest.approx(max(0.0, 0.1 - distance), abs=1e-7)


def test_a_cylinder_against_a_plane_and_a_sphere_is_exact(rng):
    for _ in range(20):
        cyl = _body("c", Cylinder(0.12, 0.2), rng.normal(size=3) * 0.1, unit_quaternion(rng))
        R = rotation_matrix(cyl.orientation)
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        plane = _body("p", Plane(tuple(n), 0.05), (0, 0, 0), static=True)
        def height(t, z):  # of the rim point at angle t on the end z, along n
            return float(n @ (np.asarray(cyl.position) + R @ (0.12 * math.cos(t), 0.12 * math.sin(t), z)))

        lowest = math.inf  # the lowest point is on a rim: sample each, then refine about the lowest sample
        for z in (-0.2, 0.2):
            t0 = min(np.linspace(0, 2 * np.pi, 721), key=lambda t: height(t, z))
            found = minimize_scalar(lambda t: height(t, z), bounds=(t0 - 0.01, t0 + 0.01), method="bounded",
                                    options=dict(xatol=1e-10))
            lowest = min(lowest, found.fun)  # a smooth minimum: 1e-10 rad off costs 0.12 * 1e-20 m
        assert penetration(cyl, plane) == pytest.approx(max(0.0, 0.05 - lowest), abs=1e-14)
        centre = rng.normal(size=3) * 0.25
        local = R.T @ (centre - np.asarray(cyl.position))
        rho, z = math.hypot(local[0], local[1]), local[2]
        if rho < 0.12 and abs(z) < 0.2:  # the centre inside: the nearer of the side and the caps
            expect = 0.1 + min(0.12 - rho, 0.2 - abs(z))
        else:
            expect = 0.1 - math.hypot(max(0.0, rho - 0.12), max(0.0, abs(z) - 0.2))
        assert penetration(cyl, _body("s", Sphere(0.1), centre)) == pytest.approx(max(0.0, expect), abs=1e-12)


@pytest.mark.parametrize("other", ["box", "cylinder", "hull", "capsule"])
def test_a_cylinder_pair_lies_between_its_inscribed_and_circumscribed_prisms(other, rng):
    """Depth grows with the solid (A in A' gives depth(A) <= depth(A')), so a cylinder's depth
    lies between those of the n-gon prisms inscribed in it and drawn about it (circumradius
    r / cos(pi / n)), hulls measured exactly; the local search must land in that interval
    (it bounds the depth from above, so it may not fall below the inner prism)."""
    n = 32 if other == "cylinder" else 64  # two fine prisms cost (3n)^2 edge pairs
    r, h = 0.1, 0.15
    inner, outer = Hull(prism(n, r, h)), Hull(prism(n, r / math.cos(math.pi / n), h))
    shapes = {"box": Box((0.12, 0.08, 0.1)), "cylinder": Cylinder(0.08, 0.1), "hull": Hull(prism(5, 0.1, 0.08)),
              "capsule": Capsule(0.05, 0.1)}
    found = 0
    for _ in range(6):
        pose = dict(position=rng.normal(size=3) * 0.1, orientation=unit_quaternion(rng))
        b = _body("b", shapes[other], pose["position"] + rng.normal(size=3) * 0.08, unit_quaternion(rng))
        lo = penetration(_body("a", inner, **pose), b if other != "cylinder" else
                         _body("b", Hull(prism(n, 0.08, 0.1)), b.position, b.orientation))
        hi = penetration(_body("a", outer, **pose), b if other != "cylinder" else
                         _body("b", Hull(prism(n, 0.08 / math.cos(math.pi / n), 0.1)), b.position, b.orientation))
        depth = penetration(_body("a", Cylinder(r, h), **pose), b)
        assert lo - 1e-12 <= depth <= hi + 1e-12, (lo, depth, hi)  # round-off of the supports
        found += depth > 0
    assert found >= 3  # the poses exercise overlapping pairs
    assert not exact("cylinder", other) and exact("cylinder", "sphere") and exact("cylinder", "plane")


def test_a_flat_mesh_ground_overlaps_as_the_plane(rng):
    """A body over the inside of a flat two-triangle ground, away from its diagonal, sinks
    into it as into the plane z = 0."""
    floor = _body("floor", Mesh([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], [(0, 1, 2), (0, 2, 3)]), (0, 0, 0),
                  static=True)
    plane = ground()
    shapes = [Sphere(0.1), Box((0.1, 0.05, 0.08)), Capsule(0.05, 0.1), Cylinder(0.06, 0.1), Hull(prism(6, 0.1, 0.05))]
    for shape in shapes:
        for depth in (0.0, 0.01):
            q = unit_quaternion(rng)
            body = _body("x", shape, (0.8, -0.8, 0.0), q)  # find its lowest point, then place it
            below = penetration(body, plane)
            body = _body("x", shape, (0.8, -0.8, below - depth), q)
            assert penetration(body, plane) == pytest.approx(depth, abs=1e-12)
            assert penetration(body, floor) == pytest.approx(depth, abs=1e-9), shape.kind


def test_the_start_check_refuses_what_it_cannot_vouch_for_and_passes_contact():
    box = Body("box", Box((0.5, 0.5, 0.1)), static=True)
    lying = quat_about_y(math.pi / 2)  # the cylinder's axis along x: it touches the box along a line
    Scene(bodies=(box, Body("c", Cylinder(0.05, 0.2), mass=1.0, position=(0, 0, 0.15), orientation=lying)))
    with pytest.raises(SceneError, match=r"'box' and 'c' start 0.001 m inside each other \(at most: .*"
                                         r"box-cylinder pair's depth from above\): allowed_overlap is 1e-06 m"):
        Scene(bodies=(box, Body("c", Cylinder(0.05, 0.2), mass=1.0, position=(0, 0, 0.149), orientation=lying)))
    with pytest.raises(SceneError, match=r"'ground' and 'h' start 0.02 m inside each other: allowed"):
        Scene(bodies=(ground(), Body("h", Hull(CUBE), mass=1.0, position=(0, 0, 0.08))))
    Scene(bodies=(ground(), Body("p", Polygon(SQUARE), mass=1.0, position=(0, 0, 0.1))), dimension=2)


def test_polygons_overlap_as_rects_in_2d(rng):
    for _ in range(30):
        a, c = rng.uniform(0.05, 0.2, 2)
        corners = [(a, c), (-a, c), (-a, -c), (a, -c)]
        pose = dict(position=(rng.normal() * 0.2, 0.0, rng.normal() * 0.2), orientation=quat_about_y(rng.uniform(0, 6)))
        other = _body("o", rng.choice([Circle(0.1), Rect((0.1, 0.15))]), (rng.normal() * 0.2, 0.0, rng.normal() * 0.2),
                      quat_about_y(rng.uniform(0, 6)))
        assert penetration(_body("p", Polygon(corners), **pose), other) == \
            pytest.approx(penetration(_body("r", Rect((a, c)), **pose), other), abs=1e-12)


# --- engines --------------------------------------------------------------------------------

NEW_SHAPES = {"capsule": Capsule(0.05, 0.1), "cylinder": Cylinder(0.05, 0.1), "hull": Hull(CUBE),
              "mesh": Mesh(GROUND, [(0, 1, 2), (0, 2, 3)]), "polygon": Polygon(SQUARE)}


def _scene_with(kind: str) -> Scene:
    shape = NEW_SHAPES[kind]
    if kind == "mesh":
        return Scene(bodies=(Body("floor", shape, static=True), Body("b", Sphere(0.1), mass=1.0, position=(0, 0, 0.1))))
    return Scene(bodies=(ground(), Body("b", shape, mass=1.0, position=(0, 0, 0.5))),
                 dimension=shape.dimension)


def test_every_engine_declares_known_shapes_and_reports_the_others_unsupported_with_its_reason():
    """A shape an engine does not represent, in a scene of a dimension it runs, is refused
    with the engine's reason for it (Capabilities.why_not), never a bare refusal."""
    from adapters import registry
    for name in registry.engine_names():
        try:
            caps = registry.get(name).capabilities
        except registry.EngineError:
            continue  # not installed here: its declaration is checked where it is
        assert set(caps.shapes) <= set(SHAPE_KINDS), name
        for kind in set(NEW_SHAPES) - set(caps.shapes):
            scene = _scene_with(kind)
            if scene.dimension in caps.dimensions:
                why = dict(caps.why_not).get(kind)
                assert why, f"{name} declares no reason for lacking {kind} (Capabilities.why_not)"
                assert caps.cannot_run(scene) == f"shape {kind} not available in this engine: {why}", name


def test_a_shape_reason_is_for_a_shape_the_engine_lacks():
    from adapters.base import Capabilities
    caps = dict(dimensions=frozenset({3}), shapes=frozenset({"sphere", "plane"}), native_restitution=True,
                static_kinetic=True, contact_forces=True, iterations=True)
    assert Capabilities(**caps, why_not=(("capsule", "no capsule collider"),)).why_not
    with pytest.raises(ValueError, match="why_not"):
        Capabilities(**caps, why_not=(("sphere", "a shape it has"),))


@pytest.mark.parametrize("kind", sorted(NEW_SHAPES))
def test_the_reference_engine_builds_the_shapes_it_declares_and_refuses_the_others(kind):
    """A shape the reference declares builds and steps; one it does not is refused by name.
    (It skipped every shape it came to map: a check of four parameters that could not fail.)"""
    from adapters.reference_engine import ReferenceAdapter
    adapter = ReferenceAdapter()
    if kind not in adapter.capabilities.shapes:
        with pytest.raises(Unsupported, match=f"shape {kind} not available"):
            adapter.build(_scene_with(kind), Settings(dt=1e-3))
        return
    with adapter.build(_scene_with(kind), Settings(dt=1e-3)) as sim:
        sim.step()
        assert np.all(np.isfinite(sim.states()["b"])), kind


def test_capabilities_name_only_shapes_of_the_vocabulary():
    with pytest.raises(ValueError, match=r"shapes = \['convex'\]: must be among sphere, box"):
        Capabilities(dimensions=frozenset({3}), shapes=frozenset({"sphere", "convex"}), native_restitution=True,
                     static_kinetic=True, contact_forces=True, iterations=False)
