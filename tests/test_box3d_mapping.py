"""What the Box3D adapter derives (adapters/box3d_engine.py): every pair's own materials
through Box3D's mixing callbacks, the stated inertia from the first step on, contact forces
from the bodies' momenta, and the 2D scenes on motion locks.

Each test skips cleanly when robox3d is missing."""
from __future__ import annotations

import numpy as np
import pytest

from adapters.base import Settings
from cases.scene import Body, Material, Scene, ball, cube, ground

G = 9.81


@pytest.fixture(scope="module")
def box3d():
    pytest.importorskip("robox3d")
    from adapters import box3d_engine
    return box3d_engine


def _run(sim, steps: int):
    for _ in range(steps):
        sim.step()
    return sim.states()


@pytest.mark.engine("box3d")
@pytest.mark.parametrize("dim", (3, 2))
def test_box3d_every_pair_bounces_with_its_own_e(box3d, dim):
    """Two balls dropped side by side with e = 0.5 and 0.9 against the ground and 0 between
    them (no per-body rule reproduces that table; the callbacks return each pair's value):
    each leaves the ground at exactly e times its approach (float32 velocities)."""
    a = Body("a", ball(0.1, dim), mass=1.0, position=(0, 0, 0.2))
    b = Body("b", ball(0.1, dim), mass=2.0, position=(1.0, 0, 0.2))
    scene = Scene(bodies=(ground(), a, b), gravity=(0, 0, -G), dimension=dim,
                  pairs=(("ground", "a", Material(e=0.5)), ("ground", "b", Material(e=0.9)),
                         ("a", "b", Material(e=0.0))))
    sim = box3d.Box3DAdapter().build(scene, Settings(dt=1e-3))
    vz = {"a": [], "b": []}
    for _ in range(300):
        sim.step()
        s = sim.states()
        for n in vz:
            vz[n].append(s[n][9])
    for name, e in (("a", 0.5), ("b", 0.9)):
        v = np.array(vz[name])
        k = int(np.argmax(v > 0))  # the step of the bounce
        assert -v[k] / v[k - 1] == pytest.approx(e, abs=1e-6)


@pytest.mark.engine("box3d")
def test_box3d_stated_inertia_acts_from_the_first_step(box3d):
    """A 1 kg ball (I = 2/5 m r^2) created sliding at 2 m/s on the ground with mu = 0.2
    spins up at mu g m r / I in its first step too (b3Body_SetMassData alone leaves the
    shapes' density inertia for that step: 8.8 rad/s instead of 0.049)."""
    r, mu = 0.1, 0.2
    scene = Scene(bodies=(ground(), Body("ball", ball(r, 3), mass=1.0, position=(0, 0, r), velocity=(2.0, 0, 0))),
                  gravity=(0, 0, -G), material=Material(mu_s=mu))
    sim = box3d.Box3DAdapter().build(scene, Settings(dt=1e-3))
    w = _run(sim, 1)["ball"][11]
    assert w == pytest.approx(mu * G * r / (0.4 * r * r) * 1e-3, rel=1e-3)


@pytest.mark.engine("box3d")
def test_box3d_stack_forces_are_the_weights_above(box3d):
    """A resting stack of three boxes: each interface carries the weight above it, to
    float32 round-off, step by step once settled (the momentum read-out; the contact
    points' last sub-step impulses read 1-2 % heavy)."""
    boxes = tuple(Body(f"box{k}", cube(0.1, 3), mass=1.0, position=(0, 0, 0.1 + 0.2 * k)) for k in range(3))
    scene = Scene(bodies=(ground(),) + boxes, gravity=(0, 0, -G), material=Material(mu_s=0.5))
    sim = box3d.Box3DAdapter().build(scene, Settings(dt=1e-3))
    _run(sim, 500)
    below = {("box0", "ground"): 3, ("box0", "box1"): 2, ("box1", "box2"): 1}
    forces = {k: [] for k in below}
    for _ in range(200):
        sim.step()
        f = sim.contact_forces()
        for k in below:
            forces[k].append(f[k])
    for k, n in below.items():
        assert np.mean(forces[k]) == pytest.approx(n * G, rel=1e-4)


@pytest.mark.engine("box3d")
def test_box3d_2d_bodies_stay_in_their_plane(box3d):
    """A tilted square landing and sliding in a 2D scene (motion locks) moves only in x-z and turns only about y."""
    import math
    half = math.radians(10) / 2
    sq = Body("sq", cube(0.1, 2), mass=1.0, position=(0, 0, 0.3), velocity=(0.5, 0, 0),
              orientation=(math.cos(half), 0.0, math.sin(half), 0.0))
    scene = Scene(bodies=(ground(), sq), gravity=(0, 0, -G), material=Material(mu_s=0.5, e=0.3), dimension=2)
    s = _run(box3d.Box3DAdapter().build(scene, Settings(dt=1e-3)), 400)["sq"]
    assert s[1] == 0.0 and s[8] == 0.0  # y, vy
    assert s[4] == 0.0 and s[6] == 0.0  # the quaternion turns about y only
    assert s[10] == 0.0 and s[12] == 0.0  # no spin about x or z


@pytest.mark.engine("box3d")
@pytest.mark.parametrize("e", (1.0, 0.5))
def test_box3d_touching_balls_land_one_impact_at_a_time(box3d, e):
    """The declared impact model, as measured (IMPACT_MODEL_MEASURED): a 0.1 kg ball resting
    on a 1 kg one (touching, no overlap), both landing at 2 m/s, gravity off. The landing
    step bounces the bottom ball alone; the next resolves the pair as an impact of its own:
    the sequential model's closed form (cases/column_impact.py), not the simultaneous
    one's (both at e V)."""
    from cases.column_impact import sequential_velocities
    assert box3d.Box3DAdapter.capabilities.impact_model == "sequential"
    v = 2.0
    bottom = Body("bottom", ball(0.1, 3), mass=1.0, position=(0, 0, 0.1), velocity=(0, 0, -v))
    top = Body("top", ball(0.1, 3), mass=0.1, position=(0, 0, 0.3), velocity=(0, 0, -v))
    scene = Scene(bodies=(ground(), bottom, top), gravity=(0, 0, 0), material=Material(e=e))
    s = _run(box3d.Box3DAdapter().build(scene, Settings(dt=1e-3)), 5)
    (v_top, v_bottom, _), _ = sequential_velocities([0.1, 1.0, float("inf")], [v, v, 0.0], e)
    # float32 velocities of a few m/s, three impacts: 1e-5 m/s
    assert s["top"][9] == pytest.approx(-v_top, abs=1e-5)
    assert s["bottom"][9] == pytest.approx(-v_bottom, abs=1e-5)
