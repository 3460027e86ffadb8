"""adapters.impulse_split: the contact impulses Box2D's and Box3D's adapters read from the
bodies' momenta, split over the touching pairs with the pairs' normals. Hand-worked
configurations, each with its closed form."""
from __future__ import annotations

import math

import numpy as np
import pytest

from adapters.impulse_split import split_impulses

G, DT, M = 9.81, 1e-3, 1.0
W = M * G * DT  # the weight's impulse in a step, N s


def _groove(alpha: float, dim: int):
    """A ball at rest in a V-groove of two planes tilted +-alpha: J = (0, W) taken from
    both faces; normals from each face into the ball."""
    up = [0.0] * (dim - 1) + [W]
    n_left = (math.sin(alpha), 0.0, math.cos(alpha)) if dim == 3 else (math.sin(alpha), math.cos(alpha))
    n_right = (-math.sin(alpha), 0.0, math.cos(alpha)) if dim == 3 else (-math.sin(alpha), math.cos(alpha))
    pairs = [("ball", "left"), ("ball", "right")]
    return {"ball": up}, pairs, {pairs[0]: n_left, pairs[1]: n_right}


@pytest.mark.parametrize("dim", (2, 3))
@pytest.mark.parametrize("alpha_deg", (10.0, 45.0, 60.0))
def test_a_frictionless_groove_gives_each_face_its_own_normal_impulse(dim, alpha_deg):
    """N n_left + N n_right = W up: N = W / (2 cos alpha) on each face, exactly, and the
    split is determined (the half-and-half split without normals reads W cos(alpha) / 2)."""
    alpha = math.radians(alpha_deg)
    J, pairs, normals = _groove(alpha, dim)
    P, open_ = split_impulses(J, pairs, normals, {p: False for p in pairs})
    for pair in pairs:
        assert np.dot(P[pair], normals[pair]) == pytest.approx(W / (2 * math.cos(alpha)), rel=1e-12)
        assert np.allclose(np.cross(P[pair], normals[pair]) if dim == 3 else
                           P[pair][0] * normals[pair][1] - P[pair][1] * normals[pair][0], 0.0, atol=1e-15)
    assert not open_


@pytest.mark.parametrize("dim", (2, 3))
def test_friction_around_a_cycle_leaves_the_split_open_and_takes_the_least_friction(dim):
    """With friction a wedged ball may be squeezed (friction carrying the difference):
    momentum does not tell; the split without friction is returned and flagged."""
    alpha = math.radians(45.0)
    J, pairs, normals = _groove(alpha, dim)
    P, open_ = split_impulses(J, pairs, normals, {p: True for p in pairs})
    for pair in pairs:
        assert np.dot(P[pair], normals[pair]) == pytest.approx(W / (2 * math.cos(alpha)), rel=1e-9)
        assert np.linalg.norm(np.asarray(P[pair]) - np.dot(P[pair], normals[pair]) * np.asarray(normals[pair])) \
            == pytest.approx(0.0, abs=1e-12)
    assert open_


def test_a_forest_is_split_uniquely_whatever_the_normals():
    """Two boxes stacked on the ground (2D), the top one also pushed sideways: each pair
    carries what the bodies above it took, its full vector (friction included)."""
    J = {"box0": (0.0, W), "box1": (0.3 * W, W)}
    pairs = [("box0", "ground"), ("box0", "box1")]
    normals = {pairs[0]: (0.0, 1.0), pairs[1]: (0.0, -1.0)}
    P, open_ = split_impulses(J, pairs, normals, {p: True for p in pairs})
    assert np.allclose(P[("box0", "ground")], (0.3 * W, 2 * W), rtol=1e-12)
    assert np.allclose(P[("box0", "box1")], (-0.3 * W, -W), rtol=1e-12)
    assert not open_


def test_a_frictionless_corner_in_3d_is_determined():
    """A ball pressed into the corner of a floor (normal z) and a wall (normal x), both
    frictionless: each takes its own component of the impulse."""
    J = {"ball": (0.4 * W, 0.0, W)}
    pairs = [("ball", "floor"), ("ball", "wall")]
    normals = {pairs[0]: (0.0, 0.0, 1.0), pairs[1]: (1.0, 0.0, 0.0)}
    P, open_ = split_impulses(J, pairs, normals, {p: False for p in pairs})
    assert np.allclose(P[("ball", "floor")], (0.0, 0.0, W), atol=1e-15)
    assert np.allclose(P[("ball", "wall")], (0.4 * W, 0.0, 0.0), atol=1e-15)
    assert not open_


def test_parallel_faces_leave_the_squeeze_open_and_take_none():
    """A ball between two frictionless parallel walls takes no sideways impulse: any equal
    pair of pushes balances; the least (none) is returned and flagged."""
    J = {"ball": (0.0, 0.0)}
    pairs = [("ball", "east"), ("ball", "west")]
    normals = {pairs[0]: (-1.0, 0.0), pairs[1]: (1.0, 0.0)}
    P, open_ = split_impulses(J, pairs, normals, {p: False for p in pairs})
    assert np.allclose(P[pairs[0]], 0.0) and np.allclose(P[pairs[1]], 0.0)
    assert open_
