"""2D scenes on Newton (adapters/newton_engine.py): each body on a D6 joint to the world that
slides along x and z and turns about y. A rectangle tilted 30 deg about y, launched at
(1, 0, 0.5) m/s turning at 2 rad/s with no gravity and nothing to touch, is after 0.1 s where
its constant velocities put it; a rectangle sliding on the ground at mu = 0.5 decelerates at
mu g and stays in its plane. Slow: Newton and Warp start in ~10 s a process (measured)."""
from __future__ import annotations

import numpy as np
import pytest

from adapters.base import Settings
from cases import rotations
from cases.scene import Body, Material, Rect, Scene, ground, quat_about_y
from tests.helpers import adapter_or_skip

pytestmark = [pytest.mark.engine("newton-*"), pytest.mark.slow]

G, MU, DT = 9.81, 0.5, 1e-3
# Free flight, 100 steps. Featherstone integrates the joint's coordinates: a constant rate to
# float32's rounding (measured 7e-8 m, 2.4e-7 m/s). XPBD and the semi-implicit solver move the
# bodies in float32 and project the joint each step (measured 3.6e-6 m, 3.7e-5 m/s). A joint
# with an axis along y, or one about x or z, leaves the start pose by 0.05 m and 0.2 rad.
FLIGHT = {"newton-featherstone": (1e-6, 1e-6), "newton-xpbd": (1e-5, 1e-4), "newton-semi-implicit": (1e-5, 1e-4)}
# Sliding (0.05-0.2 s): the deceleration's float32 read-out over 0.15 s (measured within
# 3e-5 of mu g = 4.905 on these three solvers; a box rocking on a corner or a friction taken per
# contact point misses it by 1e-2 or more)
DECELERATION = 1e-3  # m/s^2


def _joint_axes(sim, name: str):
    """(type, linear axes, angular axes) of the joint of body `name` in Newton's model."""
    import newton
    model, i = sim._model, sim._index[name]
    j = list(model.joint_child.numpy()).index(i)
    lin, ang = int(model.joint_dof_dim.numpy()[j][0]), int(model.joint_dof_dim.numpy()[j][1])
    start = int(model.joint_qd_start.numpy()[j])
    axes = model.joint_axis.numpy()[start:start + lin + ang]
    return int(model.joint_type.numpy()[j]) == int(newton.JointType.D6), axes[:lin].round(6), axes[lin:].round(6)


@pytest.mark.parametrize("engine", sorted(FLIGHT))
def test_a_planar_body_flies_and_turns_in_its_plane(engine):
    adapter = adapter_or_skip(engine)
    q0 = np.asarray(quat_about_y(np.radians(30.0)))
    scene = Scene(bodies=(Body("r", Rect((0.2, 0.1)), mass=1.0, position=(0, 0, 1), orientation=tuple(q0),
                               velocity=(1.0, 0.0, 0.5), angular_velocity=(0.0, 2.0, 0.0)),),
                  gravity=(0, 0, 0), dimension=2)
    with adapter.build(scene, Settings(dt=DT)) as sim:
        d6, linear, angular = _joint_axes(sim, "r")
        assert d6 and linear.tolist() == [[1, 0, 0], [0, 0, 1]] and angular.tolist() == [[0, 1, 0]]
        for _ in range(100):
            sim.step()
        s = sim.states()["r"]
    at, rate = FLIGHT[engine]
    np.testing.assert_allclose(s[0:3], (0.1, 0.0, 1.05), atol=at)
    turned = rotations.multiply(quat_about_y(0.2), q0)
    # the orientation's components, as the position: float32 rounding of a turn of 0.2 rad
    # (measured 3.9e-8 on Featherstone, 1.5e-6 on XPBD); a turn about another axis is 0.1 off
    assert min(np.abs(s[3:7] - turned).max(), np.abs(s[3:7] + turned).max()) < at * 10, (s[3:7], turned)
    np.testing.assert_allclose(s[7:13], (1.0, 0.0, 0.5, 0.0, 2.0, 0.0), atol=rate)


@pytest.mark.parametrize("engine", sorted(FLIGHT))
def test_a_planar_box_slides_at_mu_g_in_its_plane(engine):
    adapter = adapter_or_skip(engine)
    scene = Scene(bodies=(ground(), Body("r", Rect((0.1, 0.1)), mass=1.0, position=(0, 0, 0.1), velocity=(2.0, 0, 0))),
                  gravity=(0, 0, -G), material=Material(e=0.0, mu_s=MU), dimension=2)
    rows = []
    with adapter.build(scene, Settings(dt=DT)) as sim:
        for _ in range(200):
            sim.step()
            rows.append(sim.states()["r"].copy())
    rows = np.array(rows)
    assert -(rows[199, 7] - rows[49, 7]) / 0.15 == pytest.approx(MU * G, abs=DECELERATION)
    assert np.abs(rows[:, [1, 8]]).max() < 1e-6  # y and its velocity: the joint has no axis along y
