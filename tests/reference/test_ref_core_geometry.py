"""Narrow phase of reference_impl against depths, normals and points derived by hand."""
from __future__ import annotations

import math

import pytest

from reference_impl.geometry import Box, Circle, Plane, Rect, Sphere, collide, is_edge_feature
from reference_impl.rigid_body import RigidBody

MARGIN = 1e-9  # contacts only when touching, for these checks
S2 = math.sqrt(2.0)


def body(shape, x=(0.0, 0.0, 0.0), q=(1.0, 0.0, 0.0, 0.0), static=False, planar=False):
    if static:
        return RigidBody("s", shape, x=x, q=q, static=True, planar=planar)
    return RigidBody("d", shape, 1.0, (1.0, 1.0, 1.0), x=x, q=q, planar=planar)


def about(axis: str, angle: float):
    """Quaternion (w, x, y, z) for a rotation by `angle` about a coordinate axis."""
    c, s = math.cos(angle / 2), math.sin(angle / 2)
    return {"x": (c, s, 0.0, 0.0), "y": (c, 0.0, s, 0.0), "z": (c, 0.0, 0.0, s)}[axis]


def ground(normal=(0.0, 0.0, 1.0), offset=0.0, planar=False):
    return body(Plane(normal, offset), static=True, planar=planar)


def points_of(A, B, margin=MARGIN):
    first, second, points = collide(A, B, margin)
    return first, second, points


def close(a, b, tol=1e-12):
    return all(abs(x - y) <= tol for x, y in zip(a, b))


def same_point_sets(found, expected, tol=1e-12):
    left = list(found)
    for p in expected:
        match = [q for q in left if close(q, p, tol)]
        assert match, f"point {p} missing, got {found}"
        left.remove(match[0])
    assert not left, f"extra points {left}"


# --- round shapes ----------------------------------------------------------------------

def test_sphere_on_plane_overlaps_by_radius_minus_height():
    A, B = ground(), body(Sphere(0.1), x=(0.3, -0.2, 0.09))
    first, second, [(p, n, depth, _)] = points_of(A, B)
    assert (first, second) == (A, B)
    assert depth == pytest.approx(0.01, abs=1e-15)
    assert n == (0.0, 0.0, 1.0)
    assert close(p, (0.3, -0.2, -0.005))  # midway between the sphere's lowest point and the plane


def test_sphere_on_tilted_plane_measures_along_the_plane_normal():
    a = math.radians(30)
    n_plane = (math.sin(a), 0.0, math.cos(a))
    A, B = ground(n_plane, 0.05), body(Sphere(0.1), x=(0.0, 0.0, 0.15))
    _, _, [(p, n, depth, _)] = points_of(B, A)  # either order: the normal leaves the plane
    # distance of the centre above the plane: n . c - offset = 0.15 cos 30 - 0.05
    assert depth == pytest.approx(0.1 - (0.15 * math.cos(a) - 0.05), abs=1e-15)
    assert close(n, n_plane)


def test_spheres_overlap_along_the_line_of_centres():
    A, B = body(Sphere(0.1)), body(Sphere(0.2), x=(0.15, 0.05, 0.0))
    _, _, [(p, n, depth, _)] = points_of(A, B)
    dist = math.hypot(0.15, 0.05)
    assert depth == pytest.approx(0.3 - dist, abs=1e-15)
    assert close(n, (0.15 / dist, 0.05 / dist, 0.0))
    # midway between A's surface point n * 0.1 and B's, which is depth further in
    assert close(p, tuple(c * (0.1 - depth / 2) for c in n))


def test_spheres_apart_make_no_contact_but_a_speculative_one_within_margin():
    A, B = body(Sphere(0.1)), body(Sphere(0.1), x=(0.2 + 1e-6, 0.0, 0.0))
    assert points_of(A, B)[2] == []
    _, _, [(_, _, depth, _)] = points_of(A, B, margin=1e-4)
    assert depth == pytest.approx(-1e-6, abs=1e-15)


def test_sphere_against_box_face_and_corner():
    box = body(Box((0.2, 0.2, 0.2)))
    _, _, [(p, n, depth, _)] = points_of(box, body(Sphere(0.1), x=(0.25, 0.0, 0.0)))
    assert (depth, n) == (pytest.approx(0.05), (1.0, 0.0, 0.0))
    assert close(p, (0.175, 0.0, 0.0))
    first, _, [(p, n, depth, _)] = points_of(body(Sphere(0.1), x=(0.25, 0.25, 0.25)), box)
    assert first is box  # normals point from the box to the sphere
    assert depth == pytest.approx(0.1 - 0.05 * math.sqrt(3), abs=1e-15)
    assert close(n, (1 / math.sqrt(3),) * 3)


def test_sphere_centre_inside_a_box_leaves_through_the_nearest_face():
    box = body(Box((0.2, 0.3, 0.4)))
    _, _, [(_, n, depth, _)] = points_of(box, body(Sphere(0.05), x=(0.0, 0.25, 0.1)))
    assert n == (0.0, 1.0, 0.0)
    assert depth == pytest.approx(0.05 + 0.05, abs=1e-15)  # radius + distance to the face


# --- boxes on planes -------------------------------------------------------------------

def test_flat_box_on_plane_touches_at_its_four_bottom_corners():
    A, B = ground(), body(Box((0.2, 0.1, 0.05)), x=(0.0, 0.0, 0.047))
    _, _, points = points_of(A, B)
    assert len(points) == 4
    assert {f for *_, f in points} == {0, 2, 4, 6}  # the corners with sz = -1
    for p, n, depth, _ in points:
        assert n == (0.0, 0.0, 1.0)
        assert depth == pytest.approx(0.003, abs=1e-15)
        assert p[2] == pytest.approx(-0.0015, abs=1e-15)
    same_point_sets([p[:2] for p, *_ in points], [(sx * 0.2, sy * 0.1) for sx in (-1, 1) for sy in (-1, 1)])


def test_box_rotated_about_y_touches_with_its_lowest_edge():
    # R_y(th) sends body x to (cos th, 0, -sin th) and body z to (sin th, 0, cos th): the
    # corner (+hx, +-hy, -hz) sits hx sin th + hz cos th below the centre.
    th, hx, hy, hz, zc = math.radians(30), 0.2, 0.1, 0.05, 0.14
    A, B = ground(), body(Box((hx, hy, hz)), x=(0.0, 0.0, zc), q=about("y", th))
    _, _, points = points_of(A, B)
    assert len(points) == 2
    expected_depth = hx * math.sin(th) + hz * math.cos(th) - zc
    for p, n, depth, _ in points:
        assert depth == pytest.approx(expected_depth, abs=1e-15)
        # the corner's x: hx cos th - hz sin th (body z points to +x when turned by +th)
        assert p[0] == pytest.approx(hx * math.cos(th) - hz * math.sin(th), abs=1e-15)
    assert sorted(p[1] for p, *_ in points) == pytest.approx([-hy, hy])


def test_box_above_plane_gives_no_contact():
    assert points_of(ground(), body(Box((0.1, 0.1, 0.1)), x=(0.0, 0.0, 0.1 + 1e-6)))[2] == []


# --- box against box ---------------------------------------------------------------------

def test_offset_box_on_box_clips_to_the_overlap_rectangle():
    A = body(Box((0.1, 0.1, 0.1)))
    B = body(Box((0.1, 0.1, 0.1)), x=(0.02, 0.03, 0.195))
    first, second, points = points_of(A, B)
    assert (first, second) == (A, B)
    # B's bottom face spans x in [-0.08, 0.12], y in [-0.07, 0.13]; A's top x, y in [-0.1, 0.1]
    same_point_sets([p for p, *_ in points],
                    [(x, y, 0.0975) for x in (-0.08, 0.1) for y in (-0.07, 0.1)], tol=1e-15)
    for _, n, depth, _ in points:
        assert n == (0.0, 0.0, 1.0)
        assert depth == pytest.approx(0.005, abs=1e-15)


def test_box_turned_45_degrees_on_a_box_touches_at_eight_points():
    # Two equal squares, one turned by 45 deg: B's edges |x| + |y| = 0.1 sqrt 2 cross A's
    # edges x, y = +-0.1 at the other coordinate +-(0.1 sqrt 2 - 0.1): an octagon.
    A = body(Box((0.1, 0.1, 0.1)))
    B = body(Box((0.1, 0.1, 0.1)), x=(0.0, 0.0, 0.195), q=about("z", math.pi / 4))
    _, _, points = points_of(A, B)
    assert len(points) == 8
    c = 0.1 * S2 - 0.1
    octagon = [(sx * 0.1, sy * c) for sx in (-1, 1) for sy in (-1, 1)] + \
              [(sx * c, sy * 0.1) for sx in (-1, 1) for sy in (-1, 1)]
    same_point_sets([p[:2] for p, *_ in points], octagon, tol=1e-12)
    for p, n, depth, _ in points:
        assert close(n, (0.0, 0.0, 1.0), 1e-15)
        assert depth == pytest.approx(0.005, abs=1e-12)
        assert p[2] == pytest.approx(0.0975, abs=1e-12)
    assert len({f for *_, f in points}) == 8


def test_crossed_edges_touch_at_one_point():
    # A turned 45 deg about x has a top edge along x at 0.1 sqrt 2; B turned 45 deg about y
    # has a bottom edge along y at 0.1 sqrt 2 below its centre: the edges cross over the
    # origin, overlapping by 0.2 sqrt 2 - z_B. Every face axis overlaps more (0.073 m).
    zb = 0.28
    A = body(Box((0.1, 0.1, 0.1)), q=about("x", math.pi / 4))
    B = body(Box((0.1, 0.1, 0.1)), x=(0.0, 0.0, zb), q=about("y", math.pi / 4))
    _, _, [(p, n, depth, feature)] = points_of(A, B)
    assert depth == pytest.approx(0.2 * S2 - zb, abs=1e-15)
    assert close(n, (0.0, 0.0, 1.0), 1e-15)
    assert close(p, (0.0, 0.0, 0.1 * S2 - depth / 2), 1e-15)  # midway between the edges
    assert is_edge_feature(feature)


def test_box_box_normal_points_from_first_to_second_in_either_order():
    A = body(Box((0.1, 0.1, 0.1)))
    B = body(Box((0.1, 0.1, 0.1)), x=(0.0, 0.195, 0.0), q=about("x", 0.1))
    for first, second in ((A, B), (B, A)):
        f, s, points = points_of(first, second)
        assert points
        d = [s.x[k] - f.x[k] for k in range(3)]
        for _, n, _, _ in points:
            assert sum(n[k] * d[k] for k in range(3)) > 0


def test_boxes_resting_exactly_face_to_face_keep_four_corner_features():
    # equal boxes aligned to rounding: corners, not slivers cut a rounding-level apart
    A = body(Box((0.1, 0.1, 0.1)), x=(0.0, 0.0, 0.1))
    B = body(Box((0.1, 0.1, 0.1)), x=(0.0, 0.0, 0.1 + 0.2), q=about("z", 1e-12))
    _, _, points = points_of(A, B)
    assert len(points) == 4
    tilted = body(Box((0.1, 0.1, 0.1)), x=(0.0, 0.0, 0.3), q=about("x", 1e-10))
    assert {f for *_, f in points_of(A, tilted, 1e-6)[2]} == {f for *_, f in points}


def test_separated_boxes_make_no_contact():
    A = body(Box((0.1, 0.1, 0.1)))
    assert points_of(A, body(Box((0.1, 0.1, 0.1)), x=(0.0, 0.0, 0.2 + 1e-6)))[2] == []
    # apart only along an edge axis: the crossed edges lifted by 1 mm
    A = body(Box((0.1, 0.1, 0.1)), q=about("x", math.pi / 4))
    B = body(Box((0.1, 0.1, 0.1)), x=(0.0, 0.0, 0.2 * S2 + 1e-3), q=about("y", math.pi / 4))
    assert points_of(A, B)[2] == []


# --- 2D: shapes in the x-z plane ------------------------------------------------------------

def test_circle_on_a_sloped_line():
    a = math.radians(20)
    n_line = (-math.sin(a), 0.0, math.cos(a))
    A = ground(n_line, 0.0, planar=True)
    B = body(Circle(0.1), x=(0.5, 0.0, 0.5 * math.tan(a) + 0.09 / math.cos(a)), planar=True)
    _, _, [(p, n, depth, _)] = points_of(A, B)
    assert depth == pytest.approx(0.01, abs=1e-14)
    assert close(n, n_line) and p[1] == 0.0


def test_circles_overlap_in_the_plane():
    A, B = body(Circle(0.1), planar=True), body(Circle(0.1), x=(0.12, 0.0, 0.16), planar=True)
    _, _, [(p, n, depth, _)] = points_of(A, B)
    assert depth == pytest.approx(0.2 - 0.2, abs=1e-15)
    assert close(n, (0.6, 0.0, 0.8)) and p[1] == 0.0


def test_flat_rect_on_a_line_touches_at_two_corners():
    A = ground(planar=True)
    B = body(Rect((0.2, 0.05)), x=(0.0, 0.0, 0.049), planar=True)
    _, _, points = points_of(A, B)
    assert len(points) == 2
    same_point_sets([p for p, *_ in points], [(-0.2, 0.0, -0.0005), (0.2, 0.0, -0.0005)], tol=1e-15)
    assert all(d == pytest.approx(0.001, abs=1e-15) for _, _, d, _ in points)


def test_rect_turned_about_y_touches_a_line_with_one_corner():
    th, hx, hz, zc = math.radians(30), 0.2, 0.05, 0.14
    A = ground(planar=True)
    B = body(Rect((hx, hz)), x=(0.0, 0.0, zc), q=about("y", th), planar=True)
    _, _, [(p, n, depth, _)] = points_of(A, B)
    assert depth == pytest.approx(hx * math.sin(th) + hz * math.cos(th) - zc, abs=1e-15)
    assert p[0] == pytest.approx(hx * math.cos(th) - hz * math.sin(th), abs=1e-15)
    assert p[1] == 0.0


def test_rect_on_rect_clips_to_the_shared_edge():
    A = body(Rect((0.2, 0.1)), planar=True)
    B = body(Rect((0.1, 0.1)), x=(0.15, 0.0, 0.198), planar=True)
    _, _, points = points_of(A, B)
    # B's bottom edge spans x in [0.05, 0.25], A's top edge x in [-0.2, 0.2]
    same_point_sets([p for p, *_ in points], [(0.05, 0.0, 0.099), (0.2, 0.0, 0.099)], tol=1e-15)
    for _, n, depth, _ in points:
        assert n == (0.0, 0.0, 1.0)
        assert depth == pytest.approx(0.002, abs=1e-15)


def test_rect_corner_on_a_rect_face():
    # a square turned 45 deg about y rests a corner on A's top face: one point, depth by hand
    A = body(Rect((0.2, 0.1)), planar=True)
    zb = 0.1 + 0.1 * S2 - 0.003
    B = body(Rect((0.1, 0.1)), x=(0.0, 0.0, zb), q=about("y", math.pi / 4), planar=True)
    _, _, [(p, n, depth, _)] = points_of(A, B)
    assert depth == pytest.approx(0.003, abs=1e-15)
    assert close(n, (0.0, 0.0, 1.0), 1e-15)
    assert close(p, (0.0, 0.0, 0.1 - 0.0015), 1e-15)


def test_circle_against_rect_face():
    A = body(Rect((0.2, 0.1)), planar=True)
    _, _, [(p, n, depth, _)] = points_of(A, body(Circle(0.05), x=(0.1, 0.0, 0.14), planar=True))
    assert n == (0.0, 0.0, 1.0)
    assert depth == pytest.approx(0.01, abs=1e-15)
    assert close(p, (0.1, 0.0, 0.095))
