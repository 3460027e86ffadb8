"""World and sequential-impulse behaviour of reference_impl, against closed forms."""
from __future__ import annotations

import math

import pytest

from reference_impl.compiled import JIT
from reference_impl.config import Config
from reference_impl.geometry import Box, Circle, Plane, Rect, Sphere
from reference_impl.rigid_body import RigidBody, mat_vec, similarity
from reference_impl.world import Material, World, formulation

G = 9.81


def ball_world(e, h, dt, gravity=(0.0, 0.0, -G)):
    w = World(gravity=gravity, material=Material(e=e))
    w.add(RigidBody("ground", Plane(), static=True))
    ball = w.add(RigidBody("ball", Sphere(0.1), 1.0, (0.004,) * 3, x=(0.0, 0.0, 0.1 + h), can_rotate=False))
    return w, ball


@pytest.mark.parametrize("dt", [1e-3, 5e-3, 1e-2])
@pytest.mark.parametrize("phase", [0.0, 0.3, 0.6, 0.9])
def test_restitution_ratio_is_e_at_any_dt_and_contact_phase(dt, phase):
    # restitution acts on the velocity before the step's gravity: v+ = -e v- exactly
    e = 0.7
    w, ball = ball_world(e, 0.5 + phase * 3.13 * dt, dt)
    for _ in range(int(0.5 / dt)):
        before = ball.v[2]
        w.step(dt)
        if before < 0 <= ball.v[2]:
            assert ball.v[2] == pytest.approx(-e * before, rel=1e-14)
            return
    pytest.fail("no bounce")


def test_resting_box_is_held_by_its_weight_in_one_warm_started_sweep():
    dt = 1e-3
    w = World(material=Material(mu_s=0.5, mu_k=0.5))
    w.add(RigidBody("ground", Plane(), static=True))
    box = w.add(RigidBody("box", Box((0.1, 0.1, 0.1)), 2.0, (0.0133,) * 3, x=(0.0, 0.0, 0.1)))
    for _ in range(20):
        w.step(dt)
    assert "si:warm_start" in w.stages
    assert w.normal_impulses[("box", "ground")] == pytest.approx(2.0 * G * dt, rel=1e-12)
    assert len(w.contacts) == 4
    assert box.x == pytest.approx([0.0, 0.0, 0.1], abs=1e-12)
    assert max(map(abs, [*box.v, *box.w])) < 1e-12


@pytest.mark.parametrize("angle", [0.0, 30.0, 45.0, 117.0])
def test_sliding_friction_is_isotropic(angle):
    # a box sliding on level ground decelerates at mu g along its velocity, in any direction
    # of the tangent basis (a pyramid would give mu g sqrt 2 at 45 deg)
    mu, v0, dt = 0.4, 2.0, 1e-3
    w = World(material=Material(mu_s=mu, mu_k=mu))
    w.add(RigidBody("ground", Plane(), static=True))
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    box = w.add(RigidBody("box", Box((0.1, 0.1, 0.1)), 1.0, (0.00667,) * 3, x=(0.0, 0.0, 0.1),
                          v=(v0 * c, v0 * s, 0.0)))
    for _ in range(200):
        w.step(dt)
    speed = math.hypot(box.v[0], box.v[1])
    assert speed == pytest.approx(v0 - mu * G * 0.2, rel=1e-9)
    # no sideways turn, to the solver's tolerance (1e-10 m/s per sweep)
    assert box.v[0] * s - box.v[1] * c == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("shape,inertia,ratio", [(Sphere(0.1), 0.4 * 0.01, 5 / 7), (Circle(0.1), 0.5 * 0.01, 2 / 3)],
                         ids=["sphere", "disc-2D"])
def test_sliding_ball_ends_rolling_at_the_closed_form_speed(shape, inertia, ratio):
    # Friction acts at the contact point, gravity and the normal force along the line through
    # it: angular momentum about the contact point, m v r + I w, is kept. Rolling (v = w r)
    # therefore sets in at v = m r v0 / (m r + I / r): 5/7 v0 (sphere), 2/3 v0 (disc).
    v0, dt = 2.0, 1e-3
    planar = isinstance(shape, Circle)
    w = World(material=Material(mu_s=0.3, mu_k=0.3))
    w.add(RigidBody("ground", Plane(), static=True, planar=planar))
    ball = w.add(RigidBody("ball", shape, 1.0, (inertia,) * 3, x=(0.0, 0.0, 0.1), v=(v0, 0.0, 0.0), planar=planar))
    for _ in range(400):  # sliding ends at 2 v0 / (7 mu g) = 0.19 s (sphere)
        w.step(dt)
    assert ball.v[0] == pytest.approx(ratio * v0, rel=1e-9)
    assert ball.w[1] * 0.1 == pytest.approx(ball.v[0], rel=1e-9)  # rolls without slipping
    assert ball.x[2] == pytest.approx(0.1, abs=1e-12) and ball.v[2] == 0.0


def test_box_landing_flat_bounces_all_corners_alike():
    e, dt = 0.5, 1e-3
    w = World(material=Material(e=e, mu_s=0.5, mu_k=0.5))
    w.add(RigidBody("ground", Plane(), static=True))
    box = w.add(RigidBody("box", Box((0.1, 0.2, 0.05)), 1.0, (0.01, 0.01, 0.01), x=(0.0, 0.0, 0.35)))
    for _ in range(400):
        before = box.v[2]
        w.step(dt)
        if before < 0 <= box.v[2]:
            # four corners solved one after another: exact to the solver's tolerance
            assert box.v[2] == pytest.approx(-e * before, rel=1e-9)
            assert max(map(abs, box.w)) < 1e-9 and max(abs(box.v[0]), abs(box.v[1])) < 1e-9
            return
    pytest.fail("no bounce")


def test_frictionless_world_builds_no_tangent_rows():
    w, ball = ball_world(0.0, 0.0, 1e-3)
    w.step(1e-3)
    assert w.contacts and all(c.tangents == () for c in w.contacts)
    assert "si:friction" not in w.stages


def test_stages_follow_the_world():
    w, ball = ball_world(0.5, 1.0, 1e-3, gravity=(0.0, 0.0, 0.0))
    w.step(1e-3)
    assert w.stages == ("collide", "positions")  # no gravity, no contact yet, no rotation
    w, ball = ball_world(0.5, 0.0, 1e-3)
    w.step(1e-3)
    assert w.stages[:2] == ("collide", "gravity") and "rotations" not in w.stages


def test_bodies_that_cannot_rotate_keep_their_orientation():
    w = World(material=Material(mu_s=0.8, mu_k=0.8))
    w.add(RigidBody("ground", Plane(), static=True))
    q = (math.cos(0.2), math.sin(0.2), 0.0, 0.0)
    box = w.add(RigidBody("box", Box((0.1, 0.1, 0.1)), 1.0, (0.0067,) * 3, x=(0.0, 0.0, 0.3), q=q,
                          v=(1.0, 0.0, 0.0), can_rotate=False))
    for _ in range(500):
        w.step(1e-3)
    assert tuple(box.q) == q and list(box.w) == [0.0, 0.0, 0.0]


def test_free_tumbling_body_keeps_its_angular_momentum():
    w = World(gravity=(0.0, 0.0, 0.0))
    inertia = (0.01, 0.02, 0.03)
    box = w.add(RigidBody("box", Box((0.3, 0.2, 0.1)), 1.0, inertia, w=(1.0, 2.0, 0.5)))
    L0 = mat_vec(similarity(box.R, inertia), box.w)
    for _ in range(1000):
        w.step(1e-3)
    L = mat_vec(similarity(box.R, inertia), box.w)
    assert L == pytest.approx(L0, rel=1e-12, abs=1e-14)
    assert sum(c * c for c in box.q) == pytest.approx(1.0, abs=1e-15)


def test_planar_bodies_stay_in_the_plane():
    w = World(material=Material(e=0.3, mu_s=0.6, mu_k=0.4))
    w.add(RigidBody("line", Plane((math.sin(-0.2), 0.0, math.cos(-0.2)), 0.0), static=True, planar=True))
    q = (math.cos(0.35), 0.0, math.sin(0.35), 0.0)
    rect = w.add(RigidBody("rect", Rect((0.2, 0.1)), 1.0, (0.0167,) * 3, x=(0.0, 0.0, 0.5), q=q,
                           v=(0.5, 0.0, 0.0), w=(0.0, 3.0, 0.0), planar=True))
    disc = w.add(RigidBody("disc", Circle(0.1), 1.0, (0.005,) * 3, x=(0.5, 0.0, 0.5), planar=True))
    for _ in range(1500):
        w.step(1e-3)
    for body in (rect, disc):
        assert body.x[1] == 0.0 and body.v[1] == 0.0
        assert body.q[1] == 0.0 and body.q[3] == 0.0 and body.w[0] == 0.0 and body.w[2] == 0.0
    assert all(c.n[1] == 0.0 and len(c.tangents) == 1 for c in w.contacts)


def test_bodies_placed_exactly_touching_do_not_fall_a_step():
    dt = 1e-3
    w = World(material=Material(mu_s=0.5, mu_k=0.5))
    w.add(RigidBody("ground", Plane(), static=True))
    boxes = [w.add(RigidBody(f"b{k}", Box((0.1, 0.1, 0.1)), 1.0, (0.0067,) * 3, x=(0.0, 0.0, 0.1 + 0.2 * k)))
             for k in range(3)]
    w.step(dt)
    # a step of free fall would be g dt^2 = 1e-5 m; what is left is the cold solver's
    # residual (a few 1e-10 m in the first step)
    for k, b in enumerate(boxes):
        assert abs(b.x[2] - (0.1 + 0.2 * k)) < 1e-8


def test_unknown_formulation_names_the_interface():
    with pytest.raises(ValueError, match="reference_impl/__init__.py"):
        formulation("no_such_solver")
    assert formulation("si").__name__ == "reference_impl.sequential_impulses"


@pytest.mark.parametrize("field,value", [("iterations", 0), ("beta", 1.5), ("slop", -1.0), ("margin", -1e-3)])
def test_config_rejects_values_out_of_range(field, value):
    with pytest.raises(ValueError, match=field):
        Config(**{field: value})


def test_rows_effective_mass_and_coupling_match_applied_impulses():
    # J_i M^-1 J_j^T measured: apply a unit impulse on row j, read the change of row i
    from reference_impl.contact import Row, coupling
    a = RigidBody("a", Box((0.3, 0.2, 0.1)), 2.0, (0.01, 0.02, 0.03), x=(0.1, -0.2, 0.3), q=(0.9, 0.1, 0.3, 0.3))
    b = RigidBody("b", Sphere(0.2), 3.0, (0.05, 0.05, 0.05), x=(0.4, 0.1, 0.2))
    a.q = [c / math.sqrt(sum(x * x for x in a.q)) for c in a.q]
    a.update_frame()
    p = (0.25, 0.0, 0.3)
    ra = tuple(p[k] - a.x[k] for k in range(3))
    rb = tuple(p[k] - b.x[k] for k in range(3))
    dirs = [(0.0, 0.0, 1.0), (0.6, 0.8, 0.0), (0.8, -0.6, 0.0)]
    rows = [Row(a, b, ra, rb, d) for d in dirs]
    for ri in rows:
        for rj in rows:
            before = ri.velocity()
            rj.apply(1.0)
            measured = ri.velocity() - before
            rj.apply(-1.0)
            assert coupling(ri, rj) == pytest.approx(measured, rel=1e-12, abs=1e-14)
        assert coupling(ri, ri) == pytest.approx(ri.K, rel=1e-14)
        assert ri.mass * ri.K == pytest.approx(1.0, rel=1e-15)


def test_a_tall_stack_starting_at_rest_is_solved_from_its_first_step():
    # Gauss-Seidel from zero would rock a ten-box stack for hundreds of steps (its slowest
    # mode decays by 0.99978 per sweep); the least-squares cold start is the symmetric
    # solution: no motion, no friction stress locked in, one sweep per step after it.
    dt = 1e-3
    w = World(material=Material(mu_s=0.5))
    w.add(RigidBody("ground", Plane(), static=True))
    boxes = [w.add(RigidBody(f"b{k}", Box((0.1, 0.1, 0.1)), 1.0, (0.0067,) * 3, x=(0.0, 0.0, 0.1 + 0.2 * k)))
             for k in range(10)]
    w.step(dt)
    assert "si:cold_start" in w.stages
    for _ in range(100):
        w.step(dt)
        assert "si:cold_start" not in w.stages
    for k, b in enumerate(boxes):
        assert max(abs(b.x[0]), abs(b.x[1]), abs(b.x[2] - (0.1 + 0.2 * k))) < 1e-12
    assert max(abs(P) for c in w.contacts for P in c.Pt) < 1e-12
    weights = {("b0", "ground"): 10 * G * dt}
    assert w.normal_impulses[("b0", "ground")] == pytest.approx(weights[("b0", "ground")], rel=1e-12)


def test_a_touching_row_passes_elastic_impacts_on_without_losing_energy():
    # striker into a row of four touching balls between walls, e = 1, no gravity: the
    # row moves as one (gaps within the slop count as touching), energy is kept
    w = World(gravity=(0.0, 0.0, 0.0), material=Material(e=1.0))
    balls = [w.add(RigidBody("striker", Sphere(0.05), 1.0, (0.001,) * 3, x=(-0.15, 0, 0), v=(1.0, 0, 0),
                             can_rotate=False))]
    balls += [w.add(RigidBody(f"ball{i}", Sphere(0.05), 1.0, (0.001,) * 3, x=(0.1 * i, 0, 0), can_rotate=False))
              for i in range(4)]
    for name, x in (("left", -0.3), ("right", 0.45)):
        w.add(RigidBody(name, Box((0.05, 0.2, 0.2)), x=(x, 0, 0), static=True))
    for _ in range(2000):
        w.step(1e-3)
    energy = sum(0.5 * b.v[0] ** 2 for b in balls)
    assert energy == pytest.approx(0.5, rel=1e-9)


@pytest.mark.skipif(not JIT, reason="compiled code only (numba installed, NUMBA_DISABLE_JIT unset)")
def test_the_collision_phase_compiles_once_for_every_formulation():
    # a step is world.begin (broad and narrow phase, rows, warm start, gravity), which takes
    # no formulation's type, then world.end (the formulation's solve, the integration): a
    # process compiles (or loads) begin once however many formulations it runs, end once each
    from reference_impl import world
    for name in ("si", "pgs"):
        w = World(config=Config(formulation=name))
        w.add(RigidBody("ground", Plane(), static=True))
        w.add(RigidBody("ball", Sphere(0.1), 1.0, (0.004,) * 3, x=(0.0, 0.0, 0.1), can_rotate=False))
        w.step(1e-3)
        assert f"{name}:velocity" in w.stages
    assert len(world.begin.signatures) == 1
    assert len(world.end.signatures) >= 2
