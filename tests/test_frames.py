"""The orientation helpers adapters share (adapters/frames.py), against each other: the
conjugate of a unit quaternion undoes its turn, one quaternion or many at once."""
from __future__ import annotations

import numpy as np

from adapters.frames import conjugate, multiply_many, rotate_many

# unit quaternions (w, x, y, z): identity, a half turn about x, and two general turns
TURNS = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0],
                  [0.5, 0.5, -0.5, 0.5], [0.8, 0.0, 0.36, -0.48]])


def test_the_conjugate_undoes_the_turn_of_one_quaternion_or_many():
    v = np.array([[0.3, -1.2, 2.0], [1.0, 0.0, 0.0], [0.0, 2.5, -0.7], [-0.4, 0.9, 1.1]])
    # round-off of a few products of numbers near 1 (a few 1e-16)
    assert np.allclose(rotate_many(conjugate(TURNS), rotate_many(TURNS, v)), v, rtol=0, atol=1e-14)
    assert np.allclose(multiply_many(TURNS, conjugate(TURNS)), [1.0, 0.0, 0.0, 0.0], rtol=0, atol=1e-14)
    for i, q in enumerate(TURNS):  # one quaternion as a list: the row of the many
        assert np.array_equal(conjugate(list(q)), conjugate(TURNS)[i])
    assert conjugate([0.5, 0.5, -0.5, 0.5]).tolist() == [0.5, -0.5, 0.5, -0.5]
