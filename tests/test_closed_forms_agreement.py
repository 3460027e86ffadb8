"""The closed forms of the agreement families (cases/tumbling_box.py, cases/stack_strike.py)
against independent derivations: the lowest vertex and the edge-tipping barrier from
scipy's rotations and a brute-force search over orientations, the rest face by
enumerating the faces, the impulse balance from a discrete plastic-impact model of a
stack on rigid ground, and the impulse read-out on a trajectory whose forces are known.
The FULL_GRID variants (not in the default run) run here on the reference."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial.transform import Rotation

from adapters import registry
from cases import stack_strike as ss
from cases import tumbling_box as tb
from cases.family import Variant
from cases.observables import impulse, point_speed_bound
from cases.trajectory import Trajectory
from physval.core import Job
from tests.helpers import run_job

A = tb.HALF


def scipy_matrix(q) -> np.ndarray:
    w, x, y, z = q
    return Rotation.from_quat([x, y, z, w]).as_matrix()  # scipy: scalar last


# --- tumbling box: lowest vertex, barrier, rest face ------------------------------------------

@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda v: np.linalg.norm(v) > 0.1))
def test_lowest_vertex_is_the_support_function_of_the_cube(v):
    """Depth of the lowest vertex below the centre = a (|n_1| + |n_2| + |n_3|), n = R^T e_z."""
    q = np.asarray(v) / np.linalg.norm(v)
    n = scipy_matrix(q).T @ [0, 0, 1]
    assert tb.lowest_vertex_depth(q, A) == pytest.approx(A * np.sum(np.abs(n)), abs=1e-12)
    assert tb.rotation(q) == pytest.approx(scipy_matrix(q), abs=1e-12)


def test_release_poses_have_the_stated_support():
    """Tilt theta about y: sigma = cos + sin (an edge lowest); phi about (1,1,0)/sqrt 2:
    sigma = sqrt 2 sin + cos (one corner lowest)."""
    for p in tb.FULL_GRID:
        q = tb.orientation(p)
        axis = [0, 1, 0] if p["tilt"] == "y" else [1 / math.sqrt(2), 1 / math.sqrt(2), 0]
        angle = math.radians(tb.TILT[p["tilt"]])
        R = Rotation.from_rotvec(angle * np.asarray(axis)).as_matrix()
        assert tb.rotation(q) == pytest.approx(R, abs=1e-12)
        sigma = math.cos(angle) + (math.sin(angle) if p["tilt"] == "y" else math.sqrt(2) * math.sin(angle))
        assert tb.release_height(p) == pytest.approx(tb.H + A * sigma, abs=1e-12)
        z = (tb.corners(A, p["dim"]) @ R.T)[:, 2]
        lowest = np.sum(np.isclose(z, z.min(), atol=1e-12))
        assert lowest == (1 if p["tilt"] == "diag" else 2 if p["dim"] == 3 else 1)


def test_barrier_is_the_lowest_support_where_the_down_face_can_change():
    """Brute force over a dense set of directions: wherever two components tie as the
    largest |n_i| (where the face down can change), sigma >= sqrt 2, attained on an edge."""
    rng = np.random.default_rng(1)
    n = rng.normal(size=(400_000, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    s = np.sort(np.abs(n), axis=1)
    near_tie = s[:, 2] - s[:, 1] < 1e-3
    sigma = np.sum(np.abs(n), axis=1)
    assert near_tie.sum() > 100
    assert sigma[near_tie].min() >= math.sqrt(2) - 2e-3
    assert sigma[near_tie].min() == pytest.approx(math.sqrt(2), abs=5e-3)
    assert tb.barrier_height(A) == pytest.approx(A * math.sqrt(2))
    # 2D: the square's support |n_x| + |n_z| over the unit circle ties at 45 deg, sqrt 2
    phi = np.linspace(0, 2 * np.pi, 100_001)
    tie = np.abs(np.abs(np.cos(phi)) - np.abs(np.sin(phi))) < 1e-4
    assert (np.abs(np.cos(phi)) + np.abs(np.sin(phi)))[tie].min() == pytest.approx(math.sqrt(2), abs=1e-6)


def test_release_energy_is_below_the_barrier_with_room_for_a_solvers_depth():
    for p in tb.FULL_GRID:
        assert tb.margin(p) > 5 * tb.PENETRATION, p


def test_down_face_is_the_face_whose_normal_points_most_downward():
    """Enumerate the 6 (2D: 4) outward face normals and pick the one lowest in the world."""
    for p in tb.FULL_GRID:
        q = tb.orientation(p)
        faces = [s * np.eye(3)[i] for i in ((0, 1, 2) if p["dim"] == 3 else (0, 2)) for s in (1, -1)]
        world_z = [(scipy_matrix(q) @ f)[2] for f in faces]
        assert tb.down_face(q, p["dim"]) == pytest.approx(faces[int(np.argmin(world_z))])


def test_tumbling_energy_and_impulse():
    p = tb.FULL_GRID[0]
    z0 = tb.H + A * (math.cos(math.radians(15)) + math.sin(math.radians(15)))
    assert tb.energy_dissipated(p) == pytest.approx(tb.M * tb.G * (z0 - A))
    assert tb.ground_impulse(0.8) == pytest.approx(tb.M * tb.G * 0.8)


# --- stack strike: impulse balance from a discrete plastic-impact model ---------------------

def plastic_chain(m_sphere: float, n: int, h: float, dt: float, steps: int):
    """A 1D sphere above n unit boxes on rigid ground, semi-implicit Euler, every contact
    plastic and rigid (solved exactly each step: a body that would move into the one below
    it moves with it; the bottom box cannot move down). Returns the sphere's velocities and
    the ground's impulse per step: an independent model of what the closed forms claim."""
    masses = [ss.M_BOX] * n + [m_sphere]
    gap = h
    v = np.zeros(n + 1)
    v_sphere, ground = [0.0], []
    for _ in range(steps):
        v -= ss.G * dt
        touching = gap + v[-1] * dt <= 1e-15
        # bottom to top: boxes sit on each other and the ground (gap 0): all stop; the sphere
        # stops if it would reach the top box this step (plastic, rigid)
        P = sum(-masses[k] * v[k] for k in range(n))  # momentum the ground removes from the boxes
        v[:n] = 0.0
        if touching:
            P += -masses[-1] * v[-1]
            v[-1] = 0.0
        gap = 0.0 if touching else gap + v[-1] * dt
        v_sphere.append(v[-1])
        ground.append(P)
    return np.array(v_sphere), np.array(ground)


@pytest.mark.parametrize("p", ss.FULL_GRID[:8], ids=ss.variant_id)
def test_ground_impulse_balance(p):
    dt = 1e-3
    steps = int(round(ss.duration(p) / dt))
    v, P = plastic_chain(p["m"], p["n"], p["h"], dt, steps)
    t_a, t_b = ss.window(p, dt)
    ka, kb = int(round(t_a / dt)), int(round(t_b / dt))
    assert v[ka] == pytest.approx(-ss.G * t_a, rel=1e-9)  # free fall at t_a
    measured = P[ka:kb].sum()  # steps ka+1 .. kb
    assert measured == pytest.approx(ss.ground_impulse(p["m"], p["n"], t_a, t_b), rel=1e-9)
    k_read = int(round((ss.impact_time(p["h"]) + ss.READ_AFTER) / dt))
    assert v[k_read] == 0.0
    assert ss.ground_impulse(p["m"], p["n"], t_a, t_b) == pytest.approx(
        (p["m"] + p["n"]) * ss.G * (t_b - t_a) + p["m"] * math.sqrt(2 * ss.G * p["h"]) - p["m"] * ss.G * (ss.impact_time(p["h"]) - t_a))


def test_stack_strike_rest_state_from_the_scene():
    """Energy dissipated = the potential energy between the scene's start and the rest
    state with the sphere lowered onto the top box, computed from the scene's bodies."""
    for p in ss.FULL_GRID:
        sc = ss.scene(p)
        sphere = sc.body("sphere")
        top = sc.body(f"box{p['n'] - 1}")
        resting = top.position[2] + ss.HALF + ss.R
        assert ss.rest_height(p["n"]) == pytest.approx(resting)
        assert ss.energy_dissipated(p["m"], p["h"]) == pytest.approx(p["m"] * ss.G * (sphere.position[2] - resting))


# --- the readings ---------------------------------------------------------------------------

def test_impulse_counts_the_steps_inside_the_window():
    dt = 0.01
    t = np.arange(11) * dt
    f = np.arange(11, dtype=float)  # sample k carries step k's force, k N
    traj = Trajectory(dt=dt, t=t, states={}, forces={("a", "b"): f})
    assert impulse(traj, "b", "a") == pytest.approx(sum(range(1, 11)) * dt)
    assert impulse(traj, "a", "b", 0.02, 0.05) == pytest.approx((3 + 4 + 5) * dt)
    assert impulse(traj, "a", "c") == 0.0


def test_point_speed_bound():
    states = np.zeros((2, 13))
    states[:, 7:10] = [3.0, 4.0, 0.0]
    states[:, 10:13] = [0.0, 0.0, 2.0]
    traj = Trajectory(dt=1.0, t=np.arange(2.0), states={"b": states})
    assert point_speed_bound(traj, "b", 0.5) == pytest.approx([6.0, 6.0])


# --- the larger grids on the reference (not in the default run) -----------------------------

FULL = [(tb.FAMILY, p) for p in tb.FULL_GRID if p not in tb.GRID] + \
       [(ss.FAMILY, p) for p in ss.FULL_GRID if p not in ss.GRID]


@pytest.mark.parametrize("family,p", FULL, ids=[f"{f.name}[{f.variant_id(p)}]" for f, p in FULL])
def test_full_grid_passes_on_the_reference(family, p):
    variant = Variant(family.name, family.variant_id(p), dict(p))
    rows = run_job(Job(family.name, variant, "reference"), family, registry.get("reference"), known=[])
    bad = [f"{r['metric']} = {r['measured']:.6g}, expected {r['expected']:.6g} ({r['reason']})"
           for r in rows if r["status"] != "pass"]
    assert not bad, "; ".join(bad)
