"""The narrow-phase family's grader (cases/narrow_phase.py) and its reading
(physval/readings/narrow_phase.py), without an engine: the footprint geometry on cases
worked by hand, the catalogue's exact values from the poses, the observer on points that
are right and on points that are each wrong in one way, and the report section. Every test
runs in milliseconds; the family itself runs on every engine in tests/test_cases.py."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from cases import narrow_phase as nph
from cases.scene import Body, Box, Hull
from cases.trajectory import ContactPoint, Trajectory
from physval.readings import narrow_phase as reading


def test_distance_to_a_convex_footprint():
    square = nph.hull_2d(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]]))
    assert len(square) == 4  # the inner point is no corner
    assert nph.to_convex(np.array([0.3, 0.7]), square) == 0.0
    assert nph.to_convex(np.array([2.0, 0.5]), square) == pytest.approx(1.0)
    assert nph.to_convex(np.array([2.0, 2.0]), square) == pytest.approx(math.sqrt(2.0))
    segment = nph.hull_2d(np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.0]]))
    assert len(segment) == 2
    assert nph.to_convex(np.array([0.5, 0.3]), segment) == pytest.approx(0.3)
    assert nph.to_convex(np.array([-0.4, 0.3]), segment) == pytest.approx(0.5)
    assert nph.to_convex(np.array([1.0, 1.0]), nph.hull_2d(np.array([[1.0, 2.0]]))) == pytest.approx(1.0)


def _corner_heights(body: Body) -> np.ndarray:
    R = Rotation.from_quat(np.roll(body.orientation, -1)).as_matrix()
    return (np.asarray(body.shape.vertices) @ R.T + body.position)[:, 2]


@pytest.mark.parametrize("name", ["hull-face", "hull-edge", "hull-vertex"])
def test_hull_poses_overlap_by_their_depth(name):
    """The top cube's lowest corners lie `depth` below the base's top face: four of them
    for a face, two for an edge, one for a vertex (the pose's rotation is right)."""
    pair = nph.CATALOGUE[name]
    z = np.sort(_corner_heights(pair.top))
    lowest = {"hull-face": 4, "hull-edge": 2, "hull-vertex": 1}[name]
    assert z[:lowest] == pytest.approx(np.full(lowest, pair.surface - pair.depth), abs=1e-12)
    assert z[lowest] > pair.surface - pair.depth + 0.1


def test_every_pair_overlaps_along_its_normal_by_its_depth():
    """The top body's support along -n reaches `depth` below the base's surface, computed
    from the shapes' own geometry (capsules and spheres by their radius, cylinders by their
    rim, boxes and hulls by their corners)."""
    for name, pair in nph.CATALOGUE.items():
        n, top = np.asarray(pair.n), pair.top
        R = Rotation.from_quat(np.roll(top.orientation, -1)).as_matrix()
        s = top.shape
        if hasattr(s, "vertices"):
            low = float(((np.asarray(s.vertices) @ R.T + top.position) @ n).min())
        elif type(s).__name__ == "Sphere":
            low = float(np.dot(top.position, n)) - s.radius
        else:  # capsule: axis ends less the radius; cylinder: its end disc's rim or its side
            axis = R[:, 2]
            ends = [np.asarray(top.position) + k * s.half_length * axis for k in (-1, 1)]
            if type(s).__name__ == "Capsule":
                low = min(float(np.dot(e, n)) for e in ends) - s.radius
            else:
                across = math.sqrt(max(0.0, 1.0 - float(np.dot(axis, n)) ** 2))
                low = min(float(np.dot(e, n)) for e in ends) - s.radius * across
        assert low == pytest.approx(pair.surface - pair.depth, abs=1e-12), name


def _points(pair, xs, depth=None, n=None, a="top"):
    depth = pair.depth if depth is None else depth
    n = np.asarray(pair.n if n is None else n, float)
    return [ContactPoint(a, "base" if a == "top" else "top", np.asarray(x, float), n if a == "top" else -n, 1.0,
                         np.zeros(3), -depth) for x in xs]


def _observe(pair_name, points):
    traj = Trajectory(dt=nph.DT, t=np.array([0.0, nph.DT]), states={}, points=points)
    return nph.observe(traj, {"pair": pair_name})


def _judge(pair_name, measured):
    return {c.metric: abs(measured[c.metric] - c.expected) <= c.tolerance for c in nph.expect({"pair": pair_name}, nph.DT)}


def test_the_exact_points_pass_and_each_wrong_point_fails():
    """Points at the footprint's corners, midway through the overlap, pass every check
    whichever body the engine names first; then one thing wrong at a time."""
    face = nph.CATALOGUE["hull-face"]
    mid = [np.array(c) - 0.5 * face.depth * np.asarray(face.n) for c in face.corners]
    for a in ("top", "base"):
        assert all(_judge("hull-face", _observe("hull-face", _points(face, mid, a=a))).values())
    tilted = (math.sin(2e-3), 0.0, math.cos(2e-3))
    assert _judge("hull-face", _observe("hull-face", _points(face, mid, n=tilted))) == {
        "normal_error": False, "depth": True, "point_offset": True, "uncovered": True}
    assert not _judge("hull-face", _observe("hull-face", _points(face, mid, depth=face.depth + 2e-3)))["depth"]
    outside = mid[:3] + [mid[3] + np.array([-1e-3, 0.0, 0.0])]
    got = _judge("hull-face", _observe("hull-face", _points(face, outside)))
    assert not got["point_offset"] and got["uncovered"]
    # one point at the centre of the face contact: in the region, but spans nothing
    got = _judge("hull-face", _observe("hull-face", _points(face, [np.mean(mid, axis=0)])))
    assert got["point_offset"] and not got["uncovered"]
    assert _observe("hull-face", [])["depth"] == math.inf


def test_a_disc_is_carried_by_a_rim_polygon_around_its_centre():
    """The cylinder on its end: three rim points around the centre carry it; two rim
    points on a chord beside the centre do not."""
    disc = nph.CATALOGUE["box-cylinder-end"]
    c, r = np.asarray(disc.corners[0]), disc.radius
    rim = [c + r * np.array([math.cos(a), math.sin(a), 0.0]) for a in (0.0, 2.1, 4.2)]
    assert all(_judge("box-cylinder-end", _observe("box-cylinder-end", _points(disc, rim))).values())
    chord = [c + r * np.array([math.cos(a), math.sin(a), 0.0]) for a in (0.3, 1.2)]
    got = _judge("box-cylinder-end", _observe("box-cylinder-end", _points(disc, chord)))
    assert got["point_offset"] and not got["uncovered"]
    beyond = [c + 1.01 * r * np.array([1.0, 0.0, 0.0])]
    assert _observe("box-cylinder-end", _points(disc, beyond))["point_offset"] == pytest.approx(0.01 * r)


def test_points_of_another_pair_are_not_read():
    face = nph.CATALOGUE["hull-face"]
    other = [ContactPoint("top", "ground", np.zeros(3), np.array([0.0, 0.0, 1.0]), 1.0, np.zeros(3), -0.5)]
    assert _observe("hull-face", other)["normal_error"] == math.inf
    assert nph.offset(face, np.array([0.0, 0.0, face.surface])) == 0.0


def test_the_catalogue_is_valid_scenes():
    for p in nph.FAMILY.grid:
        scene = nph.scene(p)
        assert scene.gravity == (0.0, 0.0, 0.0) and "friction" not in scene.effects
    assert isinstance(nph.CATALOGUE["hull-face"].base.shape, Hull)
    assert isinstance(nph.CATALOGUE["box-cylinder-end"].base.shape, Box)


def _rows():
    rows = []
    for engine, shift in (("exact", 0.0), ("margin", 0.04)):
        for p in ("hull-face", "sphere-capsule"):
            for c in nph.expect({"pair": p}, nph.DT):
                measured = c.expected + (shift if c.metric == "depth" else 0.0)
                error = abs(measured - c.expected)
                rows.append({"case": "narrow_phase", "engine": engine, "variant": p, "metric": c.metric,
                             "status": "pass" if error <= c.tolerance else "fail", "measured": measured,
                             "expected": c.expected, "abs_error": error, "tolerance": c.tolerance, "reason": ""})
    rows.append({"case": "narrow_phase", "engine": "flat", "variant": "hull-face", "metric": "depth",
                 "status": "unsupported", "measured": np.nan, "expected": 0.02, "abs_error": np.nan,
                 "tolerance": 1e-4, "reason": "reports no contact points"})
    return pd.DataFrame(rows)


def test_the_reading_tabulates_misses_and_draws_them(tmp_path):
    df = _rows()
    rows = reading.measure(df)
    table = reading.grid(rows).set_index("engine")
    assert table.loc["exact", "hull-face"] == "ok"
    assert table.loc["margin", "sphere-capsule"] == "**depth 0.04 FAIL**"
    assert table.loc["flat", "hull-face"] == "-"
    text = reading.section(rows, tmp_path)
    assert text.startswith("## Narrow phase against exact geometry")
    assert (tmp_path / "plots" / "narrow_phase.png").is_file()
    assert len(pd.read_csv(tmp_path / "narrow_phase.csv")) == len(rows)
    assert reading.measure(df[df.case != "narrow_phase"].assign(case="other")) is None
