"""What the Pymunk adapter makes of the shapes of the vocabulary (adapters/pymunk_engine.py):
a Polygon is a Poly of its corners with radius 0 and the scene's mass and moment.

Each test skips cleanly when pymunk is missing."""
from __future__ import annotations

import math

import numpy as np
import pytest

from adapters.base import Settings
from cases.scene import Body, Polygon, Rect, Scene, ground
from tests.shape_helpers import G, assert_same_points, landing, regular_polygon, settle


@pytest.fixture(scope="module")
def pymunk_engine():
    pytest.importorskip("pymunk")
    from adapters import pymunk_engine
    return pymunk_engine


@pytest.mark.engine("pymunk")
def test_pymunk_polygon_is_a_poly_of_its_corners(pymunk_engine):
    """A pentagon's Poly has the scene's corners in the body frame (Pymunk's (x, y) is the
    scene's (x, z)), radius 0, and the body the scene's mass and moment."""
    body = Body("p", Polygon(regular_polygon(5, 0.1)), mass=2.0, position=(0.0, 0.0, 0.5))
    scene = Scene(bodies=(ground(), body), gravity=(0, 0, 0), dimension=2)
    with pymunk_engine.PymunkAdapter().build(scene, Settings(dt=1e-3)) as sim:
        pb = sim._bodies["p"]
        (poly,) = pb.shapes
        assert poly.radius == 0.0
        assert_same_points([tuple(v) for v in poly.get_vertices()], body.shape.corners, 1e-15)
        assert pb.mass == 2.0 and pb.moment == body.principal_inertia[1]


@pytest.mark.engine("pymunk")
def test_pymunk_pentagon_rests_on_a_face_at_its_apothem(pymunk_engine):
    """A regular pentagon (circumradius 0.1 m, 2 kg) placed on a face settles at its apothem
    above the ground, less the overlap Pymunk leaves alone (collision_slop, 1e-4 m), and the
    ground carries its weight (Pymunk's impulses balance gravity to round-off)."""
    r = 0.1
    apothem = r * math.cos(math.pi / 5)
    body = Body("p", Polygon(regular_polygon(5, r)), mass=2.0, position=(0.0, 0.0, apothem))
    state, force = settle(pymunk_engine.PymunkAdapter(), body, 300, dimension=2)
    assert apothem - pymunk_engine.COLLISION_SLOP - 1e-9 <= state[2] <= apothem + 1e-9
    assert force == pytest.approx(2.0 * G, rel=1e-9)


@pytest.mark.engine("pymunk")
def test_pymunk_square_polygon_lands_as_the_rect(pymunk_engine):
    """A square given as a Polygon and as a Rect, dropped tilted and sliding: the same Poly
    but for the corner its points start at (a Poly keeps the scene's corner order,
    Poly.create_box starts at another), which orders Pymunk's sequential impulses. At 100
    sweeps the solve converges and the order no longer shows: the same trajectory to float64
    round-off (measured 1e-14; at the default 10 sweeps the resting square's velocities
    differ by 1e-4 m/s once it lies flat, the solver's unconverged residual)."""
    a = 0.1
    square = Polygon(((-a, -a), (a, -a), (a, a), (-a, a)))
    converged = Settings(dt=1e-3, iterations=100)
    as_polygon, as_rect = (landing(pymunk_engine.PymunkAdapter(), shape, 2, settings=converged)
                           for shape in (square, Rect((a, a))))
    assert np.abs(as_polygon - as_rect).max() < 1e-12
