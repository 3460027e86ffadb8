"""Sort-and-sweep finds exactly the pairs an all-pairs bounding-box test finds."""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings, strategies as st

from reference_impl.broadphase import candidate_pairs, overlap
from reference_impl.geometry import Box, Plane, Sphere, below_plane, bounds
from reference_impl.rigid_body import RigidBody


def random_world(seed: int, n: int):
    rng = np.random.default_rng(seed)
    bodies = []
    for k in range(n):
        x = tuple(rng.uniform(-2.0, 2.0, 3))
        q = rng.normal(size=4)
        q = tuple(q / np.linalg.norm(q))
        static = rng.random() < 0.2
        shape = Sphere(rng.uniform(0.05, 0.4)) if rng.random() < 0.5 else Box(tuple(rng.uniform(0.05, 0.4, 3)))
        if static:
            bodies.append(RigidBody(f"s{k}", shape, x=x, q=q, static=True))
        else:
            bodies.append(RigidBody(f"d{k}", shape, 1.0, (1.0, 1.0, 1.0), x=x, q=q))
    for k in range(int(rng.integers(0, 3))):
        normal = rng.normal(size=3)
        normal = tuple(normal / np.linalg.norm(normal))
        bodies.append(RigidBody(f"p{k}", Plane(normal, float(rng.uniform(-1.0, 1.0))), static=True))
    order = rng.permutation(len(bodies))
    return [bodies[i] for i in order]


def all_pairs(bodies, margin, grow):
    """O(n^2): every pair with a dynamic body whose grown boxes meet (planes: reach it)."""
    out = []
    for i in range(len(bodies)):
        for j in range(i + 1, len(bodies)):
            a, b = bodies[i], bodies[j]
            if a.static and b.static:
                continue
            ba, bb = bounds(a), bounds(b)
            if ba is None and bb is None:
                continue
            if ba is None or bb is None:
                plane, (lo, hi), k = (a, bb, j) if ba is None else (b, ba, i)
                g = grow[k]
                lo, hi = tuple(c - g for c in lo), tuple(c + g for c in hi)
                if below_plane(plane.shape, lo, hi, margin):
                    out.append((i, j))
                continue
            (lo1, hi1), (lo2, hi2) = ba, bb
            lo1, hi1 = tuple(c - grow[i] for c in lo1), tuple(c + grow[i] for c in hi1)
            lo2, hi2 = tuple(c - grow[j] for c in lo2), tuple(c + grow[j] for c in hi2)
            if overlap(lo1, hi1, lo2, hi2, margin):
                out.append((i, j))
    return out


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 60), st.sampled_from([0.0, 1e-4, 0.05]),
       st.booleans())
def test_sort_and_sweep_equals_all_pairs(seed, n, margin, grown):
    bodies = random_world(seed, n)
    rng = np.random.default_rng(seed + 1)
    grow = [float(rng.uniform(0.0, 0.1)) for _ in bodies] if grown else None
    expected = all_pairs(bodies, margin, grow or [0.0] * len(bodies))
    assert candidate_pairs(bodies, margin, grow) == expected


def test_sweep_tests_far_fewer_pairs_than_all_on_a_spread_out_row():
    # 300 unit-spaced spheres in a row: only neighbours overlap; all-pairs would test 44850
    bodies = [RigidBody(f"b{k}", Sphere(0.6), 1.0, (1.0, 1.0, 1.0), x=(float(k), 0.0, 0.0)) for k in range(300)]
    assert candidate_pairs(bodies, 0.0) == [(k, k + 1) for k in range(299)]


def test_two_static_bodies_are_never_a_pair():
    bodies = [RigidBody("a", Sphere(1.0), x=(0, 0, 0), static=True),
              RigidBody("b", Sphere(1.0), x=(0.5, 0, 0), static=True),
              RigidBody("p", Plane(), static=True)]
    assert candidate_pairs(bodies, 0.0) == []
    assert math.isfinite(bounds(bodies[0])[0][0])
