"""The geometry-only contact read-out (Capabilities.contact_geometry: Rapier, Box2D, Box3D, PhysX and
their continuous-collision configurations), on one pair whose answer is known: two balls of
radius R (discs in 2D), one static away from the origin, the other overlapping it by DEPTH
along an oblique unit direction d, gravity off, one step. Whatever frame and sign conventions
the engine uses (which body its normal points from, the sign of its separation, anchors
relative to a body or world points, Box2D's plane being the scene's x-z), the read-out must
give: the pair's points only, each normal d from the static ball into the dynamic one, each
gap -DEPTH, each point in the overlap (on the line of centres, between the two surfaces),
and the forces NaN (not read).

Tolerance: the engines compute in float32; coordinates of about 4 m carry 4 x 6e-8 = 2.4e-7 m
each, so 2e-6 m (and 2e-6 on the unit normal) is a few of those roundings, and far below any
frame or sign error (which moves a point or a depth by centimetres, or flips the normal).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from adapters import registry
from adapters.base import Settings
from cases.scene import Body, Material, Scene, ball

R, DEPTH, DT = 0.1, 0.01, 1e-3
FLOAT32_PLACE = 2e-6  # m (and on the unit normal): the module notes


def _engines():
    return [name for name in registry.engine_names()
            if registry.available(name) and registry.get(name).capabilities.contact_geometry
            and not registry.get(name).capabilities.contact_points]


def _pair(dim: int):
    """The scene, the static ball's centre and the unit direction d from it to the other."""
    d = np.array([2.0, 3.0, 6.0]) / 7.0 if dim == 3 else np.array([0.6, 0.0, 0.8])
    base = np.array([1.0, 2.0, 3.0]) if dim == 3 else np.array([1.0, 0.0, 3.0])
    top = base + (2 * R - DEPTH) * d
    bodies = (Body("base", ball(R, dim), static=True, position=tuple(base)),
              Body("top", ball(R, dim), mass=1.0, position=tuple(float(c) for c in top)))
    scene = Scene(bodies=bodies, gravity=(0.0, 0.0, 0.0), material=Material(e=0.0, mu_s=0.0), dimension=dim,
                  allowed_overlap=DEPTH + 1e-6)
    return scene, base, d


@pytest.mark.parametrize("engine", _engines())
def test_the_geometry_read_out_maps_the_engines_frame_and_sign(engine):
    adapter = registry.get(engine)
    # each engine in its own dimension: a 3D engine's 2D disc is a body of its own (Rapier's a
    # cylinder along y, whose contact normal with another is 0.026 rad off in the plane at this
    # pose and 0.0076 rad along x: measured, an engine finding no family poses yet)
    dim = max(adapter.capabilities.dimensions)
    scene, base, d = _pair(dim)
    with adapter.build(scene, Settings(dt=DT)) as sim:
        sim.step()
        points = sim.contact_points()
    assert points, "two overlapping balls report no contact point"
    for p in points:
        assert {p.a, p.b} == {"base", "top"}
        n = np.asarray(p.n, float) * (1.0 if p.a == "top" else -1.0)  # from the static ball into the dynamic one
        assert np.allclose(n, d, atol=FLOAT32_PLACE), f"normal {n}, but should be {d}"
        assert p.gap == pytest.approx(-DEPTH, abs=FLOAT32_PLACE), f"gap {p.gap}, but should be {-DEPTH}"
        r = np.asarray(p.x, float) - base
        along = float(r @ d)
        assert R - DEPTH - FLOAT32_PLACE <= along <= R + FLOAT32_PLACE, \
            f"point {p.x} lies {along} m along d from the static centre, outside the overlap [{R - DEPTH}, {R}]"
        if dim == 3:
            assert np.linalg.norm(r - along * d) <= FLOAT32_PLACE, f"point {p.x} is off the line of centres"
        else:
            assert abs(r[0] * d[2] - r[2] * d[0]) <= FLOAT32_PLACE, f"point {p.x} is off the line of centres"
        assert math.isnan(p.f_n) and np.all(np.isnan(p.f_t)), "a geometry-only read-out gives no forces"


def test_box2d_refuses_to_read_a_contact_that_persists():
    """pyb2d3 gives a manifold only in the step its contact begins: after a second step the
    read-out says so rather than report a stale manifold or leave the contact out."""
    if not registry.available("box2d"):
        pytest.skip("pyb2d3 is not installed")
    from adapters.box2d_engine import ContactGeometryUnavailable
    scene, _, _ = _pair(2)
    with registry.get("box2d").build(scene, Settings(dt=DT)) as sim:
        sim.step()
        assert sim.contact_points()
        sim.step()
        with pytest.raises(ContactGeometryUnavailable, match="persist"):
            sim.contact_points()


def test_a_family_reading_forces_at_points_is_unsupported_where_only_the_geometry_is_reported():
    """contact_points implies contact_geometry; contact_geometry alone runs the geometry
    families (narrow_phase, broad_phase) and not those that read the points' forces."""
    from adapters.base import Capabilities
    scene, _, _ = _pair(3)
    base = dict(dimensions=frozenset({3}), shapes=frozenset({"sphere"}), native_restitution=True,
                static_kinetic=False, contact_forces=True, iterations=True)
    full, geometry, none = (Capabilities(**base, contact_points=True), Capabilities(**base, contact_geometry=True),
                            Capabilities(**base))
    reads_geometry, reads_forces = frozenset({"contact_geometry"}), frozenset({"contact_points"})
    assert full.cannot_run(scene, reads_geometry) is None and full.cannot_run(scene, reads_forces) is None
    assert geometry.cannot_run(scene, reads_geometry) is None
    assert "geometry but not their forces" in geometry.cannot_run(scene, reads_forces)
    assert "does not report" in none.cannot_run(scene, reads_geometry)
    assert "contact_geometry" in geometry.describe() and "contact_geometry" not in full.describe()
