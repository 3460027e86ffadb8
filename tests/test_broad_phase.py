"""The broad-phase family's plan (cases/broad_phase.py) from the lattice's geometry, and the
reference's sort-and-sweep broad phase (reference_impl/broadphase.py) against it: the
planned pairs are exactly those that overlap, by DEPTH, every other pair is at least GAP
apart, and the sweep's candidates at margin 0 are exactly the plan, at the default and at
the thousand-body scale."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from cases import broad_phase as bp
from reference_impl.broadphase import candidate_pairs
from reference_impl.geometry import Sphere
from reference_impl.rigid_body import RigidBody

VARIANTS = bp.FAMILY.grid + bp.FAMILY.full_grid


def surface_gaps(p) -> dict[tuple[int, int], float]:
    """Every pair's surface distance (negative: overlap), from the centres alone."""
    x = bp.centres(p)
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=2) - 2 * bp.R
    i, j = np.triu_indices(len(x), 1)
    return dict(zip(zip(i.tolist(), j.tolist()), d[i, j].tolist()))


@pytest.mark.parametrize("p", bp.FAMILY.grid, ids=bp.FAMILY.variant_id)
def test_the_planned_pairs_are_those_that_overlap_and_the_rest_are_a_gap_apart(p):
    gaps = surface_gaps(p)
    overlapping = {pair for pair, g in gaps.items() if g < 0}
    assert {frozenset(map(bp.name, pair)) for pair in overlapping} == bp.planned(p)
    assert all(g == pytest.approx(-bp.DEPTH, abs=1e-12) for pair, g in gaps.items() if pair in overlapping)
    assert min(g for pair, g in gaps.items() if pair not in overlapping) == pytest.approx(bp.GAP, abs=1e-12)


@pytest.mark.parametrize("p", VARIANTS, ids=bp.FAMILY.variant_id)
def test_the_lattice_has_its_bodies_and_half_as_many_planned_pairs(p):
    n = int(np.prod(bp.counts(p)))
    assert len(bp.centres(p)) == n and len(bp.planned(p)) == n // 2
    assert n >= 1000 or p in bp.FAMILY.grid  # the full grid is the scale the family is about


@pytest.mark.parametrize("p", VARIANTS, ids=bp.FAMILY.variant_id)
def test_the_reference_sweep_finds_exactly_the_planned_pairs(p):
    bodies = [RigidBody(bp.name(k), Sphere(bp.R), bp.MASS, (1.0, 1.0, 1.0), x=tuple(map(float, x)))
              for k, x in enumerate(bp.centres(p))]
    found = {frozenset((bodies[i].name, bodies[j].name)) for i, j in candidate_pairs(bodies, 0.0)}
    assert found == bp.planned(p)
    # a margin short of the gap adds nothing; one past it adds the neighbours across the gaps
    assert {frozenset((bodies[i].name, bodies[j].name))
            for i, j in candidate_pairs(bodies, 0.99 * bp.GAP)} == bp.planned(p)
    assert len(candidate_pairs(bodies, 1.01 * bp.GAP)) > len(bp.planned(p))


def test_the_gap_exceeds_every_declared_margin():
    """The gap is wider than the largest contact margin or speculative distance the engines
    declare (Box2D's and Box3D's 2 cm, four linear slops), so a reported separated pair is a
    phantom (module notes)."""
    assert bp.GAP > 4 * 0.005


class _Point:
    def __init__(self, a, b, gap):
        self.a, self.b, self.gap = a, b, gap


class _Trajectory:
    def __init__(self, points):
        self._points = points

    def last_points(self):
        return self._points


def test_the_observer_counts_missed_and_phantom_pairs_and_reads_the_depth():
    p = bp.FAMILY.grid[0]
    plan = sorted(tuple(sorted(pair)) for pair in bp.planned(p))
    exact = [_Point(a, b, -bp.DEPTH) for a, b in plan]
    assert bp.observe(_Trajectory(exact), p) == {"missed": 0.0, "phantom": 0.0, "depth": 0.0}
    apart = next((a, b) for a, b in itertools.combinations(map(bp.name, range(8)), 2)
                 if frozenset((a, b)) not in bp.planned(p))
    wrong = exact[1:] + [_Point(*apart, 0.0), _Point(plan[1][1], plan[1][0], -bp.DEPTH - 4e-3)]
    assert bp.observe(_Trajectory(wrong), p) == pytest.approx({"missed": 1.0, "phantom": 1.0, "depth": 4e-3})
    assert bp.observe(_Trajectory([]), p)["depth"] == np.inf
