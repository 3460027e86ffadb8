"""The robustness families' closed forms and layouts, each against an independent
derivation (a direct simulation, an exhaustive enumeration or plain statics)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cases.overlap import penetration, rotation_matrix
from cases.robustness import (cradle, degenerate, free_flight_energy_tolerance, mass_ratio as ratio, overlap, stacks,
                              tunnelling, warm_start as warm)

G = 9.81


def test_warm_start_hit_time_and_lift_speed_match_a_direct_integration():
    # integrate the ball's flight with a tiny step until its top meets the plank
    dt, z, v, t = 1e-7, warm.BALL_R, warm.V0, 0.0
    plank_bottom = warm.stack_top()
    while z + warm.BALL_R < plank_bottom:
        z += v * dt + 0.5 * -G * dt * dt
        v -= G * dt
        t += dt
    assert warm.hit_time() == pytest.approx(t, abs=2e-7)
    # plastic impact of two balls (mass M each) with the plank (M, at rest): momentum only
    M = 100.0
    assert warm.lift_speed(100) == pytest.approx((2 * M * v) / (3 * M), rel=1e-6)
    # the window ends before the plank (rising at lift_speed) comes back down
    t0, t1 = warm.window({"ratio": 100})
    assert t0 < warm.hit_time() < t1 < warm.hit_time() + 2 * warm.lift_speed(100) / G


@pytest.mark.parametrize("dt", [1e-3, 5e-3])
def test_euler_free_flight_energy_drift_is_g2_dt2_over_2_per_step(dt):
    """Simulate both explicit Euler orders: position-first gains g^2 dt^2 / 2 per step in
    v^2/2 + g z, velocity-first loses as much; the tolerance bounds the gain over T."""
    n, z0 = 400, 100.0
    for first in ("position", "velocity"):
        z, v = z0, 0.0
        for _ in range(n):
            if first == "position":
                z += v * dt
                v -= G * dt
            else:
                v -= G * dt
                z += v * dt
        change = 0.5 * v * v + G * z - G * z0
        expected = (1 if first == "position" else -1) * 0.5 * G * G * dt * dt * n
        assert change == pytest.approx(expected, rel=1e-9)
    assert free_flight_energy_tolerance(1.0, G, dt, n * dt) == pytest.approx(0.5 * G * G * dt * dt * n)


@pytest.mark.parametrize("landing, lowest", [("edge", 2), ("vertex", 1)])
def test_degenerate_orientations_put_an_edge_or_a_vertex_lowest(landing, lowest):
    q = degenerate.orientation(landing)
    assert np.linalg.norm(q) == pytest.approx(1.0)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * degenerate.HALF
    z = (rotation_matrix(q) @ corners.T)[2]
    assert z.min() == pytest.approx(-degenerate.lowest_depth(landing), abs=1e-12)
    assert np.sum(np.isclose(z, z.min(), atol=1e-12)) == lowest
    # released DROP above the ground
    box = degenerate.scene({"landing": landing, "dim": 3}).body("box")
    assert box.position[2] + z.min() == pytest.approx(degenerate.DROP)


@pytest.mark.parametrize("base, dim", [(3, 2), (4, 3), (10, 3)])
def test_pyramid_rows_rest_on_the_two_boxes_below(base, dim):
    scene = stacks.scene({"structure": "pyramid", "n": base, "dim": dim, "T": 1.0})
    boxes = scene.dynamic_bodies
    assert len(boxes) == base * (base + 1) // 2 == stacks.count({"structure": "pyramid", "n": base})
    rows = {}
    for b in boxes:
        rows.setdefault(round(b.position[2], 9), []).append(b.position[0])
    heights = sorted(rows)
    for k, z in enumerate(heights[1:], start=1):
        below = sorted(rows[heights[k - 1]])
        for x in rows[z]:  # centred between two neighbours below, which do not touch each other
            gaps = [(a + b) / 2 for a, b in zip(below, below[1:])]
            assert min(abs(x - g) for g in gaps) < 1e-12
    xs = sorted(rows[heights[0]])
    assert np.diff(xs) == pytest.approx(2 * stacks.HALF + stacks.GAP)
    assert max(penetration(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:]) < 1e-12  # touching only


@pytest.mark.parametrize("order", ["heavy_on_light", "light_on_heavy"])
def test_mass_ratio_interface_forces_from_the_equilibrium_of_each_box(order):
    p = {"ratio": 1000, "order": order, "dim": 3}
    m0, m1 = ratio.masses(p)
    # unknowns F0 (ground on box0), F1 (box0 on box1): box0: F0 - F1 - m0 g = 0; box1: F1 - m1 g = 0
    A = np.array([[1.0, -1.0], [0.0, 1.0]])
    F = np.linalg.solve(A, [m0 * G, m1 * G])
    assert ratio.interface_forces(p) == pytest.approx(tuple(F))


def test_cradle_cycle_of_one_ball_out_keeps_energy_and_takes_six_gaps():
    """Event-driven pairwise elastic collisions (each pair in turn, equal masses swap
    velocities): one ball out at each end, period 6 GAP / V, energy exact."""
    x = [-2 * cradle.R - cradle.GAP] + [2 * cradle.R * i for i in range(cradle.N_ROW)]
    v = [cradle.V] + [0.0] * cradle.N_ROW
    left = -2 * cradle.R - cradle.GAP - cradle.R - cradle.GAP   # wall faces
    right = x[-1] + cradle.R + cradle.GAP
    t, hits_left = 0.0, []
    while len(hits_left) < 3:
        events = []  # (time, kind, index)
        for i in range(len(x) - 1):
            gap = x[i + 1] - x[i] - 2 * cradle.R
            closing = v[i] - v[i + 1]
            if closing > 1e-12:
                events.append((max(gap, 0.0) / closing, "pair", i))
        if v[0] < 0:
            events.append(((x[0] - cradle.R - left) / -v[0], "left", 0))
        if v[-1] > 0:
            events.append(((right - x[-1] - cradle.R) / v[-1], "right", 0))
        dt, kind, i = min(events)
        x = [xi + vi * dt for xi, vi in zip(x, v)]
        t += dt
        if kind == "pair":
            v[i], v[i + 1] = v[i + 1], v[i]
        elif kind == "left":
            v[0] = -v[0]
            hits_left.append(t)
        else:
            v[-1] = -v[-1]
        assert 0.5 * sum(vi * vi for vi in v) == pytest.approx(0.5 * cradle.V ** 2)
    period = 6 * cradle.GAP / cradle.V
    assert np.diff(hits_left) == pytest.approx([period, period])


@pytest.mark.parametrize("p", tunnelling.GRID, ids=tunnelling.FAMILY.variant_id)
def test_no_sample_of_the_bullet_overlaps_the_plate(p):
    k = np.arange(0, 60)
    x = tunnelling.start(p) + p["v"] * k * 1e-3
    clear = np.abs(x) - tunnelling.R - tunnelling.PLATE[0]
    assert np.all(clear > 0.0)
    assert np.any(x > 0)  # and a discrete engine would put it behind the plate within the run
    # the last sample in front of the plate leaves the variant's gap (to rounding)
    assert clear[x < 0].min() == pytest.approx(p.get("gap", tunnelling.GAP), abs=1e-12)


@pytest.mark.parametrize("setup", ["box_in_ground", "box_in_box", "ball_in_ground"])
def test_overlap_scenes_start_a_quarter_of_the_size_deep(setup):
    scene = overlap.scene({"setup": setup, "dim": 3})
    depths = [penetration(a, b) for a, b in scene.contact_pairs()]
    assert max(depths) == pytest.approx(overlap.OVERLAP * overlap.SIZE)
    rest = overlap.rest_heights({"setup": setup})
    assert all(math.isclose(z, overlap.HALF * (1 + 2 * k)) for k, z in enumerate(rest.values()))
