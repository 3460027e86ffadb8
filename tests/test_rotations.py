"""The quaternion helpers cases and adapters share (cases/rotations.py), against each other
and a known turn: the conjugate of a unit quaternion undoes its turn, and one quaternion
gives, bit for bit, what each row of many gives."""
from __future__ import annotations

import math

import numpy as np

from cases.rotations import conjugate, multiply, rotate

# unit quaternions (w, x, y, z): identity, a half turn about x, and two general turns
TURNS = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0],
                  [0.5, 0.5, -0.5, 0.5], [0.8, 0.0, 0.36, -0.48]])
V = np.array([[0.3, -1.2, 2.0], [1.0, 0.0, 0.0], [0.0, 2.5, -0.7], [-0.4, 0.9, 1.1]])


def test_the_conjugate_undoes_the_turn_of_one_quaternion_or_many():
    # round-off of a few products of numbers near 1 (a few 1e-16)
    assert np.allclose(rotate(conjugate(TURNS), rotate(TURNS, V)), V, rtol=0, atol=1e-14)
    assert np.allclose(multiply(TURNS, conjugate(TURNS)), [1.0, 0.0, 0.0, 0.0], rtol=0, atol=1e-14)
    for i, q in enumerate(TURNS):  # one quaternion as a list: the row of the many
        assert np.array_equal(conjugate(list(q)), conjugate(TURNS)[i])
    assert conjugate([0.5, 0.5, -0.5, 0.5]).tolist() == [0.5, -0.5, 0.5, -0.5]


def test_one_quaternion_turns_and_multiplies_as_each_row_of_many_does():
    for i, q in enumerate(TURNS):
        assert np.array_equal(rotate(q, V), rotate(np.repeat(q[None], len(V), 0), V))
        assert np.array_equal(multiply(q, TURNS), np.stack([multiply(q, t) for t in TURNS]))
        assert np.array_equal(multiply(TURNS, q)[i], multiply(TURNS[i], q))


def test_a_quarter_turn_about_z_takes_x_to_y_and_two_make_a_half_turn():
    c = math.cos(math.pi / 4)
    quarter = np.array([c, 0.0, 0.0, c])
    assert np.allclose(rotate(quarter, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], rtol=0, atol=1e-15)
    assert np.allclose(multiply(quarter, quarter), [0.0, 0.0, 0.0, 1.0], rtol=0, atol=1e-15)
    # p q is the turn q first: a quarter about z, then a half about x, takes x to -y
    half_x = np.array([0.0, 1.0, 0.0, 0.0])
    assert np.allclose(rotate(multiply(half_x, quarter), [1.0, 0.0, 0.0]), [0.0, -1.0, 0.0], rtol=0, atol=1e-15)
