"""reference_impl/joints.py: joints as equality rows beside the contact rows, in the
sequential impulses, PGS, Lemke and SPOOK formulations - the rows hold the anchor and the
hinge axis, pull as well as push (no projection), leave the free directions free, and
joined bodies do not collide. Prismatic and fixed joints, limits, joint friction and
loads: tests/reference/test_ref_formulations_joint_rows.py."""
from __future__ import annotations

import math

import numpy as np
import pytest

from reference_impl.config import Config
from reference_impl.geometry import Box, Sphere
from reference_impl.rigid_body import RigidBody
from reference_impl.world import World

FORMULATIONS = ("si", "pgs", "spook", "lemke")
# steps for a joint to take out a velocity that breaks it: PGS solves G v = 0 in one step
# (to its tolerance); SPOOK is a critically damped stiff spring relaxing over d = 4 steps
# (each step leaves 1 / (1 + 4d) of the row velocity and restores the error it made):
# under 1 % left after 20 steps (measured: 0.3 %)
SETTLE = {"si": 1, "pgs": 1, "spook": 20, "lemke": 1}
DT = 1e-3
G = 9.81


def pendulum(formulation, kind="revolute", v=(0.0, 0.0, 0.0), w=(0.0, 0.0, 0.0), gravity=(0.0, 0.0, -G)):
    """A 1 kg ball (r = 0.05 m) hung 0.5 m below-right of a pivot at the origin, at 90 deg."""
    world = World(gravity=gravity, config=Config(formulation=formulation))
    bob = world.add(RigidBody("bob", Sphere(0.05), 1.0, (1e-3,) * 3, x=(0.5, 0.0, 0.0), v=v, w=w))
    world.join(kind, bob, None, anchor=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
    return world, bob


@pytest.mark.parametrize("formulation", FORMULATIONS)
@pytest.mark.parametrize("kind", ["ball", "revolute"])
def test_a_joint_to_the_world_keeps_the_bob_on_its_circle(formulation, kind):
    """Let go at 90 deg, the bob swings down a quarter turn (0.36 s): its distance from the
    pivot stays 0.5 m to within the stabilisation's steady error. Per step a velocity-level
    row lets the radius grow by (v dt)^2 / (2 L) <= 2e-5 m (v <= sqrt(2 g L) = 3.1 m/s);
    corrected at the rate beta = 0.2 (pgs) or over d = 4 steps (spook) the error stays
    within a few steps' growth: 1e-4 m allows five."""
    world, bob = pendulum(formulation, kind)
    radius = []
    for _ in range(360):
        world.step(DT)
        radius.append(math.hypot(bob.x[0], bob.x[2]))
    assert max(abs(r - 0.5) for r in radius) < 1e-4
    assert abs(bob.x[1]) < 1e-12  # nothing pushes it out of its plane
    assert bob.x[2] < -0.45        # it swung down


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_a_hinge_keeps_its_axis_and_a_ball_joint_does_not(formulation):
    """A bob spinning about x (across the hinge axis y): the revolute joint's angular rows
    stop that spin (PGS in the first step, to its tolerance; SPOOK, a critically damped
    stiff spring, within its relaxation of d = 4 steps: 1 % left after 20 steps), the
    ball joint leaves it turning."""
    hinge, bob = pendulum(formulation, "revolute", w=(2.0, 0.0, 0.0), gravity=(0.0, 0.0, 0.0))
    for _ in range(SETTLE[formulation]):
        hinge.step(DT)
    assert abs(bob.w[0]) < 1e-2 * 2.0
    ball, bob = pendulum(formulation, "ball", w=(2.0, 0.0, 0.0), gravity=(0.0, 0.0, 0.0))
    ball.step(DT)
    assert bob.w[0] == pytest.approx(2.0, rel=1e-12)


@pytest.mark.parametrize("formulation", FORMULATIONS)
@pytest.mark.parametrize("vz", [1.0, -1.0])
def test_a_joint_row_pulls_and_pushes(formulation, vz):
    """A bob at the pivot's side moving straight at it or away from it (along the arm)
    with no gravity: the equality row stops the radial motion either way (a contact row
    could only push)."""
    world, bob = pendulum(formulation, "ball", v=(vz, 0.0, 0.0), gravity=(0.0, 0.0, 0.0))
    for _ in range(SETTLE[formulation]):
        world.step(DT)
    assert abs(bob.v[0]) < 1e-2 * abs(vz)


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_a_joint_between_two_bodies_holds_the_anchor_and_they_do_not_collide(formulation):
    """Two overlapping boxes joined by a hinge at a shared point, the lower one hung from
    the world: no contact is made between them, and the anchor of the second joint stays
    one point of both bodies while they swing (to 1e-4 m as above)."""
    world = World(gravity=(0.0, 0.0, -G), config=Config(formulation=formulation))
    upper = world.add(RigidBody("upper", Box((0.1, 0.1, 0.1)), 1.0, (1e-2,) * 3, x=(0.3, 0.0, 0.0)))
    lower = world.add(RigidBody("lower", Box((0.1, 0.1, 0.1)), 1.0, (1e-2,) * 3, x=(0.45, 0.0, 0.0)))
    world.join("revolute", upper, None, anchor=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
    world.join("revolute", lower, upper, anchor=(0.4, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
    for _ in range(200):
        world.step(DT)
        assert not world.contacts
        on_upper = upper.x + upper.R @ np.array([0.1, 0.0, 0.0])
        on_lower = lower.x + lower.R @ np.array([-0.05, 0.0, 0.0])
        assert np.max(np.abs(on_upper - on_lower)) < 1e-4
    assert upper.x[2] < -0.01  # they swung


def test_a_formulation_without_joint_rows_refuses_a_joint():
    world, _ = pendulum("acceleration_lcp", "ball")
    assert "ball joint asked" in world.unsupported()
    assert pendulum("pgs", "ball")[0].unsupported() is None


def test_pgs_and_lemke_solve_the_same_joint_rows():
    """PGS swept to convergence and Lemke's exact mixed LCP give the same steps for the
    same rows: a hinged bob swinging 0.3 s from 90 deg, positions within 1e-12 m
    (measured 1.7e-16). With the default 200 sweeps stopping at a 1e-10 m/s change, PGS
    is 1.3e-6 m off: the bob's small inertia (1e-3 against m L^2 = 0.25) couples the
    hinge's five rows tightly, and Gauss-Seidel converges slowly on them (note 004,
    "pairwise iterative solvers")."""
    ends = []
    for config in (Config(formulation="pgs", iterations=20000, position_iterations=20000, tolerance=0.0),
                   Config(formulation="lemke")):
        world = World(gravity=(0.0, 0.0, -G), config=config)
        bob = world.add(RigidBody("bob", Sphere(0.05), 1.0, (1e-3,) * 3, x=(0.5, 0.0, 0.0)))
        world.join("revolute", bob, None, anchor=(0.0, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
        for _ in range(300):
            world.step(DT)
        ends.append(bob.x.copy())
    assert np.max(np.abs(ends[0] - ends[1])) < 1e-12
