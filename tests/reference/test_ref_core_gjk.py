"""The reference's GJK narrow phase (reference_impl/gjk.py): against the box-box separating
axis routine on random poses, against exact geometry on the narrow-phase family's catalogue of convex pairs
(cases/narrow_phase.py: the poses every engine is judged on), and against an independent
collision library (python-fcl: FCL's primitive routines and libccd's GJK/EPA for convex
meshes) on the same catalogue."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from adapters.reference_engine import _shape as reference_shape
from cases import narrow_phase
from physval.readings.bench import fcl_objects
from reference_impl import gjk
from reference_impl.geometry import Box, Capsule, Cylinder, Hull, Mesh, Plane, Sphere, _separating_axes, collide
from reference_impl.rigid_body import RigidBody

# GJK stops at a relative progress of 1e-12 and EPA within 1e-10 m of the boundary
# (gjk.GJK_RELATIVE, gjk.EPA_TOLERANCE); the separating axis routine is exact to
# rounding. Depths of shapes of size ~1 m then agree to EPA's tolerance plus a few
# roundings of the coordinates (1e-15 m each): 1e-9 m leaves an order of magnitude.
DEPTH_TOLERANCE = 1e-9  # m


def body(shape, x=(0.0, 0.0, 0.0), q=(1.0, 0.0, 0.0, 0.0), static=False):
    if static:
        return RigidBody("s", shape, x=x, q=q, static=True)
    return RigidBody("d", shape, 1.0, (1.0, 1.0, 1.0), x=x, q=q)


# --- GJK and the separating axis test agree on boxes (decision 11) -----------------------

quaternions = st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda q: sum(c * c for c in q) > 0.01).map(
    lambda q: tuple(c / math.sqrt(sum(c * c for c in q)) for c in q))
halves = st.tuples(*[st.floats(0.05, 1.0)] * 3)


@given(ha=halves, hb=halves, qa=quaternions, qb=quaternions,
       offset=st.tuples(*[st.floats(-1.5, 1.5)] * 3))
def test_gjk_and_separating_axes_agree_on_boxes(ha, hb, qa, qb, offset):
    """Overlapping boxes: EPA's depth is the separating axis test's least overlap (the
    minimum translation of two convex polytopes lies along a face normal or an edge
    cross product), and its normal separates them by exactly that; boxes apart: both
    say so, and GJK's distance is at least the separating axis's gap (a lower bound)."""
    A, B = body(Box(ha), q=qa), body(Box(hb), x=offset, q=qb)
    kind, sat_depth, *_ = _separating_axes(A.R, A.x, np.asarray(ha), B.R, B.x, np.asarray(hb), 0.0, False)
    depth, n, a, b = gjk.separation(gjk.convex_of(A._bodies, 0), gjk.convex_of(B._bodies, 0))
    if kind == 0:  # apart along some axis
        assert depth <= sat_depth + DEPTH_TOLERANCE, f"GJK gap {-depth}, but the separating axis's is {-sat_depth}"
        return
    assert depth == pytest.approx(sat_depth, abs=DEPTH_TOLERANCE), \
        f"EPA depth {depth}, but the separating axis test's is {sat_depth}"
    # the overlap of the two boxes' projections on n is the depth
    radius = lambda R, h: sum(h[k] * abs(float(np.dot(R[:, k], n))) for k in range(3))  # noqa: E731
    overlap = radius(A.R, ha) + radius(B.R, hb) - float(np.dot(B.x - A.x, n))
    assert overlap == pytest.approx(depth, abs=DEPTH_TOLERANCE), f"projections overlap {overlap} along n, depth {depth}"


# --- a catalogue of convex pairs at known poses --------------------------------------------
# The narrow-phase family's catalogue (cases/narrow_phase.py), so that the reference is
# checked on the very poses each engine is judged on: its bodies as the reference adapter
# builds them, its exact normal, depth and contact region (the slab `depth` thick over the
# footprint: narrow_phase.offset).



def _reference_body(b):
    """A scene body (cases.scene.Body) as the reference adapter builds it."""
    if b.static:
        return RigidBody(b.name, reference_shape(b), x=b.position, q=b.orientation, static=True)
    return RigidBody(b.name, reference_shape(b), b.mass, b.principal_inertia, x=b.position, q=b.orientation)


CATALOGUE = [(name, _reference_body(pair.base), _reference_body(pair.top), pair)
             for name, pair in narrow_phase.CATALOGUE.items()]
# A point's distance from the exact region: rounding of the coordinates (1e-9 m), but where
# the top is turned by an angle whose sine and cosine round (the corner down: atan(sqrt 2)
# about a diagonal), which moves its corner by up to 1e-6 m
PLACE = {"hull-vertex": 1e-6}


@pytest.mark.parametrize("name, A, B, pair", CATALOGUE, ids=[c[0] for c in CATALOGUE])
def test_catalogue_against_exact_geometry(name, A, B, pair):
    """Each pair's normal and depth as the geometry gives them, every point in the exact
    contact region (a rounding-level 1e-9 m; 1e-6 m for the vertex turned by an angle
    whose sine and cosine round)."""
    first, second, points = collide(A, B, 1e-9)
    sign = 1.0 if first is A else -1.0
    depth, place = pair.depth, PLACE.get(name, 1e-9)
    assert points, f"{name}: no contact, but they overlap by {depth} m"
    for p, normal, d, _ in points:
        assert np.allclose(sign * np.asarray(normal), pair.n, atol=1e-9), f"{name}: n = {normal}, but should be {pair.n}"
        assert d <= depth + DEPTH_TOLERANCE, f"{name}: depth {d} deeper than the overlap {depth}"
        assert narrow_phase.offset(pair, p) <= place, \
            f"{name}: point {p} {narrow_phase.offset(pair, p):.3g} m outside the contact region"
    assert max(d for _, _, d, _ in points) == pytest.approx(depth, abs=1e-6), f"{name}: deepest {points}"
    if pair.patch:  # a line or face contact: the points span its corners (a disc: its centre)
        assert narrow_phase.uncovered(pair, [p for p, *_ in points]) <= place, f"{name}: points {points}"


def test_line_and_face_contacts_have_their_ends():
    """A cylinder on its side touches along a line: two points, at its ends; on its end,
    a disc: at least three points around the rim, so neither rocks."""
    ground = body(Plane(), static=True)
    lying = body(Cylinder(0.1, 0.5), x=(0.0, 0.0, 0.1 - 1e-4), q=narrow_phase.ALONG_X)
    _, _, points = collide(ground, lying, 1e-9)
    assert sorted(round(p[0], 9) for p, *_ in points) == [-0.5, 0.5]
    standing = body(Cylinder(0.1, 0.5), x=(0.0, 0.0, 0.5 - 1e-4))
    _, _, points = collide(ground, standing, 1e-9)
    assert len(points) >= 3 and all(math.hypot(p[0], p[1]) == pytest.approx(0.1, abs=1e-12) for p, *_ in points)


def test_mesh_ground_is_the_plane():
    """A box resting across the two triangles of a square mesh gets the contact points a
    plane gives it (its four bottom corners, depth and normal the same)."""
    mesh = body(Mesh(((-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)), ((0, 1, 2), (0, 2, 3))), static=True)
    box = body(Box((0.5, 0.4, 0.3)), x=(0.2, -0.1, 0.3 - 1e-4), q=narrow_phase.about((0, 0, 1), 0.3))
    on_mesh = sorted((tuple(np.round(p, 9)), round(d, 12)) for p, _, d, _ in collide(mesh, box, 1e-9)[2])
    on_plane = sorted((tuple(np.round(p, 9)), round(d, 12)) for p, _, d, _ in collide(body(Plane(), static=True), box, 1e-9)[2])
    assert on_mesh == on_plane


# Poses of the sliding box of slide_to_stop[mu=0.5,v0=2,heading=22.5deg] on reference-lemke
# after 43 and 44 steps of the as_mesh relation: lying on the 100 m ground, across its diagonal
SLIDING_ON_MESH = [((0.07516671866077759, 0.03113507430837917, 0.1),
                    (1.0, -1.7170856750348124e-16, 5.3097717195305255e-17, -1.2867369929975283e-15)),
                   ((0.07681508604509352, 0.031817850434736415, 0.1),
                    (1.0, -1.7285825548718487e-16, 5.547537255956598e-17, -1.3678032231151384e-15))]


@pytest.mark.parametrize("x, q", SLIDING_ON_MESH)
def test_box_touching_a_wide_ground_triangle_gets_its_normal(x, q):
    """A box lying exactly on (within rounding of) the invariance battery's 100 m mesh
    ground, across its diagonal: every point has the ground's normal, and the points are
    the box's four bottom corners, as on the plane. GJK on the sliver simplices of a 100 m
    triangle and a 0.2 m box ran out of passes with 1.4e-9 and 8.4e-9 m of rounding left in
    its closest point, pointing across the ground, and that direction became a speculative
    contact's normal: Lemke's exact solve obeyed it and spun the box (invariance_as_mesh
    0.90 of scale on reference-lemke)."""
    h = 50.0
    mesh = body(Mesh(((h, -h, 0.0), (h, h, 0.0), (-h, h, 0.0), (-h, -h, 0.0)), ((0, 1, 2), (0, 2, 3))), static=True)
    box = body(Box((0.1, 0.1, 0.1)), x=x, q=q)
    margin = 1e-4 + 2.1e-3  # the world's margin plus the box's reach in a step at 2 m/s
    _, _, on_mesh = collide(mesh, box, margin)
    _, _, on_plane = collide(body(Plane(), static=True), box, margin)
    assert all(np.allclose(n, (0.0, 0.0, 1.0), atol=1e-12) for _, n, _, _ in on_mesh), \
        [n for _, n, _, _ in on_mesh]
    corners = sorted(tuple(np.round(p[:2], 9)) for p, *_ in on_plane)
    assert sorted(tuple(np.round(p[:2], 9)) for p, *_ in on_mesh) == corners


def test_mesh_tree_finds_only_triangles_under_the_box():
    """The bounding-volume tree of a 20 x 20 grid of squares returns every triangle whose
    box meets the query box (checked against every triangle's box), and besides them only
    their leaf-mates (a leaf holds gjk.LEAF_SIZE triangles: within one 1 m cell of it)."""
    k = 20
    V = [(float(i), float(j), 0.0) for j in range(k + 1) for i in range(k + 1)]
    T = [t for j in range(k) for i in range(k) for t in (
        (j * (k + 1) + i, j * (k + 1) + i + 1, (j + 1) * (k + 1) + i + 1),
        (j * (k + 1) + i, (j + 1) * (k + 1) + i + 1, (j + 1) * (k + 1) + i))]
    corners, nodes = gjk.build_bvh(np.array(V), np.array(T))
    lo, hi = np.array([3.5, 7.2, -0.1]), np.array([5.1, 8.9, 0.1])
    found = set(gjk.mesh_candidates(nodes, lo, hi).tolist())
    boxes = corners.reshape(-1, 3, 3)
    meets = {t for t in range(len(boxes)) if np.all(boxes[t].min(axis=0) <= hi) and np.all(boxes[t].max(axis=0) >= lo)}
    near = {t for t in range(len(boxes)) if np.all(boxes[t].min(axis=0) <= hi + 1.0)
            and np.all(boxes[t].max(axis=0) >= lo - 1.0)}
    assert meets <= found <= near and 0 < len(found) < len(T) // 10


# --- the same catalogue against an independent library ---------------------------------------

# FCL's contact for a pair: its primitive routines (sphere-capsule, box-box, ...) are
# exact to rounding, libccd's EPA (convex meshes, cylinders) stops within its tolerance
# (1e-6, FCL's GJKSolver_libccd): depths agree to that; its normal for a flat contact is
# the face's, for a curved one the direction between the deepest points, within
# sqrt(2 * 1e-6 / 0.1 m) ~ 5e-3 of the true one (a support point off by 1e-6 m on a
# curvature radius of 0.1 m); its one point is a point of the overlap, which is `depth`
# thick along n: the reference's midway points lie within depth of it along n.
FCL_DEPTH = 1e-6  # m
FCL_NORMAL = 5e-3


@pytest.mark.parametrize("name, A, B, pair", CATALOGUE, ids=[c[0] for c in CATALOGUE])
def test_catalogue_against_fcl(name, A, B, pair):
    fcl = pytest.importorskip("fcl", reason="python-fcl (the test extra) is not installed")
    request = fcl.CollisionRequest(enable_contact=True, num_max_contacts=8)
    result = fcl.CollisionResult()
    assert fcl.collide(*fcl_objects(pair), request, result) > 0, f"{name}: FCL finds no contact"
    first, _, points = collide(A, B, 1e-9)
    sign = 1.0 if first is A else -1.0
    ours_n = sign * np.asarray(points[0][1])
    ours_depth = max(d for _, _, d, _ in points)
    theirs = max(result.contacts, key=lambda c: c.penetration_depth)
    assert theirs.penetration_depth == pytest.approx(ours_depth, abs=FCL_DEPTH), \
        f"{name}: depth {ours_depth}, but FCL's is {theirs.penetration_depth}"
    assert np.linalg.norm(np.asarray(theirs.normal) - ours_n) <= FCL_NORMAL, \
        f"{name}: n = {ours_n}, but FCL's is {theirs.normal}"
    ours = np.array([p for p, *_ in points])
    along = (np.asarray(theirs.pos) - ours) @ ours_n
    assert np.min(np.abs(along)) <= ours_depth + FCL_DEPTH, f"{name}: FCL's point {theirs.pos} off our contact plane"
    if len(ours) == 1:  # one point: FCL's lies on the segment through it along n
        across = (np.asarray(theirs.pos) - ours[0]) - along[0] * ours_n
        assert np.linalg.norm(across) <= FCL_DEPTH + FCL_NORMAL * pair.depth, f"{name}: FCL's point {theirs.pos}, ours {ours[0]}"
